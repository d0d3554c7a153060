// Binary file format of a vertex hierarchy (layout in hierarchy_io.hpp).
//
// Only the arrays the analysis produced are stored; the loader goes through VertexHierarchyBuilder::finish so
// that the derived arrays are recomputed rather than trusted, and the whole structure is re-validated.
// Every check that could be fooled by a corrupt count runs on the counts alone before a single array is
// allocated: a four-byte flip must never turn into a multi-gigabyte allocation. The checksum is CRC-32 with
// the reflected polynomial 0xEDB88320 (ISO-HDLC, as in zlib, PNG and gzip), which detects every error
// burst of up to 32 bits, so any single corrupted byte is caught.
#include "pm/hierarchy_io.hpp"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <type_traits>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"

namespace varmesh {

// The friend of VertexHierarchy that reads the stored arrays which have no public accessor of the right
// shape (the collapse records and bounds as arrays, the ring offsets, and whether `locked` is present).
struct HierarchyFileAccess {
  static const std::vector<CollapseRecord>& records(const VertexHierarchy& h) { return h.records_; }
  static const std::vector<ElementBound>& bounds(const VertexHierarchy& h) { return h.bounds_; }
  static const std::vector<Index>& ring_offsets(const VertexHierarchy& h) { return h.ring_offsets_; }
  static const std::vector<Index>& ring_items(const VertexHierarchy& h) { return h.ring_items_; }
  static const std::vector<std::uint8_t>& locked(const VertexHierarchy& h) { return h.locked_; }
};

namespace {

constexpr std::array<std::uint8_t, 8> kMagic{'V', 'M', 'P', 'M', 'H', 'I', 'E', 'R'};
constexpr std::uint32_t kFlagColors = 1u << 0;
constexpr std::uint32_t kFlagLocked = 1u << 1;
constexpr std::uint32_t kKnownFlags = kFlagColors | kFlagLocked;

constexpr std::uint64_t kOffVersion = 8, kOffFlags = 12, kOffSize = 16, kOffLeaves = 24, kOffCollapses = 32,
                        kOffFaces = 40, kOffRingItems = 48, kHeaderBytes = 56;
constexpr std::uint64_t kRecordWords = 10;   // vt, vu, vl_hat, vr_hat, fl_hat, fr_hat, fn[4]
constexpr std::uint64_t kBoundFloats = 9;    // centre xyz, radius, error, axis xyz, cos_half_angle
constexpr std::uint64_t kRepairFields = 9;
constexpr std::uint64_t kChecksumBytes = 4;

std::uint32_t load_le32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

// zlib's crc32 (the same CRC-32/ISO-HDLC the format names): it runs several times faster than a portable
// table-driven loop on a file-sized buffer, and zlib is already linked for PNG.
std::uint32_t crc32(std::span<const std::uint8_t> bytes) noexcept {
  return static_cast<std::uint32_t>(::crc32_z(::crc32_z(0L, Z_NULL, 0), bytes.data(), bytes.size()));
}

struct Counts {
  std::uint64_t leaves = 0, collapses = 0, faces = 0, ring_items = 0;
  bool colors = false, locked = false;
};

// Total file size for the counts. The caller guarantees each count is at most the file size (so below
// 2^63), which keeps every product below 2^64.
std::uint64_t file_size_for(const Counts& c) {
  const std::uint64_t nodes = c.leaves + c.collapses;
  std::uint64_t size = kHeaderBytes;
  size += nodes * 12;                          // positions
  if (c.colors) size += nodes * 12;            // colours
  size += c.collapses * kRecordWords * 4;      // records
  size += c.faces * 12;                        // faces
  size += nodes * kBoundFloats * 4;            // bounds
  size += (c.collapses + 1) * 4;               // ring offsets
  size += c.ring_items * 4;                    // ring items
  size += c.leaves * 4 + c.faces * 4;          // leaf_to_input, face_to_input
  if (c.locked) size += c.leaves;              // locked
  size += kRepairFields * 8 + kChecksumBytes;  // repair report, checksum
  return size;
}

std::string hex32(std::uint32_t v) {
  static const char* digits = "0123456789abcdef";
  std::string s = "0x";
  for (int k = 7; k >= 0; --k) s += digits[(v >> (4 * k)) & 0xFu];
  return s;
}

class ByteWriter {
 public:
  explicit ByteWriter(std::size_t capacity) { out_.reserve(capacity); }
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u32(std::uint32_t v) {
    for (int k = 0; k < 4; ++k) out_.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
  }
  void u64(std::uint64_t v) {
    for (int k = 0; k < 8; ++k) out_.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
  }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void vec3(const glm::vec3& v) {
    f32(v.x);
    f32(v.y);
    f32(v.z);
  }
  std::vector<std::uint8_t>& bytes() noexcept { return out_; }

