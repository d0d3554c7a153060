// Vertex hierarchy files (pm/hierarchy_io.hpp): write -> read gives the same hierarchy, accessor by accessor
// and in behaviour (SrMesh), and every kind of damage (truncation at every byte, flipped bytes, absurd
// counts, wrong magic or version, semantic nonsense behind a valid checksum) is an IoError naming the file.
#include "pm/hierarchy_io.hpp"

#include <algorithm>
#include <cstring>
#include <atomic>
#include <bit>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <fstream>
#include <limits>
#include <new>
#include <random>
#include <stdexcept>
#include <string>

#include <glm/common.hpp>
#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "multitri/mesh_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"
#include "test_support.hpp"

#include "alloc_guard.hpp"

namespace varmesh {
namespace {

using Bytes = std::vector<std::uint8_t>;
using testing::make_grid;
using testing::make_icosphere;
using testing::make_torus;

// Byte offsets of the documented layout (hierarchy_io.hpp), computed independently of the library.
constexpr std::size_t kVersionAt = 8, kFlagsAt = 12, kSizeAt = 16, kLeavesAt = 24, kCollapsesAt = 32,
                      kFacesAt = 40, kRingItemsAt = 48, kArraysAt = 56;
struct Layout {
  std::size_t positions, colors, records, faces, bounds, ring_offsets, ring_items, leaf_to_input, face_to_input,
      locked, repair, checksum, size;
};
// Whether `locked` is stored is not visible through the public accessors (it may be all zeros), so it is
// read from the flags of the file image.
Layout layout_of(const VertexHierarchy& h, const std::vector<std::uint8_t>& image) {
  const std::size_t n = h.num_nodes(), c = h.num_collapses(), f = h.num_faces(), l = h.num_leaves();
  std::size_t ring_items = 0;
  for (std::size_t v = l; v < n; ++v) ring_items += h.stored_ring(static_cast<Index>(v)).size();
  const bool locked = (image.at(12) & 2u) != 0;
  Layout a{};
  a.positions = kArraysAt;
  a.colors = a.positions + 12 * n;
  a.records = a.colors + (h.has_colors() ? 12 * n : 0);
  a.faces = a.records + 40 * c;
  a.bounds = a.faces + 12 * f;
  a.ring_offsets = a.bounds + 36 * n;
  a.ring_items = a.ring_offsets + 4 * (c + 1);
  a.leaf_to_input = a.ring_items + 4 * ring_items;
  a.face_to_input = a.leaf_to_input + 4 * l;
  a.locked = a.face_to_input + 4 * f;
  a.repair = a.locked + (locked ? l : 0);
  a.checksum = a.repair + 72;
  a.size = a.checksum + 4;
  return a;
}

// A hierarchy, its file image and the image's layout: what the edit-and-reseal tests start from.
// Tests bind the members to plain references, not a structured binding: clang before 16 does not let a
// lambda capture a structured binding (a C++20 addition), and several tests' lambdas use them.
struct Encoded {
  VertexHierarchy h;
  std::vector<std::uint8_t> good;
  Layout at;
};
Encoded encoded(VertexHierarchy h) {
  std::vector<std::uint8_t> image = encode_vertex_hierarchy(h);
  const Layout at = layout_of(h, image);
  return {std::move(h), std::move(image), at};
}

std::uint64_t get_le(const Bytes& b, std::size_t at, int width) {
  std::uint64_t v = 0;
  for (int k = 0; k < width; ++k) v |= static_cast<std::uint64_t>(b[at + static_cast<std::size_t>(k)]) << (8 * k);
  return v;
}
void put_le(Bytes& b, std::size_t at, std::uint64_t v, int width) {
  for (int k = 0; k < width; ++k) b[at + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(v >> (8 * k));
}

// Bit-by-bit CRC-32 (reflected 0xEDB88320, init and final xor all ones): a second implementation, so the test
// can re-seal a deliberately edited file and check the library's checksum against the documented one.
std::uint32_t reference_crc32(const std::uint8_t* data, std::size_t n) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}
void reseal(Bytes& b) { put_le(b, b.size() - 4, reference_crc32(b.data(), b.size() - 4), 4); }

VertexHierarchy decode(const Bytes& b, const std::string& name = "mem.vmh") {
  return decode_vertex_hierarchy(std::span<const std::uint8_t>(b.data(), b.size()), name);
}

// Decodes under the allocation guard; returns the error (fails the test if there is none).
IoError decode_error(const Bytes& b, std::size_t* peak = nullptr, const std::string& name = "mem.vmh") {
  g_guard_peak = 0;
  g_guard_armed = true;
  struct Disarm {
    ~Disarm() { g_guard_armed = false; }
  } disarm;
  try {
    decode(b, name);
  } catch (const IoError& e) {
    g_guard_armed = false;
    if (peak) *peak = g_guard_peak;
    return e;
  } catch (const std::bad_alloc&) {
    g_guard_armed = false;
    ADD_FAILURE() << "decode tried to allocate " << g_guard_peak.load() << " bytes in one block";
    return IoError(name, "bad_alloc");
  }
  ADD_FAILURE() << "decode accepted a damaged file";
  return IoError(name, "accepted");
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_bits(const glm::vec3& a, const glm::vec3& b) {
  return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}

// Every public accessor of the two hierarchies agrees (floats bit for bit).
void expect_identical(const VertexHierarchy& a, const VertexHierarchy& b) {
  ASSERT_EQ(a.num_leaves(), b.num_leaves());
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  ASSERT_EQ(a.num_collapses(), b.num_collapses());
  ASSERT_EQ(a.num_faces(), b.num_faces());
  ASSERT_EQ(a.has_colors(), b.has_colors());
  EXPECT_EQ(a.node_bits(), b.node_bits());
  EXPECT_EQ(a.max_depth(), b.max_depth());
  EXPECT_EQ(a.memory_bytes(), b.memory_bytes());
  for (Index v = 0; v < a.num_nodes(); ++v) {
    EXPECT_TRUE(same_bits(a.position(v), b.position(v))) << "position " << v;
    if (a.has_colors()) {
      EXPECT_TRUE(same_bits(a.color(v), b.color(v))) << "colour " << v;
    }
    const ElementBound &ba = a.bound(v), &bb = b.bound(v);
    EXPECT_TRUE(same_bits(ba.center, bb.center) && same_bits(ba.radius, bb.radius) && same_bits(ba.error, bb.error) &&
                same_bits(ba.cone.axis, bb.cone.axis) && same_bits(ba.cone.cos_half_angle, bb.cone.cos_half_angle))
        << "bound " << v;
    EXPECT_EQ(a.parent(v), b.parent(v)) << v;
    EXPECT_EQ(a.sibling(v), b.sibling(v)) << v;
    EXPECT_EQ(a.key(v).value, b.key(v).value) << v;
    EXPECT_EQ(a.depth(v), b.depth(v)) << v;
    EXPECT_EQ(a.is_leaf(v), b.is_leaf(v)) << v;
    if (a.is_leaf(v)) {
      EXPECT_EQ(a.is_locked(v), b.is_locked(v)) << v;
      continue;
    }
    const CollapseRecord &ra = a.record(v), &rb = b.record(v);
    EXPECT_TRUE(ra.vt == rb.vt && ra.vu == rb.vu && ra.vl_hat == rb.vl_hat && ra.vr_hat == rb.vr_hat &&
                ra.fl_hat == rb.fl_hat && ra.fr_hat == rb.fr_hat && ra.fn == rb.fn)
        << "record of node " << v;
    const auto sa = a.stored_ring(v), sb = b.stored_ring(v);
    EXPECT_TRUE(std::equal(sa.begin(), sa.end(), sb.begin(), sb.end())) << "stored ring of node " << v;
  }
  auto same_span = [](std::span<const Index> x, std::span<const Index> y) { return std::equal(x.begin(), x.end(), y.begin(), y.end()); };
  EXPECT_TRUE(same_span(a.face_corners(), b.face_corners()));
  EXPECT_TRUE(same_span(a.roots(), b.roots()));
  EXPECT_TRUE(same_span(a.base_faces(), b.base_faces()));
  EXPECT_TRUE(same_span(a.leaf_to_input(), b.leaf_to_input()));
  EXPECT_TRUE(same_span(a.face_to_input(), b.face_to_input()));
  for (Index f = 0; f < a.num_faces(); ++f) EXPECT_EQ(a.face_creator(f), b.face_creator(f)) << f;
  const InputRepairReport &pa = a.repair_report(), &pb = b.repair_report();
  EXPECT_EQ(pa.input_vertices, pb.input_vertices);
  EXPECT_EQ(pa.input_faces, pb.input_faces);
  EXPECT_EQ(pa.unreferenced_vertices, pb.unreferenced_vertices);
  EXPECT_EQ(pa.degenerate_faces, pb.degenerate_faces);
  EXPECT_EQ(pa.duplicate_faces, pb.duplicate_faces);
  EXPECT_EQ(pa.nonmanifold_edge_faces, pb.nonmanifold_edge_faces);
  EXPECT_EQ(pa.nonmanifold_vertices, pb.nonmanifold_vertices);
  EXPECT_EQ(pa.added_vertex_copies, pb.added_vertex_copies);
  EXPECT_EQ(pa.locked_vertices, pb.locked_vertices);
}

std::vector<std::array<Index, 4>> faces_of(const SrMesh& sr) {
  std::vector<std::array<Index, 4>> out;
  sr.for_each_face([&](Index f, Index a, Index b, Index c) { out.push_back({f, a, b, c}); });
  return out;
}

// SrMesh runs identically on both: the same faces after a partial refinement, refine_all and coarsen_all.
constexpr RefinementScheme kAllSchemes[] = {RefinementScheme::kKimLee, RefinementScheme::kHoppe97,
                                           RefinementScheme::kXiaVarshney};
void expect_same_behaviour(const VertexHierarchy& a, const VertexHierarchy& b,
                           std::span<const RefinementScheme> schemes = kAllSchemes) {
  for (RefinementScheme s : schemes) {
    SrMesh sa(a, s), sb(b, s);
    EXPECT_EQ(faces_of(sa), faces_of(sb)) << scheme_name(s) << " base mesh";
    // Split every other active non-leaf vertex, in id order.
    std::vector<Index> act = sa.active_vertices();
    std::sort(act.begin(), act.end());
    for (std::size_t i = 0; i < act.size(); i += 2)
      if (!a.is_leaf(act[i]) && sa.is_active(act[i])) {
        EXPECT_EQ(sa.vsplit(act[i]), sb.vsplit(act[i]));
      }
    EXPECT_EQ(faces_of(sa), faces_of(sb)) << scheme_name(s) << " partial";
    EXPECT_EQ(sa.refine_all(), sb.refine_all());
    EXPECT_EQ(faces_of(sa), faces_of(sb)) << scheme_name(s) << " refine_all";
    EXPECT_EQ(sa.num_faces(), a.num_faces()) << scheme_name(s);
    EXPECT_EQ(sa.coarsen_all(), sb.coarsen_all());
    EXPECT_EQ(faces_of(sa), faces_of(sb)) << scheme_name(s) << " coarsen_all";
    sb.validate();
  }
}

TriMesh colored(TriMesh m) {
  const Box3 box = m.bounds();
  const glm::vec3 ext = glm::max(box.extent(), glm::vec3(1e-6f));
  for (const glm::vec3& p : m.positions) m.colors.push_back((p - box.lo) / ext);
  return m;
}

// A grid with a fin: a third face on an interior edge makes that edge non-manifold (its copies get locked).
TriMesh grid_with_fin(int n) {
  TriMesh m = make_grid(n, n);
  const Index a = static_cast<Index>((n / 2) * (n + 1) + 1), b = a + 1;
  m.positions.push_back((m.positions[a] + m.positions[b]) * 0.5f + glm::vec3(0.0f, 0.1f, 0.4f));
  m.indices.insert(m.indices.end(), {a, b, static_cast<Index>(m.positions.size() - 1)});
  return m;
}

VertexHierarchy build_locked_colored(int n) {
  QemOptions opt;
  opt.use_colors = true;
  opt.non_manifold = NonManifoldPolicy::kLock;
  return build_vertex_hierarchy(colored(grid_with_fin(n)), opt);
}

bool any_locked(const VertexHierarchy& h) {
  for (Index v = 0; v < h.num_leaves(); ++v)
    if (h.is_locked(v)) return true;
  return false;
}

void round_trip(const VertexHierarchy& h, const std::string& what) {
  SCOPED_TRACE(what);
  const Bytes bytes = encode_vertex_hierarchy(h);
  EXPECT_EQ(bytes.size(), layout_of(h, bytes).size);
  EXPECT_EQ(get_le(bytes, bytes.size() - 4, 4), reference_crc32(bytes.data(), bytes.size() - 4));
  const VertexHierarchy back = decode(bytes);
  back.validate();
  expect_identical(h, back);
  expect_same_behaviour(h, back);
  EXPECT_EQ(encode_vertex_hierarchy(back), bytes) << "re-encoding a loaded hierarchy changed the bytes";
}

TEST(HierarchyIo, RoundTripGeneratedMeshes) {
  round_trip(build_vertex_hierarchy(make_icosphere(2)), "icosphere");
  round_trip(build_vertex_hierarchy(make_grid(12, 9)), "grid (border)");
  round_trip(build_vertex_hierarchy(testing::concat(make_torus(16, 10), make_icosphere(1), {3, 0, 0})), "torus + sphere");
  QemOptions partial;
  partial.target_vertices = 60;
  round_trip(build_vertex_hierarchy(make_torus(20, 12), partial), "torus, partial analysis");
}

TEST(HierarchyIo, RoundTripColours) {
  QemOptions opt;
  opt.use_colors = true;
  const VertexHierarchy h = build_vertex_hierarchy(colored(make_icosphere(2)), opt);
  ASSERT_TRUE(h.has_colors());
  round_trip(h, "coloured icosphere");
}

TEST(HierarchyIo, RoundTripLockedNonManifold) {
  QemOptions opt;
  opt.non_manifold = NonManifoldPolicy::kLock;
  const VertexHierarchy h = build_vertex_hierarchy(grid_with_fin(10), opt);
  ASSERT_TRUE(any_locked(h));
  ASSERT_GT(h.repair_report().locked_vertices, 0u);
  ASSERT_GT(h.repair_report().nonmanifold_edge_faces, 0u);
  round_trip(h, "locked fin");
  round_trip(build_locked_colored(4), "small locked and coloured");
}

TEST(HierarchyIo, HeaderIsLittleEndianAsDocumented) {
  const VertexHierarchy h = build_locked_colored(4);
  const Bytes b = encode_vertex_hierarchy(h);
  const Layout at = layout_of(h, b);
  ASSERT_EQ(b.size(), at.size);
  EXPECT_EQ(std::string(b.begin(), b.begin() + 8), "VMPMHIER");
  EXPECT_EQ(get_le(b, kVersionAt, 4), kVertexHierarchyFormatVersion);
  EXPECT_EQ(b[kVersionAt], 1u);
  EXPECT_EQ(get_le(b, kFlagsAt, 4), 3u);  // colours and locked
  EXPECT_EQ(get_le(b, kSizeAt, 8), b.size());
  EXPECT_EQ(get_le(b, kLeavesAt, 8), h.num_leaves());
  EXPECT_EQ(get_le(b, kCollapsesAt, 8), h.num_collapses());
  EXPECT_EQ(get_le(b, kFacesAt, 8), h.num_faces());
  EXPECT_EQ(get_le(b, kRingItemsAt, 8), (at.leaf_to_input - at.ring_items) / 4);
  EXPECT_EQ(static_cast<std::uint32_t>(get_le(b, at.positions + 4, 4)), std::bit_cast<std::uint32_t>(h.position(0).y));
  EXPECT_EQ(static_cast<std::uint32_t>(get_le(b, at.colors + 8, 4)), std::bit_cast<std::uint32_t>(h.color(0).z));
  const Index vs = static_cast<Index>(h.num_leaves());
  EXPECT_EQ(get_le(b, at.records + 4, 4), h.record(vs).vu);
  EXPECT_EQ(get_le(b, at.faces + 4, 4), h.face(0)[1]);
  EXPECT_EQ(static_cast<std::uint32_t>(get_le(b, at.bounds + 16, 4)), std::bit_cast<std::uint32_t>(h.bound(0).error));
  EXPECT_EQ(get_le(b, at.face_to_input, 4), h.face_to_input()[0]);
  EXPECT_EQ(get_le(b, at.repair + 8, 8), h.repair_report().input_faces);
  EXPECT_EQ(get_le(b, at.checksum, 4), reference_crc32(b.data(), b.size() - 4));
  const char* check = "123456789";
  EXPECT_EQ(reference_crc32(reinterpret_cast<const std::uint8_t*>(check), 9), 0xCBF43926u);
}

TEST(HierarchyIo, FilesRoundTripAndWritesAreAtomic) {
  const auto dir = testing::scratch_dir("hierarchy_io");
  const VertexHierarchy h = build_locked_colored(6);
  const std::string path = (dir / "h.vmh").string();
  write_vertex_hierarchy(path, h);
  const std::string on_disk = read_file(path);
  const Bytes expected = encode_vertex_hierarchy(h);
  EXPECT_EQ(on_disk, std::string(expected.begin(), expected.end()));
  expect_identical(h, read_vertex_hierarchy(path));

  // Overwriting replaces the file; no temporary is left beside it.
  const VertexHierarchy other = build_vertex_hierarchy(make_icosphere(1));
  write_vertex_hierarchy(path, other);
  expect_identical(other, read_vertex_hierarchy(path));
  std::size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) entries += e.is_regular_file();
  EXPECT_EQ(entries, 1u);

  // A write that cannot happen throws and creates nothing.
  const std::string bad = (dir / "missing_folder" / "h.vmh").string();
  EXPECT_THROW(write_vertex_hierarchy(bad, h), IoError);
  EXPECT_FALSE(std::filesystem::exists(bad));
  EXPECT_THROW(write_vertex_hierarchy((dir / "empty.vmh").string(), VertexHierarchy{}), InvalidInput);
  EXPECT_FALSE(std::filesystem::exists(dir / "empty.vmh"));

  try {
    read_vertex_hierarchy((dir / "nope.vmh").string());
    ADD_FAILURE() << "read a missing file";
  } catch (const IoError& e) {
    EXPECT_TRUE(contains(e.what(), "nope.vmh")) << e.what();
  }

  // A truncated file on disk: the error names the path and the offset where the data ran out.
  const std::string cut = (dir / "cut.vmh").string();
  {
    std::ofstream out(cut, std::ios::binary);
    out.write(on_disk.data(), static_cast<std::streamsize>(on_disk.size() / 2));
  }
  try {
    read_vertex_hierarchy(cut);
    ADD_FAILURE() << "read a truncated file";
  } catch (const IoError& e) {
    EXPECT_EQ(e.file(), cut);
    EXPECT_EQ(e.byte_offset(), on_disk.size() / 2);
    EXPECT_TRUE(contains(e.reason(), "truncated")) << e.what();
    EXPECT_TRUE(contains(e.what(), "cut.vmh")) << e.what();
  }
}

TEST(HierarchyIo, EveryTruncationIsRejected) {
  const Bytes full = encode_vertex_hierarchy(build_locked_colored(4));
  ASSERT_LT(full.size(), 12000u) << "keep the exhaustive loops fast under the sanitizers";
  RecordProperty("small_file_bytes", static_cast<int>(full.size()));
  for (std::size_t len = 0; len < full.size(); ++len) {
    const Bytes part(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(len));
    std::size_t peak = 0;
    const IoError e = decode_error(part, &peak, "cut.vmh");
    EXPECT_EQ(e.file(), "cut.vmh");
    EXPECT_EQ(e.byte_offset(), len) << e.what();
    EXPECT_TRUE(contains(e.reason(), "truncated")) << len << ": " << e.what();
    EXPECT_LE(peak, 4096u) << len;
    if (!contains(e.reason(), "truncated")) break;
  }
}

// Flips the bits of `mask` in every stride-th byte, one byte at a time; mask 0 flips bit (i mod 8) of byte i.
void expect_every_flip_rejected(const Bytes& full, std::size_t stride, std::uint8_t fixed_mask) {
  Bytes b = full;
  for (std::size_t i = 0; i < b.size(); i += stride) {
    const std::uint8_t mask = fixed_mask != 0 ? fixed_mask : static_cast<std::uint8_t>(1u << (i % 8));
    b[i] ^= mask;
    const IoError e = decode_error(b, nullptr, "flip.vmh");
    b[i] ^= mask;
    if (e.file() != "flip.vmh" || !contains(e.what(), "flip.vmh") || e.reason() == "accepted" || e.reason() == "bad_alloc") {
      ADD_FAILURE() << "byte " << i << " mask " << int{mask} << ": " << e.what();
      break;
    }
  }
}

TEST(HierarchyIo, EveryFlippedByteIsRejected) {
  const Bytes small = encode_vertex_hierarchy(build_locked_colored(4));
  expect_every_flip_rejected(small, 1, 0);  // every byte, each bit position in turn
  expect_every_flip_rejected(small, 13, 0xFF);
  const Bytes large = encode_vertex_hierarchy(build_vertex_hierarchy(make_icosphere(3)));
  expect_every_flip_rejected(large, large.size() / 61 + 1, 0x10);
}

TEST(HierarchyIo, TrailingBytesAreRejected) {
  Bytes b = encode_vertex_hierarchy(build_vertex_hierarchy(make_icosphere(1)));
  const std::size_t size = b.size();
  b.push_back(0);
  const IoError e = decode_error(b);
  EXPECT_EQ(e.byte_offset(), size);
  EXPECT_TRUE(contains(e.reason(), "unexpected bytes")) << e.what();
}

TEST(HierarchyIo, HugeCountsThrowWithoutAllocating) {
  const Bytes good = encode_vertex_hierarchy(build_locked_colored(4));
  for (std::size_t field : {kLeavesAt, kCollapsesAt, kFacesAt, kRingItemsAt}) {
    for (std::uint64_t value : {std::uint64_t{0xFFFFFFFE}, std::uint64_t{1} << 31, std::uint64_t{1} << 40,
                                ~std::uint64_t{0}, std::uint64_t{200000}}) {
      Bytes b = good;
      put_le(b, field, value, 8);
      reseal(b);
      std::size_t peak = 0;
      const IoError e = decode_error(b, &peak, "huge.vmh");
      EXPECT_EQ(e.byte_offset(), field) << e.what();
      EXPECT_TRUE(contains(e.reason(), "count of")) << e.what();
      EXPECT_TRUE(contains(e.what(), "huge.vmh"));
      EXPECT_LE(peak, 4096u) << "allocated " << peak << " bytes for count " << value << " at " << field;
    }
  }
  // Counts that each fit but together disagree with the file size.
  Bytes b = good;
  put_le(b, kRingItemsAt, get_le(b, kRingItemsAt, 8) + 1, 8);
  const IoError e = decode_error(b);
  EXPECT_TRUE(contains(e.reason(), "counts describe")) << e.what();
}

TEST(HierarchyIo, WrongMagicVersionAndFlagsHaveTheirOwnMessages) {
  const Bytes good = encode_vertex_hierarchy(build_vertex_hierarchy(make_icosphere(1)));
  {
    Bytes b = good;
    b[0] = 'X';
    const IoError e = decode_error(b, nullptr, "some/where/magic.vmh");
    EXPECT_EQ(e.byte_offset(), 0u);
    EXPECT_TRUE(contains(e.reason(), "bad magic")) << e.what();
    EXPECT_TRUE(contains(e.what(), "some/where/magic.vmh")) << e.what();
  }
  {
    const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const IoError e = decode_error(Bytes(off.begin(), off.end()), nullptr, "mesh.off");
    EXPECT_TRUE(contains(e.reason(), "bad magic")) << e.what();
  }
  for (std::uint32_t version : {2u, 0u, 0x01000000u}) {
    Bytes b = good;
    put_le(b, kVersionAt, version, 4);
    const IoError e = decode_error(b, nullptr, "future.vmh");
    EXPECT_EQ(e.byte_offset(), kVersionAt);
    EXPECT_TRUE(contains(e.reason(), "unsupported format version " + std::to_string(version))) << e.what();
    EXPECT_TRUE(contains(e.what(), "future.vmh")) << e.what();
  }
  {
    Bytes b = good;
    put_le(b, kFlagsAt, 4, 4);
    reseal(b);
    const IoError e = decode_error(b);
    EXPECT_EQ(e.byte_offset(), kFlagsAt);
    EXPECT_TRUE(contains(e.reason(), "unknown flags")) << e.what();
  }
}

TEST(HierarchyIo, ChecksumMismatchNamesTheChecksum) {
  const VertexHierarchy h = build_vertex_hierarchy(make_icosphere(1));
  Bytes b = encode_vertex_hierarchy(h);
  const Layout at = layout_of(h, b);
  b[at.bounds + 5] ^= 0x04;
  const IoError e = decode_error(b, nullptr, "sum.vmh");
  EXPECT_EQ(e.byte_offset(), at.checksum);
  EXPECT_TRUE(contains(e.reason(), "checksum mismatch")) << e.what();
  EXPECT_TRUE(contains(e.what(), "sum.vmh"));
}

// Damage behind a valid checksum (a buggy writer, or a deliberate edit): the parser and the builder catch it.
TEST(HierarchyIo, SemanticErrorsBehindAValidChecksum) {
  const Encoded fixture = encoded(build_locked_colored(4));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  auto edited = [&](std::size_t offset, std::uint64_t value, int width) {
    Bytes b = good;
    put_le(b, offset, value, width);
    reseal(b);
    return decode_error(b, nullptr, "edit.vmh");
  };
  const std::uint32_t nan_bits = std::bit_cast<std::uint32_t>(std::numeric_limits<float>::quiet_NaN());
  const std::uint32_t inf_bits = std::bit_cast<std::uint32_t>(std::numeric_limits<float>::infinity());
  struct Case {
    std::size_t offset;
    std::uint64_t value;
    int width;
    const char* reason;
  };
  const Case cases[] = {
      {at.positions + 12 * 3 + 4, nan_bits, 4, "non-finite value in the position of node"},
      {at.colors + 8, inf_bits, 4, "non-finite value in the colour of node"},
      {at.bounds + 36 * 2 + 12, inf_bits, 4, "non-finite value in the bound radius"},
      {at.bounds + 36 * 5 + 32, nan_bits, 4, "non-finite value in the normal cone angle"},
      {at.locked + 1, 2, 1, "locked flag of leaf 1"},
      {at.ring_offsets + 4, 0xFFFFFFFFu, 4, "stored ring offset 1"},
      {at.ring_offsets, 1, 4, "stored ring offset 0"},
  };
  for (const Case& c : cases) {
    const IoError e = edited(c.offset, c.value, c.width);
    EXPECT_EQ(e.byte_offset(), c.offset) << e.what();
    EXPECT_TRUE(contains(e.reason(), c.reason)) << e.what();
    EXPECT_EQ(e.file(), "edit.vmh");
  }
  // Errors of VertexHierarchyBuilder::finish (InvalidInput) and of validate() (std::logic_error) become
  // IoError naming the file.
  const Index nn = static_cast<Index>(h.num_nodes());
  Index child = 0;
  while (h.parent(child) == kInvalid) ++child;
  const struct {
    std::size_t offset;
    std::uint64_t value;
    const char* reason;
  } builder_cases[] = {
      {at.records, nn, "is not an earlier node"},                           // vt of the first collapse
      {at.records + 40 + 4, h.record(static_cast<Index>(h.num_leaves())).vt, "already has parent"},
      {at.faces, h.num_leaves(), "corner is not a leaf"},
      {at.ring_items, nn + 5, "stored ring item"},
      {at.bounds + 36 * child + 16, std::bit_cast<std::uint32_t>(1e30f), "larger error"},  // above its parent's
  };
  for (const auto& c : builder_cases) {
    const IoError e = edited(c.offset, c.value, 4);
    EXPECT_TRUE(contains(e.reason(), "not a valid vertex hierarchy")) << e.what();
    EXPECT_TRUE(contains(e.reason(), c.reason)) << e.what();
    EXPECT_TRUE(contains(e.what(), "edit.vmh")) << e.what();
  }
}

// An edited file, re-sealed, must be refused as an invalid hierarchy for `reason`.
void rejected(Bytes b, const std::string& reason) {
  reseal(b);
  const IoError e = decode_error(b, nullptr, "edit.vmh");
  EXPECT_TRUE(contains(e.reason(), "not a valid vertex hierarchy")) << e.what();
  EXPECT_TRUE(contains(e.reason(), reason)) << e.what();
}

// Colours and locks of an edited file (helper-55): a colour outside [0, 1] loaded and made pm query fail
// when writing its result, without naming the hierarchy; a locked leaf could be collapsed, a flag be 2.
TEST(HierarchyIo, ColoursAndLocksAreChecked) {
  const Encoded fixture = encoded(build_locked_colored(4));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  ASSERT_TRUE(h.has_colors());
  ASSERT_NE(at.locked, at.repair);  // the lock flags are stored
  auto refused = [](Bytes b, const std::string& reason) {  // by the reader itself, at a byte offset
    reseal(b);
    const IoError e = decode_error(b, nullptr, "edit.vmh");
    EXPECT_TRUE(contains(e.reason(), reason)) << e.what();
    EXPECT_TRUE(contains(e.what(), "edit.vmh (byte ")) << e.what();
  };
  {
    Bytes b = good;
    put_le(b, at.colors + 12 * 7, std::bit_cast<std::uint32_t>(1e10f), 4);
    refused(b, "the colour of node 7 is outside [0, 1]");
  }
  {
    Bytes b = good;
    put_le(b, at.colors + 12 * 3 + 8, std::bit_cast<std::uint32_t>(-0.5f), 4);
    refused(b, "the colour of node 3 is outside [0, 1]");
  }
  {
    // An unlocked leaf that the analysis collapsed, marked locked.
    Index leaf = 0;
    while (leaf < h.num_leaves() && (h.is_locked(leaf) || h.parent(leaf) == kInvalid)) ++leaf;
    ASSERT_LT(leaf, h.num_leaves());
    Bytes b = good;
    put_le(b, at.locked + leaf, 1, 1);
    put_le(b, at.repair + 64, h.repair_report().locked_vertices + 1, 8);  // and counted
    rejected(b, "is locked but collapsed");
  }
  {
    // The counts that take part in no sum: the locked vertices are the leaves locked, and each face
    // detached from a non-manifold edge and each non-manifold vertex split made a copy of a vertex.
    ASSERT_GT(h.repair_report().locked_vertices, 0u);
    Bytes b = good;
    put_le(b, at.repair + 64, h.repair_report().locked_vertices + 1, 8);
    rejected(b, "locked");
    b = good;
    put_le(b, at.repair + 40, h.repair_report().added_vertex_copies + 1, 8);
    rejected(b, "vertex copies");
    b = good;
    put_le(b, at.repair + 48, std::uint64_t{1} << 40, 8);
    rejected(b, "repair report");
  }
  // And the writer refuses a colour the reader would refuse (a library caller's input with colours past 1).
  TriMesh bright = colored(make_grid(4, 4));
  bright.colors[5] = {1.5f, 0.2f, 0.2f};
  QemOptions opt;
  opt.use_colors = true;
  EXPECT_THROW(encode_vertex_hierarchy(build_vertex_hierarchy(bright, opt)), InvalidInput);
}

// Records that are each well-formed but do not fit the hierarchy they sit in: the schemes used to loop
// forever (Hoppe's forced splits on a neighbour face created by the node itself, Xia-Varshney on a stored
// ring naming a node that is not there), read out of bounds (two equal cut vertices) or build a wrong mesh
// (fl^ and fr^ swapped with their cut vertices). Found by a review; each edit passed the reader before.
TEST(HierarchyIo, InconsistentRecordsBehindAValidChecksum) {
  const Encoded fixture = encoded(build_vertex_hierarchy(make_grid(5, 4)));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  const std::size_t nl = h.num_leaves(), nc = h.num_collapses();
  auto record_at = [&](std::size_t i) { return at.records + 40 * i; };
  // A collapse with both sides (fl^ and fr^).
  std::size_t both = 0;
  while (both < nc && (h.record(static_cast<Index>(nl + both)).fl_hat == kInvalid ||
                       h.record(static_cast<Index>(nl + both)).fr_hat == kInvalid))
    ++both;
  ASSERT_LT(both, nc);
  const CollapseRecord& r = h.record(static_cast<Index>(nl + both));
  {
    Bytes b = good;  // fn[0] := the node's own fl^
    put_le(b, record_at(both) + 24, r.fl_hat, 4);
    rejected(b, "not after it");
  }
  {
    Bytes b = good;  // vr^ := vl^
    put_le(b, record_at(both) + 12, r.vl_hat, 4);
    rejected(b, "both cut vertices are leaf");
  }
  {
    Bytes b = good;  // (vl^, fl^) and (vr^, fr^) exchanged: every face still holds its cut vertex
    put_le(b, record_at(both) + 8, r.vr_hat, 4);
    put_le(b, record_at(both) + 12, r.vl_hat, 4);
    put_le(b, record_at(both) + 16, r.fr_hat, 4);
    put_le(b, record_at(both) + 20, r.fl_hat, 4);
    rejected(b, "is not (vt, vu, cut)");
  }
  {
    Bytes b = good;  // the first stored ring names the last node, which is not in the mesh yet
    ASSERT_FALSE(h.stored_ring(static_cast<Index>(nl)).empty());
    put_le(b, at.ring_items, h.num_nodes() - 1, 4);
    rejected(b, "is not a node of the mesh after that collapse");
  }
  {
    Bytes b = good;  // leaf_to_input far beyond the input: leaves_of_inputs used to allocate by it
    put_le(b, at.leaf_to_input, 0xFFFFFFFEu, 4);
    rejected(b, "beyond the input's");
  }
  {
    // An input of 2^32 vertices (helper-53: with a leaf mapped to 2^32 - 2, pm query --measure sized an array
    // of 51 GB by it): the report must add up.
    Bytes b = good;
    put_le(b, at.repair, std::uint64_t{1} << 32, 8);
    rejected(b, "repair report");
  }
  {
    Bytes b = good;  // one input face more than kept + dropped
    put_le(b, at.repair + 8, h.repair_report().input_faces + 1, 8);
    rejected(b, "repair report");
  }
  {
    // A report raised by 2^63 on both sides of its sum added up (helper-55); the input had 32-bit indices.
    Bytes b = good;
    put_le(b, at.repair, h.repair_report().input_vertices + (std::uint64_t{1} << 63), 8);
    put_le(b, at.repair + 16, h.repair_report().unreferenced_vertices + (std::uint64_t{1} << 63), 8);
    rejected(b, "beyond 32-bit indices");
  }
  {
    // The same on the faces' sum: dropped faces raised by 2^63 twice wrapped round to the input's count.
    Bytes b = good;
    put_le(b, at.repair + 24, h.repair_report().degenerate_faces + (std::uint64_t{1} << 63), 8);
    put_le(b, at.repair + 32, h.repair_report().duplicate_faces + (std::uint64_t{1} << 63), 8);
    rejected(b, "beyond 32-bit indices");
  }
  {
    // Two faces from one input face (helper-55).
    Bytes b = good;
    put_le(b, at.face_to_input + 4, get_le(b, at.face_to_input, 4), 4);
    rejected(b, "is the source of two faces");
  }
  {
    // Every normal cone turned round: nesting still holds, but back-face culling answered for the other side
    // (helper-55: 954 triangles instead of 910 for a camera query). A leaf's cone must hold its faces' normals.
    Bytes b = good;
    for (std::size_t v = 0; v < h.num_nodes(); ++v)
      for (int k = 0; k < 3; ++k) {
        const std::size_t axis = at.bounds + 36 * v + 20 + 4 * static_cast<std::size_t>(k);
        put_le(b, axis, get_le(b, axis, 4) ^ 0x80000000u, 4);  // the sign bit
      }
    rejected(b, "is outside its normal cone");
  }
  {
    // A leaf moved to x = 3e38 with its bounds unchanged: the view criteria would test spheres it is not in.
    Bytes b = good;
    const float far = 3e38f;
    std::uint32_t bits = 0;
    std::memcpy(&bits, &far, 4);
    put_le(b, at.positions, bits, 4);
    rejected(b, "node 0: position outside its bounding sphere");
  }
}

// Edits that keep every record well-formed and every earlier check happy, but describe a topology no
// sequence of collapses makes: they passed the reader, and SrMesh then threw logic_errors, wrote out of
// bounds (list_erase), built faces other than the stored ones, or (Xia-Varshney) looped forever. Found by
// fuzzing past the checksum; validate() now replays the collapses on the original faces.
TEST(HierarchyIo, TopologyNoCollapseSequenceMakesIsRejected) {
  const Encoded fixture = encoded(build_vertex_hierarchy(make_grid(8, 7)));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  const std::size_t nl = h.num_leaves(), nc = h.num_collapses();
  {
    // A base face turned over: its edges now run the same way as its neighbours'.
    Bytes b = good;
    ASSERT_FALSE(h.base_faces().empty());
    const Index f = h.base_faces()[0];
    const auto c = h.face(f);
    put_le(b, at.faces + 12 * f + 4, c[2], 4);
    put_le(b, at.faces + 12 * f + 8, c[1], 4);
    rejected(b, "original vertex");
  }
  {
    // The first collapse's stored ring names a vertex of the mesh that is not a neighbour.
    Bytes b = good;
    const Index v = static_cast<Index>(nl);
    const auto ring = h.stored_ring(v);
    ASSERT_FALSE(ring.empty());
    Index far = 0;
    while (far < nl && (far == h.record(v).vt || far == h.record(v).vu ||
                        std::find(ring.begin(), ring.end(), far) != ring.end()))
      ++far;
    ASSERT_LT(far, nl);
    put_le(b, at.ring_items, far, 4);
    rejected(b, "the stored ring is not the set of its neighbours");
  }
  {
    // Hoppe's fn0 and fn1 exchanged (both real faces of the mesh at that time).
    std::size_t i = 0;
    while (i < nc && (h.record(static_cast<Index>(nl + i)).fn[0] == kInvalid ||
                      h.record(static_cast<Index>(nl + i)).fn[1] == kInvalid))
      ++i;
    ASSERT_LT(i, nc);
    const CollapseRecord& r = h.record(static_cast<Index>(nl + i));
    Bytes b = good;
    put_le(b, at.records + 40 * i + 24, r.fn[1], 4);
    put_le(b, at.records + 40 * i + 28, r.fn[0], 4);
    rejected(b, "fn0..fn3 are not the faces");
  }
}

// The property behind the replay: any edit of the topology fields (faces, records, stored rings) that the
// reader accepts leaves a hierarchy on which every scheme runs its operations to the end and stays valid.
// A small deterministic fuzzer; run under the sanitizers in CI, where an out-of-bounds access fails it.
TEST(HierarchyIo, AcceptedEditsBehindAValidChecksumAreSafeToRun) {
  const Encoded fixture = encoded(build_vertex_hierarchy(make_grid(6, 5)));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  const std::size_t nl = h.num_leaves(), nn = h.num_nodes();
  std::mt19937 rng(20261124);
  std::size_t accepted = 0, refused = 0;
  for (int trial = 0; trial < 600; ++trial) {
    Bytes b = good;
    // A field of the faces, the records or the stored rings, set to a nearby or a random index.
    std::size_t first = at.faces, last = at.bounds;
    if (trial % 3 == 1) first = at.records, last = at.faces;
    if (trial % 3 == 2) first = at.ring_items, last = at.leaf_to_input;
    if (last <= first) continue;
    const std::size_t field = first + 4 * std::uniform_int_distribution<std::size_t>(0, (last - first) / 4 - 1)(rng);
    const std::uint64_t old = get_le(b, field, 4);
    const std::uint64_t value = trial % 2 == 0 ? old + 1 - 2 * (rng() % 2) : rng() % nn;
    put_le(b, field, value & 0xFFFFFFFFu, 4);
    reseal(b);
    VertexHierarchy e;
    try {
      e = decode(b);
    } catch (const IoError&) {
      ++refused;
      continue;
    }
    ++accepted;
    SCOPED_TRACE("trial " + std::to_string(trial) + ": field at byte " + std::to_string(field) + " " +
                 std::to_string(old) + " -> " + std::to_string(value));
    for (RefinementScheme s : kAllSchemes) {
      SrMesh sr(e, s);
      ASSERT_NO_THROW(sr.refine_all()) << scheme_name(s);
      // Refined everywhere, the mesh is the stored original mesh, face by face and corner by corner.
      ASSERT_EQ(sr.num_faces(), e.num_faces()) << scheme_name(s);
      for (Index f = 0; f < e.num_faces(); ++f) {
        ASSERT_TRUE(sr.face_active(f)) << scheme_name(s) << " face " << f;
        auto got = sr.face(f), want = e.face(f);
        std::rotate(got.begin(), std::min_element(got.begin(), got.end()), got.end());
        std::rotate(want.begin(), std::min_element(want.begin(), want.end()), want.end());
        ASSERT_EQ(got, want) << scheme_name(s) << " face " << f;
      }
      ASSERT_NO_THROW(sr.coarsen_all()) << scheme_name(s);
      for (int step = 0; step < 200; ++step) {
        const Index v = static_cast<Index>(nl + rng() % (nn - nl));
        const CollapseRecord& r = e.record(v);
        if (sr.is_active(v)) {
          ASSERT_NO_THROW(sr.vsplit(v)) << scheme_name(s) << " vsplit " << v;
        } else if (sr.is_refined(v) && sr.is_active(r.vt) && sr.is_active(r.vu)) {
          ASSERT_NO_THROW(sr.ecol(v)) << scheme_name(s) << " ecol " << v;
        }
      }
      ASSERT_NO_THROW(sr.validate()) << scheme_name(s);
    }
  }
  // Both outcomes occur (so the test exercises both paths): most edits are refused, some harmless ones
  // (a stored ring in another order, a position of the unused field) are not.
  EXPECT_GT(refused, 0u);
  EXPECT_GT(accepted, 0u) << "no edit was accepted: the schemes ran on nothing";
  std::printf("fuzzed edits: %zu refused, %zu accepted and run\n", refused, accepted);
}

namespace {
ElementBound bound_at(glm::vec3 c, float r, float e) {
  ElementBound b;
  b.center = c;
  b.radius = r;
  b.error = e;
  return b;  // full normal cone
}
std::string finish_error(const VertexHierarchyBuilder::Raw& raw) {
  try {
    VertexHierarchyBuilder::finish(raw);
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "(accepted)";
}
}  // namespace

// VertexHierarchyBuilder::finish is public: what the reader relies on is checked there, not in the reader.
TEST(HierarchyBuilder, RejectsWhatNoAnalysisBuilds) {
  {
    // Three leaves, one collapse (0, 1) whose face dies: leaf 2 stays a root with no base face.
    VertexHierarchyBuilder::Raw raw;
    raw.num_leaves = 3;
    raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5f, 0, 0}};
    // Leaf spheres hold their face (finish() checks that too).
    raw.bounds = {bound_at({0, 0, 0}, 1.5f, 0), bound_at({1, 0, 0}, 1.5f, 0), bound_at({0, 1, 0}, 1.5f, 0), bound_at({0.5f, 0, 0}, 1.5f, 0.1f)};
    CollapseRecord r;
    r.vt = 0, r.vu = 1, r.vl_hat = 2, r.fl_hat = 0;
    raw.records = {r};
    raw.faces = {0, 1, 2};
    raw.ring_offsets = {0, 1};
    raw.ring_items = {2};
    raw.leaf_to_input = {0, 1, 2};
    raw.face_to_input = {0};
    raw.repair.input_vertices = 3, raw.repair.input_faces = 1;
    EXPECT_TRUE(contains(finish_error(raw), "root node 2 is a corner of no base face")) << finish_error(raw);
    raw.ring_offsets = {1, 0};  // decreasing (and not starting at 0)
    EXPECT_TRUE(contains(finish_error(raw), "offsets")) << finish_error(raw);
  }
  {
    // A chain of 64 leaves collapsed one after another: depth 63, one tree. Keys would need shifts by 64.
    const Index L = 64, C = 63;
    VertexHierarchyBuilder::Raw raw;
    raw.num_leaves = L;
    for (Index i = 0; i < L + C; ++i) {
      raw.positions.push_back({0, 0, 0});
      raw.bounds.push_back(bound_at({0, 0, 0}, 0, static_cast<float>(i >= L ? i - L + 1 : 0)));
    }
    for (Index i = 0; i < C; ++i) {
      CollapseRecord r;
      r.vt = i == 0 ? 0 : L + i - 1, r.vu = i + 1, r.vl_hat = 0, r.fl_hat = i;
      raw.records.push_back(r);
      raw.faces.insert(raw.faces.end(), {0, i + 1, (i + 2) % L});
      raw.face_to_input.push_back(i);
    }
    raw.ring_offsets.assign(C + 1, 0);
    for (Index i = 0; i < L; ++i) raw.leaf_to_input.push_back(i);
    raw.repair.input_vertices = L, raw.repair.input_faces = C;
    EXPECT_TRUE(contains(finish_error(raw), "more than 62 levels")) << finish_error(raw);
  }
}

// refine() hands the query's sink to the splits it forces; an exception (a leaf asked for) used to leave the
// sink pointing into the caller's dead frame, and the next vsplit called it (AddressSanitizer:
// stack-use-after-scope). An id out of range was read unchecked.
TEST(SrMeshApi, RefineChecksItsNodeAndForgetsTheSinkOnAnError) {
  const VertexHierarchy h = build_vertex_hierarchy(make_grid(6, 5));
  SrMesh sr(h);
  {
    std::size_t calls = 0;
    auto sink = [&calls](Index) { ++calls; };
    EXPECT_THROW(sr.refine(0, sink), InvalidInput);  // a leaf
    EXPECT_THROW(sr.refine(static_cast<Index>(h.num_nodes()), sink), InvalidInput);
    EXPECT_EQ(calls, 0u);
  }
  // Splits after the failed call: the old sink is gone, and nothing may call it.
  for (Index v : h.roots()) {
    if (h.is_leaf(v)) continue;
    EXPECT_TRUE(sr.vsplit(v));
  }
  sr.validate();
}

// A file large enough (over 4 MiB, over 2^14 nodes) that the reader computes the checksum beside the parse
// and runs the untrusted checks beside the derivation: whichever finds a fault first, the error is the one
// the serial order gives. The replay is split (from 2^17 collapses) only in the files of the shared data; the
// faults below are also checked with validate() split by hand.
TEST(HierarchyIo, LargeFilesReportTheSerialOrdersError) {
  const Encoded fixture = encoded(build_vertex_hierarchy(make_grid(150, 140)));
  const VertexHierarchy& h = fixture.h;
  const Bytes& good = fixture.good;
  const Layout& at = fixture.at;
  const std::size_t nl = h.num_leaves(), nc = h.num_collapses(), nn = h.num_nodes();
  ASSERT_GE(good.size(), std::size_t{1} << 22);
  ASSERT_GE(nc, std::size_t{1} << 14);
  expect_identical(h, decode(good));
  // Not under the allocation guard, whose limit is below this file's arrays.
  auto error_of = [](const Bytes& b) {
    try {
      decode(b);
    } catch (const IoError& e) {
      return e;
    }
    ADD_FAILURE() << "decode accepted a damaged file";
    return IoError("mem.vmh", "accepted");
  };
  auto rejected_large = [&](Bytes b, const std::string& reason) {
    reseal(b);
    const IoError e = error_of(b);
    EXPECT_TRUE(contains(e.reason(), "not a valid vertex hierarchy")) << e.what();
    EXPECT_TRUE(contains(e.reason(), reason)) << e.what();
  };
  const std::uint32_t nan_bits = 0x7FC00000u;
  {
    Bytes b = good;  // a NaN without a new checksum: the checksum is named, not the NaN
    put_le(b, at.positions + 12 * 5, nan_bits, 4);
    const IoError e = error_of(b);
    EXPECT_TRUE(contains(e.reason(), "checksum mismatch")) << e.what();
  }
  {
    Bytes b = good;  // the same NaN sealed: now it is the NaN, at its byte
    put_le(b, at.positions + 12 * 5 + 4, nan_bits, 4);
    reseal(b);
    const IoError e = error_of(b);
    EXPECT_TRUE(contains(e.reason(), "non-finite value in the position of node 5")) << e.what();
    EXPECT_EQ(e.byte_offset(), at.positions + 12 * 5 + 4);
  }
  {
    // An untrusted check's fault (a leaf's input vertex) and a later one of the derivation (a child that is
    // not an earlier node): the untrusted check comes first.
    Bytes b = good;
    put_le(b, at.leaf_to_input, 0xFFFFFFFEu, 4);
    put_le(b, at.records + 40 * (nc - 1), nn - 1, 4);
    rejected_large(b, "leaf 0: input vertex 4294967294 beyond the input's");
  }
  // Hoppe's fn0 and fn1 exchanged in collapse i: only the replay at node nl + i can tell.
  auto swap_fn = [&](Bytes& b, std::size_t i) {
    const CollapseRecord& r = h.record(static_cast<Index>(nl + i));
    put_le(b, at.records + 40 * i + 24, r.fn[1], 4);
    put_le(b, at.records + 40 * i + 28, r.fn[0], 4);
  };
  auto with_two_fn = [&](std::size_t i) {
    while (i < nc && (h.record(static_cast<Index>(nl + i)).fn[0] == kInvalid ||
                      h.record(static_cast<Index>(nl + i)).fn[1] == kInvalid ||
                      h.record(static_cast<Index>(nl + i)).fn[0] == h.record(static_cast<Index>(nl + i)).fn[1]))
      ++i;
    return i;
  };
  const std::size_t early = with_two_fn(nc / 10), late = with_two_fn(nc - nc / 20);
  ASSERT_LT(late, nc);
  const std::string late_node = "node " + std::to_string(nl + late) + " (replaying the collapses): fn0..fn3";
  const std::string early_node = "node " + std::to_string(nl + early) + " (replaying the collapses): fn0..fn3";
  // The same edits on the arrays, validated with the replay split: the same error as the reader's.
  auto split_error = [&](std::initializer_list<std::size_t> collapses) {
    VertexHierarchyBuilder::Raw raw = testing::raw_of(h);
    for (std::size_t i : collapses) std::swap(raw.records[i].fn[0], raw.records[i].fn[1]);
    const VertexHierarchy e = VertexHierarchyBuilder::finish(std::move(raw), false);
    try {
      e.validate(2);
    } catch (const std::logic_error& x) {
      return std::string(x.what());
    }
    return std::string("(passed)");
  };
  EXPECT_TRUE(contains(split_error({late}), late_node)) << split_error({late});
  EXPECT_TRUE(contains(split_error({late, early}), early_node)) << split_error({late, early});
  {
    Bytes b = good;  // near the end of the collapses
    swap_fn(b, late);
    rejected_large(b, late_node);
  }
  {
    Bytes b = good;  // near the end and near the start: the earlier collapse is named
    swap_fn(b, late);
    swap_fn(b, early);
    rejected_large(b, early_node);
  }
  {
    // A node check's fault (a child's error above its parent's, found before any replay) with the late
    // replay fault: the node check is named.
    Bytes b = good;
    swap_fn(b, late);
    const std::size_t v = nl + nc / 2;
    const Index child = h.record(static_cast<Index>(v)).vt;
    float big = h.bound(static_cast<Index>(v)).error * 2.0f + 1.0f;
    std::uint32_t bits = 0;
    std::memcpy(&bits, &big, 4);
    put_le(b, at.bounds + 36 * child + 16, bits, 4);
    rejected_large(b, "node " + std::to_string(v) + ": child " + std::to_string(child) + " has a larger error");
  }
}

TEST(HierarchyIo, EncodingAnEmptyHierarchyThrows) {
  EXPECT_THROW(encode_vertex_hierarchy(VertexHierarchy{}), InvalidInput);
}

TEST(HierarchyIo, SharedDataBunnyRoundTrip) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bunny_libigl_3485v.off");
  const TriMesh m = read_mesh(path);
  const VertexHierarchy h = build_vertex_hierarchy(m);
  const auto dir = testing::scratch_dir("hierarchy_io_bunny");
  const std::string file = (dir / "bunny.vmh").string();
  write_vertex_hierarchy(file, h);
  EXPECT_EQ(std::filesystem::file_size(file), layout_of(h, encode_vertex_hierarchy(h)).size);
  const VertexHierarchy back = read_vertex_hierarchy(file);
  expect_identical(h, back);
  const RefinementScheme kim_lee[] = {RefinementScheme::kKimLee};  // baselines: generated meshes above
  expect_same_behaviour(h, back, kim_lee);
  SrMesh sr(back);
  sr.refine_all();
  EXPECT_EQ(sr.num_faces(), h.num_faces());
  // A stride of flipped bytes over the real file.
  const Bytes bytes = encode_vertex_hierarchy(back);
  expect_every_flip_rejected(bytes, bytes.size() / 11 + 1, 0x40);
}

}  // namespace
}  // namespace varmesh
