#include "multitri/mesh_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "multitri/detail/topology.hpp"
#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

TriMesh make_mesh(std::vector<glm::vec3> positions, std::vector<Index> indices) {
  TriMesh m;
  m.positions = std::move(positions);
  m.indices = std::move(indices);
  return m;
}

// Positions on a circle (never three collinear), so only the fixtures that ask for zero area get it.
std::vector<glm::vec3> ring_positions(std::size_t n) {
  std::vector<glm::vec3> p;
  for (std::size_t i = 0; i < n; ++i) {
    const float t = 6.2831853f * static_cast<float>(i) / static_cast<float>(n);
    p.emplace_back(std::cos(t), std::sin(t), 0.1f * static_cast<float>(i));
  }
  return p;
}

TriMesh tetrahedron() {
  return make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3});
}

// n x m quads on a torus, each split into two triangles: V = nm, E = 3nm, F = 2nm, chi = 0.
TriMesh torus(Index n, Index m) {
  TriMesh t;
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < m; ++j) {
      const float a = 6.2831853f * static_cast<float>(i) / static_cast<float>(n);
      const float b = 6.2831853f * static_cast<float>(j) / static_cast<float>(m);
      t.positions.emplace_back((2 + std::cos(b)) * std::cos(a), (2 + std::cos(b)) * std::sin(a), std::sin(b));
    }
  auto id = [&](Index i, Index j) { return (i % n) * m + (j % m); };
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < m; ++j) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      t.indices.insert(t.indices.end(), {a, b, c, a, c, d});
    }
  return t;
}

// An independent, deliberately naive port of ../shared/data/tools/meshstat.py's analyze() (ordered maps
// and sets, per-vertex union-find), used as the slow reference for randomised soups.
struct NaiveReport {
  std::size_t unref = 0, degenerate = 0, dup = 0, edges = 0, boundary = 0, loops = 0, nm_edges = 0, nm_verts = 0,
              components = 0, zero_area = 0, inconsistent = 0, coincident = 0;
  long long chi = 0;
};

struct MapSets {
  std::map<Index, Index> parent;
  Index find(Index x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(Index a, Index b) {
    parent.try_emplace(a, a);
    parent.try_emplace(b, b);
    a = find(a);
    b = find(b);
    if (a != b) parent[a] = b;
  }
  std::size_t count() {
    std::set<Index> roots;
    for (auto& [x, p] : parent) roots.insert(find(x));
    return roots.size();
  }
};

NaiveReport naive_report(const TriMesh& m) {
  NaiveReport r;
  std::vector<std::vector<Index>> faces;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    std::vector<Index> t{m.corner(f, 0), m.corner(f, 1), m.corner(f, 2)};
    if (std::set<Index>(t.begin(), t.end()).size() < 3) {
      ++r.degenerate;
      continue;
    }
    faces.push_back(t);
    const glm::dvec3 a(m.positions[t[0]]), b(m.positions[t[1]]), c(m.positions[t[2]]);
    const glm::dvec3 u = b - a, w = c - a;  // small integer coordinates: exact in double
    if (u.y * w.z - u.z * w.y == 0 && u.z * w.x - u.x * w.z == 0 && u.x * w.y - u.y * w.x == 0) ++r.zero_area;
  }
  std::set<std::vector<Index>> sorted_faces;
  for (auto t : faces) {
    std::sort(t.begin(), t.end());
    sorted_faces.insert(t);
  }
  r.dup = faces.size() - sorted_faces.size();
  std::map<std::pair<Index, Index>, int> edge_faces, directed;
  std::set<Index> used;
  for (const auto& t : faces)
    for (int k = 0; k < 3; ++k) {
      const Index a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      used.insert(a);
      ++edge_faces[{std::min(a, b), std::max(a, b)}];
      ++directed[{a, b}];
    }
  r.edges = edge_faces.size();
  MapSets loops;
  for (const auto& [e, c] : edge_faces) {
    if (c == 2 && (directed[{e.first, e.second}] != 1 || directed[{e.second, e.first}] != 1)) ++r.inconsistent;
    if (c == 1) {
      ++r.boundary;
      loops.unite(e.first, e.second);
    }
    if (c > 2) ++r.nm_edges;
  }
  r.loops = loops.count();
  r.unref = m.num_vertices() - used.size();
  std::set<std::tuple<float, float, float>> places;
  for (const glm::vec3& p : m.positions) places.insert({p.x, p.y, p.z});
  r.coincident = m.num_vertices() - places.size();
  MapSets comps;
  for (const auto& t : faces) {
    comps.unite(t[0], t[1]);
    comps.unite(t[0], t[2]);
  }
  r.components = comps.count();
  std::map<Index, std::vector<std::size_t>> vf;
  for (std::size_t fi = 0; fi < faces.size(); ++fi)
    for (Index v : faces[fi]) vf[v].push_back(fi);
  for (const auto& [v, fl] : vf) {
    MapSets fans;
    for (auto fi : fl) fans.unite(static_cast<Index>(fi), static_cast<Index>(fi));
    std::map<Index, std::vector<std::size_t>> nb;
    for (auto fi : fl) {
      const auto& t = faces[fi];
      const auto i = static_cast<std::size_t>(std::find(t.begin(), t.end(), v) - t.begin());
      nb[t[(i + 1) % 3]].push_back(fi);
      nb[t[(i + 2) % 3]].push_back(fi);
    }
    for (const auto& [u, lst] : nb)
      for (std::size_t j = 1; j < lst.size(); ++j) fans.unite(static_cast<Index>(lst[0]), static_cast<Index>(lst[j]));
    if (fans.count() > 1) ++r.nm_verts;
  }
  r.chi = static_cast<long long>(used.size()) - static_cast<long long>(r.edges) + static_cast<long long>(faces.size());
  return r;
}

