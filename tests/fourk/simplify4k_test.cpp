// Tests of fourk/simplify4k.hpp: four-face-cluster simplification (Velho-Gomes 2000, 8.2, Figure 21) as an
// increasing 4-k Multi-Triangulation. Generated meshes (icosphere, torus grids, open grids, two components)
// run anywhere; the cow of Figure 21 runs when ../shared/data is present.
#include "fourk/simplify4k.hpp"
#include "multitri/shapes.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"
#include "distance_oracle.hpp"
#include "fourk/topology_oracle.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

using testing::point_triangle;
using Key = std::array<VertexId, 3>;

constexpr auto dkey = directed_edge_key;

// Oriented face as a rotation-normalised triple (smallest corner first).
Key oriented(VertexId a, VertexId b, VertexId c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

// Sorted oriented faces (a multiset as a sorted vector).
std::vector<Key> face_keys(const TriMesh& m, const std::vector<VertexId>* ids = nullptr) {
  std::vector<Key> s;
  auto id = [&](Index v) { return ids ? (*ids)[v] : v; };
  for (std::size_t f = 0; f < m.num_faces(); ++f) s.push_back(oriented(id(m.corner(f, 0)), id(m.corner(f, 1)), id(m.corner(f, 2))));
  std::sort(s.begin(), s.end());
  return s;
}

std::vector<Key> front_keys(const MtFront& front) {
  std::vector<Key> s;
  for (FaceId f : front.faces()) {
    const auto v = front.mt().face(f);
    s.push_back(oriented(v[0], v[1], v[2]));
  }
  std::sort(s.begin(), s.end());
  return s;
}

// ---- generated meshes ----

TriMesh icosphere(int subdivisions) { return make_icosphere(subdivisions); }

// nu x nv torus grid; each quad split by one diagonal: alternating (a 4-8 pattern, half the vertices of
// degree 4) or always the same one (every vertex of degree 6).
TriMesh torus(int nu, int nv, bool alternate, glm::vec3 offset = glm::vec3(0.0f)) {
  TriMesh m;
  const float R = 2.0f, r = 0.7f;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const float u = 2.0f * std::numbers::pi_v<float> * float(i) / float(nu);
      const float v = 2.0f * std::numbers::pi_v<float> * float(j) / float(nv);
      m.positions.push_back(offset + glm::vec3((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                                               r * std::sin(v)));
    }
  auto id = [&](int i, int j) { return static_cast<Index>(((j + nv) % nv) * nu + (i + nu) % nu); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if (!alternate || (i + j) % 2 == 0) m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      else m.indices.insert(m.indices.end(), {a, b, d, b, c, d});
    }
  return m;
}

// n x n open grid over [0, 1]^2 with height z = amplitude * sin * cos (amplitude 0: flat).
TriMesh open_grid(int n, float amplitude, bool alternate) {
  TriMesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      const float fx = float(x) / float(n), fy = float(y) / float(n);
      m.positions.push_back({fx, fy, amplitude * std::sin(3.0f * fx) * std::cos(2.0f * fy)});
    }
  auto id = [n](int x, int y) { return static_cast<Index>(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const Index a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), d = id(x, y + 1);
      if (!alternate || (x + y) % 2 == 0) m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      else m.indices.insert(m.indices.end(), {a, b, d, b, c, d});
    }
  return m;
}

TriMesh concat(const TriMesh& a, const TriMesh& b) {
  TriMesh m = a;
  const auto off = static_cast<Index>(a.positions.size());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  for (Index i : b.indices) m.indices.push_back(i + off);
  return m;
}

// ---- oracles ----

// Each directed edge once (manifold edges, consistent orientation), no non-manifold vertex, no repeated
// corner. Returns an explanation or "".
// No fold-over: every image face of a node makes a non-negative normal dot product with each pre-image face
// it shares an edge with (the default min_normal_dot = 0, checked here independently of the builder).
std::string fold_problem(const Mt& mt, NodeId n) {
  auto normal = [&](FaceId f) {
    const auto v = mt.face(f);
    const glm::dvec3 a(mt.position(v[0])), b(mt.position(v[1])), c(mt.position(v[2]));
    return glm::normalize(glm::cross(b - a, c - a));
  };
  auto shares_edge = [&](FaceId f, FaceId g) {
    const auto a = mt.face(f), b = mt.face(g);
    int common = 0;
    for (VertexId x : a) common += std::find(b.begin(), b.end(), x) != b.end();
    return common >= 2;
  };
  for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f)
    for (FaceId g : mt.pre_image(n))
      if (shares_edge(f, g) && glm::dot(normal(f), normal(g)) < -1e-9)
        return "face " + std::to_string(f) + " folds over face " + std::to_string(g);
  return "";
}

