// Primal subdivision as binary 4-8 steps (fourk/subdiv.hpp): box-spline masks on periodic grids, tables
// against the fast path, topology invariants, the adaptive Mt against uniform subdivision, bad input.
#include "fourk/subdiv.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <functional>
#include <string>

#include <unistd.h>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"

namespace varmesh {
namespace {

// Dense 2D polynomial in (z1, z2) with an exponent offset, for box-spline symbols.
struct Poly2 {
  int lo1 = 0, lo2 = 0;
  std::vector<std::vector<double>> c{{1.0}};  // c[i][j] = coefficient of z1^(lo1+i) z2^(lo2+j)
  Poly2 times_binomial(int d1, int d2) const {  // * (1 + z1^d1 z2^d2) / 2
    Poly2 r;
    const int n1 = static_cast<int>(c.size()), n2 = static_cast<int>(c[0].size());
    r.lo1 = std::min(lo1, lo1 + d1);
    r.lo2 = std::min(lo2, lo2 + d2);
    const int hi1 = std::max(lo1 + n1 - 1, lo1 + d1 + n1 - 1), hi2 = std::max(lo2 + n2 - 1, lo2 + d2 + n2 - 1);
    r.c.assign(hi1 - r.lo1 + 1, std::vector<double>(hi2 - r.lo2 + 1, 0.0));
    for (int i = 0; i < n1; ++i)
      for (int j = 0; j < n2; ++j) {
        r.c[lo1 + i - r.lo1][lo2 + j - r.lo2] += 0.5 * c[i][j];
        r.c[lo1 + d1 + i - r.lo1][lo2 + d2 + j - r.lo2] += 0.5 * c[i][j];
      }
    return r;
  }
  double at(int e1, int e2) const {
    const int i = e1 - lo1, j = e2 - lo2;
    if (i < 0 || j < 0 || i >= static_cast<int>(c.size()) || j >= static_cast<int>(c[0].size())) return 0.0;
    return 4.0 * c[i][j];  // dyadic masks sum to 4
  }
};

// A periodic n x n grid (torus topology) with random values in the three coordinates.
PolyMesh random_periodic_grid(int n, unsigned seed) {
  PolyMesh m = make_quad_torus(n, n);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& p : m.positions) p = {u(rng), u(rng), u(rng)};
  return m;
}

// Fine-lattice coordinates (in [0, 2n)^2) of every vertex after one quadrisection of the periodic grid.
std::vector<std::array<int, 2>> fine_coordinates(const PolyMesh& grid, int n) {
  const SubdivTopology t = make_subdiv_topology(grid);
  auto coord = [n](Index v) { return std::array<int, 2>{static_cast<int>(v) / n, static_cast<int>(v) % n}; };
  auto wrap = [n](int d) { return d > 1 ? d - n : (d < -1 ? d + n : d); };
  std::vector<std::array<int, 2>> out(t.num_vertices + t.num_faces + t.num_edges());
  auto fine = [&](std::array<int, 2> c0, int d0, int d1) {
    const int m = 2 * n;
    return std::array<int, 2>{((2 * c0[0] + d0) % m + m) % m, ((2 * c0[1] + d1) % m + m) % m};
  };
  for (Index v = 0; v < t.num_vertices; ++v) out[v] = fine(coord(v), 0, 0);
  for (Index f = 0; f < t.num_faces; ++f) {
    const auto c0 = coord(t.face_verts[4 * f]);
    int s0 = 0, s1 = 0;
    for (int i = 0; i < 4; ++i) {
      const auto c = coord(t.face_verts[4 * f + i]);
      s0 += wrap(c[0] - c0[0]);
      s1 += wrap(c[1] - c0[1]);
    }
    out[t.num_vertices + f] = fine(c0, s0 / 2, s1 / 2);
  }
  for (std::size_t e = 0; e < t.num_edges(); ++e) {
    const auto a = coord(t.edge_verts[2 * e]), b = coord(t.edge_verts[2 * e + 1]);
    out[t.num_vertices + t.num_faces + e] = fine(a, wrap(b[0] - a[0]), wrap(b[1] - a[1]));
  }
  return out;
}

// Two binary steps of `scheme` on a periodic grid against the dyadic mask of `symbol`.
void expect_dyadic_mask(SubdivScheme scheme, const Poly2& symbol, int centre1, int centre2) {
  const int n = 12;
  const PolyMesh grid = random_periodic_grid(n, 7);
  const SubdivMesh fine = subdivide(grid, scheme, 2);
  const auto at = fine_coordinates(grid, n);
  ASSERT_EQ(at.size(), fine.positions.size());
  double worst = 0.0;
  for (std::size_t v = 0; v < at.size(); ++v) {
    glm::dvec3 want(0.0);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        // p'_x = sum_j a_{x - 2j} p_j over the periodic lattice (nearest representative of x - 2j).
        int d0 = at[v][0] - 2 * i, d1 = at[v][1] - 2 * j;
        d0 = ((d0 % (2 * n)) + 3 * n) % (2 * n) - n;
        d1 = ((d1 % (2 * n)) + 3 * n) % (2 * n) - n;
        const double w = symbol.at(d0 + centre1, d1 + centre2);
        if (w != 0.0) want += w * grid.positions[static_cast<std::size_t>(i * n + j)];
      }
    worst = std::max(worst, glm::length(want - fine.positions[v]));
  }
  EXPECT_LT(worst, 1e-12) << to_string(scheme);
}