void expect_matches_naive(const TriMesh& m) {
  const MeshReport r = analyze_mesh(m);
  const NaiveReport n = naive_report(m);
  EXPECT_EQ(r.unreferenced_vertices, n.unref);
  EXPECT_EQ(r.degenerate_faces, n.degenerate);
  EXPECT_EQ(r.duplicate_faces, n.dup);
  EXPECT_EQ(r.edges, n.edges);
  EXPECT_EQ(r.boundary_edges, n.boundary);
  EXPECT_EQ(r.boundary_loops, n.loops);
  EXPECT_EQ(r.non_manifold_edges, n.nm_edges);
  EXPECT_EQ(r.non_manifold_vertices, n.nm_verts);
  EXPECT_EQ(r.components, n.components);
  EXPECT_EQ(r.euler_characteristic, n.chi);
  EXPECT_EQ(r.zero_area_faces, n.zero_area);
  EXPECT_EQ(r.orientation_inconsistent_edges, n.inconsistent);
  EXPECT_EQ(r.coincident_vertices, n.coincident);
}

TEST(MeshReportFixtures, EmptyMeshIsAllZeros) {
  const MeshReport r = analyze_mesh(TriMesh{});
  EXPECT_EQ(r.vertices, 0u);
  EXPECT_EQ(r.faces, 0u);
  EXPECT_EQ(r.edges, 0u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.genus, -1);
  EXPECT_TRUE(r.bounds.empty());
  EXPECT_NE(format_report(r).find("empty"), std::string::npos);
}

TEST(MeshReportFixtures, VerticesWithoutFaces) {
  const MeshReport r = analyze_mesh(make_mesh({{0, 0, 0}, {1, 2, 3}}, {}));
  EXPECT_EQ(r.vertices, 2u);
  EXPECT_EQ(r.unreferenced_vertices, 2u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.bounds.hi.z, 3.0f);
}

TEST(MeshReportFixtures, SingleTriangle) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(3), {0, 1, 2}));
  EXPECT_EQ(r.vertices, 3u);
  EXPECT_EQ(r.faces, 1u);
  EXPECT_EQ(r.edges, 3u);
  EXPECT_EQ(r.boundary_edges, 3u);
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.euler_characteristic, 1);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.genus, -1);
  EXPECT_EQ(r.zero_area_faces, 0u);
}

