// Stanford PLY reading and writing (ascii, binary_little_endian, binary_big_endian).
//
// The header is text (errors name its line); the body is read by one element loop templated on the value
// source, so ascii (line numbers) and binary (byte offsets) share the decoding of vertices, faces and
// triangle strips. Before anything is allocated, the minimum body size implied by the header's counts is
// compared with the actual body size, so a header that promises 10^12 vertices fails at once.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <string>
#include <vector>

#include "multitri/detail/mesh_io_formats.hpp"
#include "multitri/detail/number_format.hpp"
#include "multitri/detail/text_cursor.hpp"
#include "multitri/errors.hpp"

namespace varmesh::detail {
namespace {

enum class PlyType : std::uint8_t { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::kI8:
    case PlyType::kU8: return 1;
    case PlyType::kI16:
    case PlyType::kU16: return 2;
    case PlyType::kI32:
    case PlyType::kU32:
    case PlyType::kF32: return 4;
    case PlyType::kF64: return 8;
  }
  return 0;
}

bool is_integer(PlyType t) { return t != PlyType::kF32 && t != PlyType::kF64; }

bool parse_type(std::string_view s, PlyType& t) {
  struct Name {
    const char* name;
    PlyType type;
  };
  static constexpr Name kNames[] = {
      {"char", PlyType::kI8},    {"int8", PlyType::kI8},     {"uchar", PlyType::kU8},    {"uint8", PlyType::kU8},
      {"short", PlyType::kI16},  {"int16", PlyType::kI16},   {"ushort", PlyType::kU16},  {"uint16", PlyType::kU16},
      {"int", PlyType::kI32},    {"int32", PlyType::kI32},   {"uint", PlyType::kU32},    {"uint32", PlyType::kU32},
      {"float", PlyType::kF32},  {"float32", PlyType::kF32}, {"double", PlyType::kF64},  {"float64", PlyType::kF64},
  };
  for (const Name& n : kNames)
    if (s == n.name) {
      t = n.type;
      return true;
    }
  return false;
}

// Range of an integer type, for ascii values and colour scaling.
void integer_range(PlyType t, std::int64_t& lo, std::int64_t& hi) {
  switch (t) {
    case PlyType::kI8: lo = INT8_MIN, hi = INT8_MAX; return;
    case PlyType::kU8: lo = 0, hi = UINT8_MAX; return;
    case PlyType::kI16: lo = INT16_MIN, hi = INT16_MAX; return;
    case PlyType::kU16: lo = 0, hi = UINT16_MAX; return;
    case PlyType::kI32: lo = INT32_MIN, hi = INT32_MAX; return;
    default: lo = 0, hi = UINT32_MAX; return;
  }
}

// What a property feeds; kSkip properties are read past.
enum class Role : std::uint8_t { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kU, kV, kIndices, kSkip };
constexpr int kNumValueRoles = 11;  // kX..kV

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kF32;  // the item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::kU8;
  Role role = Role::kSkip;
  float divisor = 1.0f;  // colours stored as integers are divided by their full scale
  std::size_t line = 0;
};

enum class ElementKind { kOther, kVertex, kFace, kStrips };

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::size_t line = 0;
  ElementKind kind = ElementKind::kOther;
  std::vector<PlyProperty> props;
};

enum class PlyFormat { kAscii, kBinaryLe, kBinaryBe };

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;
  std::size_t body_line = 1;        // first line of an ascii body
  std::size_t end_header_line = 0;
  const PlyElement* vertex = nullptr;
};

// The extent of the header text, found before it is parsed so that line ends can be unified in it
// without touching a binary body: lines end at LF, CRLF or a lone CR, and the header runs to the line end
// of the first line whose first token is end_header (to the end of the data when there is none, and
// parse_header then says so).
struct HeaderExtent {
  std::size_t size = 0;       // bytes up to and including the end_header line's line end
  bool ends_in_crlf = false;  // that line end is CR LF
  bool lf_before = false;     // some earlier header line ends in LF or CR LF
};