struct Topology {
  std::string problem;  // "" when manifold and consistently oriented
  std::size_t components = 0, boundary_loops = 0;
  long long chi = 0;
  bool closed = false;
};
Topology topology(const TriMesh& m) {
  Topology t;
  std::vector<std::uint64_t> directed;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const Index a = m.corner(f, 0), b = m.corner(f, 1), c = m.corner(f, 2);
    if (a == b || b == c || a == c) t.problem = "degenerate face " + std::to_string(f);
    for (int k = 0; k < 3; ++k) directed.push_back(dkey(m.corner(f, k), m.corner(f, (k + 1) % 3)));
  }
  std::sort(directed.begin(), directed.end());
  if (std::adjacent_find(directed.begin(), directed.end()) != directed.end())
    t.problem = "a directed edge is used twice (non-manifold edge or flipped face)";
  const MeshReport r = analyze_mesh(m);
  if (r.non_manifold_edges != 0) t.problem = "non-manifold edges";
  if (r.non_manifold_vertices != 0) t.problem = std::to_string(r.non_manifold_vertices) + " non-manifold vertices";
  if (r.duplicate_faces != 0) t.problem = "duplicate faces";
  t.components = r.components;
  t.boundary_loops = r.boundary_loops;
  t.chi = r.euler_characteristic;
  t.closed = r.closed;
  return t;
}

// Points of the input surface: every used vertex, every face centroid and `per_face` random points per face.
std::vector<glm::dvec3> surface_samples(const TriMesh& input, int per_face, std::uint32_t seed) {
  std::vector<glm::dvec3> pts;
  std::vector<std::uint8_t> used(input.num_vertices(), 0);
  for (Index i : input.indices) used[i] = 1;
  for (std::size_t v = 0; v < input.num_vertices(); ++v)
    if (used[v]) pts.push_back(glm::dvec3(input.positions[v]));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t f = 0; f < input.num_faces(); ++f) {
    const glm::dvec3 a(input.positions[input.corner(f, 0)]), b(input.positions[input.corner(f, 1)]),
        c(input.positions[input.corner(f, 2)]);
    pts.push_back((a + b + c) / 3.0);
    for (int i = 0; i < per_face; ++i) {
      double s = u(rng), t = u(rng);
      if (s + t > 1.0) {
        s = 1.0 - s;
        t = 1.0 - t;
      }
      pts.push_back(a + s * (b - a) + t * (c - a));
    }
  }
  return pts;
}

// The points that lie farther than `r` from every face of the front (a uniform grid of face boxes grown by
// r finds the candidates; each candidate is checked exactly).
std::size_t points_farther_than(const std::vector<glm::dvec3>& pts, const MtFront& front, double r) {
  std::vector<std::array<glm::dvec3, 3>> tris;
  std::vector<std::array<double, 6>> boxes;  // grown by r
  glm::dvec3 lo(1e300), hi(-1e300);
  for (FaceId f : front.faces()) {
    const auto v = front.mt().face(f);
    std::array<glm::dvec3, 3> t{glm::dvec3(front.mt().position(v[0])), glm::dvec3(front.mt().position(v[1])),
                                glm::dvec3(front.mt().position(v[2]))};
    for (const auto& p : t) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    tris.push_back(t);
    const glm::dvec3 tlo = glm::min(glm::min(t[0], t[1]), t[2]) - glm::dvec3(r);
    const glm::dvec3 thi = glm::max(glm::max(t[0], t[1]), t[2]) + glm::dvec3(r);
    boxes.push_back({tlo.x, tlo.y, tlo.z, thi.x, thi.y, thi.z});
  }
  for (const auto& p : pts) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  lo -= glm::dvec3(r);
  hi += glm::dvec3(r);
  const double diag = glm::length(hi - lo);
  const double cell = std::max({r, diag / std::cbrt(double(tris.size()) + 1.0), 1e-9});
  auto cell_of = [&](const glm::dvec3& p) {
    return glm::ivec3(glm::floor((p - lo) / cell));
  };
  const glm::ivec3 dims = cell_of(hi) + glm::ivec3(1);
  std::unordered_map<std::int64_t, std::vector<std::size_t>> grid;
  auto key = [&](const glm::ivec3& c) { return (std::int64_t(c.z) * dims.y + c.y) * dims.x + c.x; };
  for (std::size_t i = 0; i < tris.size(); ++i) {
    const glm::ivec3 a = cell_of({boxes[i][0], boxes[i][1], boxes[i][2]}), b = cell_of({boxes[i][3], boxes[i][4], boxes[i][5]});
    for (int z = a.z; z <= b.z; ++z)
      for (int y = a.y; y <= b.y; ++y)
        for (int x = a.x; x <= b.x; ++x) grid[key({x, y, z})].push_back(i);
  }
  std::size_t far = 0;
  for (const auto& p : pts) {
    bool near = false;
    const auto it = grid.find(key(cell_of(p)));
    if (it != grid.end())
      for (std::size_t i : it->second) {
        const auto& b = boxes[i];
        if (p.x < b[0] || p.y < b[1] || p.z < b[2] || p.x > b[3] || p.y > b[4] || p.z > b[5]) continue;
        if (point_triangle(p, tris[i][0], tris[i][1], tris[i][2]) <= r) {
          near = true;
          break;
        }
      }
    far += !near;
  }
  return far;
}