TEST(MeshReportFixtures, TetrahedronIsClosedGenusZero) {
  const MeshReport r = analyze_mesh(tetrahedron());
  EXPECT_EQ(r.edges, 6u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus, 0);
}

TEST(MeshReportFixtures, TorusHasGenusOne) {
  const MeshReport r = analyze_mesh(torus(5, 4));
  EXPECT_EQ(r.vertices, 20u);
  EXPECT_EQ(r.faces, 40u);
  EXPECT_EQ(r.edges, 60u);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_EQ(r.genus, 1);
}

TEST(MeshReportFixtures, BowTieHasOneNonManifoldVertexAndOneLoop) {
  // Two triangles sharing only vertex 0: two fans at 0; their boundaries touch there, forming one loop.
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(5), {0, 1, 2, 0, 3, 4}));
  EXPECT_EQ(r.non_manifold_vertices, 1u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_EQ(r.edges, 6u);
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.euler_characteristic, 1);
}

TEST(MeshReportFixtures, VertexWithThreeFans) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(7), {0, 1, 2, 0, 3, 4, 0, 5, 6}));
  EXPECT_EQ(r.non_manifold_vertices, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.boundary_loops, 1u);
}

TEST(MeshReportFixtures, ThreeTrianglesOnOneEdge) {
  // Edge (0,1) carries three faces. Vertex 0's faces are joined through that edge: one fan, so no
  // non-manifold vertex (meshstat.py's rule).
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(5), {0, 1, 2, 1, 0, 3, 0, 1, 4}));
  EXPECT_EQ(r.edges, 7u);
  EXPECT_EQ(r.non_manifold_edges, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_EQ(r.euler_characteristic, 1);
  EXPECT_FALSE(r.closed);
}

TEST(MeshReportFixtures, SquareWithSquareHole) {
  // Outer square 0..3, inner square 4..7, a ring of 8 triangles: annulus, chi 0, two boundary loops.
  std::vector<glm::vec3> p{{0, 0, 0}, {3, 0, 0}, {3, 3, 0}, {0, 3, 0}, {1, 1, 0}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}};
  std::vector<Index> idx;
  for (Index i = 0; i < 4; ++i) {
    const Index j = (i + 1) % 4;
    idx.insert(idx.end(), {i, j, 4 + j, i, 4 + j, 4 + i});
  }
  const MeshReport r = analyze_mesh(make_mesh(p, idx));
  EXPECT_EQ(r.faces, 8u);
  EXPECT_EQ(r.edges, 16u);
  EXPECT_EQ(r.boundary_edges, 8u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_EQ(r.zero_area_faces, 0u);
}

TEST(MeshReportFixtures, ReversedDuplicateOfASingleTriangleIsAClosedPillow) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(3), {0, 1, 2, 0, 2, 1}));
  EXPECT_EQ(r.duplicate_faces, 1u);
  EXPECT_EQ(r.edges, 3u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_EQ(r.genus, 0);
}

TEST(MeshReportFixtures, TetrahedronWithReversedDuplicateFace) {
  TriMesh t = tetrahedron();
  t.indices.insert(t.indices.end(), {2, 0, 1});  // face 0 = (0,2,1) again, other orientation and rotation
  const MeshReport r = analyze_mesh(t);
  EXPECT_EQ(r.faces, 5u);
  EXPECT_EQ(r.duplicate_faces, 1u);
  EXPECT_EQ(r.edges, 6u);
  EXPECT_EQ(r.non_manifold_edges, 3u);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.euler_characteristic, 3);
  EXPECT_EQ(r.genus, -1);
}

TEST(MeshReportFixtures, RepeatedIndexFaceIsDegenerateAndIgnored) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(4), {0, 1, 2, 2, 3, 3}));
  EXPECT_EQ(r.faces, 2u);
  EXPECT_EQ(r.degenerate_faces, 1u);
  EXPECT_EQ(r.zero_area_faces, 0u);
  EXPECT_EQ(r.unreferenced_vertices, 1u);  // vertex 3 only appears in the degenerate face
  EXPECT_EQ(r.edges, 3u);
  EXPECT_EQ(r.euler_characteristic, 1);
  EXPECT_EQ(r.components, 1u);
}