HeaderExtent find_header_extent(std::string_view data) {
  HeaderExtent e;
  std::size_t pos = 0;
  while (pos < data.size()) {
    std::size_t first = pos;
    while (first < data.size() && data[first] != '\r' && TextCursor::is_blank(data[first])) ++first;
    std::size_t eol = first;
    while (eol < data.size() && data[eol] != '\n' && data[eol] != '\r') ++eol;
    const std::string_view line = data.substr(first, eol - first);
    constexpr std::string_view kEnd = "end_header";
    const bool is_end = line.substr(0, kEnd.size()) == kEnd &&
                        (line.size() == kEnd.size() || TextCursor::is_blank(line[kEnd.size()]));
    const bool crlf = eol + 1 < data.size() && data[eol] == '\r' && data[eol + 1] == '\n';
    const std::size_t next = eol == data.size() ? eol : eol + (crlf ? 2 : 1);
    if (is_end) {
      e.size = next;
      e.ends_in_crlf = crlf;
      return e;
    }
    e.lf_before = e.lf_before || (next > eol && data[next - 1] == '\n');
    pos = next;
  }
  e.size = data.size();
  return e;
}

PlyHeader parse_header(const std::string& path, std::string_view data) {
  TextCursor cur(data, path);
  PlyHeader h;
  if (cur.token() != "ply" || !cur.at_eol()) cur.fail("not a PLY file (the first line must be 'ply')");
  cur.next_line();
  bool have_format = false;
  for (;;) {
    if (!cur.skip_empty_lines()) cur.fail("the header has no end_header line");
    const std::size_t line = cur.line();
    const std::string_view key = cur.token();
    if (key == "comment" || key == "obj_info") {
      cur.next_line();
      continue;
    }
    if (key == "end_header") {
      if (!cur.at_eol()) cur.fail("unexpected text after end_header");
      h.end_header_line = line;
      cur.next_line();
      h.body_offset = cur.offset();
      h.body_line = cur.line();
      break;
    }
    if (key == "format") {
      const std::string_view fmt = cur.token();
      if (fmt == "ascii") h.format = PlyFormat::kAscii;
      else if (fmt == "binary_little_endian") h.format = PlyFormat::kBinaryLe;
      else if (fmt == "binary_big_endian") h.format = PlyFormat::kBinaryBe;
      else cur.fail("unsupported PLY format " + quote(fmt));
      // 1.0 is the only version there is; a file that says otherwise was written for a format this
      // reader does not know, and guessing would misread it.
      const std::string_view version = cur.token();
      if (version.empty()) cur.fail("the format line has no version");
      double v = 0.0;
      if (parse_double(version, v) != NumberStatus::kOk || v != 1.0)
        cur.fail("unsupported PLY format version " + quote(version) + " (only 1.0 is supported)");
      if (!cur.at_eol()) cur.fail("unexpected text on the format line");
      have_format = true;
    } else if (key == "element") {
      PlyElement el;
      el.name = std::string(cur.token());
      if (el.name.empty()) cur.fail("element without a name");
      const std::string_view count = cur.token();
      std::int64_t n = 0;
      const NumberStatus s = count.empty() ? NumberStatus::kMalformed : parse_int(count, n);
      if (s != NumberStatus::kOk) cur.fail_number(s, count, "element count");
      if (n < 0) cur.fail("negative element count " + quote(count));
      if (!cur.at_eol()) cur.fail("unexpected text on the element line");
      el.count = static_cast<std::uint64_t>(n);
      el.line = line;
      h.elements.push_back(std::move(el));
    } else if (key == "property") {
      if (h.elements.empty()) cur.fail("property before any element");
      PlyProperty prop;
      prop.line = line;
      std::string_view type = cur.token();
      if (type == "list") {
        prop.is_list = true;
        const std::string_view ct = cur.token();
        if (!parse_type(ct, prop.count_type)) cur.fail("unknown list count type " + quote(ct));
        if (!is_integer(prop.count_type)) cur.fail("list count type must be an integer type, not " + quote(ct));
        type = cur.token();
      }
      if (!parse_type(type, prop.type)) cur.fail("unknown property type " + quote(type));
      prop.name = std::string(cur.token());
      if (prop.name.empty()) cur.fail("property without a name");
      if (!cur.at_eol()) cur.fail("unexpected text on the property line");
      h.elements.back().props.push_back(std::move(prop));
    } else {
      cur.fail("unknown header line " + quote(key));
    }
    cur.next_line();
  }
  if (!have_format) throw IoError(path, "the header has no format line", h.end_header_line);
  return h;
}