// Checks one node's shape: a swap is 2 -> 2 on the same four vertices with the diagonal exchanged; a
// split is 2 -> 4 (one new vertex shared by the four faces, the pre-image's common edge gone) or 1 -> 2.
std::string node_problem(const Mt& mt, NodeId n) {
  const auto pre = mt.pre_image(n);
  std::vector<std::array<VertexId, 3>> img;
  for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) img.push_back(mt.face(f));
  std::vector<std::array<VertexId, 3>> pf;
  for (FaceId f : pre) pf.push_back(mt.face(f));
  auto verts = [](const std::vector<std::array<VertexId, 3>>& fs) {
    std::set<VertexId> s;
    for (const auto& f : fs) s.insert(f.begin(), f.end());
    return s;
  };
  auto common = [](const std::array<VertexId, 3>& a, const std::array<VertexId, 3>& b) {
    std::set<VertexId> s;
    for (VertexId x : a)
      if (std::find(b.begin(), b.end(), x) != b.end()) s.insert(x);
    return s;
  };
  if (mt.kind(n) == NodeKind::kSwap) {
    if (pf.size() != 2 || img.size() != 2) return "swap arity";
    const auto vp = verts(pf), vi = verts(img);
    if (vp.size() != 4 || vp != vi) return "swap vertices differ";
    const auto e0 = common(pf[0], pf[1]), e1 = common(img[0], img[1]);
    if (e0.size() != 2 || e1.size() != 2) return "swap faces do not share an edge";
    for (VertexId x : e0)
      if (e1.count(x)) return "swap keeps an endpoint of its diagonal";
    return "";
  }
  if (mt.kind(n) != NodeKind::kSplit) return "unexpected node kind";
  const auto vp = verts(pf), vi = verts(img);
  std::vector<VertexId> fresh;
  for (VertexId x : vi)
    if (!vp.count(x)) fresh.push_back(x);
  if (fresh.size() != 1) return "split does not add exactly one vertex";
  for (const auto& f : img)
    if (std::find(f.begin(), f.end(), fresh[0]) == f.end()) return "split image face misses the new vertex";
  if (pf.size() == 2 && img.size() == 4) {
    if (common(pf[0], pf[1]).size() != 2) return "split pre-image faces do not share an edge";
    return "";
  }
  if (pf.size() == 1 && img.size() == 2) return "";
  return "split arity";
}