// Found by fuzz/fuzz_pipeline: with no non-degenerate face there is no edge, the bucket sort of the edges
// ran on an empty (null) array and stepped past it (UBSan in the sanitizer build).
TEST(MeshReportFixtures, OnlyDegenerateFacesGiveNoEdge) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(5), {0, 1, 0}));
  EXPECT_EQ(r.faces, 1u);
  EXPECT_EQ(r.degenerate_faces, 1u);
  EXPECT_EQ(r.edges, 0u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.unreferenced_vertices, 5u);  // a degenerate face references nothing
  EXPECT_EQ(r.boundary_loops, 0u);
}

TEST(MeshReportFixtures, CollinearFaceHasZeroArea) {
  const MeshReport r =
      analyze_mesh(make_mesh({{0, 0, 0}, {1, 1, 1}, {3, 3, 3}, {0, 1, 0}}, {0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(r.zero_area_faces, 1u);
  EXPECT_EQ(r.degenerate_faces, 0u);
  EXPECT_EQ(r.edges, 5u);  // a zero-area face is still a face with three edges
  EXPECT_EQ(r.euler_characteristic, 1);
}

TEST(MeshReportFixtures, CoincidentCornersHaveZeroArea) {
  const MeshReport r = analyze_mesh(make_mesh({{0.5f, 0.25f, 2}, {0.5f, 0.25f, 2}, {7, 1, -3}}, {0, 1, 2}));
  EXPECT_EQ(r.zero_area_faces, 1u);
  EXPECT_EQ(r.degenerate_faces, 0u);
}

TEST(MeshReportFixtures, UnreferencedVertices) {
  auto p = ring_positions(5);
  p[4] = {100, -50, 25};  // unreferenced, but inside the box: the box covers every position
  const MeshReport r = analyze_mesh(make_mesh(p, {0, 1, 2}));
  EXPECT_EQ(r.vertices, 5u);
  EXPECT_EQ(r.unreferenced_vertices, 2u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.euler_characteristic, 1);
  EXPECT_EQ(r.bounds.hi.x, 100.0f);
  EXPECT_EQ(r.bounds.lo.y, -50.0f);
}

TEST(MeshReportFixtures, TwoComponents) {
  const MeshReport r = analyze_mesh(make_mesh(ring_positions(6), {0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.euler_characteristic, 2);
}

TEST(MeshReportFixtures, TwoClosedComponentsHaveNoGenus) {
  TriMesh t = tetrahedron();
  const TriMesh u = tetrahedron();
  for (const auto& p : u.positions) t.positions.push_back(p + glm::vec3(5, 0, 0));
  for (Index i : u.indices) t.indices.push_back(i + 4);
  const MeshReport r = analyze_mesh(t);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.euler_characteristic, 4);
  EXPECT_EQ(r.genus, -1);
}

TEST(MeshReportFixtures, TwoTetrahedraSharingAVertexArePinched) {
  TriMesh t = tetrahedron();
  const TriMesh u = tetrahedron();
  for (std::size_t i = 1; i < 4; ++i) t.positions.push_back(u.positions[i] * -1.0f);
  for (Index i : u.indices) t.indices.push_back(i == 0 ? 0 : i + 3);  // shares vertex 0 only
  const MeshReport r = analyze_mesh(t);
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.non_manifold_vertices, 1u);
  EXPECT_EQ(r.euler_characteristic, 3);
  EXPECT_EQ(r.genus, -1);
}

TEST(MeshReportFixtures, InvalidIndexThrows) {
  EXPECT_THROW(analyze_mesh(make_mesh(ring_positions(3), {0, 1, 3})), InvalidInput);
  EXPECT_THROW(analyze_mesh(make_mesh(ring_positions(3), {0, 1})), InvalidInput);
}

TEST(MeshReportFixtures, FormatMentionsTheCounts) {
  TriMesh t = tetrahedron();
  t.positions.push_back({9, 9, 9});
  const std::string s = format_report(analyze_mesh(t));
  EXPECT_NE(s.find("vertices      5 (1 unreferenced, 0 at the position of another)"), std::string::npos) << s;
  EXPECT_NE(s.find("faces         4"), std::string::npos) << s;
  EXPECT_NE(s.find("boundary      0 edges in 0 loops"), std::string::npos) << s;
  EXPECT_NE(s.find("genus         0"), std::string::npos) << s;
  EXPECT_NE(s.find("[0, 0, 0] .. [9, 9, 9]"), std::string::npos) << s;
}

// A count of one takes the singular: one triangle has one boundary loop; three triangles on one edge make
// one non-manifold edge.
TEST(MeshReportFixtures, FormatAgreesCountsWithTheirNouns) {
  const std::string one = format_report(analyze_mesh(make_mesh(ring_positions(3), {0, 1, 2})));
  EXPECT_NE(one.find("boundary      3 edges in 1 loop\n"), std::string::npos) << one;
  std::vector<glm::vec3> p = ring_positions(3);
  p.push_back({0.f, 0.f, 1.f});
  p.push_back({0.f, 0.f, -1.f});
  const std::string fin = format_report(analyze_mesh(make_mesh(p, {0, 1, 2, 1, 0, 3, 0, 1, 4})));
  EXPECT_NE(fin.find("non-manifold  1 edge, "), std::string::npos) << fin;
}

TEST(MeshReportFixtures, FlippedFaceMakesItsThreeEdgesInconsistent) {
  TriMesh t = tetrahedron();
  EXPECT_EQ(analyze_mesh(t).orientation_inconsistent_edges, 0u);
  std::swap(t.indices[1], t.indices[2]);  // face 0 turned round: each of its edges now runs one way twice
  const MeshReport r = analyze_mesh(t);
  EXPECT_EQ(r.orientation_inconsistent_edges, 3u);
  EXPECT_TRUE(r.closed);
  EXPECT_NE(format_report(r).find("3 where its two faces disagree on orientation"), std::string::npos) << format_report(r);
}

TEST(MeshReportFixtures, CoincidentVerticesCountCopiesNotFirsts) {
  TriMesh t = tetrahedron();
  const std::size_t n = t.num_vertices();
  t.positions.push_back(t.positions[0]);  // one copy of vertex 0, unreferenced
  t.positions.push_back(t.positions[0]);  // and another
  t.positions.push_back(t.positions[2]);
  t.positions.push_back({-0.0f, 7.0f, 7.0f});
  t.positions.push_back({0.0f, 7.0f, 7.0f});  // -0 and +0 are one place
  const MeshReport r = analyze_mesh(t);
  EXPECT_EQ(r.vertices, n + 5);
  EXPECT_EQ(r.coincident_vertices, 4u);
  EXPECT_NE(format_report(r).find("4 at the position of another"), std::string::npos) << format_report(r);
}

// analyze_mesh counts coincident positions with a hash of their bit patterns, which is only right for finite
// coordinates (NaN != NaN); validate() keeps NaN and infinity out, naming the vertex.
TEST(MeshReportFixtures, NonFinitePositionsThrowNamingTheVertex) {
  const float bad[] = {std::nanf(""), -std::nanf(""), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (const float b : bad)
    for (int axis = 0; axis < 3; ++axis) {
      TriMesh t = tetrahedron();
      t.positions.push_back(t.positions[1]);
      t.positions.push_back(t.positions[1]);
      t.positions[4][axis] = b;
      t.positions[5][axis] = b;
      try {
        analyze_mesh(t);
        ADD_FAILURE() << "no throw for " << b << " on axis " << axis;
      } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("not finite"), std::string::npos) << e.what();
        EXPECT_EQ(e.element(), 4u) << e.what();
      }
    }
}

TEST(MeshReportExact, Collinearity) {
  using detail::exactly_collinear;
  EXPECT_TRUE(exactly_collinear({1, 2, 3}, {3, 5, 7}, {5, 8, 11}));
  EXPECT_TRUE(exactly_collinear({1, 2, 3}, {1, 2, 3}, {-4, 0.5f, 1e9f}));
  EXPECT_FALSE(exactly_collinear({0, 0, 0}, {1, 1, 0}, {2, 2 + 0x1p-20f, 0}));
  // Large offsets: rounding in a naive float evaluation would hide the tiny nonzero area.
  const float big = 16777216.0f;  // 2^24
  EXPECT_TRUE(exactly_collinear({big, big, big}, {big + 2, big + 4, big + 6}, {big + 4, big + 8, big + 12}));
  EXPECT_FALSE(exactly_collinear({big, 0.5f, 0}, {big + 2, 0.5f, 0}, {big + 4, 0.5f + 0x1p-24f, 0}));
  EXPECT_FALSE(exactly_collinear({1e-30f, 0, 0}, {0, 1e-30f, 0}, {0, 0, 0}));
}

TEST(MeshReportOracle, RandomSoupsMatchNaivePortOfMeshstat) {
  std::mt19937 rng(12345);
  for (int trial = 0; trial < 300; ++trial) {
    const Index nv = 3 + static_cast<Index>(rng() % 14);
    const std::size_t nf = rng() % 40;
    TriMesh m;
    for (Index v = 0; v < nv; ++v)
      m.positions.emplace_back(static_cast<float>(rng() % 3), static_cast<float>(rng() % 3), 0.0f);
    for (std::size_t f = 0; f < 3 * nf; ++f) m.indices.push_back(static_cast<Index>(rng() % nv));
    SCOPED_TRACE("trial " + std::to_string(trial));
    expect_matches_naive(m);
  }
}

// Coincident vertices against an ordered set of positions, on clouds drawn from a few values (so most
// positions repeat, some many times), with -0 and +0 among them, tiny and huge magnitudes, and sizes that
// make the hash table wrap around.
TEST(MeshReportOracle, CoincidentVerticesMatchAnOrderedSet) {
  std::mt19937 rng(2024);
  const float values[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.1f, 1e-45f, -1e-45f, 1e-38f, 3.4e38f, -3.4e38f, 16777216.0f,
                          16777217.0f, 0.30000001f, 0.3f};
  const std::size_t num_values = std::size(values);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t nv = rng() % (trial < 100 ? 40 : 5000);
    // Per trial, how many distinct values each coordinate draws from: from all equal to mostly distinct.
    const std::size_t spread = 1 + rng() % num_values;
    TriMesh m;
    for (std::size_t v = 0; v < nv; ++v) {
      glm::vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = values[rng() % spread];
      if (rng() % 4 == 0) p.z = static_cast<float>(rng() % 64);  // more distinct places
      if (v > 0 && rng() % 8 == 0) p = m.positions[rng() % v];   // an exact copy of an earlier vertex
      m.positions.push_back(p);
    }
    std::set<std::tuple<float, float, float>> places;  // std::less<float>: -0 and +0 are one key
    for (const glm::vec3& p : m.positions) places.insert({p.x, p.y, p.z});
    SCOPED_TRACE("trial " + std::to_string(trial) + ", " + std::to_string(nv) + " vertices");
    EXPECT_EQ(analyze_mesh(m).coincident_vertices, nv - places.size());
  }
}

// Positions on an integer lattice, all distinct, and then each repeated with its zero coordinates written as
// -0: hash keys that differ in few bits, and copies that differ from the original in their bits.
TEST(MeshReportOracle, CoincidentVerticesOnALattice) {
  TriMesh m;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      for (int k = 0; k < 8; ++k) m.positions.emplace_back(static_cast<float>(i), static_cast<float>(j), static_cast<float>(k));
  const std::size_t n = m.num_vertices();
  EXPECT_EQ(analyze_mesh(m).coincident_vertices, 0u);
  for (std::size_t v = 0; v < n; ++v) {
    glm::vec3 p = m.positions[v];
    for (int k = 0; k < 3; ++k)
      if (p[k] == 0.0f) p[k] = -0.0f;
    m.positions.push_back(p);
  }
  EXPECT_EQ(analyze_mesh(m).coincident_vertices, n);
}

TEST(MeshReportOracle, ReportIsInvariantUnderFaceOrderAndCornerRotation) {
  std::mt19937 rng(7);
  TriMesh m = torus(6, 5);
  m.indices.insert(m.indices.end(), {0, 1, 7, 7, 1, 0, 3, 3, 4});
  const MeshReport a = analyze_mesh(m);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::size_t> order(m.num_faces());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    TriMesh s = m;
    for (std::size_t i = 0; i < order.size(); ++i) {
      const int rot = static_cast<int>(rng() % 3);
      for (int k = 0; k < 3; ++k) s.indices[3 * i + static_cast<std::size_t>(k)] = m.corner(order[i], (k + rot) % 3);
    }
    const MeshReport b = analyze_mesh(s);
    EXPECT_EQ(format_report(a), format_report(b));
  }
}