TEST(Subdiv, FourEightTwoStepsAreTheC4BoxSplineMask) {
  // Directions e1, e2, e1 + e2, e1 - e2, each twice (Velho-Zorin 2001).
  Poly2 s;
  for (int r = 0; r < 2; ++r) s = s.times_binomial(1, 0).times_binomial(0, 1).times_binomial(1, 1).times_binomial(1, -1);
  expect_dyadic_mask(SubdivScheme::kFourEight, s, 3, 1);
}

TEST(Subdiv, CatmullClarkTwoStepsAreTheBicubicBSplineMask) {
  Poly2 s;
  for (int r = 0; r < 4; ++r) s = s.times_binomial(1, 0).times_binomial(0, 1);
  expect_dyadic_mask(SubdivScheme::kCatmullClark, s, 2, 2);
}

TEST(Subdiv, LinearTwoStepsAreTheBilinearMask) {
  Poly2 s;
  for (int r = 0; r < 2; ++r) s = s.times_binomial(1, 0).times_binomial(0, 1);
  expect_dyadic_mask(SubdivScheme::kLinear, s, 1, 1);
}

// An open grid (with a border) paired from triangles, with leftovers: a mixed triangle/quad base.
PolyMesh mixed_open_mesh() {
  PolyMesh m;
  const int n = 5;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) m.positions.emplace_back(i, j, 0.1 * std::sin(i + 2.0 * j));
  auto id = [&](int i, int j) { return static_cast<Index>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      if ((i + j) % 3 == 0) {
        const Index t0[3] = {id(i, j), id(i + 1, j), id(i + 1, j + 1)}, t1[3] = {id(i, j), id(i + 1, j + 1), id(i, j + 1)};
        m.add_face(t0);
        m.add_face(t1);
      } else {
        const Index q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
        m.add_face(q);
      }
    }
  return m;
}

std::vector<PolyMesh> test_meshes() {
  return {make_quad_cube(), make_quad_torus(6, 5), mixed_open_mesh()};
}