// The common battery: MT definition, refine-all = input, coarsen-all = coarsest level, every level as the
// simplification made it, manifold, same topology, decreasing face counts, node shapes.
void check_hierarchy(const TriMesh& input, const Simplify4kResult& r, bool closed) {
  ASSERT_NO_THROW(r.mt.validate());
  ASSERT_GE(r.num_levels(), 2u) << "no simplification happened";
  ASSERT_EQ(r.level_meshes.size(), r.num_levels());
  const Topology in_shape = topology(input);

  MtFront all(r.mt);
  for (NodeId n = 1; n < r.mt.num_nodes(); ++n) all.apply(n);
  ASSERT_NO_THROW(all.validate());
  EXPECT_EQ(front_keys(all), face_keys(input)) << "refine-all front differs from the input";
  const MtFront none(r.mt);
  EXPECT_EQ(front_keys(none), face_keys(r.level_meshes.back())) << "coarsen-all front differs from the coarsest level";

  for (std::size_t l = 0; l < r.num_levels(); ++l) {
    const MtFront front = simplify4k_level_front(r, l);
    ASSERT_NO_THROW(front.validate());
    EXPECT_EQ(front_keys(front), face_keys(r.level_meshes[l])) << "level " << l;
    EXPECT_EQ(front.num_faces(), r.levels[l].faces) << "level " << l;
    std::vector<VertexId> ids;
    const TriMesh m = simplify4k_level_mesh(r, l, &ids);
    EXPECT_EQ(face_keys(m, &ids), face_keys(r.level_meshes[l])) << "level " << l;
    const Topology s = topology(m);
    EXPECT_EQ(s.problem, "") << "level " << l;
    EXPECT_EQ(s.components, in_shape.components) << "level " << l;
    EXPECT_EQ(s.chi, in_shape.chi) << "level " << l;
    EXPECT_EQ(s.boundary_loops, in_shape.boundary_loops) << "level " << l;
    if (closed) {
      EXPECT_TRUE(s.closed) << "level " << l;
    }
    if (l > 0) {
      EXPECT_LT(r.levels[l].faces, r.levels[l - 1].faces) << "level " << l;
      EXPECT_GE(r.levels[l].max_error, r.levels[l - 1].max_error) << "level " << l;
    }
  }
  std::size_t swaps = 0, splits = 0;
  for (NodeId n = 1; n < r.mt.num_nodes(); ++n) {
    EXPECT_EQ(node_problem(r.mt, n), "") << "node " << n;
    EXPECT_EQ(fold_problem(r.mt, n), "") << "node " << n;
    swaps += r.mt.kind(n) == NodeKind::kSwap;
    splits += r.mt.kind(n) == NodeKind::kSplit;
    // Parents come from the same or a coarser level (what simplify4k_level_front relies on).
    for (NodeId p : r.mt.parents(n))
      if (p != 0) {
        EXPECT_GE(r.node_level[p], r.node_level[n]) << "node " << n;
      }
  }
  EXPECT_EQ(swaps, r.num_swap_nodes);
  EXPECT_EQ(splits, r.num_split_nodes);
  std::size_t level_swaps = 0, level_collapses = 0;
  for (const auto& l : r.levels) {
    level_swaps += l.swaps;
    level_collapses += l.collapses + l.border_collapses;
  }
  EXPECT_EQ(level_swaps, swaps);
  EXPECT_EQ(level_collapses, splits);
  // Each collapse removes one vertex and two faces (one on the border).
  for (std::size_t l = 1; l < r.num_levels(); ++l) {
    EXPECT_EQ(r.levels[l - 1].faces - r.levels[l].faces, 2 * r.levels[l].collapses + r.levels[l].border_collapses);
    EXPECT_EQ(r.levels[l - 1].vertices - r.levels[l].vertices, r.levels[l].collapses + r.levels[l].border_collapses);
  }
}

// Extracts fronts at random object-space errors: conforming, same topology, and the documented bound:
// every input vertex, face centroid and random surface sample lies within e of the front.
void check_queries(const TriMesh& input, const Simplify4kResult& r, bool closed, int count, std::uint32_t seed,
                   int samples_per_face = 3) {
  const Topology in_shape = topology(input);
  const std::vector<glm::dvec3> pts = surface_samples(input, samples_per_face, seed);
  const double top = r.levels.back().max_error;
  const double eps = 1e-5 * double(input.bounds().diagonal());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  MtFront front(r.mt);
  int coarser = 0;
  for (int i = 0; i < count; ++i) {
    const double e = i == 0 ? 0.0 : top * u(rng) * u(rng);
    Query q;
    q.criterion = Criterion::object_error(static_cast<float>(e));
    extract(front, q);
    ASSERT_NO_THROW(front.validate());
    const Topology s = topology(front.to_mesh());
    EXPECT_EQ(s.problem, "") << "e = " << e;
    EXPECT_EQ(s.chi, in_shape.chi);
    EXPECT_EQ(s.components, in_shape.components);
    if (closed) {
      EXPECT_TRUE(s.closed) << "crack in the front at e = " << e;
    }
    if (i == 0) {
      EXPECT_EQ(front_keys(front), face_keys(input)) << "zero error must give the input";
    } else {
      coarser += front.num_faces() < input.num_faces();
    }
    EXPECT_EQ(points_farther_than(pts, front, e + eps), 0u)
        << "bound violated at e = " << e << " (" << front.num_faces() << " faces)";
  }
  EXPECT_GT(coarser, 0) << "no query gave a coarser mesh";
}

