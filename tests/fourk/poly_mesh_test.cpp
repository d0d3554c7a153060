// Polygon meshes: triangulate() refuses input its TriMesh could not hold; find_topology_problem() reports
// the first broken manifold rule as its contract orders them (against a brute-force reading of it), and
// PolyMesh::validate() and the FourKMesh constructor refuse exactly what it reports, naming its element.
#include "fourk/poly_mesh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "fourk/fourk_mesh.hpp"
#include "fourk/topology_oracle.hpp"
#include "multitri/errors.hpp"

namespace varmesh {
namespace {

TEST(PolyMesh, TriangulateGivesValidMeshes) {
  for (const PolyMesh& p : {make_quad_cube(), make_quad_torus(5, 4)}) {
    const TriMesh t = triangulate(p);
    EXPECT_NO_THROW(t.validate());
    EXPECT_EQ(t.num_faces(), 2 * p.num_faces());
    EXPECT_EQ(t.num_vertices(), p.num_vertices());
  }
  // A pentagon is a fan of three triangles; a face of two corners gives none.
  PolyMesh p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 1, 0}};
  const Index five[] = {0, 1, 2, 3, 4}, two[] = {0, 1};
  p.add_face(five);
  p.add_face(two);
  const TriMesh t = triangulate(p);
  EXPECT_EQ(t.num_faces(), 3u);
  EXPECT_NO_THROW(t.validate());
}

TEST(PolyMesh, TriangulateRefusesBadInputByName) {
  PolyMesh p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Index ok[] = {0, 1, 2}, oob[] = {0, 5, 9};
  p.add_face(ok);
  p.add_face(oob);
  try {
    triangulate(p);
    ADD_FAILURE() << "no throw for a corner out of range";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 1u);
  }
  PolyMesh offsets = make_quad_cube();
  offsets.face_offsets.back() += 4;  // runs past the corners
  EXPECT_THROW(triangulate(offsets), InvalidInput);
  offsets = make_quad_cube();
  std::swap(offsets.face_offsets[2], offsets.face_offsets[3]);  // decreasing
  EXPECT_THROW(triangulate(offsets), InvalidInput);
  PolyMesh huge = make_quad_cube();
  huge.positions[3].y = 1e300;  // valid in double, infinite in float
  try {
    triangulate(huge);
    ADD_FAILURE() << "no throw for a position beyond float";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 3u);
  }
}

PolyMesh poly_of(const testing::FaceList& faces) {
  PolyMesh p;
  Index nv = 0;
  for (const auto& f : faces) {
    p.add_face(f);
    for (Index c : f) nv = std::max(nv, c + 1);
  }
  p.positions.assign(nv + 1, glm::dvec3(0.0));  // one unreferenced vertex: allowed
  return p;
}

TopologyProblem problem_of(const testing::FaceList& faces, const TopologyRules& rules = kPolyMeshRules) {
  return find_topology_problem(poly_of(faces), rules);
}