// Counts from ../shared/data/MANIFEST.md, measured by tools/meshstat.py (an independent tool).
struct Expected {
  const char* file;
  std::size_t v, f, unref, boundary_edges, loops, nm_edges, nm_verts, components, dup, degenerate, zero_area;
  long long chi;
  int genus;
  float lo[3], hi[3];  // bbox, printed to 4 significant digits
};

void check_against_manifest(const std::string& path, const Expected& e) {
  const TriMesh mesh = read_mesh(path);
  const MeshReport r = analyze_mesh(mesh);
  EXPECT_EQ(r.vertices, e.v);
  EXPECT_EQ(r.faces, e.f);
  EXPECT_EQ(r.unreferenced_vertices, e.unref);
  EXPECT_EQ(r.boundary_edges, e.boundary_edges);
  EXPECT_EQ(r.boundary_loops, e.loops);
  EXPECT_EQ(r.non_manifold_edges, e.nm_edges);
  EXPECT_EQ(r.non_manifold_vertices, e.nm_verts);
  EXPECT_EQ(r.components, e.components);
  EXPECT_EQ(r.duplicate_faces, e.dup);
  EXPECT_EQ(r.degenerate_faces, e.degenerate);
  EXPECT_EQ(r.zero_area_faces, e.zero_area);
  EXPECT_EQ(r.euler_characteristic, e.chi);
  EXPECT_EQ(r.genus, e.genus);
  EXPECT_EQ(r.closed, e.boundary_edges == 0 && e.nm_edges == 0);
  for (int k = 0; k < 3; ++k) {
    // 4 significant digits: off by at most half a unit in the 4th digit, i.e. 5e-4 relative (plus slack).
    EXPECT_NEAR(r.bounds.lo[k], e.lo[k], 6e-4f * std::fabs(e.lo[k])) << "axis " << k;
    EXPECT_NEAR(r.bounds.hi[k], e.hi[k], 6e-4f * std::fabs(e.hi[k])) << "axis " << k;
  }
  // chi = V_used - E + F_nondegenerate gives the edge count the manifest implies.
  EXPECT_EQ(static_cast<long long>(r.edges),
            static_cast<long long>(e.v - e.unref) + static_cast<long long>(e.f - e.degenerate) - e.chi);
}