TEST(Subdiv, StencilTablesEqualTheFastPath) {
  for (const PolyMesh& base : test_meshes())
    for (SubdivScheme scheme : {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight}) {
      const int steps = 5;
      const auto tables = subdiv_stencil_tables(base, scheme, steps);
      ASSERT_EQ(tables.size(), static_cast<std::size_t>(steps));
      std::vector<double> values;
      for (const auto& p : base.positions) values.insert(values.end(), {p.x, p.y, p.z});
      StencilTable composed = tables[0];
      for (int s = 1; s < steps; ++s) composed = tables[s].after(composed);
      const std::vector<double> once = composed.apply(std::span<const double>(values), 3);
      for (const auto& t : tables) values = t.apply(std::span<const double>(values), 3);
      const SubdivMesh m = subdivide(base, scheme, steps);
      ASSERT_EQ(values.size(), 3 * m.positions.size());
      double worst = 0.0, worst_composed = 0.0;
      for (std::size_t v = 0; v < m.positions.size(); ++v)
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::abs(values[3 * v + c] - m.positions[v][c]));
          worst_composed = std::max(worst_composed, std::abs(once[3 * v + c] - m.positions[v][c]));
        }
      EXPECT_LT(worst, 1e-12) << to_string(scheme);
      EXPECT_LT(worst_composed, 1e-12) << to_string(scheme);
      // Affine invariance: every stencil's weights sum to 1 and are positive (all three schemes are convex
      // combinations, so the result lies in the convex hull).
      for (const auto& t : tables)
        for (std::size_t i = 0; i < t.num_outputs(); ++i) {
          double sum = 0.0;
          for (Index j = t.offsets[i]; j < t.offsets[i + 1]; ++j) {
            sum += t.weights[j];
            EXPECT_GE(t.weights[j], 0.0);
          }
          ASSERT_NEAR(sum, 1.0, 1e-14) << "output " << i;
        }
    }
}

TEST(Subdiv, TopologyInvariantsAtEveryStep) {
  for (const PolyMesh& base : test_meshes()) {
    const PolyEdgeCount e0 = count_edges(base);
    const long euler0 = static_cast<long>(base.num_vertices()) - static_cast<long>(e0.edges) +
                        static_cast<long>(base.num_faces());
    for (int steps = 0; steps <= 5; ++steps) {
      const SubdivMesh m = subdivide(base, SubdivScheme::kFourEight, steps);
      const PolyMesh poly = m.to_poly_mesh();
      ASSERT_NO_THROW(poly.validate()) << "steps " << steps;
      const PolyEdgeCount e = count_edges(poly);
      EXPECT_EQ(static_cast<long>(poly.num_vertices()) - static_cast<long>(e.edges) + static_cast<long>(poly.num_faces()),
                euler0)
          << "steps " << steps;
      // Each quadrisection doubles the border; a diagonal step leaves it.
      EXPECT_EQ(e.border_edges, e0.border_edges << (steps / 2)) << "steps " << steps;
      const TriMesh tri = m.to_tri_mesh();
      ASSERT_NO_THROW(poly_from_triangles(tri).validate());
      if (steps >= 2) {
        EXPECT_TRUE(m.topo.all_quads());
        // Stored valences and border flags agree with the edges.
        std::vector<int> val(m.topo.num_vertices, 0);
        for (Index v : m.topo.edge_verts) ++val[v];
        for (std::size_t v = 0; v < val.size(); ++v) ASSERT_EQ(val[v], m.topo.valence[v]) << v;
        // Face points of the first quadrisection have one edge per corner of their base face; every later
        // vertex is regular: valence 4 inside, 3 on the border.
        for (std::size_t f = 0; f < base.num_faces(); ++f)
          ASSERT_EQ(val[base.num_vertices() + f], static_cast<int>(base.face_size(f)));
        const std::size_t first_regular = base.num_vertices() + base.num_faces();
        for (std::size_t v = first_regular; v < val.size(); ++v)
          ASSERT_EQ(val[v], m.topo.vertex_border[v] ? 3 : 4) << v;
      }
    }
  }
}