// One small mesh per rule, with the data each must give, and the order between the rules and within them.
TEST(TopologyProblem, EachRuleWithItsFacesAndVertices) {
  // A square of two triangles, 0-1-2 and 0-2-3, is fine under both rule sets.
  EXPECT_FALSE(problem_of({{0, 1, 2}, {0, 2, 3}}));
  EXPECT_FALSE(problem_of({{0, 1, 2}, {0, 2, 3}}, kFourKMeshRules));

  TopologyProblem p = problem_of({{0, 1, 2}, {3, 4, 5, 4}, {6, 7, 6}});
  EXPECT_EQ(p.rule, TopologyRule::kRepeatedCorner);
  EXPECT_EQ(p.faces, (std::vector<Index>{1}));
  EXPECT_EQ(p.vertices[0], 4u);
  EXPECT_EQ(p.element(), 1u);

  // Face 1 runs 0 -> 1 like face 0; face 3 is a third face on 2-0 later on: the orientation shows first.
  p = problem_of({{0, 1, 2}, {0, 1, 3}, {2, 0, 4}, {0, 2, 5}});
  EXPECT_EQ(p.rule, TopologyRule::kInconsistentOrientation);
  EXPECT_EQ(p.faces, (std::vector<Index>{0, 1}));
  EXPECT_EQ(p.vertices, (std::array<Index, 2>{0, 1}));
  EXPECT_EQ(p.element(), 1u);
  // A repeated corner comes before any edge, wherever it is.
  p = problem_of({{0, 1, 2}, {0, 1, 3}, {5, 6, 5}});
  EXPECT_EQ(p.rule, TopologyRule::kRepeatedCorner);
  EXPECT_EQ(p.faces, (std::vector<Index>{2}));

  // Faces 0 and 2 run 1 -> 0 the same way, face 4 is the edge's third: all four faces of it are named and the
  // edge is a non-manifold one, oriented as face 0 runs it; its element is its third face.
  p = problem_of({{1, 0, 2}, {0, 1, 3}, {1, 0, 4}, {7, 8, 9}, {0, 1, 5}});
  EXPECT_EQ(p.rule, TopologyRule::kNonManifoldEdge);
  EXPECT_EQ(p.faces, (std::vector<Index>{0, 1, 2, 4}));
  EXPECT_EQ(p.vertices, (std::array<Index, 2>{1, 0}));
  EXPECT_EQ(p.element(), 2u);
  // The edge named is the one whose problem shows first: 4-5's third face (face 3) before 0-1's (face 4).
  p = problem_of({{0, 1, 2}, {1, 0, 3}, {4, 5, 6}, {5, 4, 7}, {4, 5, 8}, {0, 1, 9}});
  EXPECT_EQ(p.rule, TopologyRule::kNonManifoldEdge);
  EXPECT_EQ(p.faces, (std::vector<Index>{2, 3, 4}));
  EXPECT_EQ(p.vertices, (std::array<Index, 2>{4, 5}));

  // A closed pillow of two triangles: manifold, but a doubled face under FourKMesh's rules.
  const testing::FaceList pillow = {{7, 8, 9}, {0, 1, 2}, {3, 4, 5}, {2, 1, 0}};
  EXPECT_FALSE(problem_of(pillow));
  p = problem_of(pillow, kFourKMeshRules);
  EXPECT_EQ(p.rule, TopologyRule::kDoubledFace);
  EXPECT_EQ(p.faces, (std::vector<Index>{1, 3}));
  EXPECT_EQ(p.element(), 3u);

  // Three triangles that meet only at vertex 3, and a bow-tie at vertex 1 after them: vertex 1 is the lowest.
  const testing::FaceList fans = {{3, 4, 5}, {3, 6, 7}, {3, 8, 9}, {1, 10, 11}, {1, 12, 13}};
  p = problem_of(fans);
  EXPECT_EQ(p.rule, TopologyRule::kNonManifoldVertex);
  EXPECT_EQ(p.vertices[0], 1u);
  EXPECT_EQ(p.faces, (std::vector<Index>{3, 4}));
  EXPECT_EQ(p.element(), 1u);
  EXPECT_FALSE(problem_of(fans, kFourKMeshRules));
  p = problem_of({{3, 4, 5}, {3, 6, 7}, {3, 8, 9}});
  EXPECT_EQ(p.vertices[0], 3u);
  EXPECT_EQ(p.faces, (std::vector<Index>{0, 1, 2}));  // one face per fan
}