// The bound of each level (every `stride`-th): the input surface samples lie within levels[l].max_error of
// the level's mesh.
void check_level_bounds(const TriMesh& input, const Simplify4kResult& r, std::size_t stride, std::uint32_t seed) {
  const std::vector<glm::dvec3> pts = surface_samples(input, 1, seed);
  const double eps = 1e-5 * double(input.bounds().diagonal());
  for (std::size_t l = 1; l < r.num_levels(); l += stride) {
    const MtFront front = simplify4k_level_front(r, l);
    EXPECT_EQ(points_farther_than(pts, front, r.levels[l].max_error + eps), 0u) << "level " << l;
  }
}

// Random walks of legal single moves keep the front valid and conforming.
void check_walk(const Simplify4kResult& r, bool closed, int steps, std::uint32_t seed) {
  std::mt19937 rng(seed);
  MtFront front(r.mt);
  const auto nn = static_cast<NodeId>(r.mt.num_nodes());
  std::uniform_int_distribution<NodeId> pick(1, nn - 1);
  for (int i = 0; i < steps; ++i) {
    const NodeId n = pick(rng);
    if (rng() % 2) front.refine(n);
    else front.coarsen(n);
    if (i % 50 == 0) {
      ASSERT_NO_THROW(front.validate());
      const Topology t = topology(front.to_mesh());
      ASSERT_EQ(t.problem, "");
      if (closed) {
        ASSERT_TRUE(t.closed);
      }
    }
  }
}

Simplify4kOptions test_options() {
  Simplify4kOptions o;
  o.keep_level_meshes = true;
  return o;
}

void print_levels(const char* name, const Simplify4kResult& r) {
  std::string line;
  for (std::size_t l = 0; l < r.num_levels(); ++l)
    line += (l ? " " : "") + std::to_string(r.levels[l].faces);
  std::printf("[ simplify4k ] %s: faces per level: %s; %zu split, %zu swap nodes\n", name, line.c_str(),
              r.num_split_nodes, r.num_swap_nodes);
}

// ---- tests ----

TEST(Simplify4k, IcosphereHierarchy) {
  const TriMesh in = icosphere(3);  // 1280 faces, degrees 5 and 6
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("icosphere", r);
  check_hierarchy(in, r, true);
  EXPECT_GT(r.num_swap_nodes, 0u) << "an icosphere has no degree-4 vertex: swaps must occur";
  EXPECT_LE(r.levels.back().faces, 40u);
  check_queries(in, r, true, 6, 1);
  check_level_bounds(in, r, 1, 14);
  check_walk(r, true, 600, 2);
}

TEST(Simplify4k, Regular48TorusHalvesPerLevel) {
  // Alternating diagonals: a regular 4-8 mesh. Its degree-4 vertices are independent four-face clusters
  // that cover all the faces, so the first level collapses all of them without any swap (8.2).
  const TriMesh in = torus(32, 16, true);
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("4-8 torus", r);
  check_hierarchy(in, r, true);
  ASSERT_GE(r.num_levels(), 2u);
  EXPECT_EQ(r.levels[1].faces, in.num_faces() / 2);
  EXPECT_EQ(r.levels[1].swaps, 0u);
  check_queries(in, r, true, 6, 3);
}

TEST(Simplify4k, Degree6TorusNeedsSwaps) {
  const TriMesh in = torus(24, 12, false);  // every vertex of degree 6
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("degree-6 torus", r);
  check_hierarchy(in, r, true);
  EXPECT_GT(r.levels[1].swaps, 0u) << "no degree-4 vertex at the start: clusters need swaps";
  check_queries(in, r, true, 6, 4);
  check_walk(r, true, 1000, 5);
}

TEST(Simplify4k, WavyGridWithBorder) {
  const TriMesh in = open_grid(16, 0.15f, false);
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("wavy grid", r);
  check_hierarchy(in, r, false);
  std::size_t border = 0;
  for (const auto& l : r.levels) border += l.border_collapses;
  EXPECT_GT(border, 0u) << "border vertices collapse 2 -> 1";
  check_queries(in, r, false, 6, 6);
  check_level_bounds(in, r, 1, 15);
  check_walk(r, false, 1000, 7);
}