 private:
  std::vector<std::uint8_t> out_;
};

// Sequential little-endian reads with a bounds check on each; errors carry the file name and byte offset.
class ByteReader {
 public:
  ByteReader(std::span<const std::uint8_t> bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  std::uint64_t offset() const noexcept { return pos_; }
  void seek(std::size_t pos) noexcept { pos_ = pos; }

  [[noreturn]] void fail(const std::string& reason, std::uint64_t at) const {
    throw IoError(name_, reason, IoError::kNoLine, at);
  }

  std::uint8_t u8() {
    need(1);
    return bytes_[pos_++];
  }
  std::uint32_t u32() {
    need(4);
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v |= static_cast<std::uint32_t>(bytes_[pos_ + static_cast<std::size_t>(k)]) << (8 * k);
    pos_ += 4;
    return v;
  }
  std::uint64_t u64() {
    need(8);
    std::uint64_t v = 0;
    for (int k = 0; k < 8; ++k) v |= static_cast<std::uint64_t>(bytes_[pos_ + static_cast<std::size_t>(k)]) << (8 * k);
    pos_ += 8;
    return v;
  }
  /// The next n bytes, as they are (for the arrays, copied in bulk by copy_words).
  const std::uint8_t* take(std::size_t n) {
    need(n);
    const std::uint8_t* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  [[noreturn, gnu::noinline, gnu::cold]] void fail_non_finite(const char* what, std::size_t element,
                                                               std::uint64_t at) const {
    fail(std::string("non-finite value in ") + what + " " + std::to_string(element), at);
  }

 private:
  // The checks stay small enough to inline into every read; the messages are built out of line.
  void need(std::size_t n) const {
    if (bytes_.size() - pos_ < n) fail_truncated();
  }
  [[noreturn, gnu::noinline, gnu::cold]] void fail_truncated() const {
    fail("truncated: the data ends at byte " + std::to_string(bytes_.size()) + " in the middle of a field",
         bytes_.size());
  }

  std::span<const std::uint8_t> bytes_;
  const std::string& name_;
  std::size_t pos_ = 0;
};

// Header checks, all before anything is allocated. Returns the counts; the reader is left at the arrays.
Counts read_header(ByteReader& in, std::span<const std::uint8_t> bytes) {
  const std::size_t size = bytes.size();
  const std::size_t magic_seen = std::min<std::size_t>(size, kMagic.size());
  if (!std::equal(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(magic_seen), kMagic.begin()))
    in.fail("bad magic: not a varmesh vertex hierarchy file (expected it to start with \"VMPMHIER\")", 0);
  const std::string header_cut = size == 0 ? "truncated: the file is empty"
                                            : "truncated: the file ends at byte " + std::to_string(size) +
                                                  ", inside the " + std::to_string(kHeaderBytes) + "-byte header";
  if (size < kOffFlags) in.fail(header_cut, size);
  in.seek(kOffVersion);
  const std::uint32_t version = in.u32();
  if (version != kVertexHierarchyFormatVersion)
    in.fail("unsupported format version " + std::to_string(version) + " (this build reads version " +
                std::to_string(kVertexHierarchyFormatVersion) + ")",
            kOffVersion);
  if (size < kHeaderBytes) in.fail(header_cut, size);
  const std::uint32_t flags = in.u32();
  if ((flags & ~kKnownFlags) != 0) in.fail("unknown flags " + hex32(flags), kOffFlags);
  in.seek(kOffSize);
  const std::uint64_t declared = in.u64();
  if (declared > size)
    in.fail("truncated: the file ends at byte " + std::to_string(size) + " but its header declares " +
                std::to_string(declared) + " bytes",
            size);
  if (declared < size)
    in.fail(std::to_string(size - declared) + " unexpected bytes after the declared end of the file", declared);

  Counts c;
  c.colors = (flags & kFlagColors) != 0;
  c.locked = (flags & kFlagLocked) != 0;
  c.leaves = in.u64();
  c.collapses = in.u64();
  c.faces = in.u64();
  c.ring_items = in.u64();
  // Fewest bytes one unit of each count occupies: a count whose minimum exceeds the whole file is absurd.
  struct CountField {
    const char* name;
    std::uint64_t value, offset, min_bytes;
  };
  const CountField fields[] = {
      {"leaves", c.leaves, kOffLeaves, 12 + kBoundFloats * 4 + 4},
      {"collapses", c.collapses, kOffCollapses, 12 + kBoundFloats * 4 + kRecordWords * 4 + 4},
      {"faces", c.faces, kOffFaces, 12 + 4},
      {"stored ring items", c.ring_items, kOffRingItems, 4},
  };
  for (const CountField& f : fields)
    if (f.value > size / f.min_bytes)
      in.fail(std::string("count of ") + f.name + " (" + std::to_string(f.value) + ") needs at least " +
                  std::to_string(f.min_bytes) + " bytes each, more than the whole file holds (" +
                  std::to_string(size) + " bytes)",
              f.offset);
  // Indices are 32-bit with kInvalid reserved (only reachable with files of hundreds of gigabytes).
  if (c.leaves + c.collapses >= kInvalid) in.fail("more nodes than 32-bit indices can number", kOffLeaves);
  if (c.faces >= kInvalid) in.fail("more faces than 32-bit indices can number", kOffFaces);
  if (c.ring_items > 0xFFFFFFFFull) in.fail("more stored ring items than 32-bit offsets can reach", kOffRingItems);
  const std::uint64_t needed = file_size_for(c);
  if (needed != size)
    in.fail("the counts describe a file of " + std::to_string(needed) + " bytes but the file holds " +
                std::to_string(size),
            kOffLeaves);

  return c;
}

// The checksum check that follows the header's; `computed` is the CRC of every byte before the checksum.
void check_checksum(const ByteReader& in, std::span<const std::uint8_t> bytes, std::uint32_t computed) {
  const std::uint32_t stored = load_le32(bytes.data() + (bytes.size() - kChecksumBytes));
  if (stored != computed)
    in.fail("checksum mismatch: stored " + hex32(stored) + ", computed " + hex32(computed) + " (the file is corrupt)",
            bytes.size() - kChecksumBytes);
}

// From this size on the checksum is computed on a second thread while the arrays are parsed (the 89 MB
// dragon's: 21 ms, beside a parse of about 50).
constexpr std::size_t kThreadedChecksumBytes = std::size_t{1} << 22;

// The arrays are runs of little-endian 32-bit words, and so are the structs they are read into (checked
// below): on a little-endian host one copy reads a whole array, which is several times faster than a read
// per field; elsewhere each word is assembled from its bytes.
static_assert(sizeof(glm::vec3) == 12 && sizeof(CollapseRecord) == 4 * kRecordWords &&
              sizeof(ElementBound) == 4 * kBoundFloats && offsetof(ElementBound, radius) == 12 &&
              offsetof(ElementBound, error) == 16 && offsetof(ElementBound, cone) == 20 &&
              offsetof(CollapseRecord, fn) == 24 && offsetof(NormalCone, cos_half_angle) == 12);

template <class T>
void copy_words(ByteReader& in, std::vector<T>& out, std::uint64_t count) {
  static_assert(std::is_trivially_copyable_v<T> && sizeof(T) % 4 == 0);
  out.resize(static_cast<std::size_t>(count));
  const std::size_t n = out.size() * sizeof(T);
  const std::uint8_t* src = in.take(n);
  if constexpr (std::endian::native == std::endian::little) {
    if (n != 0) std::memcpy(out.data(), src, n);
  } else {
    auto* dst = reinterpret_cast<unsigned char*>(out.data());
    for (std::size_t i = 0; i < n; i += 4) {
      const std::uint32_t w = load_le32(src + i);
      std::memcpy(dst + i, &w, 4);
    }
  }
}

std::vector<Index> read_indices(ByteReader& in, std::uint64_t count) {
  std::vector<Index> v;
  copy_words(in, v, count);
  return v;
}

// The first non-finite float of `values` (read from byte `at` on) fails the read, naming its element: `per`
// floats per element, `names[k]` the k-th float's.
void check_finite(const ByteReader& in, std::span<const float> values, std::uint64_t at, std::size_t per,
                  const char* const* names) {
  for (std::size_t j = 0; j < values.size(); ++j)
    if (!std::isfinite(values[j])) in.fail_non_finite(names[j % per], j / per, at + 4 * j);
}

// The arrays after the header, checked as they are read (see hierarchy_io.hpp).
VertexHierarchyBuilder::Raw parse_arrays(ByteReader& in, std::span<const std::uint8_t> bytes, const Counts& c) {
  const std::uint64_t nodes = c.leaves + c.collapses;

  VertexHierarchyBuilder::Raw raw;
  raw.num_leaves = static_cast<std::size_t>(c.leaves);
  auto floats = [](auto& v) {
    return std::span<const float>(reinterpret_cast<const float*>(v.data()), v.size() * sizeof(v[0]) / sizeof(float));
  };
  {
    static const char* const names[] = {"the position of node", "the position of node", "the position of node"};
    const std::uint64_t at = in.offset();
    copy_words(in, raw.positions, nodes);
    check_finite(in, floats(raw.positions), at, 3, names);
  }
  if (c.colors) {
    const std::uint64_t at = in.offset();
    copy_words(in, raw.colors, nodes);
    for (std::size_t v = 0; v < raw.colors.size(); ++v) {
      const glm::vec3& col = raw.colors[v];
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(col[k])) in.fail_non_finite("the colour of node", v, at + 12 * v + 4 * static_cast<std::uint64_t>(k));
      // In [0, 1], as the mesh writers need: pm query failed only when writing its result, without naming
      // this file (helper-55).
      if (!is_unit_color(col)) in.fail("the colour of node " + std::to_string(v) + " is outside [0, 1]", at + 12 * v);
    }
  }
  copy_words(in, raw.records, c.collapses);
  raw.faces = read_indices(in, c.faces * 3);
  {
    static const char* const names[] = {"the bound centre of node",     "the bound centre of node",
                                        "the bound centre of node",     "the bound radius of node",
                                        "the bound error of node",      "the normal cone axis of node",
                                        "the normal cone axis of node", "the normal cone axis of node",
                                        "the normal cone angle of node"};
    const std::uint64_t at = in.offset();
    copy_words(in, raw.bounds, nodes);
    check_finite(in, floats(raw.bounds), at, kBoundFloats, names);
  }
  // The builder checks the first and last offsets but stored_ring() also needs them non-decreasing.
  const std::uint64_t offsets_at = in.offset();
  raw.ring_offsets = read_indices(in, c.collapses + 1);
  for (std::size_t i = 0; i < raw.ring_offsets.size(); ++i) {
    const std::uint64_t at = offsets_at + 4 * i;
    const Index o = raw.ring_offsets[i];
    const Index lower = i == 0 ? 0 : raw.ring_offsets[i - 1];
    if ((i == 0 && o != 0) || o < lower || o > c.ring_items)
      in.fail("stored ring offset " + std::to_string(i) + " (" + std::to_string(o) +
                  ") is not between the previous offset and the item count",
              at);
    raw.ring_offsets[i] = o;
  }
  if (raw.ring_offsets.back() != c.ring_items)
    in.fail("the last stored ring offset is not the item count " + std::to_string(c.ring_items), in.offset() - 4);
  raw.ring_items = read_indices(in, c.ring_items);
  raw.leaf_to_input = read_indices(in, c.leaves);
  raw.face_to_input = read_indices(in, c.faces);
  if (c.locked) {
    const std::uint64_t at = in.offset();
    const std::uint8_t* src = in.take(static_cast<std::size_t>(c.leaves));
    raw.locked.assign(src, src + c.leaves);
    for (std::size_t l = 0; l < raw.locked.size(); ++l)
      if (raw.locked[l] > 1) in.fail("locked flag of leaf " + std::to_string(l) + " is neither 0 nor 1", at + l);
  }
  InputRepairReport& rep = raw.repair;
  for (std::size_t* x : {&rep.input_vertices, &rep.input_faces, &rep.unreferenced_vertices, &rep.degenerate_faces,
                         &rep.duplicate_faces, &rep.nonmanifold_edge_faces, &rep.nonmanifold_vertices,
                         &rep.added_vertex_copies, &rep.locked_vertices})
    *x = static_cast<std::size_t>(in.u64());
  if (in.offset() + kChecksumBytes != bytes.size())
    throw std::logic_error("decode_vertex_hierarchy: layout size disagrees with the bytes read");
  return raw;
}

}  // namespace

std::vector<std::uint8_t> encode_vertex_hierarchy(const VertexHierarchy& h) {
  if (h.num_leaves() == 0) throw InvalidInput("encode_vertex_hierarchy: the hierarchy is empty (never built)");
  // The reader takes colours in [0, 1] only (the mesh writers need them so); the analysis keeps a node's
  // colour within its input's range, so only an input with colours outside [0, 1] gets here.
  for (std::size_t v = 0; v < h.colors().size(); ++v) {
    const glm::vec3& col = h.colors()[v];
    if (!is_unit_color(col))
      throw InvalidInput("encode_vertex_hierarchy: the colour of node " + std::to_string(v) + " is outside [0, 1]", v);
  }
  const auto& records = HierarchyFileAccess::records(h);
  const auto& bounds = HierarchyFileAccess::bounds(h);
  const auto& ring_offsets = HierarchyFileAccess::ring_offsets(h);
  const auto& ring_items = HierarchyFileAccess::ring_items(h);
  const auto& locked = HierarchyFileAccess::locked(h);

  Counts c;
  c.leaves = h.num_leaves();
  c.collapses = h.num_collapses();
  c.faces = h.num_faces();
  c.ring_items = ring_items.size();
  c.colors = h.has_colors();
  c.locked = !locked.empty();
  const std::uint64_t size = file_size_for(c);

  ByteWriter out(static_cast<std::size_t>(size));
  for (std::uint8_t b : kMagic) out.u8(b);
  out.u32(kVertexHierarchyFormatVersion);
  out.u32((c.colors ? kFlagColors : 0u) | (c.locked ? kFlagLocked : 0u));
  out.u64(size);
  out.u64(c.leaves);
  out.u64(c.collapses);
  out.u64(c.faces);
  out.u64(c.ring_items);
  for (const glm::vec3& p : h.positions()) out.vec3(p);
  if (c.colors)
    for (const glm::vec3& col : h.colors()) out.vec3(col);  // in [0, 1]: checked before anything is written
  for (const CollapseRecord& r : records) {
    for (Index x : {r.vt, r.vu, r.vl_hat, r.vr_hat, r.fl_hat, r.fr_hat}) out.u32(x);
    for (Index x : r.fn) out.u32(x);
  }
  for (Index x : h.face_corners()) out.u32(x);
  for (const ElementBound& b : bounds) {
    out.vec3(b.center);
    out.f32(b.radius);
    out.f32(b.error);
    out.vec3(b.cone.axis);
    out.f32(b.cone.cos_half_angle);
  }
  for (Index x : ring_offsets) out.u32(x);
  for (Index x : ring_items) out.u32(x);
  for (Index x : h.leaf_to_input()) out.u32(x);
  for (Index x : h.face_to_input()) out.u32(x);
  for (std::uint8_t x : locked) out.u8(x);
  const InputRepairReport& rep = h.repair_report();
  for (std::size_t x : {rep.input_vertices, rep.input_faces, rep.unreferenced_vertices, rep.degenerate_faces,
                        rep.duplicate_faces, rep.nonmanifold_edge_faces, rep.nonmanifold_vertices,
                        rep.added_vertex_copies, rep.locked_vertices})
    out.u64(static_cast<std::uint64_t>(x));
  std::vector<std::uint8_t>& bytes = out.bytes();
  out.u32(crc32(bytes));
  if (bytes.size() != size) throw std::logic_error("encode_vertex_hierarchy: layout size disagrees with the bytes written");
  return std::move(bytes);
}

VertexHierarchy decode_vertex_hierarchy(std::span<const std::uint8_t> bytes, const std::string& name_for_errors) {
  ByteReader in(bytes, name_for_errors);
  const Counts c = read_header(in, bytes);
  // The parse below trusts only the counts, checked against the file size; the checksum's verdict comes
  // first all the same, as if it had been computed before the parse.
  const std::span<const std::uint8_t> sealed = bytes.first(bytes.size() - kChecksumBytes);
  std::uint32_t computed = 0;
  std::thread checksum;
  if (bytes.size() >= kThreadedChecksumBytes) {
    try {
      checksum = std::thread([&] { computed = crc32(sealed); });
    } catch (const std::system_error&) {
    }
  }
  if (!checksum.joinable()) check_checksum(in, bytes, crc32(sealed));
  auto join_checksum = [&] {
    if (!checksum.joinable()) return;
    checksum.join();
    check_checksum(in, bytes, computed);
  };
  VertexHierarchyBuilder::Raw raw;
  try {
    raw = parse_arrays(in, bytes, c);
  } catch (...) {
    join_checksum();
    throw;
  }
  join_checksum();

  try {
    return VertexHierarchyBuilder::finish(std::move(raw));
  } catch (const std::logic_error& e) {  // InvalidInput from the builder, std::logic_error from validate()
    throw IoError(name_for_errors, std::string("not a valid vertex hierarchy: ") + e.what());
  }
}


void write_vertex_hierarchy(const std::string& path, const VertexHierarchy& h) {
  const std::vector<std::uint8_t> bytes = encode_vertex_hierarchy(h);
  write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

VertexHierarchy read_vertex_hierarchy(const std::string& path) {
  const FileBytes data = read_file_bytes(path);
  return decode_vertex_hierarchy(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(data.data()), data.size()), path);
}

}  // namespace varmesh
