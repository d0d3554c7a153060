#include "multitri/tar_archive.hpp"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <vector>

#include "multitri/errors.hpp"

// The header layout is POSIX.1-1988 ustar (IEEE Std 1003.1, "pax" chapter): 512-byte blocks, a header
// block per member, its data padded to whole blocks, two zero blocks at the end.

namespace varmesh {
namespace {

constexpr std::size_t kBlock = 512;

// Sequential reads through zlib's gz* interface, which passes files that are not gzip through unchanged.
class GzStream {
 public:
  explicit GzStream(const std::string& path) : path_(path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw IoError(path, "is a folder, not an archive");
    file_ = gzopen(path.c_str(), "rb");
    if (file_ == nullptr) throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
    gzbuffer(file_, 1u << 17);
  }
  GzStream(const GzStream&) = delete;
  GzStream& operator=(const GzStream&) = delete;
  ~GzStream() { gzclose(file_); }

  // Reads up to n bytes; fewer only at the end of the stream. Throws on a corrupt or unreadable stream.
  std::size_t read(char* out, std::size_t n) {
    std::size_t done = 0;
    while (done < n) {
      const auto chunk = static_cast<unsigned>(std::min<std::size_t>(n - done, INT_MAX / 2));
      const int got = gzread(file_, out + done, chunk);
      if (got < 0) {
        int code = Z_OK;
        const char* msg = gzerror(file_, &code);
        throw IoError(path_, std::string("cannot decompress: ") + (msg != nullptr ? msg : "zlib error"),
                      IoError::kNoLine, offset_ + done);
      }
      if (got == 0) break;
      done += static_cast<std::size_t>(got);
    }
    offset_ += done;
    return done;
  }

  void read_exactly(char* out, std::size_t n, const char* what) {
    const std::uint64_t at = offset_;
    if (read(out, n) != n) throw IoError(path_, std::string("archive ends inside ") + what, IoError::kNoLine, at);
  }

  void skip(std::uint64_t n, const char* what) {
    std::array<char, 1 << 16> scratch;
    while (n > 0) {
      const auto chunk = static_cast<std::size_t>(std::min<std::uint64_t>(n, scratch.size()));
      read_exactly(scratch.data(), chunk, what);
      n -= chunk;
    }
  }

  std::uint64_t offset() const { return offset_; }