TEST(Simplify4k, FlatGridNeverFlipsAFace) {
  const TriMesh in = open_grid(12, 0.0f, true);
  const Simplify4kResult r = simplify4k(in, test_options());
  check_hierarchy(in, r, false);
  // Every face of every level and of random fronts keeps its upward normal.
  auto all_up = [](const TriMesh& m) {
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      const glm::vec3 a = m.positions[m.corner(f, 0)], b = m.positions[m.corner(f, 1)], c = m.positions[m.corner(f, 2)];
      if (glm::cross(b - a, c - a).z <= 0.0f) return false;
    }
    return true;
  };
  for (std::size_t l = 0; l < r.num_levels(); ++l) EXPECT_TRUE(all_up(simplify4k_level_mesh(r, l))) << "level " << l;
  std::mt19937 rng(8);
  MtFront front(r.mt);
  for (int i = 0; i < 300; ++i) {
    const NodeId n = 1 + static_cast<NodeId>(rng() % (r.mt.num_nodes() - 1));
    if (rng() % 2) front.refine(n);
    else front.coarsen(n);
    ASSERT_TRUE(all_up(front.to_mesh()));
  }
  // With max_error = 0 only exact steps are allowed: interior vertices of the plane and border vertices on a
  // straight border go, the four corners stay, and every level has bound 0.
  Simplify4kOptions exact = test_options();
  exact.max_error = 0.0;
  const Simplify4kResult z = simplify4k(in, exact);
  check_hierarchy(in, z, false);
  for (const auto& l : z.levels) EXPECT_EQ(l.max_error, 0.0);
  const TriMesh base = z.level_meshes.back();
  const std::set<Index> used(base.indices.begin(), base.indices.end());
  for (Index corner : {0u, 12u, 12u * 13u, 12u * 13u + 12u}) EXPECT_TRUE(used.count(corner)) << corner;
  EXPECT_LE(base.num_faces(), 16u) << "a flat square needs only a few triangles";
}

TEST(Simplify4k, LockedBorderKeepsItsVertices) {
  const TriMesh in = open_grid(12, 0.1f, false);
  Simplify4kOptions o = test_options();
  o.lock_border = true;
  const Simplify4kResult r = simplify4k(in, o);
  check_hierarchy(in, r, false);
  const TriMesh base = r.level_meshes.back();
  std::set<Index> used(base.indices.begin(), base.indices.end());
  for (int i = 0; i <= 12; ++i)
    for (Index v : {Index(i), Index(12 * 13 + i), Index(i * 13), Index(i * 13 + 12)}) EXPECT_TRUE(used.count(v)) << v;
  for (const auto& l : r.levels) EXPECT_EQ(l.border_collapses, 0u);
}

TEST(Simplify4k, NoisySphere) {
  // Random displacements make the connectivity regular but the geometry rough: many stars do not project
  // one-to-one, which exercises the fallback bound.
  TriMesh in = icosphere(2);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-0.06f, 0.06f);
  for (auto& p : in.positions) p += glm::vec3(u(rng), u(rng), u(rng));
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("noisy sphere", r);
  check_hierarchy(in, r, true);
  EXPECT_LE(r.levels.back().faces, 40u);
  check_queries(in, r, true, 5, 12);
  check_level_bounds(in, r, 1, 16);
}

TEST(Simplify4k, DegreeThreeVertices) {
  // Every face of an icosphere split at its centre: half the vertices have degree 3 (one outward swap each).
  const TriMesh ico = icosphere(1);
  TriMesh in;
  in.positions = ico.positions;
  for (std::size_t f = 0; f < ico.num_faces(); ++f) {
    const Index a = ico.corner(f, 0), b = ico.corner(f, 1), c = ico.corner(f, 2);
    in.positions.push_back(glm::normalize(ico.positions[a] + ico.positions[b] + ico.positions[c]));
    const auto m = static_cast<Index>(in.positions.size() - 1);
    in.indices.insert(in.indices.end(), {a, b, m, b, c, m, c, a, m});
  }
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("centre-split sphere", r);
  check_hierarchy(in, r, true);
  // The degree-3 centres can only leave by the outward swap (or after a neighbour changed their degree).
  const TriMesh& l1 = r.level_meshes[1];
  const std::set<Index> used(l1.indices.begin(), l1.indices.end());
  std::size_t centres_gone = 0;
  for (Index v = static_cast<Index>(ico.num_vertices()); v < in.num_vertices(); ++v) centres_gone += !used.count(v);
  EXPECT_GT(centres_gone, ico.num_faces() / 4);
  check_queries(in, r, true, 4, 13);
}

TEST(Simplify4k, SeveralComponents) {
  const TriMesh in = concat(icosphere(2), torus(16, 8, false, glm::vec3(5.0f, 0.0f, 0.0f)));
  const Simplify4kResult r = simplify4k(in, test_options());
  print_levels("sphere + torus", r);
  check_hierarchy(in, r, true);
  check_queries(in, r, true, 5, 9);
}