// Marks the properties the reader uses and checks their types and multiplicity.
void assign_roles(const std::string& path, PlyHeader& h) {
  for (PlyElement& el : h.elements) {
    auto find = [&](const char* name) -> PlyProperty* {
      for (PlyProperty& p : el.props)
        if (p.name == name) return &p;
      return nullptr;
    };
    auto scalar = [&](PlyProperty* p, Role role) {
      if (p->is_list) throw IoError(path, "property '" + p->name + "' must be a scalar, not a list", p->line);
      p->role = role;
    };
    if (el.name == "vertex") {
      if (h.vertex != nullptr) throw IoError(path, "a second vertex element", el.line);
      el.kind = ElementKind::kVertex;
      h.vertex = &el;
      const char* xyz[3] = {"x", "y", "z"};
      for (int k = 0; k < 3; ++k) {
        PlyProperty* p = find(xyz[k]);
        if (p == nullptr) throw IoError(path, std::string("element vertex has no property '") + xyz[k] + "'", el.line);
        scalar(p, static_cast<Role>(static_cast<int>(Role::kX) + k));
      }
      // Optional groups: all of a group or none of it.
      auto group = [&](std::initializer_list<const char*> names, Role first) {
        std::vector<PlyProperty*> found;
        for (const char* n : names) found.push_back(find(n));
        const auto present = std::count_if(found.begin(), found.end(), [](PlyProperty* p) { return p != nullptr; });
        if (present == 0) return false;
        if (present != static_cast<long>(found.size())) {
          for (PlyProperty* p : found)
            if (p != nullptr)
              throw IoError(path, "vertex property '" + p->name + "' without the rest of its group", p->line);
        }
        for (std::size_t k = 0; k < found.size(); ++k)
          scalar(found[k], static_cast<Role>(static_cast<int>(first) + static_cast<int>(k)));
        return true;
      };
      group({"nx", "ny", "nz"}, Role::kNx);
      if (!group({"red", "green", "blue"}, Role::kRed))
        group({"diffuse_red", "diffuse_green", "diffuse_blue"}, Role::kRed);
      if (!group({"u", "v"}, Role::kU) && !group({"s", "t"}, Role::kU) && !group({"texture_u", "texture_v"}, Role::kU))
        group({"texture_s", "texture_t"}, Role::kU);
      for (PlyProperty& p : el.props) {
        if (p.role < Role::kRed || p.role > Role::kBlue) continue;
        if (p.type == PlyType::kU16) p.divisor = 65535.0f;
        else if (is_integer(p.type)) p.divisor = 255.0f;
      }
    } else if (el.name == "face" || el.name == "tristrips") {
      el.kind = el.name == "face" ? ElementKind::kFace : ElementKind::kStrips;
      PlyProperty* p = find("vertex_indices");
      if (p == nullptr && el.kind == ElementKind::kFace) p = find("vertex_index");
      if (p == nullptr) throw IoError(path, "element " + el.name + " has no vertex_indices list", el.line);
      if (!p->is_list) throw IoError(path, "property '" + p->name + "' must be a list", p->line);
      if (!is_integer(p->type)) throw IoError(path, "vertex indices must have an integer type", p->line);
      p->role = Role::kIndices;
    }
  }
}

// Binary: every scalar has its size and every list at least its count. Ascii: every value at least one
// character and one separator (the very last one needs no separator).
void check_body_size(const std::string& path, const PlyHeader& h, std::uint64_t body_size) {
  const bool ascii = h.format == PlyFormat::kAscii;
  std::uint64_t total = 0;
  for (const PlyElement& el : h.elements) {
    std::uint64_t per = 0;
    for (const PlyProperty& p : el.props) per += ascii ? 2 : type_size(p.is_list ? p.count_type : p.type);
    total = sat_add(total, sat_mul(el.count, per));
    if (total > body_size + (ascii ? 1 : 0))
      throw IoError(path,
                    "element " + el.name + " count " + std::to_string(el.count) +
                        " is larger than the file can hold (the body needs at least " + std::to_string(total) +
                        " bytes, it has " + std::to_string(body_size) + ")",
                    el.line);
  }
}