// keep_last_edges = false (what the benchmark runs) drops only the last level's edges: faces, valences,
// border flags and positions equal those of the default run.
TEST(Subdiv, DroppingTheLastEdgesKeepsEverythingElse) {
  SubdivOptions no_edges;
  no_edges.keep_last_edges = false;
  for (const PolyMesh& base : test_meshes()) {
    for (int steps : {0, 2, 4}) {
      for (SubdivScheme scheme : {SubdivScheme::kCatmullClark, SubdivScheme::kFourEight}) {
        const SubdivMesh full = subdivide(base, scheme, steps);
        const SubdivMesh lean = subdivide(base, scheme, steps, no_edges);
        EXPECT_EQ(lean.topo.face_verts, full.topo.face_verts) << "steps " << steps;
        EXPECT_EQ(lean.topo.valence, full.topo.valence) << "steps " << steps;
        EXPECT_EQ(lean.topo.vertex_border, full.topo.vertex_border) << "steps " << steps;
        EXPECT_EQ(lean.positions, full.positions) << "steps " << steps;
        if (steps > 0) {
          EXPECT_FALSE(lean.topo.has_edges());
        }
        EXPECT_NO_THROW(lean.to_tri_mesh().validate());
      }
    }
    // An odd step count ends on a diagonal step, which needs the edges of the level before: they stay.
    const SubdivMesh odd = subdivide(base, SubdivScheme::kFourEight, 3, no_edges);
    EXPECT_TRUE(odd.topo.has_edges());
    EXPECT_EQ(odd.to_poly_mesh().corners, subdivide(base, SubdivScheme::kFourEight, 3).to_poly_mesh().corners);
  }
}

TEST(Subdiv, FacesQuadrupleEveryTwoSteps) {
  const PolyMesh cube = make_quad_cube();
  for (int steps = 0; steps <= 8; steps += 2) {
    const SubdivMesh m = subdivide(cube, SubdivScheme::kCatmullClark, steps);
    EXPECT_EQ(m.topo.num_faces, 6u << steps);
    // Closed quad mesh: V - E + F = 2 with E = 2F.
    EXPECT_EQ(m.topo.num_vertices, m.topo.num_faces + 2);
  }
}

TEST(Subdiv, PlanesAreReproducedAndBordersFollowTheBorderCurve) {
  PolyMesh flat = mixed_open_mesh();
  for (auto& p : flat.positions) p.z = 0.25 * p.x - 0.5 * p.y + 1.0;
  for (SubdivScheme scheme : {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight}) {
    const SubdivMesh m = subdivide(flat, scheme, 4);
    for (const auto& p : m.positions) ASSERT_NEAR(p.z, 0.25 * p.x - 0.5 * p.y + 1.0, 1e-12);
    // Border vertices follow the cubic B-spline of the border polygon: away from the four corners (where
    // the curve is rounded) they stay on the straight sides.
    for (std::size_t v = 0; v < m.topo.num_vertices; ++v)
      if (m.topo.vertex_border[v]) {
        const auto& p = m.positions[v];
        if (std::min({std::hypot(p.x, p.y), std::hypot(p.x - 5, p.y), std::hypot(p.x, p.y - 5),
                      std::hypot(p.x - 5, p.y - 5)}) < 1.0)
          continue;
        const bool on_line = std::abs(p.x) < 1e-12 || std::abs(p.x - 5) < 1e-12 || std::abs(p.y) < 1e-12 ||
                             std::abs(p.y - 5) < 1e-12;
        ASSERT_TRUE(on_line) << v;
      }
  }
}

