#pragma once
/// A forward scanner over an in-memory text file for the mesh readers: blanks, tokens, numbers and the
/// 1-based line number of the current position, so that every error can name file:line.
///
/// Numbers are parsed with std::from_chars (locale independent, no allocation). A float token is parsed
/// directly as float so that a shortest-form float written by std::to_chars reads back bit-exactly.
///
/// The cursor ends lines at LF only and takes CR for a blank, which reads CRLF files as they are. A lone CR
/// (classic Mac OS) would join two lines, so the readers first pass their text through lone_cr_to_lf.
///
/// Line continuations (OBJ; asked for at construction): a backslash followed by nothing but blanks up to the
/// line end or the end of the text joins the next line to the current one and counts as a blank, so it also
/// ends a token it is glued to ("2\"). at_eol, skip_empty_lines, token, the read_ functions and
/// next_statement follow continuations; skip_blanks, next_line and rest_of_line stay on the physical line.
/// A comment ends at its own line end (a backslash in it continues nothing), and a backslash anywhere else
/// is an ordinary character. line() is always the physical line of the position, so an error names the
/// line its token is on; statement_line() is where the current statement started (begin_statement), for
/// errors about a statement as a whole.
#include <algorithm>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <system_error>

#include "multitri/errors.hpp"

namespace varmesh::detail {

enum class NumberStatus { kOk, kMalformed, kNotFinite, kOutOfRange };

inline const char* strip_plus(const char* first, const char* last) noexcept {
  // from_chars rejects a leading '+', which some writers emit.
  if (last - first >= 2 && first[0] == '+' && first[1] != '-' && first[1] != '+') return first + 1;
  return first;
}

/// Parses the whole of `s` as a finite float. Values below the smallest subnormal become (signed) zero.
inline NumberStatus parse_float(std::string_view s, float& out) noexcept {
  const char* last = s.data() + s.size();
  const char* first = strip_plus(s.data(), last);
  auto [ptr, ec] = std::from_chars(first, last, out);
  if (ec == std::errc::result_out_of_range) {
    // libstdc++ reports underflow as out of range too; tell it apart from overflow through double.
    double d = 0.0;
    auto [dptr, dec] = std::from_chars(first, last, d);
    if (dptr != last) return NumberStatus::kMalformed;
    if (dec == std::errc()) {
      if (std::fabs(d) > static_cast<double>(FLT_MAX)) return NumberStatus::kOutOfRange;
      out = static_cast<float>(d);
      return NumberStatus::kOk;
    }
    // Out of range even for double: the exponent's sign says which way.
    const char* e = first;
    while (e != last && *e != 'e' && *e != 'E') ++e;
    if (e + 1 < last && e[1] == '-') {
      out = *first == '-' ? -0.0f : 0.0f;
      return NumberStatus::kOk;
    }
    return NumberStatus::kOutOfRange;
  }
  if (ec != std::errc() || ptr != last) return NumberStatus::kMalformed;
  return std::isfinite(out) ? NumberStatus::kOk : NumberStatus::kNotFinite;
}

/// Parses the whole of `s` as a finite double.
inline NumberStatus parse_double(std::string_view s, double& out) noexcept {
  const char* last = s.data() + s.size();
  const char* first = strip_plus(s.data(), last);
  auto [ptr, ec] = std::from_chars(first, last, out);
  if (ec == std::errc::result_out_of_range) {
    if (ptr != last) return NumberStatus::kMalformed;
    const char* e = first;
    while (e != last && *e != 'e' && *e != 'E') ++e;
    if (e + 1 < last && e[1] == '-') {
      out = *first == '-' ? -0.0 : 0.0;
      return NumberStatus::kOk;
    }
    return NumberStatus::kOutOfRange;
  }
  if (ec != std::errc() || ptr != last) return NumberStatus::kMalformed;
  return std::isfinite(out) ? NumberStatus::kOk : NumberStatus::kNotFinite;
}

/// Parses the whole of `s` as a decimal integer that fits in int64.
inline NumberStatus parse_int(std::string_view s, std::int64_t& out) noexcept {
  const char* last = s.data() + s.size();
  const char* first = strip_plus(s.data(), last);
  auto [ptr, ec] = std::from_chars(first, last, out);
  if (ec == std::errc::result_out_of_range) return NumberStatus::kOutOfRange;
  if (ec != std::errc() || ptr != last) return NumberStatus::kMalformed;
  return NumberStatus::kOk;
}

/// A short printable excerpt of a token for error messages.
inline std::string quote(std::string_view s) {
  constexpr std::size_t kMax = 32;
  std::string out = "'";
  for (std::size_t i = 0; i < s.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    out += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
  }
  if (s.size() > kMax) out += "...";
  out += "'";
  return out;
}

/// The position of the first lone CR (one not followed by LF) in `text`, or npos. O(size).
///
/// LF files have no CR at all, and memchr says so at memory speed. From the first CR on, bytes are tested
/// in blocks with no exit inside a block, a loop the compiler vectorizes, so that a CRLF file costs about
/// what an LF file costs (a memchr call per line, to look at the byte after each CR, took three times as
/// long on a 47 MB OBJ).
inline std::size_t find_lone_cr(std::string_view text) noexcept {
  const std::size_t first = text.find('\r');
  if (first == std::string_view::npos) return first;
  const char* p = text.data();
  const std::size_t last = text.size() - 1;  // a CR there has no byte after it: it is lone
  constexpr std::size_t kBlock = 256;
  for (std::size_t i = first; i < last; i += kBlock) {
    const std::size_t end = std::min(i + kBlock, last);
    unsigned char lone = 0;
    for (std::size_t j = i; j < end; ++j) lone |= static_cast<unsigned char>((p[j] == '\r') & (p[j + 1] != '\n'));
    if (lone != 0)
      for (std::size_t j = i;; ++j)
        if (p[j] == '\r' && p[j + 1] != '\n') return j;
  }
  return p[last] == '\r' ? last : std::string_view::npos;
}

/// Returns `text` with every lone CR turned into LF, so that LF, CRLF and a lone CR each end one line for
/// TextCursor, also mixed in one file. Returns `text` itself when it has no lone CR (LF and CRLF files are
/// read in place), else a copy held in `storage`, which must outlive the result. Bytes keep their places,
/// so line numbers count each line end once and byte offsets stay those of the input. O(size).
inline std::string_view lone_cr_to_lf(std::string_view text, std::string& storage) {
  std::size_t cr = find_lone_cr(text);
  if (cr == std::string_view::npos) return text;
  storage.assign(text);
  for (; cr != std::string::npos; cr = storage.find('\r', cr + 1))
    if (cr + 1 == storage.size() || storage[cr + 1] != '\n') storage[cr] = '\n';
  return storage;
}

class TextCursor {
 public:
  /// `comment` (0 = none) starts a comment that runs to the end of the line when it begins a token;
  /// `continuations` follows backslash line continuations (see the file comment). The cursor refers to
  /// `text` and `file`, which must outlive it (a temporary file name does not compile).
  TextCursor(std::string_view text, const std::string& file, char comment = '\0', bool continuations = false) noexcept
      : begin_(text.data()), p_(text.data()), end_(text.data() + text.size()), file_(file), comment_(comment),
        continuations_(continuations) {}
  TextCursor(std::string_view text, const std::string&& file, char comment = '\0', bool continuations = false) = delete;

