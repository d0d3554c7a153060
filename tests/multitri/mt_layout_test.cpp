// The Mt's compact layout: relations derived instead of stored (creator, parents, children), corners
// packed 21 bits each, bounds packed into 16 bytes. Each is checked against the definition it replaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "multitri/bounds.hpp"
#include "multitri/mt.hpp"
#include "multitri/mt_grid_fixture.hpp"

namespace varmesh {
namespace {

using testing::GridMtOptions;
using testing::make_grid_mt;

GridMtOptions terrain_options(bool saturate, std::uint32_t seed) {
  GridMtOptions o;
  o.n = 3;
  o.levels = 6;
  o.swap_probability = 0.3;
  o.errors = GridMtOptions::Errors::kRandom;
  o.saturate = saturate;
  o.seed = seed;
  o.height = [](float x, float y) { return 0.6f * std::sin(2.1f * x) * std::cos(1.7f * y) + 0.05f * x * y; };
  return o;
}

// Creator by scanning the image ranges, independently of Mt::creator's hint table.
std::vector<NodeId> creators_by_ranges(const Mt& mt) {
  std::vector<NodeId> c(mt.num_faces(), kInvalid);
  for (NodeId n = 0; n < mt.num_nodes(); ++n)
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) c[f] = n;
  return c;
}

glm::vec3 normal_of(const Mt& mt, FaceId f) {
  const auto v = mt.face(f);
  return glm::normalize(glm::cross(mt.position(v[1]) - mt.position(v[0]), mt.position(v[2]) - mt.position(v[0])));
}

std::vector<FaceId> region(const Mt& mt, NodeId n) {
  std::vector<FaceId> faces(mt.pre_image(n).begin(), mt.pre_image(n).end());
  for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) faces.push_back(f);
  return faces;
}

TEST(MtLayout, CreatorParentsAndChildrenMatchTheirDefinitions) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const Mt mt = make_grid_mt(terrain_options(true, seed)).mt;
    const std::vector<NodeId> creator = creators_by_ranges(mt);
    for (FaceId f = 0; f < mt.num_faces(); ++f) ASSERT_EQ(mt.creator(f), creator[f]) << "face " << f;
    std::size_t with_two_parents = 0;
    for (NodeId n = 0; n < mt.num_nodes(); ++n) {
      std::vector<NodeId> want_p, want_c;
      for (FaceId f : mt.pre_image(n)) want_p.push_back(creator[f]);
      for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f)
        if (mt.destroyer(f) != kInvalid) want_c.push_back(mt.destroyer(f));
      for (auto* v : {&want_p, &want_c}) {
        std::sort(v->begin(), v->end());
        v->erase(std::unique(v->begin(), v->end()), v->end());
      }
      const std::vector<NodeId> got_p(mt.parents(n).begin(), mt.parents(n).end());
      std::vector<NodeId> got_c(mt.children(n).begin(), mt.children(n).end());
      EXPECT_EQ(got_p, want_p) << "node " << n << ": parents are the distinct creators, in increasing order";
      // size(), empty() and front() answer for the definitions too, not only for the ranges' own walks.
      EXPECT_EQ(mt.parents(n).size(), want_p.size()) << "node " << n;
      EXPECT_EQ(mt.children(n).size(), want_c.size()) << "node " << n;
      EXPECT_EQ(mt.parents(n).empty(), want_p.empty()) << "node " << n;
      EXPECT_EQ(mt.children(n).empty(), want_c.empty()) << "node " << n;
      if (!want_p.empty()) { EXPECT_EQ(mt.parents(n).front(), want_p.front()) << "node " << n; }
      std::sort(got_c.begin(), got_c.end());
      EXPECT_EQ(got_c, want_c) << "node " << n << ": children are the distinct destroyers, each once";
      with_two_parents += want_p.size() >= 2;
    }
    EXPECT_GT(with_two_parents, 0u) << "the fixture should have nodes with several parents";
  }
}

TEST(MtLayout, PackedBoundsContainTheRegionTheyBound) {
  for (bool saturate : {false, true}) {
    const Mt mt = make_grid_mt(terrain_options(saturate, 7)).mt;
    std::size_t cones = 0;
    for (NodeId n = 1; n < mt.num_nodes(); ++n) {
      const ElementBound b = mt.bound(n);
      for (FaceId f : region(mt, n)) {
        for (VertexId v : mt.face(f))
          EXPECT_LE(glm::length(mt.position(v) - b.center), b.radius) << "node " << n << " vertex " << v;
        if (!b.cone.is_full()) {
          EXPECT_GE(glm::dot(normal_of(mt, f), b.cone.axis), b.cone.cos_half_angle) << "node " << n;
        }
      }
      cones += !b.cone.is_full();
    }
    EXPECT_GT(cones, mt.num_nodes() / 2) << "most nodes of a smooth terrain should keep a normal cone";
  }
}