TEST(Subdiv, CatmullClarkLimitOfASmoothFieldIsCloseAndConverges) {
  // Limit positions after more steps move less: |limit(L) - positions(L)| shrinks about 4x per level.
  const PolyMesh torus = make_quad_torus(8, 6);
  double prev = 1e9;
  for (int steps = 2; steps <= 8; steps += 2) {
    const SubdivMesh m = subdivide(torus, SubdivScheme::kCatmullClark, steps);
    const auto lim = catmull_clark_limit_positions(m);
    double worst = 0.0;
    for (std::size_t v = 0; v < lim.size(); ++v) worst = std::max(worst, glm::length(lim[v] - m.positions[v]));
    EXPECT_LT(worst, prev / 3.0) << steps;
    prev = worst;
  }
  // The limit of a base vertex does not depend on the level it is evaluated from.
  const auto a = catmull_clark_limit_positions(subdivide(torus, SubdivScheme::kCatmullClark, 2));
  const auto b = catmull_clark_limit_positions(subdivide(torus, SubdivScheme::kCatmullClark, 6));
  for (std::size_t v = 0; v < torus.num_vertices(); ++v) EXPECT_LT(glm::length(a[v] - b[v]), 1e-12) << v;
}

using Tri = std::array<Index, 3>;
Tri canonical(Tri t) {
  std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  return t;
}

TEST(Subdiv, AdaptiveMtFullyRefinedIsUniformAndFrontsConform) {
  for (const PolyMesh& base : test_meshes())
    for (int steps : {1, 2, 3, 4}) {
      SubdivMtInfo info;
      const Mt mt = build_subdivision_mt(base, SubdivScheme::kFourEight, steps, &info);
      const SubdivMesh uni = subdivide(base, SubdivScheme::kFourEight, steps);
      MtFront front(mt);
      for (NodeId n = 1; n < mt.num_nodes(); ++n) front.apply(n);
      front.validate();
      std::vector<VertexId> vids;
      const TriMesh got = front.to_mesh(nullptr, &vids);
      const TriMesh want = uni.to_tri_mesh();
      ASSERT_EQ(got.num_faces(), want.num_faces());
      EXPECT_EQ(info.uniform_faces, want.num_faces());
      std::multiset<Tri> a, b;
      for (std::size_t f = 0; f < got.num_faces(); ++f)
        a.insert(canonical({vids[got.corner(f, 0)], vids[got.corner(f, 1)], vids[got.corner(f, 2)]}));
      for (std::size_t f = 0; f < want.num_faces(); ++f)
        b.insert(canonical({want.corner(f, 0), want.corner(f, 1), want.corner(f, 2)}));
      EXPECT_EQ(a, b) << "steps " << steps;
      for (std::size_t v = 0; v < got.num_vertices(); ++v)
        ASSERT_EQ(got.positions[v], want.positions[vids[v]]);
      // A coarse query gives a conforming (validated) front with fewer faces.
      MtFront part(mt);
      Query q;
      q.criterion = Criterion::object_error(0.05f);
      extract(part, q);
      part.validate();
      EXPECT_LE(part.num_faces(), want.num_faces());
      EXPECT_NO_THROW(poly_from_triangles(part.to_mesh()).validate());
      ASSERT_EQ(info.node_step.size(), mt.num_nodes());
    }
}

// A quad whose fan diagonal (corner 0 to corner 2) is already an edge of the mesh behind it: the Mt's
// base triangles then used that directed edge twice, so no front was a conforming mesh (and since
// MtBuilder checks for it, the build was refused). The fan now starts at a corner whose diagonals are new.
PolyMesh quad_over_its_diagonal() {
  PolyMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.7, 0.3, -1}, {0.3, 0.7, -1}};
  for (const std::vector<Index>& face : std::vector<std::vector<Index>>{
           {0, 1, 2, 3}, {1, 0, 4}, {2, 1, 4}, {0, 2, 4}, {0, 3, 5}, {3, 2, 5}, {2, 0, 5}})
    m.add_face(face);
  return m;
}