template <class T>
T load(const unsigned char* p, bool swap) {
  std::array<unsigned char, sizeof(T)> b;
  std::memcpy(b.data(), p, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  return std::bit_cast<T>(b);
}

// Unchecked loads; the caller has made sure the bytes are there.
std::int64_t integer_at(const unsigned char* q, PlyType t, bool swap) {
  switch (t) {
    case PlyType::kI8: return static_cast<std::int8_t>(*q);
    case PlyType::kU8: return *q;
    case PlyType::kI16: return load<std::int16_t>(q, swap);
    case PlyType::kU16: return load<std::uint16_t>(q, swap);
    case PlyType::kI32: return load<std::int32_t>(q, swap);
    case PlyType::kU32: return load<std::uint32_t>(q, swap);
    default: return 0;  // the header check admits integer types only where integers are read
  }
}

double real_at(const unsigned char* q, PlyType t, bool swap) {
  switch (t) {
    case PlyType::kF32: return load<float>(q, swap);
    case PlyType::kF64: return load<double>(q, swap);
    default: return static_cast<double>(integer_at(q, t, swap));
  }
}

class BinarySource {
 public:
  static constexpr bool kBinary = true;

  BinarySource(const std::string& path, std::string_view data, std::size_t body, bool big_endian)
      : path_(path),
        base_(reinterpret_cast<const unsigned char*>(data.data())),
        p_(base_ + body),
        end_(base_ + data.size()),
        swap_(big_endian != (std::endian::native == std::endian::big)) {}

  [[noreturn]] void fail(const std::string& reason) const { throw IoError(path_, reason, IoError::kNoLine, mark_); }
  // A binary body has no lines (ReadInfo's provenance says 0).
  std::size_t line() const { return 0; }

  double scalar(PlyType t, const char* what) { return real_at(take(type_size(t), what), t, swap_); }
  std::int64_t integer(PlyType t, const char* what) { return integer_at(take(type_size(t), what), t, swap_); }
  void skip_scalar(PlyType t) { take(type_size(t), "a skipped property"); }

  // A list of `n` items: the bytes of all of them are checked at once, so a huge count in a short file
  // fails here, and item() needs no check of its own.
  void begin_list(std::uint64_t n, PlyType t, const char* what) {
    const std::uint64_t bytes = sat_mul(n, type_size(t));
    if (static_cast<std::uint64_t>(end_ - p_) < bytes) truncated(bytes, what);
  }
  std::int64_t item(PlyType t, const char*) {
    mark_ = static_cast<std::uint64_t>(p_ - base_);
    const unsigned char* q = p_;
    p_ += type_size(t);
    return integer_at(q, t, swap_);
  }

  void skip_items(std::uint64_t n, PlyType t) { skip_bytes(sat_mul(n, type_size(t)), "a skipped list"); }

  // Elements whose properties are all scalars are skipped in one step.
  void skip_bytes(std::uint64_t n, const char* what) { p_ = take(n, what) + n; }

  // The body must end with the last element, as an ascii body must (AsciiSource::expect_end): bytes
  // after it mean the header's counts do not describe the body, and would be lost without a word. No
  // trailer is tolerated, not even a line end: none of the binary files at hand has one, and an LF or a
  // space is as much a byte of an undeclared element as any other.
  void expect_end() {
    if (p_ == end_) return;
    mark_ = static_cast<std::uint64_t>(p_ - base_);
    const std::uint64_t extra = static_cast<std::uint64_t>(end_ - p_);
    fail("data after the last element declared in the header: " + std::to_string(extra) +
         (extra == 1 ? " byte" : " bytes") + " after the last element (the file has " +
         std::to_string(end_ - base_) + " bytes)");
  }

 private:
  const unsigned char* take(std::uint64_t n, const char* what) {
    mark_ = static_cast<std::uint64_t>(p_ - base_);
    if (static_cast<std::uint64_t>(end_ - p_) < n) [[unlikely]]
      truncated(n, what);
    const unsigned char* q = p_;
    p_ += n;
    return q;
  }

  [[noreturn, gnu::cold, gnu::noinline]] void truncated(std::uint64_t n, const char* what) {
    mark_ = static_cast<std::uint64_t>(p_ - base_);
    fail(std::string("truncated body: ") + what + " needs " + std::to_string(n) + " bytes, " +
         std::to_string(end_ - p_) + " remain");
  }

  const std::string& path_;
  const unsigned char* base_;
  const unsigned char* p_;
  const unsigned char* end_;
  bool swap_;
  std::uint64_t mark_ = 0;
};

class AsciiSource {
 public:
  static constexpr bool kBinary = false;

  AsciiSource(const std::string& path, std::string_view data, std::size_t body, std::size_t body_line)
      : cur_(data.substr(body), path), first_line_(body_line) {}

  [[noreturn]] void fail(const std::string& reason) const {
    throw IoError(cur_.file(), reason, cur_.line() + first_line_ - 1);
  }
  // The line of the next value: values may be spread over lines in any way, so this is where the next
  // element starts when called before it.
  std::size_t line() {
    cur_.skip_empty_lines();
    return cur_.line() + first_line_ - 1;
  }

  double scalar(PlyType t, const char* what) {
    const std::string_view tok = next(what);
    if (t == PlyType::kF32) {
      float v = 0.0f;
      const NumberStatus s = parse_float(tok, v);
      return finish_real(s, tok, what, v);
    }
    if (t == PlyType::kF64) {
      double v = 0.0;
      const NumberStatus s = parse_double(tok, v);
      return finish_real(s, tok, what, v);
    }
    return static_cast<double>(integer_token(tok, t, what));
  }

  std::int64_t integer(PlyType t, const char* what) { return integer_token(next(what), t, what); }

  void skip_scalar(PlyType) { next("a skipped property"); }
  void begin_list(std::uint64_t, PlyType, const char*) {}
  std::int64_t item(PlyType t, const char* what) { return integer(t, what); }
  void skip_items(std::uint64_t n, PlyType) {
    for (std::uint64_t k = 0; k < n; ++k) next("a skipped list item");
  }

  // After the last element only blanks and empty lines may follow. Anything else means the header's
  // counts do not describe the body (a face more than announced, say), which would otherwise be lost
  // without a word.
  void expect_end() {
    const std::string_view tok = cur_.token_any_line();
    if (!tok.empty()) fail("data after the last element declared in the header: " + quote(tok));
  }

 private:
  std::string_view next(const char* what) {
    const std::string_view tok = cur_.token_any_line();
    if (tok.empty()) fail(std::string("truncated body: the file ends before ") + what);
    return tok;
  }

  double finish_real(NumberStatus s, std::string_view tok, const char* what, double v) const {
    if (s == NumberStatus::kMalformed) fail(std::string("bad number ") + quote(tok) + " for " + what);
    if (s == NumberStatus::kOutOfRange) return HUGE_VAL;  // the caller reports it as not finite
    return v;
  }

  std::int64_t integer_token(std::string_view tok, PlyType t, const char* what) const {
    std::int64_t v = 0;
    const NumberStatus s = parse_int(tok, v);
    if (s != NumberStatus::kOk) fail(std::string("bad integer ") + quote(tok) + " for " + what);
    std::int64_t lo, hi;
    integer_range(t, lo, hi);
    if (v < lo || v > hi) fail("value " + quote(tok) + " for " + what + " is out of range for its type");
    return v;
  }

  TextCursor cur_;
  std::size_t first_line_;
};

class BodyReader {
 public:
  BodyReader(const std::string& path, const PlyHeader& h, TriMesh& mesh, ReadInfo& info)
      : path_(path), h_(h), mesh_(mesh), info_(info) {
    nv_ = h.vertex->count;
  }

  template <class Src>
  void read(Src& src) {
    for (const PlyElement& el : h_.elements) {
      switch (el.kind) {
        case ElementKind::kVertex: read_vertices(src, el); break;
        case ElementKind::kFace: read_faces(src, el, false); break;
        case ElementKind::kStrips: read_faces(src, el, true); break;
        case ElementKind::kOther: skip_element(src, el); break;
      }
    }
  }

 private:
  template <class Src>
  void skip_list(Src& src, const PlyProperty& p) {
    const std::int64_t n = src.integer(p.count_type, "a list count");
    if (n < 0) src.fail("negative list count " + std::to_string(n) + " in property '" + p.name + "'");
    src.skip_items(static_cast<std::uint64_t>(n), p.type);
  }

  template <class Src>
  void skip_element(Src& src, const PlyElement& el) {
    if (el.props.empty()) return;  // a count with nothing to read: no bytes, and no loop over the count
    if constexpr (Src::kBinary) {
      std::uint64_t size = 0;
      bool fixed = true;
      for (const PlyProperty& p : el.props) {
        fixed = fixed && !p.is_list;
        size += type_size(p.type);
      }
      if (fixed) {
        src.skip_bytes(sat_mul(size, el.count), "a skipped element");
        return;
      }
    }
    for (std::uint64_t i = 0; i < el.count; ++i)
      for (const PlyProperty& p : el.props) {
        if (p.is_list) skip_list(src, p);
        else src.skip_scalar(p.type);
      }
  }

  template <class Src>
  void read_vertices(Src& src, const PlyElement& el) {
    float vals[kNumValueRoles] = {};
    for (std::uint64_t i = 0; i < el.count; ++i) {
      if (info_.want_sources) info_.vertex_lines.push_back(src.line());
      for (const PlyProperty& p : el.props) {
        if (p.is_list) {
          skip_list(src, p);
          continue;
        }
        if (p.role == Role::kSkip) {
          src.skip_scalar(p.type);
          continue;
        }
        const double d = src.scalar(p.type, "a vertex property");
        float f = static_cast<float>(d);
        if (!std::isfinite(f)) src.fail("vertex " + std::to_string(i) + ": '" + p.name + "' is not finite");
        if (p.role >= Role::kRed && p.role <= Role::kBlue) {
          if (p.divisor != 1.0f) {
            if (d < 0.0 || d > static_cast<double>(p.divisor))
              src.fail("vertex " + std::to_string(i) + ": colour '" + p.name + "' is out of range");
            f /= p.divisor;
          } else if (!(f >= 0.0f && f <= 1.0f)) {
            src.fail("vertex " + std::to_string(i) + ": float colour '" + p.name + "' is outside [0, 1]");
          }
        }
        vals[static_cast<int>(p.role)] = f;
      }
      mesh_.positions[i] = {vals[0], vals[1], vals[2]};
      if (!mesh_.normals.empty()) mesh_.normals[i] = {vals[3], vals[4], vals[5]};
      if (!mesh_.colors.empty()) mesh_.colors[i] = {vals[6], vals[7], vals[8]};
      if (!mesh_.texcoords.empty()) mesh_.texcoords[i] = {vals[9], vals[10]};
    }
  }

  template <class Src>
  Index read_index(Src& src, const PlyProperty& p, std::uint64_t element, bool strip) {
    const std::int64_t v = src.item(p.type, "a vertex index");
    if (v < 0 || static_cast<std::uint64_t>(v) >= nv_) {
      if (strip && v == -1) return kInvalid;  // restart
      src.fail(std::string(strip ? "strip " : "face ") + std::to_string(element) + ": vertex index " +
               std::to_string(v) + " out of range (" + std::to_string(nv_) + " vertices)");
    }
    return static_cast<Index>(v);
  }

  template <class Src>
  void read_faces(Src& src, const PlyElement& el, bool strips) {
    for (std::uint64_t i = 0; i < el.count; ++i) {
      const std::size_t line = info_.want_sources ? src.line() : 0;
      const std::size_t triangles_before = info_.want_sources ? mesh_.indices.size() / 3 : 0;
      std::uint64_t corners = 0;
      for (const PlyProperty& p : el.props) {
        if (p.role != Role::kIndices) {
          if (p.is_list) skip_list(src, p);
          else src.skip_scalar(p.type);
          continue;
        }
        const std::int64_t n = src.integer(p.count_type, "a list count");
        if (n < 0) src.fail("negative list count " + std::to_string(n) + " in '" + p.name + "'");
        src.begin_list(static_cast<std::uint64_t>(n), p.type, strips ? "a triangle strip" : "a face");
        if (strips) read_strip(src, p, i, static_cast<std::uint64_t>(n));
        else read_polygon(src, p, i, n);
        corners = strips ? 0 : static_cast<std::uint64_t>(n);
      }
      // A strip owns the triangles it kept, none of them when all were degenerate.
      if (info_.want_sources) add_face_source(path_, info_, line, corners, mesh_.indices.size() / 3 - triangles_before);
    }
  }

  template <class Src>
  void read_polygon(Src& src, const PlyProperty& p, std::uint64_t face, std::int64_t n) {
    if (n < 3) src.fail("face " + std::to_string(face) + " has " + std::to_string(n) + " corners (at least 3 needed)");
    if (n > 3) ++info_.polygons_triangulated;
    const Index first = read_index(src, p, face, false);
    Index prev = read_index(src, p, face, false);
    for (std::int64_t k = 2; k < n; ++k) {
      const Index cur = read_index(src, p, face, false);
      mesh_.indices.push_back(first);
      mesh_.indices.push_back(prev);
      mesh_.indices.push_back(cur);
      prev = cur;
    }
  }

  // Strip triangle i is (s[i], s[i+1], s[i+2]) for even i and (s[i+1], s[i], s[i+2]) for odd i, so every
  // triangle keeps the strip's orientation; i restarts at 0 after each -1. Triangles with a repeated
  // vertex (the swaps that join strips) are dropped and counted.
  template <class Src>
  void read_strip(Src& src, const PlyProperty& p, std::uint64_t element, std::uint64_t n) {
    Index a = kInvalid, b = kInvalid;  // s[i], s[i+1]
    std::uint64_t in_strip = 0;
    for (std::uint64_t k = 0; k < n; ++k) {
      const Index c = read_index(src, p, element, true);
      if (c == kInvalid) {
        in_strip = 0;
        continue;
      }
      if (in_strip >= 2) {
        if (a == b || b == c || a == c) {
          ++info_.strip_degenerates_dropped;
        } else {
          const bool odd = (in_strip - 2) % 2 == 1;
          mesh_.indices.push_back(odd ? b : a);
          mesh_.indices.push_back(odd ? a : b);
          mesh_.indices.push_back(c);
        }
      }
      a = b;
      b = c;
      ++in_strip;
    }
  }

  const std::string& path_;
  const PlyHeader& h_;
  TriMesh& mesh_;
  ReadInfo& info_;
  std::uint64_t nv_ = 0;
};

template <class T>
void put_le(char*& out, T v) {
  auto b = std::bit_cast<std::array<char, sizeof(T)>>(v);
  if constexpr (std::endian::native == std::endian::big) std::reverse(b.begin(), b.end());
  std::memcpy(out, b.data(), sizeof(T));
  out += sizeof(T);
}

std::uint8_t to_uchar(float c) { return static_cast<std::uint8_t>(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f)); }

}  // namespace