// Malformed input is refused by name, not read past.
TEST(TopologyProblem, RefusesMalformedInput) {
  const std::vector<Index> corners = {0, 1, 2, 0, 2, 3};
  EXPECT_NO_THROW(find_topology_problem(std::vector<Index>{0, 3, 6}, corners, 4));
  EXPECT_THROW(find_topology_problem(std::vector<Index>{0, 3, 6}, corners, 3), InvalidInput);  // corner 3
  EXPECT_THROW(find_topology_problem(std::vector<Index>{0, 3, 5}, corners, 4), InvalidInput);  // end != size
  EXPECT_THROW(find_topology_problem(std::vector<Index>{0, 100, 6}, corners, 4), InvalidInput);
  EXPECT_THROW(find_topology_problem(std::vector<Index>{0, 2, 6}, corners, 4), InvalidInput);  // 2 corners
  EXPECT_THROW(find_topology_problem(std::vector<Index>{}, corners, 4), InvalidInput);
  try {
    find_topology_problem(std::vector<Index>{0, 3, 6}, std::vector<Index>{0, 1, 2, 0, 2, 7}, 4);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 1u);
  }
}

// Grids of quads and triangles damaged at random (testing::damaged_grid): the fast search agrees with the
// brute-force reading of its contract under both rule sets, PolyMesh::validate() refuses exactly what it
// reports with its element, and so does the FourKMesh constructor on the all-triangle meshes.
TEST(TopologyProblem, AgreesWithBruteForceOnDamagedGrids) {
  std::mt19937 rng(4711);
  std::map<TopologyRule, int> seen_poly, seen_fourk;
  int fourk_meshes = 0;
  for (int round = 0; round < 1500; ++round) {
    const testing::DamagedGrid grid = testing::damaged_grid(rng);
    const testing::FaceList& faces = grid.faces;
    const bool triangles_only = grid.triangles_only;
    const PolyMesh p = poly_of(faces);
    for (const TopologyRules& rules : {kPolyMeshRules, kFourKMeshRules}) {
      const TopologyProblem fast = find_topology_problem(p, rules);
      const TopologyProblem slow = testing::slow_topology_problem(faces, rules);
      ASSERT_TRUE(testing::same_problem(fast, slow))
          << "round " << round << ": " << describe_topology_problem(fast) << " / " << describe_topology_problem(slow);
      ++(rules.one_fan_per_vertex ? seen_poly : seen_fourk)[fast.rule];
    }
    const TopologyProblem expected = testing::slow_topology_problem(faces, kPolyMeshRules);
    try {
      p.validate();
      EXPECT_FALSE(expected) << "round " << round;
    } catch (const InvalidInput& e) {
      ASSERT_TRUE(expected) << "round " << round << ": " << e.what();
      EXPECT_EQ(e.element(), expected.element()) << e.what();
    }
    if (!triangles_only) continue;
    ++fourk_meshes;
    TriMesh t;
    t.positions.assign(p.num_vertices(), glm::vec3(0.0f));
    for (const auto& f : faces) t.indices.insert(t.indices.end(), f.begin(), f.end());
    const TopologyProblem fourk = testing::slow_topology_problem(faces, kFourKMeshRules);
    try {
      const FourKMesh m(t);
      EXPECT_FALSE(fourk) << "round " << round;
      EXPECT_NO_THROW(m.validate());
    } catch (const InvalidInput& e) {
      ASSERT_TRUE(fourk) << "round " << round << ": " << e.what();
      EXPECT_EQ(e.element(), fourk.element()) << e.what();
    }
  }
  // Every rule came up often enough to mean something.
  for (TopologyRule r : {TopologyRule::kNone, TopologyRule::kRepeatedCorner, TopologyRule::kNonManifoldEdge,
                         TopologyRule::kInconsistentOrientation, TopologyRule::kNonManifoldVertex})
    EXPECT_GT(seen_poly[r], 40) << int(r);
  for (TopologyRule r : {TopologyRule::kNone, TopologyRule::kNonManifoldEdge, TopologyRule::kInconsistentOrientation,
                         TopologyRule::kDoubledFace})
    EXPECT_GT(seen_fourk[r], 20) << int(r);
  EXPECT_GT(fourk_meshes, 500);
}

}  // namespace
}  // namespace varmesh