TEST(Subdiv, FanDiagonalsAreNewEdges) {
  const PolyMesh m = quad_over_its_diagonal();
  ASSERT_NO_THROW(m.validate());
  for (SubdivScheme scheme : {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight}) {
    Mt mt;
    ASSERT_NO_THROW(mt = build_subdivision_mt(m, scheme, 2)) << to_string(scheme);
    MtFront front(mt);
    ASSERT_NO_THROW(front.validate()) << to_string(scheme) << " base";
    for (NodeId n = 1; n < mt.num_nodes(); ++n) {
      front.refine(n);
      ASSERT_NO_THROW(front.validate()) << to_string(scheme) << " after node " << n;
    }
    EXPECT_EQ(front.num_faces(), subdivide(m, scheme, 2).to_tri_mesh().num_faces()) << to_string(scheme);
  }
}

TEST(Subdiv, UnreferencedVerticesStayWhereTheyAre) {
  PolyMesh cube = make_quad_cube();
  cube.positions.emplace_back(5.0, 6.0, 7.0);  // no face uses it
  for (SubdivScheme scheme : {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight}) {
    const SubdivMesh m = subdivide(cube, scheme, 5);
    EXPECT_EQ(m.positions[8], glm::dvec3(5.0, 6.0, 7.0)) << to_string(scheme);
  }
  const SubdivMesh cc = subdivide(cube, SubdivScheme::kCatmullClark, 4);
  EXPECT_EQ(catmull_clark_limit_positions(cc)[8], glm::dvec3(5.0, 6.0, 7.0));
}

TEST(Subdiv, BadInputIsRejectedBeforeAllocating) {
  const PolyMesh cube = make_quad_cube();
  EXPECT_THROW(subdivide(cube, SubdivScheme::kCatmullClark, -1), InvalidInput);
  EXPECT_THROW(subdivide(cube, SubdivScheme::kCatmullClark, 40), InvalidInput);
  EXPECT_THROW(subdiv_stencil_tables(cube, SubdivScheme::kFourEight, 60), InvalidInput);
  PolyMesh nan = cube;
  nan.positions[3].y = std::nan("");
  EXPECT_THROW(subdivide(nan, SubdivScheme::kFourEight, 2), InvalidInput);
  PolyMesh flipped = cube;
  std::reverse(flipped.corners.begin(), flipped.corners.begin() + 4);  // one face against the others
  EXPECT_THROW(subdivide(flipped, SubdivScheme::kFourEight, 2), InvalidInput);
  // Two cubes sharing one vertex: a non-manifold vertex.
  PolyMesh two = cube;
  const Index shift = static_cast<Index>(cube.num_vertices()) - 1;
  for (const auto& p : cube.positions) two.positions.push_back(p + glm::dvec3(2.0, 2.0, 2.0));
  two.positions.pop_back();
  for (std::size_t f = 0; f < cube.num_faces(); ++f) {
    std::vector<Index> face;
    for (Index c : cube.face(f)) face.push_back(c == 0 ? 7 : c + shift);
    two.add_face(face);
  }
  try {
    subdivide(two, SubdivScheme::kFourEight, 1);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 7"), std::string::npos) << e.what();
  }
}