TriMesh read_ply(const std::string& path, std::string_view data, ReadInfo& info) {
  // Header lines may end in LF, CRLF or a lone CR (classic Mac OS), as in OBJ and OFF. Only the header
  // text is unified; a binary body is read from `data` as it is.
  const HeaderExtent extent = find_header_extent(data);
  std::string header_storage;
  PlyHeader h = parse_header(path, lone_cr_to_lf(data.substr(0, extent.size), header_storage));
  // A binary body starts right after the end_header line's line end: LF, CR LF, or a lone CR. CR LF is
  // ambiguous only in a header written with lone CRs, where the CR alone ends the line and the LF is the
  // body's first byte (a 10 in the first value); a header with no LF at all is taken to be such a file.
  if (h.format != PlyFormat::kAscii && extent.ends_in_crlf && !extent.lf_before) --h.body_offset;
  assign_roles(path, h);
  if (h.vertex == nullptr) throw IoError(path, "the header has no vertex element", h.end_header_line);
  check_body_size(path, h, data.size() - h.body_offset);
  if (h.vertex->count >= kInvalid)
    throw IoError(path, "vertex count " + std::to_string(h.vertex->count) + " exceeds 32-bit indices", h.vertex->line);
  std::uint64_t face_lists = 0;
  const PlyElement* first_face = nullptr;
  for (const PlyElement& el : h.elements)
    if (el.kind == ElementKind::kFace || el.kind == ElementKind::kStrips) {
      face_lists += el.count;
      if (first_face == nullptr) first_face = &el;
    }
  if (face_lists == 0)
    throw IoError(path, "no faces (empty mesh): no face or tristrips element with a nonzero count",
                  first_face ? first_face->line : h.end_header_line);

  TriMesh mesh;
  const std::size_t nv = static_cast<std::size_t>(h.vertex->count);
  mesh.positions.resize(nv);
  bool normals = false, colors = false, texcoords = false;
  for (const PlyProperty& p : h.vertex->props) {
    normals = normals || p.role == Role::kNx;
    colors = colors || p.role == Role::kRed;
    texcoords = texcoords || p.role == Role::kU;
  }
  if (normals) mesh.normals.resize(nv);
  if (colors) mesh.colors.resize(nv);
  if (texcoords) mesh.texcoords.resize(nv);
  // A triangle takes at least 4 bytes of the body (a list count and three indices of one byte each), so the
  // reservation stays within 3 x the file size whatever count the header claims (check_body_size only knows
  // that each list has its count).
  const std::uint64_t most_triangles = data.size() / 4;
  for (const PlyElement& el : h.elements)
    if (el.kind == ElementKind::kFace)
      mesh.indices.reserve(mesh.indices.size() + static_cast<std::size_t>(std::min(el.count, most_triangles)) * 3);

  info.first_vertex_number = 0;
  BodyReader reader(path, h, mesh, info);
  if (h.format == PlyFormat::kAscii) {
    std::string body_storage;
    AsciiSource src(path, lone_cr_to_lf(data.substr(h.body_offset), body_storage), 0, h.body_line);
    reader.read(src);
    src.expect_end();
  } else {
    BinarySource src(path, data, h.body_offset, h.format == PlyFormat::kBinaryBe);
    reader.read(src);
    src.expect_end();
  }
  if (mesh.indices.empty())
    throw IoError(path, "no faces (empty mesh): every triangle strip was degenerate", first_face->line);
  return mesh;
}

