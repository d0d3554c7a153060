// Multi-Triangulation files: see mt_io.hpp for the layout.
#include "multitri/mt_io.hpp"

#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "multitri/detail/binary_codec.hpp"
#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"

namespace varmesh {

namespace {
constexpr char kMagic[8] = {'V', 'M', 'S', 'H', 'M', 'T', '\r', '\n'};
constexpr std::uint32_t kVersion = 1;
}  // namespace

std::string encode_mt(const Mt& mt) {
  if (mt.num_nodes() == 0) throw InvalidInput("encode_mt: the Mt is empty (default-constructed or moved-from)");
  detail::Writer w;
  w.reserve(sizeof kMagic + 24 + 12 * mt.num_vertices() + 12 * mt.num_faces() + 13 * mt.num_nodes() +
            4 * mt.num_faces() + 8);
  w.bytes(kMagic, sizeof kMagic);
  w.le<std::uint32_t>(kVersion);
  w.le(static_cast<std::uint32_t>(mt.num_vertices()));
  w.le(static_cast<std::uint32_t>(mt.num_faces()));
  w.le(static_cast<std::uint32_t>(mt.num_nodes()));
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
  w.finish_with_checksum();
  return std::move(w.str());
}

Mt decode_mt(std::string_view bytes, const std::string& name) {
  detail::Reader r(bytes, name);
  r.need(sizeof kMagic, "magic");
  if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) r.fail("not a varmesh MT file (bad magic)");
  for (std::size_t i = 0; i < sizeof kMagic; ++i) r.le<std::uint8_t>("magic");
  const std::uint32_t version = r.le<std::uint32_t>("version");
  if (version != kVersion) r.fail("unsupported MT file version " + std::to_string(version) + " (this build reads version 1)");
  r.check_checksum_up_front();
  const std::uint32_t nv = r.count("vertex count", 12);
  const std::uint32_t nf = r.le<std::uint32_t>("face count");
  const std::uint32_t nn = r.le<std::uint32_t>("node count");
  if (nn == 0) r.fail("node count is 0 (the source is missing)");
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
  if (static_cast<std::uint64_t>(nn - 1) * 13 > r.remaining()) r.fail("node count " + std::to_string(nn) + " larger than the file can hold");
  std::uint64_t next_face = 0;
  auto take_image = [&](std::uint32_t size, std::vector<FaceId>& out) {
    if (next_face + size > nf) r.fail("node images use more faces than the file has");
    out.resize(size);
    for (std::uint32_t i = 0; i < size; ++i) out[i] = static_cast<FaceId>(next_face + i);
    next_face += size;
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
  r.check_checksum();
  try {
    return std::move(b).build();
  } catch (const InvalidInput& e) {
    throw IoError(name, std::string("invalid Multi-Triangulation: ") + e.what());
  }
}

void write_mt(const std::string& path, const Mt& mt) { write_file_atomically(path, encode_mt(mt)); }

Mt read_mt(const std::string& path) { return decode_mt(read_file(path), path); }

}  // namespace varmesh