// The manifest's coincident-position and orientation counts (its notes line); every file of it has 0
// orientation-inconsistent edges.
TEST(MeshReportManifest, CoincidentPositionsAndOrientation) {
  const std::pair<const char*, std::size_t> files[] = {
      {"meshes/cow_cgal_2904v.off", 1},          {"meshes/beetle_boundary_19887v.off", 2},
      {"meshes/elephant-with-holes_2798v.off", 65}, {"meshes/dragon_vrip_res3_22998v.ply", 0},
      {"meshes/bun_zipper_35947v.obj", 0},       {"meshes/dragon_vrip_437645v_binary_le.ply", 2100}};
  for (const auto& [file, coincident] : files) {
    VARMESH_REQUIRE_SHARED(path, file);
    SCOPED_TRACE(path);
    const MeshReport r = analyze_mesh(read_mesh(path));
    EXPECT_EQ(r.coincident_vertices, coincident);
    EXPECT_EQ(r.orientation_inconsistent_edges, 0u);
  }
}

#define VARMESH_MANIFEST_TEST(name, ...)              \
  TEST(MeshReportManifest, name) {                    \
    const Expected e{__VA_ARGS__};                    \
    VARMESH_REQUIRE_SHARED(path, e.file);             \
    SCOPED_TRACE(path);                               \
    check_against_manifest(path, e);                  \
  }