TEST(Simplify4k, OptionsStopEarly) {
  const TriMesh in = icosphere(2);
  Simplify4kOptions o = test_options();
  o.target_faces = 150;
  const Simplify4kResult r = simplify4k(in, o);
  check_hierarchy(in, r, true);
  EXPECT_LE(r.levels.back().faces, 150u);
  EXPECT_GT(r.levels[r.num_levels() - 2].faces, 150u);
  o = test_options();
  o.max_levels = 2;
  EXPECT_EQ(simplify4k(in, o).num_levels(), 3u);
  o = test_options();
  o.max_error = 0.05;
  const Simplify4kResult e = simplify4k(in, o);
  check_hierarchy(in, e, true);
  EXPECT_LE(e.levels.back().max_error, 0.05);
  const Simplify4kResult full = simplify4k(in);
  EXPECT_GT(full.levels.back().max_error, 0.05);
  EXPECT_GT(e.levels.back().faces, full.levels.back().faces) << "the error limit must stop the simplification earlier";
  o = test_options();
  o.max_levels = 0;
  const Simplify4kResult none = simplify4k(in, o);
  EXPECT_EQ(none.num_levels(), 1u);
  EXPECT_EQ(none.mt.num_nodes(), 1u);
  EXPECT_EQ(simplify4k_closest_level(r, 1u << 20), 0u);
}

TEST(Simplify4k, TinyClosedMeshesStayValid) {
  // A tetrahedron cannot lose a vertex; an octahedron (all degree 4) goes down to a tetrahedron.
  TriMesh tet;
  tet.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  tet.indices = {0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2};
  Simplify4kOptions o = test_options();
  const Simplify4kResult rt = simplify4k(tet, o);
  EXPECT_EQ(rt.num_levels(), 1u);
  EXPECT_NO_THROW(rt.mt.validate());
  TriMesh oct;
  oct.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  oct.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  o.min_dihedral_cos = -1.0;
  o.min_normal_dot = -1.0;
  const Simplify4kResult ro = simplify4k(oct, o);
  check_hierarchy(oct, ro, true);
  EXPECT_EQ(ro.levels.back().faces, 4u);
}

TEST(Simplify4k, BadInputThrowsNamingTheElement) {
  auto throws_at = [](const TriMesh& m, std::uint64_t element) {
    try {
      simplify4k(m);
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.element(), element) << e.what();
      return;
    }
    ADD_FAILURE() << "no InvalidInput";
  };
  TriMesh empty;
  empty.positions = {{0, 0, 0}};
  EXPECT_THROW(simplify4k(empty), InvalidInput);
  TriMesh grid = open_grid(3, 0.0f, false);
  TriMesh degenerate = grid;
  degenerate.indices.insert(degenerate.indices.end(), {1, 2, 1});
  throws_at(degenerate, grid.num_faces());
  TriMesh book = grid;  // a third face on the edge (0, 1): non-manifold edge
  book.positions.push_back({0.5f, -0.5f, 1.0f});
  book.indices.insert(book.indices.end(), {0, 1, static_cast<Index>(book.positions.size() - 1)});
  throws_at(book, grid.num_faces());
  TriMesh flipped = grid;  // face 3 reversed: inconsistent orientation
  std::swap(flipped.indices[3 * 3 + 1], flipped.indices[3 * 3 + 2]);
  EXPECT_THROW(simplify4k(flipped), InvalidInput);
  TriMesh nan = grid;
  nan.positions[2].y = std::numeric_limits<float>::quiet_NaN();
  throws_at(nan, 2);
  TriMesh out_of_range = grid;
  out_of_range.indices[4] = 999;
  throws_at(out_of_range, 1);
  Simplify4kOptions o;
  o.max_swap_degree = 2;
  EXPECT_THROW(simplify4k(grid, o), InvalidInput);
  o = {};
  o.min_quality = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(simplify4k(grid, o), InvalidInput);
  const Simplify4kResult r = simplify4k(grid);
  EXPECT_THROW(simplify4k_level_front(r, r.num_levels()), InvalidInput);
}