 private:
  std::string path_;
  gzFile file_ = nullptr;
  std::uint64_t offset_ = 0;
};

std::uint64_t padded(std::uint64_t size) { return (size + kBlock - 1) / kBlock * kBlock; }

// A NUL-terminated field of at most `width` bytes.
std::string field(const char* block, std::size_t at, std::size_t width) {
  const char* begin = block + at;
  return std::string(begin, std::find(begin, begin + width, '\0'));
}

// An octal number, optionally led by spaces and ended by NUL or space; GNU tar's base-256 form (high bit
// of the first byte set) for sizes of 8 GiB and more. Returns false on anything else.
bool parse_number(const char* block, std::size_t at, std::size_t width, std::uint64_t& value) {
  const auto* f = reinterpret_cast<const unsigned char*>(block + at);
  value = 0;
  if ((f[0] & 0x80u) != 0) {
    if ((f[0] & 0x40u) != 0) return false;  // negative
    std::uint64_t v = f[0] & 0x3fu;
    for (std::size_t i = 1; i < width; ++i) {
      if (v > (UINT64_MAX >> 8)) return false;
      v = (v << 8) | f[i];
    }
    value = v;
    return true;
  }
  std::size_t i = 0;
  while (i < width && f[i] == ' ') ++i;
  bool any = false;
  for (; i < width && f[i] >= '0' && f[i] <= '7'; ++i) {
    if (value > (UINT64_MAX >> 3)) return false;
    value = (value << 3) | static_cast<std::uint64_t>(f[i] - '0');
    any = true;
  }
  for (; i < width; ++i)
    if (f[i] != ' ' && f[i] != '\0') return false;
  return any;
}

// The header checksum: the sum of its bytes with the checksum field read as spaces. Old archivers summed
// signed chars, so both sums are accepted.
bool checksum_ok(const char* block) {
  std::uint64_t stored = 0;
  if (!parse_number(block, 148, 8, stored)) return false;
  std::int64_t signed_sum = 0;
  std::uint64_t unsigned_sum = 0;
  for (std::size_t i = 0; i < kBlock; ++i) {
    const char c = (i >= 148 && i < 156) ? ' ' : block[i];
    signed_sum += static_cast<signed char>(c);
    unsigned_sum += static_cast<unsigned char>(c);
  }
  return stored == unsigned_sum || static_cast<std::int64_t>(stored) == signed_sum;
}

std::string_view without_dot_slash(std::string_view name) {
  while (name.size() >= 2 && name[0] == '.' && name[1] == '/') name.remove_prefix(2);
  return name;
}

// The `path` record of a pax extended header ("<length> <key>=<value>\n" records), if there is one.
std::optional<std::string> pax_path(const std::string& data) {
  std::size_t at = 0;
  std::optional<std::string> path;
  while (at < data.size()) {
    // The record's length (digits, then a space) counts the whole record, itself and the newline included.
    std::size_t len = 0;
    std::size_t i = at;
    for (; i < data.size() && data[i] >= '0' && data[i] <= '9'; ++i) {
      len = len * 10 + static_cast<std::size_t>(data[i] - '0');
      if (len > data.size()) return path;  // longer than the header: malformed, nothing more to read
    }
    if (len == 0 || at + len > data.size() || i >= data.size() || data[i] != ' ' || data[at + len - 1] != '\n') break;
    const std::string_view record(data.data() + i + 1, at + len - 1 - (i + 1));
    const std::size_t eq = record.find('=');
    if (eq != std::string_view::npos && record.substr(0, eq) == "path") path = std::string(record.substr(eq + 1));
    at += len;
  }
  return path;
}

}  // namespace

std::optional<std::string> read_tar_member(const std::string& archive, std::string_view member,
                                           std::uint64_t max_bytes) {
  GzStream in(archive);
  const std::string_view wanted = without_dot_slash(member);
  std::optional<std::string> long_name;  // from a GNU 'L' entry or a pax 'path' record, for the next member
  std::array<char, kBlock> block{};
  constexpr std::uint64_t kMaxNameBytes = 1 << 16;
  for (;;) {
    const std::uint64_t at = in.offset();
    const std::size_t got = in.read(block.data(), kBlock);
    if (got == 0) return std::nullopt;  // ended without the zero blocks: tolerated, as GNU tar does
    if (got != kBlock) throw IoError(archive, "archive ends inside a header", IoError::kNoLine, at);
    if (std::all_of(block.begin(), block.end(), [](char c) { return c == '\0'; })) return std::nullopt;
    if (!checksum_ok(block.data()))
      throw IoError(archive, "tar header checksum mismatch (not a tar archive, or a corrupt one)", IoError::kNoLine, at);
    std::uint64_t size = 0;
    if (!parse_number(block.data(), 124, 12, size))
      throw IoError(archive, "tar header with a malformed size field", IoError::kNoLine, at);
    const char type = block[156];

    if (type == 'L' || type == 'x') {
      if (size > kMaxNameBytes)
        throw IoError(archive, "tar extended header of " + std::to_string(size) + " bytes (more than 64 KiB)",
                      IoError::kNoLine, at);
      std::string data(static_cast<std::size_t>(size), '\0');
      in.read_exactly(data.data(), data.size(), "an extended header");
      in.skip(padded(size) - size, "an extended header");
      if (type == 'L') {
        long_name = data.substr(0, data.find('\0'));
      } else if (auto p = pax_path(data)) {
        long_name = std::move(p);
      }
      continue;
    }

    std::string name;
    if (long_name) {
      name = std::move(*long_name);
      long_name.reset();
    } else {
      name = field(block.data(), 0, 100);
      const bool ustar = std::memcmp(block.data() + 257, "ustar", 5) == 0;
      const std::string prefix = ustar ? field(block.data(), 345, 155) : std::string();
      if (!prefix.empty()) name = prefix + "/" + name;
    }
    const bool regular = type == '0' || type == '\0' || type == '7';
    if (regular && without_dot_slash(name) == wanted) {
      if (size > max_bytes)
        throw IoError(archive,
                      "member " + name + " holds " + std::to_string(size) + " bytes, more than the " +
                          std::to_string(max_bytes) + " allowed",
                      IoError::kNoLine, at);
      std::string data(static_cast<std::size_t>(size), '\0');
      in.read_exactly(data.data(), data.size(), ("member " + name).c_str());
      return data;
    }
    // Links, folders and devices carry no data in the archive whatever their size field says.
    const bool has_data = regular || type == 'g' || (type >= 'A' && type <= 'Z');
    if (has_data) in.skip(padded(size), "a member's data");
  }
}

}  // namespace varmesh