// Fields: file, V, F, unreferenced, boundary edges, loops, non-manifold edges, non-manifold vertices,
// components, duplicates, degenerate, zero-area, chi, genus, bbox lo, bbox hi.
VARMESH_MANIFEST_TEST(DragonRes4, "meshes/dragon_vrip_res4_5205v.ply",
                      5205, 11102, 2, 0, 0, 803, 7, 1, 502, 0, 0, 509, -1,
                      {-0.1076f, 0.05284f, -0.04984f}, {0.09524f, 0.1963f, 0.04083f})
VARMESH_MANIFEST_TEST(DragonRes3, "meshes/dragon_vrip_res3_22998v.ply",
                      22998, 47794, 16, 0, 0, 2094, 5, 1, 1254, 0, 0, 1267, -1,
                      {-0.1077f, 0.05277f, -0.05005f}, {0.09598f, 0.1966f, 0.04083f})
VARMESH_MANIFEST_TEST(DragonRes2, "meshes/dragon_vrip_res2_100250v.ply",
                      100250, 202520, 43, 0, 0, 2534, 16, 7, 1489, 0, 0, 1520, -1,
                      {-0.1082f, 0.05274f, -0.05035f}, {0.09641f, 0.1971f, 0.04114f})
VARMESH_MANIFEST_TEST(BunnyZipper, "meshes/bun_zipper_35947v.obj", 35947, 69451, 1113, 223, 5, 0, 0, 1, 0, 0, 0, -3, -1,
                      {-0.09469f, 0.03299f, -0.06187f}, {0.06101f, 0.1873f, 0.0588f})
