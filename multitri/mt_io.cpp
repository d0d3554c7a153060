// Multi-Triangulation files: see mt_io.hpp for the layout and the order of the checks.
#include "multitri/mt_io.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "multitri/detail/binary_codec.hpp"
#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"

namespace varmesh {

namespace {
constexpr char kMagic[8] = {'V', 'M', 'S', 'H', 'M', 'T', '\r', '\n'};
constexpr std::size_t kVersionAt = 8;
constexpr std::size_t kCountsAt = 12;  // V, F, N: u32 each, in both versions
constexpr std::size_t kSizeAt = 24;    // version 2: u64 file size
constexpr std::size_t kHeaderSumAt = 32;  // version 2: u64 checksum of bytes 0 .. 31
constexpr std::size_t kHeaderBytesV1 = 24;
constexpr std::size_t kHeaderBytes = 40;
constexpr std::size_t kChecksumBytes = 8;
constexpr std::size_t kNodeFixedBytes = 13;  // kind, error, removed count, image size

struct Header {
  std::uint32_t version = 0;
  std::uint32_t nv = 0, nf = 0, nn = 0;
  std::size_t bytes = 0;  // where the positions start
};

std::string hex64(std::uint64_t v) {
  char s[19];
  std::snprintf(s, sizeof s, "0x%016llx", static_cast<unsigned long long>(v));
  return s;
}

std::string plural(std::uint64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// How far the data of `bytes` goes in the layout the header's counts and the node records' removed counts
// describe: either every section is there (`fits`, and `needed` is the size they add up to, checksum
// included) or `where` names the element the data stops in. Reads only bytes that exist; O(nodes present).
struct DataEnd {
  bool fits = false;
  std::uint64_t needed = 0;
  std::string where;
};

DataEnd locate_data_end(std::string_view bytes, const Header& h) {
  const std::uint64_t size = bytes.size();
  std::uint64_t at = h.bytes;
  auto stop = [&](const std::string& what) {
    return DataEnd{false, 0, (size == at ? "before " : "in the middle of ") + what};
  };
  auto array = [&](std::uint64_t count, std::uint64_t item, const char* name, DataEnd& out) {
    if (size - at >= count * item) {
      at += count * item;
      return false;
    }
    const std::uint64_t i = (size - at) / item;
    at += i * item;
    out = stop(std::string(name) + " " + std::to_string(i) + " (of " + std::to_string(count) + ")");
    return true;
  };
  DataEnd end;
  if (array(h.nv, 12, "the position of vertex", end)) return end;
  if (array(h.nf, 12, "face", end)) return end;
  if (size - at < 4) return stop("the base image size");
  at += 4;
  // Every version-1 file is walked here: the node's name is built only where the data stops.
  auto node = [&](std::uint64_t n) {
    return "the record of node " + std::to_string(n) + " (nodes 1 to " + std::to_string(h.nn - 1) + ")";
  };
  for (std::uint64_t n = 1; n < h.nn; ++n) {
    if (size - at < 9) return stop(node(n));
    const std::uint64_t removed = detail::load_le<std::uint32_t>(bytes.data() + at + 5);
    if (size - at < kNodeFixedBytes + 4 * removed) return stop(node(n));
    at += kNodeFixedBytes + 4 * removed;
  }
  if (size - at < kChecksumBytes) return stop("the checksum");
  return DataEnd{true, at + kChecksumBytes, {}};
}

// FNV-1a 64 of bytes [0, end) with the version field read as `version`.
std::uint64_t sum_with_version(std::string_view bytes, std::size_t end, std::uint32_t version) noexcept {
  char field[4];
  for (std::size_t k = 0; k < 4; ++k) field[k] = static_cast<char>((version >> (8 * k)) & 0xffu);
  std::uint64_t h = detail::fnv1a64(bytes.data(), kVersionAt);
  h = detail::fnv1a64(field, sizeof field, h);
  return detail::fnv1a64(bytes.data() + kVersionAt + 4, end - kVersionAt - 4, h);
}

// A version field that does not read 2 (the file has at least the magic and the field). Tells a damaged
// field from a format this build does not know by the checksums, which cover the field: the version-2 header
// checksum (bytes 0 .. 31) and, for version 1, the whole file's. Returns when the field reads 1 and nothing
// says otherwise; throws through `fail` when the file is corrupt or of an unknown version.
template <class Fail> void check_version_field(std::string_view bytes, std::uint32_t version, const Fail& fail) {
  const std::size_t size = bytes.size();
  const std::string reads = "its format version reads " + std::to_string(version);
  const bool has_v2_header = size >= kHeaderBytes;
  const std::uint64_t stored_header_sum = has_v2_header ? detail::load_le<std::uint64_t>(bytes.data() + kHeaderSumAt) : 0;
  // A version-1 file (whose bytes 24 .. 39 are positions) passes this test with probability 2^-64.
  if (has_v2_header && stored_header_sum == sum_with_version(bytes, kHeaderSumAt, kMtFormatVersion))
    fail("the file is corrupt: " + reads + ", but its header checksum matches version " +
             std::to_string(kMtFormatVersion) + " (the version field is damaged)",
         kVersionAt);
  if (version == 1) return;
  if (has_v2_header && stored_header_sum == detail::fnv1a64(bytes.data(), kHeaderSumAt))
    fail("unsupported MT file version " + std::to_string(version) + " (this build reads versions 1 and " +
             std::to_string(kMtFormatVersion) + "; the header checksum matches, so this is not damage)",
         kVersionAt);
  // Laid out as version 2 (the size field holds the real size), yet its header checksum fails.
  if (has_v2_header && detail::load_le<std::uint64_t>(bytes.data() + kSizeAt) == size)
    fail("the file is corrupt: " + reads + ", which this build does not know, and its version-" +
             std::to_string(kMtFormatVersion) + " header fails its checksum (stored " + hex64(stored_header_sum) +
             ", computed " + hex64(detail::fnv1a64(bytes.data(), kHeaderSumAt)) + ")",
         kVersionAt);
  if (size >= kHeaderBytesV1 + kChecksumBytes &&
      detail::load_le<std::uint64_t>(bytes.data() + size - kChecksumBytes) ==
          sum_with_version(bytes, size - kChecksumBytes, 1))
    fail("the file is corrupt: " + reads + ", but its checksum matches version 1 (the version field is damaged)",
         kVersionAt);
  fail("unsupported MT file version " + std::to_string(version) + " (this build reads versions 1 and " +
           std::to_string(kMtFormatVersion) + "; no checksum shows the file as either, so it is newer or damaged)",
       kVersionAt);
}

// Magic, version and counts; for version 2 also the header checksum and the declared size against the real
// one. Throws IoError; every "truncated" comes from here (or from a version-1 file, see decode_mt).
Header read_header(std::string_view bytes, const std::string& name) {
  const std::size_t size = bytes.size();
  auto fail = [&](const std::string& reason, std::uint64_t at) { throw IoError(name, reason, IoError::kNoLine, at); };
  if (size == 0) fail("truncated: the file is empty", 0);
  if (std::memcmp(bytes.data(), kMagic, std::min(size, sizeof kMagic)) != 0)
    fail("not a varmesh MT file (bad magic)", 0);
  if (size < kVersionAt + 4)
    fail("truncated: the file has " + plural(size, "byte", "bytes") + " and ends inside the " +
             (size < kVersionAt ? "magic" : "format version"),
         size);
  Header h;
  h.version = detail::load_le<std::uint32_t>(bytes.data() + kVersionAt);
  if (h.version != kMtFormatVersion) check_version_field(bytes, h.version, fail);
  h.bytes = h.version == 1 ? kHeaderBytesV1 : kHeaderBytes;
  if (size < h.bytes)
    fail("truncated: the file has " + plural(size, "byte", "bytes") + ", less than the " + std::to_string(h.bytes) +
             "-byte header of a version-" + std::to_string(h.version) + " file",
         size);
  h.nv = detail::load_le<std::uint32_t>(bytes.data() + kCountsAt);
  h.nf = detail::load_le<std::uint32_t>(bytes.data() + kCountsAt + 4);
  h.nn = detail::load_le<std::uint32_t>(bytes.data() + kCountsAt + 8);
  if (h.version == 1) return h;

  // The header has its own checksum, so the size and counts below can be trusted: a file shorter than it
  // declares was cut, not damaged (damage of the right length fails one of the two checksums).
  const std::uint64_t stored_sum = detail::load_le<std::uint64_t>(bytes.data() + kHeaderSumAt);
  const std::uint64_t header_sum = detail::fnv1a64(bytes.data(), kHeaderSumAt);
  if (stored_sum != header_sum)
    fail("checksum mismatch in the header: stored " + hex64(stored_sum) + ", computed " + hex64(header_sum) +
             " (the file is corrupt)",
         kHeaderSumAt);
  const std::uint64_t declared = detail::load_le<std::uint64_t>(bytes.data() + kSizeAt);
  if (declared > size) {
    const DataEnd end = locate_data_end(bytes, h);
    fail("truncated: the file has " + plural(size, "byte", "bytes") + " but its header declares " +
             std::to_string(declared) + " (" + std::to_string(declared - size) + " missing)" +
             (end.fits ? std::string() : "; the data ends " + end.where),
         size);
  }
  if (declared < size)
    fail(plural(size - declared, "unexpected byte", "unexpected bytes") + " after the end the header declares (byte " +
             std::to_string(declared) + ")",
         declared);
  // Counts that need more than the file holds (a file made by hand: the checksums passed), refused before
  // anything is allocated from them.
  const std::uint64_t least = kHeaderBytes + 12 * std::uint64_t{h.nv} + 12 * std::uint64_t{h.nf} + 4 +
                              kNodeFixedBytes * (std::uint64_t{h.nn} - (h.nn > 0)) + kChecksumBytes;
  if (least > size)
    fail("the header's counts (" + std::to_string(h.nv) + " vertices, " + std::to_string(h.nf) + " faces, " +
             std::to_string(h.nn) + " nodes) need at least " + std::to_string(least) + " bytes, the file has " +
             std::to_string(size),
         kCountsAt);
  return h;
}

}  // namespace

std::string encode_mt(const Mt& mt) {
  if (mt.num_nodes() == 0) throw InvalidInput("encode_mt: the Mt is empty (default-constructed or moved-from)");
  std::uint64_t size = kHeaderBytes + 12 * std::uint64_t{mt.num_vertices()} + 12 * std::uint64_t{mt.num_faces()} + 4 +
                       kChecksumBytes;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) size += kNodeFixedBytes + 4 * std::uint64_t{mt.pre_image(n).size()};
  detail::Writer w;
  w.reserve(static_cast<std::size_t>(size));
  w.bytes(kMagic, sizeof kMagic);
  w.le<std::uint32_t>(kMtFormatVersion);
  w.le(static_cast<std::uint32_t>(mt.num_vertices()));
  w.le(static_cast<std::uint32_t>(mt.num_faces()));
  w.le(static_cast<std::uint32_t>(mt.num_nodes()));
  w.le<std::uint64_t>(size);
  w.append_checksum();
  for (const glm::vec3& p : mt.positions()) {
    w.f32(p.x);
    w.f32(p.y);
    w.f32(p.z);
  }
  for (FaceId f = 0; f < mt.num_faces(); ++f)
    for (VertexId v : mt.face(f)) w.le<std::uint32_t>(v);
  w.le(static_cast<std::uint32_t>(mt.image_size(Mt::source())));
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    w.le(static_cast<std::uint8_t>(mt.kind(n)));
    w.f32(mt.bound(n).error);
    const auto removed = mt.pre_image(n);
    w.le(static_cast<std::uint32_t>(removed.size()));
    for (FaceId f : removed) w.le<std::uint32_t>(f);
    w.le(static_cast<std::uint32_t>(mt.image_size(n)));
  }
  w.append_checksum();
  if (w.str().size() != size) throw std::logic_error("encode_mt: the declared size disagrees with the bytes written");
  return std::move(w.str());
}