// Found by a review: each of these used to reach the arithmetic or the allocator.
TEST(Subdiv, ExtremeInputIsRejectedByName) {
  auto message = [](const std::function<void()>& fn) -> std::string {
    try {
      fn();
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "(no InvalidInput)";
  };
  // A face of 2^16 corners: its centre's valence wrapped to 0 in 16 bits and moved points by ~1e6. (The
  // repeated-corner check of validate() is linear now: this polygon took 53 s to validate before.)
  PolyMesh big;
  constexpr Index k = 65536;
  for (Index i = 0; i < k; ++i) {
    const double a = 6.283185307179586 * i / k;
    big.positions.push_back({10.0 + std::cos(a), std::sin(a), 0.0});
  }
  std::vector<Index> ring(k);
  for (Index i = 0; i < k; ++i) ring[i] = i;
  big.add_face(ring);
  EXPECT_NE(message([&] { subdivide(big, SubdivScheme::kCatmullClark, 2); }).find("face 0 has 65536 corners"), std::string::npos)
      << message([&] { subdivide(big, SubdivScheme::kCatmullClark, 2); });
  // Coordinates whose sums overflow.
  PolyMesh huge = make_quad_cube();
  huge.positions[2].x = 1e301;
  EXPECT_NE(message([&] { subdivide(huge, SubdivScheme::kLinear, 2); }).find("vertex 2 has a coordinate beyond 1e300"),
            std::string::npos);
  // A stencil table whose fields (public) do not form a table.
  StencilTable bad;
  bad.num_inputs = 2;
  bad.offsets = {0, 2};
  bad.sources = {0, 5};
  bad.weights = {0.5, 0.5};
  const std::vector<double> in(6, 1.0);
  EXPECT_NE(message([&] { bad.apply(in, 3); }).find("reads input 5 of 2"), std::string::npos);
  EXPECT_NE(message([&] { bad.after(bad); }).find("reads input 5 of 2"), std::string::npos);
  bad.sources = {0};
  EXPECT_NE(message([&] { bad.apply(in, 3); }).find("do not match"), std::string::npos);
  // More memory than the machine has: refused before allocating (26 binary steps of a cube make about
  // 400 M positions, some 39 GB of arrays by the estimate).
  const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (ram > 36e9) GTEST_SKIP() << "more than 36 GB of memory here: 26 steps would not be refused";
  EXPECT_NE(message([&] { subdivide(make_quad_cube(), SubdivScheme::kCatmullClark, 26); }).find("GB, more than the"),
            std::string::npos)
      << message([&] { subdivide(make_quad_cube(), SubdivScheme::kCatmullClark, 26); });
}

// Every split node's error is at least the distance between its new vertex and the midpoint of the edge
// it splits (the edge of its pre-image that no image triangle keeps), read from the Mt itself. A base quad
// whose fan had to start at corner 1 (FanDiagonalsAreNewEdges) used to be measured against the midpoint of
// corners 0 and 2, the diagonal it does not split: Catmull-Clark, 2 steps, 0.133 instead of 0.185.
TEST(Subdiv, AdaptiveNodeErrorsCoverTheSplitEdge) {
  std::vector<PolyMesh> bases = test_meshes();
  bases.push_back(quad_over_its_diagonal());
  auto key = [](Index a, Index b) { return std::pair<Index, Index>{std::min(a, b), std::max(a, b)}; };
  for (const PolyMesh& base : bases)
    for (SubdivScheme scheme : {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight})
      for (int steps : {1, 2, 3}) {
        const Mt mt = build_subdivision_mt(base, scheme, steps);
        const std::vector<glm::dvec3> p = subdivide(base, scheme, steps).positions;
        int checked = 0;
        for (NodeId n = 1; n < mt.num_nodes(); ++n) {
          if (mt.kind(n) != NodeKind::kSplit) continue;
          std::set<Index> pre_vertices;
          std::set<std::pair<Index, Index>> pre_edges, image_edges;
          for (FaceId f : mt.pre_image(n)) {
            const auto c = mt.face(f);
            for (int i = 0; i < 3; ++i) {
              pre_vertices.insert(c[i]);
              pre_edges.insert(key(c[i], c[(i + 1) % 3]));
            }
          }
          Index fresh = kInvalid;
          for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) {
            const auto c = mt.face(f);
            for (int i = 0; i < 3; ++i) {
              image_edges.insert(key(c[i], c[(i + 1) % 3]));
              if (!pre_vertices.count(c[i])) fresh = c[i];
            }
          }
          std::vector<std::pair<Index, Index>> split;
          for (const auto& e : pre_edges)
            if (!image_edges.count(e)) split.push_back(e);
          ASSERT_EQ(split.size(), 1u) << "node " << n;
          ASSERT_NE(fresh, kInvalid) << "node " << n;
          const double want = glm::length(p[fresh] - 0.5 * (p[split[0].first] + p[split[0].second]));
          EXPECT_GE(mt.bound(n).error, want * (1.0 - 1e-6))
              << to_string(scheme) << " steps " << steps << " node " << n << " splits " << split[0].first << "-"
              << split[0].second;
          ++checked;
        }
        EXPECT_GT(checked, 0);
      }
}