// Triangle grids damaged at random (testing::damaged_grid): simplify4k refuses a mesh exactly when the
// brute-force oracle of a FourKMesh's manifold rules (topology_oracle.hpp) finds one broken, naming the
// oracle's element in find_topology_problem's words, and simplifies the others (bow-ties included).
TEST(Simplify4k, RefusesWhatTheTopologyOracleRefuses) {
  std::mt19937 rng(5150);
  std::map<TopologyRule, int> seen;
  int meshes = 0;
  Simplify4kOptions o;
  o.max_levels = 3;
  for (int round = 0; meshes < 700; ++round) {
    const testing::DamagedGrid grid = testing::damaged_grid(rng);
    if (!grid.triangles_only) continue;
    ++meshes;
    const TriMesh mesh = testing::triangles_of(grid.faces, grid.num_vertices);
    const TopologyProblem oracle = testing::slow_topology_problem(grid.faces, kFourKMeshRules);
    ++seen[oracle.rule];
    try {
      const Simplify4kResult r = simplify4k(mesh, o);
      EXPECT_FALSE(oracle) << "round " << round << ": " << describe_topology_problem(oracle);
      EXPECT_NO_THROW(r.mt.validate()) << "round " << round;
    } catch (const InvalidInput& e) {
      ASSERT_TRUE(oracle) << "round " << round << ": " << e.what();
      EXPECT_EQ(e.element(), oracle.element()) << "round " << round << ": " << e.what();
      EXPECT_EQ(std::string(e.what()), testing::refusal("simplify4k", oracle)) << "round " << round;
    }
  }
  for (TopologyRule r : {TopologyRule::kNone, TopologyRule::kRepeatedCorner, TopologyRule::kNonManifoldEdge,
                         TopologyRule::kInconsistentOrientation, TopologyRule::kDoubledFace})
    EXPECT_GT(seen[r], 20) << int(r);
}

TEST(Simplify4k, NonManifoldVertexIsLocked) {
  // Two open grids sharing one corner vertex: a bow-tie vertex with two fans.
  const TriMesh a = open_grid(6, 0.1f, false);
  TriMesh b = open_grid(6, 0.1f, true);
  for (auto& p : b.positions) p = -p;  // point reflection: b's corner 0 lands on a's corner 0
  TriMesh m = concat(a, b);
  const auto off = static_cast<Index>(a.positions.size());
  for (Index& i : m.indices)
    if (i == off) i = 0;
  // the reflection reversed b's orientation; flip its faces back
  for (std::size_t f = a.num_faces(); f < m.num_faces(); ++f) std::swap(m.indices[3 * f + 1], m.indices[3 * f + 2]);
  ASSERT_EQ(analyze_mesh(m).non_manifold_vertices, 1u);
  const Simplify4kResult r = simplify4k(m, test_options());
  EXPECT_EQ(r.locked_vertices, 1u);
  ASSERT_NO_THROW(r.mt.validate());
  for (const TriMesh& level : r.level_meshes)
    EXPECT_NE(std::find(level.indices.begin(), level.indices.end(), Index(0)), level.indices.end());
  EXPECT_LT(r.levels.back().faces, m.num_faces() / 3);
}

TEST(Simplify4k, CowFigure21SharedData) {
  VARMESH_REQUIRE_SHARED(path, "meshes/cow_cgal_2904v.off");
  const TriMesh in = read_mesh(path);
  ASSERT_EQ(in.num_faces(), 5804u);
  const auto t0 = std::chrono::steady_clock::now();
  const Simplify4kResult r = simplify4k(in, test_options());
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  print_levels("cow", r);
  std::printf("[ simplify4k ] cow: %.0f ms (this build), bound per level:", ms);
  for (const auto& l : r.levels) std::printf(" %.4g", l.max_error);
  std::printf("\n[ simplify4k ] cow: Figure 21 targets ->");
  for (std::size_t target : {1200u, 700u, 400u, 300u, 200u}) {
    const std::size_t l = simplify4k_closest_level(r, target);
    std::printf(" %zu: level %zu (%zu faces)", target, l, r.levels[l].faces);
  }
  std::printf("\n");
  check_hierarchy(in, r, true);
  EXPECT_GT(r.num_swap_nodes, 0u);
  // Figure 21 reaches about 200 faces.
  EXPECT_LE(r.levels.back().faces, 300u);
  check_queries(in, r, true, 3, 10, 0);
  check_level_bounds(in, r, 3, 17);
}

// The level front refers to result.mt: a temporary result is refused at compile time.
template <class R>
concept LevelFrontAccepts = requires(R&& r) { simplify4k_level_front(std::forward<R>(r), std::size_t{0}); };
static_assert(LevelFrontAccepts<const Simplify4kResult&>);
static_assert(LevelFrontAccepts<Simplify4kResult&>);
static_assert(!LevelFrontAccepts<Simplify4kResult>);
static_assert(!LevelFrontAccepts<const Simplify4kResult>);

}  // namespace
}  // namespace varmesh