TEST(MtLayout, PackedBoundsAreTight) {
  const Mt mt = make_grid_mt(terrain_options(false, 11)).mt;
  Box3 box;
  for (const glm::vec3& p : mt.positions()) box.add(p);
  const float step = glm::length(box.extent()) / 65535.0f;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    std::vector<glm::vec3> pts;
    std::vector<glm::vec3> normals;
    for (FaceId f : region(mt, n)) {
      for (VertexId v : mt.face(f)) pts.push_back(mt.position(v));
      normals.push_back(normal_of(mt, f));
    }
    const Sphere exact = bounding_sphere(pts.data(), pts.size());
    const ElementBound b = mt.bound(n);
    EXPECT_LE(glm::length(b.center - exact.center), step) << "node " << n;
    EXPECT_LE(b.radius, exact.radius * 1.001f + 2.0f * step) << "node " << n;
    // The narrowest cone around the decoded axis is at most about one angle step (0.35 degrees) plus
    // the axis quantization narrower than the decoded one.
    if (b.cone.is_full()) continue;
    float widest = 1.0f;
    for (const glm::vec3& nr : normals) widest = std::min(widest, glm::dot(nr, b.cone.axis));
    const float slack = std::acos(std::clamp(b.cone.cos_half_angle, -1.0f, 1.0f)) - std::acos(std::clamp(widest, -1.0f, 1.0f));
    EXPECT_GE(slack, -1e-3f) << "node " << n;  // acos of a float near 1 resolves about 3e-4 rad
    EXPECT_LE(slack, 0.012f) << "node " << n;
  }
}

TEST(MtLayout, DecodedBoundsAreNested) {
  const Mt mt = make_grid_mt(terrain_options(true, 5)).mt;
  std::size_t checked_cones = 0;
  for (NodeId n = 0; n < mt.num_nodes(); ++n) {
    const ElementBound p = mt.bound(n);
    for (NodeId c : mt.children(n)) {
      const ElementBound q = mt.bound(c);
      EXPECT_LE(glm::length(q.center - p.center) + q.radius, p.radius) << "node " << n << " child " << c;
      EXPECT_LE(q.error, p.error) << "node " << n << " child " << c;
      if (p.cone.is_full()) continue;
      ASSERT_FALSE(q.cone.is_full()) << "node " << n << " has a cone but its child " << c << " has none";
      const double between = std::acos(std::clamp(double(glm::dot(p.cone.axis, q.cone.axis)), -1.0, 1.0));
      EXPECT_LE(between + std::acos(double(q.cone.cos_half_angle)), std::acos(double(p.cone.cos_half_angle)) + 1e-4)
          << "node " << n << " child " << c;
      ++checked_cones;
    }
  }
  EXPECT_GT(checked_cones, 0u);
}

TEST(MtLayout, OctahedralAxesDecodeToUnitVectorsCloseToTheirSource) {
  // Every grid code decodes to a unit vector, and the code's neighbours are within the angle the packer
  // adds to a cone for its axis quantization.
  for (std::uint32_t u = 0; u < 4096; u += 37)
    for (std::uint32_t v = 0; v < 4096; v += 41) {
      const glm::vec3 a = Mt::decode_octahedral(u | (v << 12));
      ASSERT_NEAR(glm::length(a), 1.0f, 1e-6f);
    }
  EXPECT_FLOAT_EQ(Mt::cone_cos(0), 1.0f);
  EXPECT_NEAR(Mt::cone_cos(254), 0.0f, 1e-6f);
  EXPECT_EQ(Mt::cone_cos(Mt::kFullConeCode), -1.0f);
  for (unsigned k = 1; k < 255; ++k) EXPECT_LT(Mt::cone_cos(k), Mt::cone_cos(k - 1));
}

TEST(MtLayout, CornersWidenAboveTwoToTheTwentyOneVertices) {
  for (std::size_t pad : {std::size_t{0}, (std::size_t{1} << Mt::kCornerBits) + 3}) {
    MtBuilder b;
    for (std::size_t i = 0; i < pad; ++i) b.add_vertex({float(i % 7), 0.0f, -1.0f});  // unreferenced
    const VertexId v0 = b.add_vertex({0, 0, 0}), v1 = b.add_vertex({1, 0, 0}), v2 = b.add_vertex({1, 1, 0}),
                   v3 = b.add_vertex({0, 1, 0}), m = b.add_vertex({0.5f, 0.5f, 0.1f});
    const FaceId t0 = b.add_face(v0, v1, v2), t1 = b.add_face(v0, v2, v3);
    const FaceId c[] = {b.add_face(m, v0, v1), b.add_face(m, v1, v2), b.add_face(m, v2, v3), b.add_face(m, v3, v0)};
    const FaceId base[] = {t0, t1};
    b.set_base(base);
    b.add_node(NodeKind::kSplit, base, c, 0.5f);
    const Mt mt = std::move(b).build();
    mt.validate();
    EXPECT_EQ(mt.wide_corners(), pad > 0);
    std::vector<std::array<VertexId, 3>> faces;
    for (FaceId f = 0; f < mt.num_faces(); ++f) faces.push_back(mt.face(f));
    const std::vector<std::array<VertexId, 3>> want = {{v0, v1, v2}, {v0, v2, v3}, {m, v0, v1},
                                                       {m, v1, v2},  {m, v2, v3},  {m, v3, v0}};
    EXPECT_EQ(faces, want);
    std::size_t sum = 0;
    for (const auto& item : mt.memory_breakdown()) sum += item.bytes;
    EXPECT_EQ(sum, mt.memory_bytes());
  }
}

}  // namespace
}  // namespace varmesh