// The allocating apply() checks the input size before it sizes the output: a component count that does
// not match the input used to allocate num_outputs() x components doubles first (std::bad_alloc here).
TEST(Subdiv, StencilApplyChecksSizesBeforeAllocating) {
  const std::vector<StencilTable> tables = subdiv_stencil_tables(make_quad_cube(), SubdivScheme::kLinear, 1);
  const std::vector<double> in(3 * tables[0].num_inputs, 1.0);
  EXPECT_THROW((void)tables[0].apply(std::span<const double>(in), 1 << 30), InvalidInput);
  EXPECT_THROW((void)tables[0].apply(std::span<const double>(in), 0), InvalidInput);
  EXPECT_EQ(tables[0].apply(std::span<const double>(in), 3).size(), 3 * tables[0].num_outputs());
}

// A base beyond float's range (validate() takes coordinates up to 1e300) is refused naming its vertex; the
// builder used to say that some subdivided vertex's position was not finite.
TEST(Subdiv, AdaptiveMtRefusesABaseBeyondFloatRange) {
  PolyMesh cube = make_quad_cube();
  cube.positions[5] *= 1e39;
  ASSERT_NO_THROW(cube.validate());
  try {
    (void)build_subdivision_mt(cube, SubdivScheme::kCatmullClark, 1);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 5 has a coordinate beyond float's range"), std::string::npos) << e.what();
    EXPECT_EQ(e.element(), 5u);
  }
  cube.positions[5] = glm::dvec3(3e38, -3e38, 1.0);  // within range: built
  EXPECT_NO_THROW((void)build_subdivision_mt(cube, SubdivScheme::kCatmullClark, 1));
}

// `make(steps)` on a 4-8 cube is refused as needing more memory than the machine has, naming `steps`.
template <typename Make>
void expect_refused_for_memory(const Make& make, int steps) {
  try {
    (void)make(steps);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("GB of memory here (steps)"), std::string::npos) << e.what();
    EXPECT_EQ(e.element(), static_cast<std::uint64_t>(steps));
  }
}

// The hierarchy holds every triangle of every step, about 120 bytes each: 24 binary steps of a cube make
// about 400 M of them (some 48 GB), while the uniform mesh alone (about 10 GB by subdivide()'s estimate)
// passed subdivide()'s check. The build would then run out of memory part of the way (estimated from the
// measured 726 MB at 18 steps; under a 4 GB `ulimit -v` it ended in std::bad_alloc); refused by name now.
TEST(Subdiv, AdaptiveMtTooLargeForMemoryIsRefusedBeforeAllocating) {
  const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (ram > 44e9) GTEST_SKIP() << "more than 44 GB of memory here: 24 steps would not be refused";
  expect_refused_for_memory([](int steps) { return build_subdivision_mt(make_quad_cube(), SubdivScheme::kFourEight, steps); }, 24);
}

// The stencil tables of every step take about 240 bytes per final position: 25 binary steps of a cube
// (200 M positions, some 48 GB of tables, estimated from the measured 367 MB at 18 steps) passed
// subdivide()'s estimate (about 13 GB) and would then run out of memory (std::bad_alloc under a 4 GB
// `ulimit -v`). Refused by name now.
TEST(Subdiv, StencilTablesTooLargeForMemoryAreRefusedBeforeAllocating) {
  const double ram = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (ram > 44e9) GTEST_SKIP() << "more than 44 GB of memory here: 25 steps would not be refused";
  expect_refused_for_memory([](int steps) { return subdiv_stencil_tables(make_quad_cube(), SubdivScheme::kFourEight, steps); }, 25);
}

}  // namespace
}  // namespace varmesh