  bool at_end() const noexcept { return p_ == end_; }
  std::size_t line() const noexcept { return line_; }
  std::size_t offset() const noexcept { return static_cast<std::size_t>(p_ - begin_); }
  std::size_t remaining() const noexcept { return static_cast<std::size_t>(end_ - p_); }
  const std::string& file() const noexcept { return file_; }

  static bool is_blank(char c) noexcept { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

  /// Skips blanks on the current line (not the newline, nor a continuation).
  void skip_blanks() noexcept {
    while (p_ != end_ && is_blank(*p_)) ++p_;
  }

  /// True when only blanks or a comment remain on the current line; with continuations, moves past those
  /// first (so: when the statement has no token left).
  bool at_eol() noexcept {
    for (;;) {
      skip_blanks();
      if (p_ == end_ || *p_ == '\n' || (comment_ != '\0' && *p_ == comment_)) return true;
      // The common path pays one more test of the byte at hand: continuations are rare.
      if (*p_ != '\\' || !continuations_) [[likely]] return false;
      const char* after = continuation_end(p_);
      if (after == nullptr) return false;  // a backslash that begins a token
      line_ += after != end_ ? 1 : 0;
      p_ = after;
    }
  }

  /// Moves to the start of the next line (or the end of the text). Physical lines: a continuation at the
  /// end of the current line is not followed (see next_statement).
  void next_line() noexcept {
    const void* nl = std::memchr(p_, '\n', static_cast<std::size_t>(end_ - p_));
    if (nl == nullptr) {
      p_ = end_;
    } else {
      p_ = static_cast<const char*>(nl) + 1;
      ++line_;
    }
  }

  /// Moves past the rest of the current statement: to the start of the first line that the current one
  /// does not continue onto. Without continuations, next_line().
  void next_statement() noexcept {
    if (p_ != end_ && *p_ == '\n') {  // where a statement that was read to its end stops
      ++p_;
      ++line_;
      return;
    }
    if (continuations_) {
      // Most lines do not end in a backslash, as their last non-blank byte tells. One that does is
      // followed token by token, since a comment before that backslash makes it no continuation.
      const void* nl = std::memchr(p_, '\n', static_cast<std::size_t>(end_ - p_));
      const char* stop = nl ? static_cast<const char*>(nl) : end_;
      while (stop != p_ && is_blank(stop[-1])) --stop;
      if (stop != p_ && stop[-1] == '\\')
        while (!at_eol()) token();
    }
    next_line();
  }

  /// Marks the current line as the start of a statement, for statement_line() and the errors about a
  /// missing token.
  void begin_statement() noexcept { statement_line_ = line_; }
  /// The line given to begin_statement(); line() when it was never called.
  std::size_t statement_line() const noexcept { return statement_line_ != 0 ? statement_line_ : line_; }

  /// Skips blank and comment-only lines; false when the text ends first.
  bool skip_empty_lines() noexcept {
    for (;;) {
      if (!at_eol()) return true;
      if (p_ == end_) return false;
      next_line();
    }
  }

  /// The next token of the current line; empty at the end of the line.
  std::string_view token() noexcept {
    if (at_eol()) return {};
    const char* start = p_;
    while (p_ != end_ && !is_blank(*p_) && *p_ != '\n') ++p_;
    // A continuation glued to the token is not part of it: leave it for at_eol. (A token that is a lone
    // backslash is not a continuation, or at_eol would have taken it.)
    if (p_[-1] == '\\' && continuations_ && p_ - start > 1 && continuation_end(p_ - 1) != nullptr) [[unlikely]]
      --p_;
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  /// The next token, crossing line ends (and comment lines); empty at the end of the text.
  std::string_view token_any_line() noexcept {
    if (!skip_empty_lines()) return {};
    return token();
  }

  /// The rest of the current line, without the line end, trimmed of trailing blanks.
  std::string_view rest_of_line() noexcept {
    skip_blanks();
    const char* start = p_;
    const void* nl = std::memchr(p_, '\n', static_cast<std::size_t>(end_ - p_));
    const char* stop = nl ? static_cast<const char*>(nl) : end_;
    p_ = stop;
    while (stop != start && is_blank(stop[-1])) --stop;
    return {start, static_cast<std::size_t>(stop - start)};
  }

  [[noreturn]] void fail(const std::string& reason) const { throw IoError(file_, reason, line_); }
  /// Throws naming statement_line(): for an error about a statement as a whole.
  [[noreturn]] void fail_statement(const std::string& reason) const { throw IoError(file_, reason, statement_line()); }

  /// Throws for a token that did not parse: names the token and what was expected. A missing token is the
  /// statement's fault, named at statement_line().
  [[noreturn]] void fail_number(NumberStatus status, std::string_view tok, const char* what) const {
    if (tok.empty()) fail_statement(std::string("missing ") + what + (p_ == end_ ? " (file truncated?)" : ""));
    switch (status) {
      case NumberStatus::kNotFinite: fail(std::string(what) + " is not finite: " + quote(tok));
      case NumberStatus::kOutOfRange: fail(std::string(what) + " is out of range: " + quote(tok));
      default: fail(std::string("bad number ") + quote(tok) + " for " + what);
    }
  }

  /// Reads the next token of the line as a finite float.
  float read_float(const char* what) {
    const std::string_view tok = token();
    float v = 0.0f;
    const NumberStatus s = tok.empty() ? NumberStatus::kMalformed : parse_float(tok, v);
    if (s != NumberStatus::kOk) fail_number(s, tok, what);
    return v;
  }

  /// Reads the next token of the line as a finite double.
  double read_double(const char* what) {
    const std::string_view tok = token();
    double v = 0.0;
    const NumberStatus s = tok.empty() ? NumberStatus::kMalformed : parse_double(tok, v);
    if (s != NumberStatus::kOk) fail_number(s, tok, what);
    return v;
  }

  /// Reads the next token of the line as an integer.
  std::int64_t read_int(const char* what) {
    const std::string_view tok = token();
    std::int64_t v = 0;
    const NumberStatus s = tok.empty() ? NumberStatus::kMalformed : parse_int(tok, v);
    if (s != NumberStatus::kOk) fail_number(s, tok, what);
    return v;
  }

 private:
  // For a backslash at `backslash`: the position after the line end it continues over (end_ at the end of
  // the text), or nullptr when something other than blanks follows it on its line.
  const char* continuation_end(const char* backslash) const noexcept {
    const char* q = backslash + 1;
    while (q != end_ && is_blank(*q)) ++q;
    if (q == end_) return q;
    return *q == '\n' ? q + 1 : nullptr;
  }

  const char* begin_;
  const char* p_;
  const char* end_;
  const std::string& file_;
  char comment_;
  bool continuations_;
  std::size_t line_ = 1;
  std::size_t statement_line_ = 0;  // 0: no statement begun
};

}  // namespace varmesh::detail