VARMESH_MANIFEST_TEST(CowTristrips, "meshes/cow_viewpoint_2903v_tristrips.ply",
                      2903, 5804, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1, -1,
                      {-4.446f, -3.637f, -1.701f}, {5.998f, 2.76f, 1.701f})
VARMESH_MANIFEST_TEST(CowObj, "meshes/cow_viewpoint_2903v.obj", 2903, 5804, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1, -1,
                      {-4.446f, -3.637f, -1.701f}, {5.998f, 2.76f, 1.701f})
VARMESH_MANIFEST_TEST(ElephantWithHoles, "meshes/elephant-with-holes_2798v.off",
                      2798, 4463, 0, 1353, 106, 0, 0, 1, 0, 0, 0, -110, -1,
                      {-0.3602f, -0.5f, -0.3015f}, {0.3602f, 0.5f, 0.3015f})
VARMESH_MANIFEST_TEST(BeetleBoundary, "meshes/beetle_boundary_19887v.off",
                      19887, 38656, 0, 1136, 11, 0, 0, 1, 0, 0, 0, -9, -1,
                      {-0.2029f, -0.1693f, -0.5f}, {0.2029f, 0.1693f, 0.5f})
VARMESH_MANIFEST_TEST(CowCgal, "meshes/cow_cgal_2904v.off", 2904, 5804, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0,
                      {-0.5f, -0.3062f, -0.1629f}, {0.5f, 0.3062f, 0.1629f})
VARMESH_MANIFEST_TEST(ChineseDragon, "meshes/ChineseDragon-10kv.off", 10000, 19994, 0, 6, 2, 0, 0, 1, 0, 0, 0, 0, -1,
                      {-34.43f, -52.7f, -1037.0f}, {27.16f, 60.19f, -927.3f})
VARMESH_MANIFEST_TEST(Armadillo, "meshes/armadillo_cgal_26002v.off", 26002, 52000, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0,
                      {-63.5f, -54.2f, -57.7f}, {63.52f, 97.11f, 57.72f})
VARMESH_MANIFEST_TEST(DragonFull, "meshes/dragon_vrip_437645v_binary_le.ply",
                      437645, 871414, 0, 4270, 407, 0, 0, 151, 0, 0, 108, -197, -1,
                      {-0.1083f, 0.05273f, -0.05041f}, {0.09657f, 0.1972f, 0.04121f})

}  // namespace
}  // namespace varmesh