Mt decode_mt(std::string_view bytes, const std::string& name) {
  const Header h = read_header(bytes, name);
  const std::size_t size = bytes.size();
  if (h.version == 1) {
    // A version-1 file does not record its size: when the data stops before the end its counts describe,
    // the file was cut or a count was damaged, and only an intact checksum (a file edited and re-sealed)
    // tells the second apart; that case is left to the parser, which names the overrun.
    const DataEnd end = locate_data_end(bytes, h);
    if (!end.fits && (size < h.bytes + kChecksumBytes ||
                      detail::load_le<std::uint64_t>(bytes.data() + size - kChecksumBytes) !=
                          detail::fnv1a64(bytes.data(), size - kChecksumBytes)))
      throw IoError(name,
                    "truncated, or a count is damaged (a version-1 file does not record its size): the file has " +
                        plural(size, "byte", "bytes") + " and the data ends " + end.where,
                    IoError::kNoLine, size);
  }
  const std::size_t body_end = size - kChecksumBytes;
  const std::uint64_t stored_sum = detail::load_le<std::uint64_t>(bytes.data() + body_end);
  const std::uint64_t sum = detail::fnv1a64(bytes.data(), body_end);
  if (stored_sum != sum)
    throw IoError(name, "checksum mismatch: stored " + hex64(stored_sum) + ", computed " + hex64(sum) + " (the file is corrupt)",
                  IoError::kNoLine, body_end);
  if (h.nn == 0) throw IoError(name, "node count is 0 (the source is missing)", IoError::kNoLine, kCountsAt + 8);

  // Both checksums passed, so a read past the data means counts that disagree with the file's size.
  detail::Reader r(bytes.substr(0, body_end), name, "the counts disagree with the file's size");
  r.seek(kCountsAt);
  const std::uint32_t nv = r.count("vertex count", 12);
  const std::uint32_t nf = r.le<std::uint32_t>("face count");
  const std::uint32_t nn = r.le<std::uint32_t>("node count");
  r.seek(h.bytes);
  MtBuilder b;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const float x = r.f32("vertex x"), y = r.f32("vertex y"), z = r.f32("vertex z");
    b.add_vertex({x, y, z});
  }
  if (static_cast<std::uint64_t>(nf) * 12 > r.remaining()) r.fail("face count " + std::to_string(nf) + " larger than the file can hold");
  for (std::uint32_t f = 0; f < nf; ++f) {
    const auto at = r.offset();
    const std::uint32_t a = r.le<std::uint32_t>("face"), c1 = r.le<std::uint32_t>("face"), c2 = r.le<std::uint32_t>("face");
    if (a >= nv || c1 >= nv || c2 >= nv)
      throw IoError(name, "face " + std::to_string(f) + ": vertex index out of range", IoError::kNoLine, at);
    b.add_face(a, c1, c2);
  }
  if (static_cast<std::uint64_t>(nn - 1) * kNodeFixedBytes > r.remaining())
    r.fail("node count " + std::to_string(nn) + " larger than the file can hold");
  std::uint64_t next_face = 0;
  auto take_image = [&](std::uint32_t image_size, std::vector<FaceId>& out) {
    if (next_face + image_size > nf) r.fail("node images use more faces than the file has");
    out.resize(image_size);
    for (std::uint32_t i = 0; i < image_size; ++i) out[i] = static_cast<FaceId>(next_face + i);
    next_face += image_size;
  };
  std::vector<FaceId> created, removed;
  take_image(r.le<std::uint32_t>("base size"), created);
  b.set_base(created);
  for (std::uint32_t n = 1; n < nn; ++n) {
    const auto at = r.offset();
    const std::uint8_t kind = r.le<std::uint8_t>("node kind");
    if (kind < 1 || kind > 3) throw IoError(name, "node " + std::to_string(n) + ": unknown kind " + std::to_string(kind), IoError::kNoLine, at);
    const float error = r.f32("node error");
    if (error < 0.0f) r.fail("node " + std::to_string(n) + ": negative error");
    const std::uint32_t nr = r.count("removed count", 4);
    removed.resize(nr);
    for (std::uint32_t i = 0; i < nr; ++i) {
      removed[i] = r.le<std::uint32_t>("removed face");
      if (removed[i] >= nf) r.fail("node " + std::to_string(n) + ": removed face out of range");
    }
    take_image(r.le<std::uint32_t>("image size"), created);
    b.add_node(static_cast<NodeKind>(kind), removed, created, error);
  }
  if (next_face != nf) r.fail("faces not created by any node");
  if (r.remaining() != 0)
    r.fail(plural(r.remaining(), "byte", "bytes") + " between the last node record and the checksum");
  try {
    return std::move(b).build();
  } catch (const InvalidInput& e) {
    throw IoError(name, std::string("invalid Multi-Triangulation: ") + e.what());
  }
}

void write_mt(const std::string& path, const Mt& mt) { write_file_atomically(path, encode_mt(mt)); }

Mt read_mt(const std::string& path) { return decode_mt(read_file_bytes(path), path); }

}  // namespace varmesh