std::string format_ply(const TriMesh& mesh, bool binary) {
  const std::size_t nv = mesh.num_vertices(), nf = mesh.num_faces();
  const bool normals = mesh.has_normals(), colors = mesh.has_colors(), texcoords = mesh.has_texcoords();
  // int is what most readers expect for indices; uint only when the vertex count needs it.
  const bool uint_indices = nv > static_cast<std::size_t>(INT32_MAX);
  std::string out = "ply\nformat ";
  out += binary ? "binary_little_endian" : "ascii";
  out += " 1.0\ncomment varmesh\nelement vertex ";
  append_uint(out, nv);
  out += "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  if (colors) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (texcoords) out += "property float u\nproperty float v\n";
  out += "element face ";
  append_uint(out, nf);
  out += uint_indices ? "\nproperty list uchar uint vertex_indices\nend_header\n"
                      : "\nproperty list uchar int vertex_indices\nend_header\n";

  if (binary) {
    const std::size_t vsize = 12 + (normals ? 12 : 0) + (colors ? 3 : 0) + (texcoords ? 8 : 0);
    const std::size_t header = out.size();
    out.resize(header + nv * vsize + nf * 13);
    char* w = out.data() + header;
    for (std::size_t v = 0; v < nv; ++v) {
      put_le(w, mesh.positions[v].x);
      put_le(w, mesh.positions[v].y);
      put_le(w, mesh.positions[v].z);
      if (normals) {
        put_le(w, mesh.normals[v].x);
        put_le(w, mesh.normals[v].y);
        put_le(w, mesh.normals[v].z);
      }
      if (colors) {
        put_le(w, to_uchar(mesh.colors[v].x));
        put_le(w, to_uchar(mesh.colors[v].y));
        put_le(w, to_uchar(mesh.colors[v].z));
      }
      if (texcoords) {
        put_le(w, mesh.texcoords[v].x);
        put_le(w, mesh.texcoords[v].y);
      }
    }
    for (std::size_t f = 0; f < nf; ++f) {
      put_le(w, std::uint8_t{3});
      for (int k = 0; k < 3; ++k) put_le(w, mesh.corner(f, k));  // same bytes as int below 2^31
    }
    return out;
  }

  out.reserve(out.size() + nv * 40 + nf * 24);
  for (std::size_t v = 0; v < nv; ++v) {
    append_vec3(out, mesh.positions[v]);
    if (normals) {
      out += ' ';
      append_vec3(out, mesh.normals[v]);
    }
    if (colors) {
      const glm::vec3& c = mesh.colors[v];
      out += ' ';
      append_uint(out, to_uchar(c.x));
      out += ' ';
      append_uint(out, to_uchar(c.y));
      out += ' ';
      append_uint(out, to_uchar(c.z));
    }
    if (texcoords) {
      out += ' ';
      append_float(out, mesh.texcoords[v].x);
      out += ' ';
      append_float(out, mesh.texcoords[v].y);
    }
    out += '\n';
  }
  append_triangle_lines(out, mesh);
  return out;
}

}  // namespace varmesh::detail
