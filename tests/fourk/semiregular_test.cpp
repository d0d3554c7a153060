// Tests of fourk/semiregular.hpp: the maximum matching (against brute force and a Tutte-Berge
// certificate), the pairing of mesh faces with leftovers on the border, and the semi-regular 4-8
// hierarchy (Velho-Gomes 2000, sections 6.2, 7.2, 8.1) as a Multi-Triangulation: valences per level,
// conforming fronts, face counts, round trips, query fronts, agreement with build_bisection_mt, eq. 4.
#include "fourk/semiregular.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "mesh_fixtures.hpp"

#include "mt_oracles.hpp"
#include "test_support.hpp"

#include "fourk/bisection.hpp"
#include "multitri/errors.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/mt_metrics.hpp"
#include "multitri/query.hpp"

namespace varmesh {
namespace {

using Tri = std::array<VertexId, 3>;

Tri canonical(Tri t) {
  while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
  return t;
}

// --- generated meshes ----------------------------------------------------------------------------------

TriMesh torus(int nu, int nv) { return testing::torus_grid(nu, nv); }

// A polar disc: a fan of k triangles around the centre, then `rings` - 1 rings of k quads cut in two.
// k + 2k(rings - 1) faces: odd when k is odd.
TriMesh disc(int k, int rings) {
  TriMesh m;
  m.positions.push_back({0, 0, 0});
  for (int r = 1; r <= rings; ++r)
    for (int i = 0; i < k; ++i) {
      const float a = 6.2831853f * float(i) / float(k) + 0.3f * float(r);
      m.positions.push_back({float(r) * std::cos(a), float(r) * std::sin(a), 0.0f});
    }
  auto id = [&](int r, int i) { return static_cast<Index>(1 + (r - 1) * k + (i % k)); };
  for (int i = 0; i < k; ++i) m.indices.insert(m.indices.end(), {0, id(1, i), id(1, i + 1)});
  for (int r = 1; r < rings; ++r)
    for (int i = 0; i < k; ++i) {
      const Index a = id(r, i), b = id(r + 1, i), c = id(r + 1, i + 1), d = id(r, i + 1);
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  return m;
}

TriMesh tetrahedron() { return testing::tetrahedron_mesh(); }
TriMesh icosahedron() { return testing::icosahedron_mesh(); }

TriMesh square() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TriMesh triangle() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2};
  return m;
}

TriMesh append(TriMesh a, const TriMesh& b, const glm::vec3& shift) {
  const auto off = static_cast<Index>(a.positions.size());
  for (const glm::vec3& p : b.positions) a.positions.push_back(p + shift);
  for (Index i : b.indices) a.indices.push_back(i + off);
  return a;
}

// --- mesh checks ---------------------------------------------------------------------------------------

constexpr auto dkey = directed_edge_key;

// Directed edges of a mesh, sorted (sorted vectors rather than sets: these checks run on ~10^5 faces in
// the sanitizer build too).
std::vector<std::uint64_t> directed_edges(const TriMesh& m) {
  std::vector<std::uint64_t> d;
  d.reserve(3 * m.num_faces());
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) d.push_back(dkey(m.corner(f, k), m.corner(f, (k + 1) % 3)));
  std::sort(d.begin(), d.end());
  return d;
}

// Each directed edge used once (interior edges shared by exactly two consistently oriented faces).
// Returns the border edges (directed edges without reverse).
std::vector<std::uint64_t> expect_conforming(const TriMesh& m) {
  const std::vector<std::uint64_t> d = directed_edges(m);
  const auto dup = std::adjacent_find(d.begin(), d.end());
  EXPECT_EQ(dup, d.end()) << "directed edge (" << (*dup >> 32) << ", " << (*dup & 0xffffffffu) << ") used twice";
  std::vector<std::uint64_t> border;
  for (std::uint64_t e : d)
    if (!std::binary_search(d.begin(), d.end(), (e << 32) | (e >> 32))) border.push_back(e);
  return border;
}

// Undirected edges (smaller vertex first), sorted and unique.
std::vector<std::uint64_t> undirected_edges(const TriMesh& m) {
  std::vector<std::uint64_t> u;
  u.reserve(3 * m.num_faces());
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Index a = m.corner(f, k), b = m.corner(f, (k + 1) % 3);
      u.push_back(dkey(std::min(a, b), std::max(a, b)));
    }
  std::sort(u.begin(), u.end());
  u.erase(std::unique(u.begin(), u.end()), u.end());
  return u;
}

long euler(const TriMesh& m) {
  std::vector<std::uint8_t> used(m.num_vertices(), 0);
  for (Index v : m.indices) used[v] = 1;
  const long nv = long(std::count(used.begin(), used.end(), std::uint8_t{1}));
  return nv - long(undirected_edges(m).size()) + long(m.num_faces());
}

// The dual graph of a mesh, built independently of the library (map of directed edges).
std::vector<std::vector<Index>> dual_graph(const TriMesh& m) {
  std::vector<std::pair<std::uint64_t, Index>> owner;
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) owner.push_back({dkey(m.corner(f, k), m.corner(f, (k + 1) % 3)), static_cast<Index>(f)});
  std::sort(owner.begin(), owner.end());
  std::vector<std::vector<Index>> adj(m.num_faces());
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t rev = dkey(m.corner(f, (k + 1) % 3), m.corner(f, k));
      const auto it = std::lower_bound(owner.begin(), owner.end(), std::make_pair(rev, Index{0}));
      if (it != owner.end() && it->first == rev) adj[f].push_back(it->second);
    }
  return adj;
}

// Brute-force maximum matching size (memoised over vertex subsets; n <= 20).
int brute_force_matching(const std::vector<std::vector<Index>>& adj) {
  const std::size_t n = adj.size();
  std::vector<int> memo(std::size_t(1) << n, -1);
  std::function<int(std::uint32_t)> best = [&](std::uint32_t mask) -> int {
    if (mask == 0) return 0;
    if (memo[mask] >= 0) return memo[mask];
    const int v = __builtin_ctz(mask);
    const std::uint32_t rest = mask & ~(1u << v);
    int b = best(rest);
    for (Index w : adj[v])
      if (w != Index(v) && (rest >> w & 1u)) b = std::max(b, 1 + best(rest & ~(1u << w)));
    return memo[mask] = b;
  };
  return best(static_cast<std::uint32_t>((std::uint64_t(1) << n) - 1));
}

// Checks a matching: partners are mutual and adjacent; returns the number of pairs.
std::size_t expect_valid_matching(const std::vector<std::vector<Index>>& adj, const std::vector<Index>& mate) {
  std::size_t pairs = 0;
  for (Index v = 0; v < adj.size(); ++v) {
    if (mate[v] == kInvalid) continue;
    EXPECT_EQ(mate[mate[v]], v);
    EXPECT_NE(std::find(adj[v].begin(), adj[v].end(), mate[v]), adj[v].end()) << "partners not adjacent";
    pairs += mate[v] > v;
  }
  return pairs;
}

// Tutte-Berge: for any set U, a matching has at most (n + |U| - odd(G - U)) / 2 pairs. Equality for the
// returned set certifies maximality whatever algorithm produced it.
void expect_tutte_berge_certificate(const std::vector<std::vector<Index>>& adj, const GraphMatching& gm) {
  const std::size_t n = adj.size();
  std::vector<std::uint8_t> in_u(n, 0);
  for (Index u : gm.tutte_set) in_u[u] = 1;
  std::vector<std::uint8_t> seen(n, 0);
  std::size_t odd = 0;
  for (Index s = 0; s < n; ++s) {
    if (in_u[s] || seen[s]) continue;
    std::size_t size = 0;
    std::vector<Index> stack{s};
    seen[s] = 1;
    while (!stack.empty()) {
      const Index v = stack.back();
      stack.pop_back();
      ++size;
      for (Index w : adj[v])
        if (!in_u[w] && !seen[w]) {
          seen[w] = 1;
          stack.push_back(w);
        }
    }
    odd += size % 2;
  }
  EXPECT_EQ(gm.num_unmatched + gm.tutte_set.size(), odd) << "Tutte-Berge bound not met";
}

void to_csr(const std::vector<std::vector<Index>>& adj, std::vector<Index>& off, std::vector<Index>& nbr) {
  off.assign(1, 0);
  nbr.clear();
  for (const auto& a : adj) {
    nbr.insert(nbr.end(), a.begin(), a.end());
    off.push_back(static_cast<Index>(nbr.size()));
  }
}

// --- maximum_matching ----------------------------------------------------------------------------------

TEST(MaximumMatching, MatchesBruteForceOnRandomGraphs) {
  std::mt19937 rng(11);
  std::size_t augmentations = 0, moved = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const int n = 1 + int(rng() % 15);
    const double p = 0.08 + 0.5 * double(rng() % 100) / 100.0;
    std::vector<std::vector<Index>> adj(n);
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (std::uniform_real_distribution<double>(0, 1)(rng) < p) {
          const int copies = rng() % 8 == 0 ? 2 : 1;  // parallel edges
          for (int c = 0; c < copies; ++c) {
            adj[i].push_back(Index(j));
            adj[j].push_back(Index(i));
          }
        }
    if (n > 1 && rng() % 6 == 0) {
      const Index s = Index(rng() % n);
      adj[s].push_back(s);  // self-loop, ignored
      adj[s].push_back(s);
    }
    for (auto& a : adj) std::shuffle(a.begin(), a.end(), rng);
    std::vector<Index> off, nbr;
    to_csr(adj, off, nbr);
    const int want = brute_force_matching(adj);
    std::vector<std::uint8_t> flags(n, 0);
    for (auto& f : flags) f = rng() % 3 == 0;
    for (bool greedy : {true, false}) {
      MatchingOptions mo;
      mo.certificate = true;
      mo.greedy_start = greedy;
      if (trial % 2) mo.prefer_unmatched = flags;  // moving unmatched vertices keeps the size
      const GraphMatching gm = maximum_matching(off, nbr, mo);
      ASSERT_EQ(expect_valid_matching(adj, gm.mate), gm.num_pairs);
      ASSERT_EQ(int(gm.num_pairs), want) << "trial " << trial << " n=" << n << " greedy=" << greedy;
      EXPECT_EQ(gm.num_unmatched, std::size_t(n) - 2 * gm.num_pairs);
      EXPECT_EQ(gm.greedy_pairs + gm.augmentations, gm.num_pairs);
      expect_tutte_berge_certificate(adj, gm);
      if (!greedy) augmentations += gm.augmentations;
      moved += gm.moved;
    }
  }
  EXPECT_GT(augmentations, 1000u);
  EXPECT_GT(moved, 50u);
}

// Graphs where a search must shrink (nested) blossoms to find the augmenting path.
TEST(MaximumMatching, BlossomsAreShrunk) {
  auto run = [](int n, const std::vector<std::pair<int, int>>& edges, const std::vector<std::pair<int, int>>& start,
                int want) {
    std::vector<std::vector<Index>> adj(n);
    for (auto [a, b] : edges) {
      adj[a].push_back(Index(b));
      adj[b].push_back(Index(a));
    }
    ASSERT_EQ(brute_force_matching(adj), want);
    std::vector<Index> off, nbr;
    to_csr(adj, off, nbr);
    MatchingOptions mo;
    mo.greedy_start = false;
    mo.certificate = true;
    const GraphMatching gm = maximum_matching(off, nbr, mo);
    EXPECT_EQ(int(gm.num_pairs), want);
    expect_valid_matching(adj, gm.mate);
    expect_tutte_berge_certificate(adj, gm);
    (void)start;
  };
  // A 5-cycle 0..4 with a stem 5-0 and a tail 3-6: the augmenting path from 5 to 6 runs around the blossom.
  run(7, {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 0}, {5, 0}, {3, 6}}, {}, 3);
  // The Petersen graph: cubic and bridgeless, so perfectly matchable.
  run(10, {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 0}, {0, 5}, {1, 6}, {2, 7}, {3, 8}, {4, 9},
           {5, 7}, {7, 9}, {9, 6}, {6, 8}, {8, 5}},
      {}, 5);
  // Two triangles sharing a vertex with pendant vertices (a blossom inside a blossom).
  run(9, {{0, 1}, {1, 2}, {2, 0}, {2, 3}, {3, 4}, {4, 2}, {0, 5}, {1, 6}, {3, 7}, {4, 8}}, {}, 4);
  // A triangle: one vertex always left.
  run(3, {{0, 1}, {1, 2}, {2, 0}}, {}, 1);
}

TEST(MaximumMatching, PreferredVerticesAreLeftUnmatched) {
  // The path 0-1-2-3-4: two pairs, one vertex left; the preferred one is the one left when possible.
  std::vector<std::vector<Index>> adj{{1}, {0, 2}, {1, 3}, {2, 4}, {3}};
  std::vector<Index> off, nbr;
  to_csr(adj, off, nbr);
  for (Index preferred : {0u, 2u, 4u})
    for (bool greedy : {true, false}) {
      std::vector<std::uint8_t> flag(5, 0);
      flag[preferred] = 1;
      MatchingOptions mo;
      mo.prefer_unmatched = flag;
      mo.greedy_start = greedy;
      const GraphMatching gm = maximum_matching(off, nbr, mo);
      EXPECT_EQ(gm.num_pairs, 2u);
      EXPECT_EQ(gm.mate[preferred], kInvalid) << "preferred " << preferred;
    }
  // Vertex 1 can never be the one left (odd position on the path): the request cannot be met.
  std::vector<std::uint8_t> flag{0, 1, 0, 0, 0};
  MatchingOptions mo;
  mo.prefer_unmatched = flag;
  const GraphMatching gm = maximum_matching(off, nbr, mo);
  EXPECT_EQ(gm.num_pairs, 2u);
  EXPECT_NE(gm.mate[1], kInvalid);
}

TEST(MaximumMatching, RejectsMalformedGraphs) {
  const std::vector<Index> off{0, 1, 1}, nbr{1};  // 0 lists 1, 1 lists nobody
  EXPECT_THROW(maximum_matching(off, nbr), InvalidInput);
  const std::vector<Index> off2{0, 1, 2}, nbr2{5, 0};
  EXPECT_THROW(maximum_matching(off2, nbr2), InvalidInput);
  const std::vector<Index> off3{0, 2, 1}, nbr3{1, 0};
  EXPECT_THROW(maximum_matching(off3, nbr3), InvalidInput);
  const std::vector<Index> off4{1, 2}, nbr4{0};
  EXPECT_THROW(maximum_matching(off4, nbr4), InvalidInput);
  const std::vector<Index> off5{0, 1, 2}, nbr5{1, 0};
  const std::vector<std::uint8_t> bad_flags{1};
  MatchingOptions mo;
  mo.prefer_unmatched = bad_flags;
  EXPECT_THROW(maximum_matching(off5, nbr5, mo), InvalidInput);
  EXPECT_EQ(maximum_matching(off5, nbr5).num_pairs, 1u);
  const std::vector<Index> off6{0};
  EXPECT_EQ(maximum_matching(off6, {}).num_pairs, 0u);  // the empty graph
}

// --- the pairing of mesh faces -------------------------------------------------------------------------

// Checks what match_dual_faces promises: maximum (certificate and, when small, brute force), leftovers
// on border faces, a compatible marking.
void check_dual_matching(const TriMesh& m, const DualMatching& dm, bool brute) {
  const auto adj = dual_graph(m);
  ASSERT_EQ(dm.mate.size(), m.num_faces());
  EXPECT_EQ(expect_valid_matching(adj, dm.mate), dm.num_pairs);
  EXPECT_EQ(dm.num_leftovers, m.num_faces() - 2 * dm.num_pairs);
  if (brute) {
    EXPECT_EQ(int(dm.num_pairs), brute_force_matching(adj));
  }
  expect_tutte_berge_certificate(adj, dm.graph);
  const std::vector<std::uint64_t> d = directed_edges(m);
  auto has = [&](Index a, Index b) { return std::binary_search(d.begin(), d.end(), dkey(a, b)); };
  std::size_t border_faces = 0;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const int k = dm.refinement_edge[f];
    ASSERT_LT(k, 3);
    const Index a = m.corner(f, k), b = m.corner(f, (k + 1) % 3);
    bool has_border = false;
    for (int j = 0; j < 3; ++j)
      has_border |= !has(m.corner(f, (j + 1) % 3), m.corner(f, j));
    border_faces += has_border;
    const FaceId g = dm.mate[f];
    if (g == kInvalid) {
      EXPECT_TRUE(has_border) << "leftover face " << f << " is interior";
      EXPECT_FALSE(has(b, a)) << "leftover face " << f << " is not marked on a border edge";
    } else {
      const int kg = dm.refinement_edge[g];
      EXPECT_EQ(m.corner(g, kg), b) << "pair " << f << ", " << g << " marks different edges";
      EXPECT_EQ(m.corner(g, (kg + 1) % 3), a);
    }
  }
  EXPECT_EQ(border_faces, dm.num_border_faces);
}

// A w x h grid of unit squares, each cut along a random diagonal; keep(number of faces) of its faces, chosen
// at random, are kept (the grid's vertices all stay: unreferenced ones included). Borders, several components
// and non-manifold vertices arise at random.
template <class Keep>
TriMesh random_grid_subset(int w, int h, std::mt19937& rng, Keep keep) {
  TriMesh grid;
  for (int y = 0; y <= h; ++y)
    for (int x = 0; x <= w; ++x) grid.positions.push_back({float(x), float(y), 0.0f});
  std::vector<std::array<Index, 3>> faces;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Index a = Index(y * (w + 1) + x), b = a + 1, c = a + Index(w) + 2, d = a + Index(w) + 1;
      if (rng() % 2) {
        faces.push_back({a, b, c});
        faces.push_back({a, c, d});
      } else {
        faces.push_back({a, b, d});
        faces.push_back({b, c, d});
      }
    }
  std::shuffle(faces.begin(), faces.end(), rng);
  const std::size_t kept = keep(faces.size());
  for (std::size_t i = 0; i < kept; ++i) grid.indices.insert(grid.indices.end(), faces[i].begin(), faces[i].end());
  return grid;
}

// Random face subsets of a triangulated grid: borders, several components, non-manifold vertices.
TEST(DualMatching, RandomSmallMeshesAgainstBruteForce) {
  std::mt19937 rng(5);
  std::size_t leftovers = 0, moved = 0;
  for (int trial = 0; trial < 250; ++trial) {
    const TriMesh grid = random_grid_subset(5, 4, rng, [&](std::size_t) { return 6 + rng() % 13; });
    const DualMatching dm = match_dual_faces(grid, true);
    check_dual_matching(grid, dm, true);
    leftovers += dm.num_leftovers;
    moved += dm.graph.moved;
  }
  EXPECT_GT(leftovers, 100u);
  std::printf("[dual] random small meshes: %zu leftovers, %zu moved from interior faces to border faces\n", leftovers,
              moved);
}

// Larger random face subsets (many interior faces): the search may first leave an interior face
// unmatched, which must then be exchanged for a border face; the certificate proves maximality.
TEST(DualMatching, LargerRandomMeshesLeaveOnlyBorderFaces) {
  std::mt19937 rng(23);
  std::size_t leftovers = 0, moved = 0;
  for (int trial = 0; trial < 120; ++trial) {
    const TriMesh grid =
        random_grid_subset(12, 10, rng, [&](std::size_t all) { return all * (60 + rng() % 40) / 100; });
    const DualMatching dm = match_dual_faces(grid, true);
    check_dual_matching(grid, dm, false);
    leftovers += dm.num_leftovers;
    moved += dm.graph.moved;
  }
  std::printf("[dual] larger random meshes: %zu leftovers, %zu moved from interior faces to border faces\n", leftovers,
              moved);
  EXPECT_GT(leftovers, 200u);
  EXPECT_GT(moved, 0u);
}

TEST(DualMatching, ClosedMeshesArePerfectlyMatched) {
  // Petersen: the dual of a closed edge-manifold triangle mesh is cubic and bridgeless.
  for (const TriMesh& m : {tetrahedron(), icosahedron(), torus(7, 5), torus(3, 3)}) {
    const DualMatching dm = match_dual_faces(m, true);
    check_dual_matching(m, dm, m.num_faces() <= 20);
    EXPECT_EQ(dm.num_leftovers, 0u);
    EXPECT_EQ(dm.num_border_faces, 0u);
  }
}

TEST(DualMatching, OddDiscsLeaveOneBorderFace) {
  // A fan of 7 triangles ringed by 14: 21 faces, so one is left, on the border ring (check_dual_matching).
  const TriMesh m = disc(7, 2);
  ASSERT_EQ(m.num_faces(), 21u);
  const DualMatching dm = match_dual_faces(m, true);
  check_dual_matching(m, dm, false);
  EXPECT_EQ(dm.num_leftovers, 1u);
  const DualMatching big = match_dual_faces(disc(9, 6), true);
  check_dual_matching(disc(9, 6), big, false);
  EXPECT_EQ(big.num_leftovers, 1u);
}

// --- the semi-regular hierarchy ------------------------------------------------------------------------

float edge_length_error(const BisectionSplit& s) { return glm::length(s.positions[s.e1] - s.positions[s.e0]); }

// The mesh with every node of level <= upto applied, with its Mt vertex ids.
TriMesh mesh_at_level(const Mt& mt, const std::vector<std::uint16_t>& node_level, int upto,
                      std::vector<VertexId>& vertex_ids) {
  MtFront front(mt);
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    if (node_level[n] <= upto) front.apply(n);  // parents first: always legal
  front.validate();
  return front.to_mesh(nullptr, &vertex_ids);
}

// Valences of the new vertices of the mesh of level `upto` (vertex v of m is vertex ids[v] of the
// hierarchy, or v itself when ids is empty): interior 4 when created, 8 afterwards; border 3, then 5.
void check_level_valences(const TriMesh& m, const std::vector<VertexId>& ids,
                          const std::vector<std::uint16_t>& vertex_level, int upto) {
  const std::vector<std::uint64_t> border = expect_conforming(m);
  std::vector<std::uint8_t> on_border(m.num_vertices(), 0);
  for (std::uint64_t e : border) on_border[e >> 32] = on_border[e & 0xffffffffu] = 1;
  std::vector<std::size_t> valence(m.num_vertices(), 0);
  for (std::uint64_t e : undirected_edges(m)) {
    ++valence[e >> 32];
    ++valence[e & 0xffffffffu];
  }
  std::size_t checked = 0;
  for (std::size_t v = 0; v < m.num_vertices(); ++v) {
    const VertexId id = ids.empty() ? VertexId(v) : ids[v];
    const int lv = vertex_level[id];
    if (lv == 0) continue;
    if (on_border[v]) {
      EXPECT_EQ(valence[v], lv == upto ? 3u : 5u) << "border vertex " << id << " of level " << lv << " at level " << upto;
    } else {
      EXPECT_EQ(valence[v], lv == upto ? 4u : 8u) << "vertex " << id << " of level " << lv << " at level " << upto;
    }
    ++checked;
  }
  EXPECT_GT(checked, 0u);
}

// The same at every level of an Mt built by build_semiregular_mt.
void check_valences(const Mt& mt, const SemiRegularInfo& info, int levels) {
  for (int upto = 1; upto <= levels; ++upto) {
    std::vector<VertexId> ids;
    const TriMesh m = mesh_at_level(mt, info.node_level, upto, ids);
    check_level_valences(m, ids, info.vertex_level, upto);
    if (upto >= 2) {
      // Every edge of the base mesh has been split: base vertices are pairwise non-adjacent.
      for (std::uint64_t e : undirected_edges(m))
        EXPECT_FALSE(info.vertex_level[ids[e >> 32]] == 0 && info.vertex_level[ids[e & 0xffffffffu]] == 0)
            << "base vertices " << ids[e >> 32] << " and " << ids[e & 0xffffffffu] << " still adjacent at level " << upto;
    }
  }
}

// Query fronts (object_error thresholds, with and without a focus sphere): conforming, same topology,
// nothing exposed is wanted, and update() from the previous answer equals extract().
void check_query_fronts(const Mt& mt, long base_euler, std::mt19937& rng) {
  float lo = 1e30f, hi = 0.0f;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    lo = std::min(lo, mt.bound(n).error);
    hi = std::max(hi, mt.bound(n).error);
  }
  MtFront moving(mt);
  for (int q = 0; q < 12; ++q) {
    Query query;
    const float t = lo + (hi - lo) * std::uniform_real_distribution<float>(0.0f, 1.0f)(rng);
    query.criterion = Criterion::object_error(t);
    if (q % 3 == 2) {
      const glm::vec3 c = mt.position(VertexId(rng() % mt.num_vertices()));
      query.focus.spheres.push_back({c, mt.bound(0).radius * 0.3f});
    }
    MtFront front(mt);
    extract(front, query);
    front.validate();
    const TriMesh m = front.to_mesh();
    expect_conforming(m);
    EXPECT_EQ(euler(m), base_euler);
    for (FaceId f : front.faces()) {
      const NodeId d = mt.destroyer(f);
      if (d != kInvalid) {
        EXPECT_FALSE(query.wants(mt.bound(d))) << "an exposed node is still wanted";
      }
    }
    update(moving, query);
    moving.validate();
    for (NodeId n = 0; n < mt.num_nodes(); ++n) ASSERT_EQ(moving.is_applied(n), front.is_applied(n)) << "node " << n;
  }
}

struct Case {
  std::string name;
  TriMesh mesh;
  int levels;
  bool closed;
};

std::vector<Case> generated_cases() {
  return {
      {"torus 8x6 (genus 1)", torus(8, 6), 4, true},
      {"disc, 35 faces (odd: a leftover)", disc(7, 3), 4, false},
      {"icosahedron", icosahedron(), 4, true},
      {"tetrahedron", tetrahedron(), 5, true},
      {"square (2 faces, border)", square(), 5, false},
      {"two components: icosahedron + disc", append(icosahedron(), disc(5, 2), {5, 0, 0}), 3, false},
      {"torus + 3-face fan + lone triangle", append(append(torus(4, 3), disc(3, 1), {9, 0, 0}), triangle(), {0, 9, 0}), 3,
       false},
  };
}

TEST(SemiRegular, GeneratedMeshesGiveConformingSemiRegularHierarchies) {
  std::mt19937 rng(17);
  for (const Case& c : generated_cases()) {
    SCOPED_TRACE(c.name);
    const TriMesh& base = c.mesh;
    const std::size_t n = base.num_faces();
    const long chi = euler(base);
    SemiRegularInfo info;
    const Mt mt = build_semiregular_mt(base, c.levels, {}, &info);
    mt.validate();
    // Matching and sizes.
    check_dual_matching(base, info.matching, n <= 20);
    if (c.closed) {
      EXPECT_EQ(info.matching.num_leftovers, 0u);
    }
    ASSERT_EQ(info.faces_per_level.size(), std::size_t(c.levels) + 1);
    for (int j = 0; j <= c.levels; ++j) EXPECT_EQ(info.faces_per_level[j], n << j) << "level " << j;
    EXPECT_EQ(info.border_splits_per_level[1], info.matching.num_leftovers);
    EXPECT_EQ(info.splits_per_level[1], info.matching.num_pairs + info.matching.num_leftovers);
    const MtMetrics met = compute_metrics(mt);
    EXPECT_EQ(met.coarsest_faces, n);
    EXPECT_EQ(met.finest_faces, n << c.levels);
    EXPECT_EQ(met.depth, std::size_t(c.levels));
    EXPECT_EQ(met.nodes_per_level, info.splits_per_level);
    EXPECT_EQ(compute_node_levels(mt), std::vector<Index>(info.node_level.begin(), info.node_level.end()));
    for (NodeId v = 1; v < mt.num_nodes(); ++v) EXPECT_EQ(mt.kind(v), NodeKind::kSplit);

    check_valences(mt, info, c.levels);

    // Refine all: conforming, |K0| 2^levels faces, same surface and topology; coarsen all: the base.
    MtFront front(mt);
    for (NodeId v = 1; v < mt.num_nodes(); ++v) front.refine(v);
    front.validate();
    EXPECT_EQ(front.num_faces(), n << c.levels);
    const TriMesh fine = front.to_mesh();
    const auto border = expect_conforming(fine);
    if (c.closed) {
      EXPECT_TRUE(border.empty());
    }
    EXPECT_EQ(euler(fine), chi);
    EXPECT_NEAR(surface_area(fine), surface_area(base), 1e-4 * surface_area(base));
    for (NodeId v : mt.children(0)) front.coarsen(v);
    front.validate();
    std::vector<FaceId> faces(front.faces().begin(), front.faces().end());
    std::sort(faces.begin(), faces.end());
    std::vector<FaceId> base_faces(n);
    for (FaceId f = 0; f < n; ++f) base_faces[f] = f;
    EXPECT_EQ(faces, base_faces);
    EXPECT_EQ(front.num_applied(), 1u);
    for (FaceId f = 0; f < n; ++f)
      EXPECT_EQ(canonical(mt.face(f)), canonical({base.corner(f, 0), base.corner(f, 1), base.corner(f, 2)}));

    check_query_fronts(mt, chi, rng);

    // The 4-k structure itself.
    SemiRegularInfo info2;
    const FourKMesh fk = build_semiregular_fourk(base, c.levels, {}, &info2);
    fk.validate();
    EXPECT_EQ(fk.num_current_faces(), n << c.levels);
    EXPECT_EQ(info2.modification_level.size(), fk.num_modifications());
  }
}

// The same marking through fourk/bisection.hpp gives the same Mt (same vertices, faces up to a cyclic
// shift of corners, nodes, errors).
TEST(SemiRegular, AgreesWithBuildBisectionMt) {
  for (const Case& c : generated_cases()) {
    SCOPED_TRACE(c.name);
    SemiRegularOptions so;
    so.node_error = edge_length_error;
    SemiRegularInfo info;
    const Mt a = build_semiregular_mt(c.mesh, c.levels, so, &info);
    BisectionOptions bo;
    bo.node_error = edge_length_error;
    BisectionInfo binfo;
    const Mt b = build_bisection_mt(c.mesh, info.matching.refinement_edge, c.levels, bo, &binfo);
    ASSERT_EQ(a.num_vertices(), b.num_vertices());
    ASSERT_EQ(a.num_faces(), b.num_faces());
    ASSERT_EQ(a.num_nodes(), b.num_nodes());
    EXPECT_EQ(a.positions(), b.positions());
    for (FaceId f = 0; f < a.num_faces(); ++f) {
      ASSERT_EQ(canonical(a.face(f)), canonical(b.face(f))) << "face " << f;
      EXPECT_EQ(a.creator(f), b.creator(f));
      EXPECT_EQ(a.destroyer(f), b.destroyer(f));
    }
    for (NodeId n = 0; n < a.num_nodes(); ++n) {
      EXPECT_EQ(a.bound(n).error, b.bound(n).error);
      EXPECT_EQ(info.node_level[n], binfo.node_level[n]);
    }
    EXPECT_EQ(info.vertex_level, binfo.vertex_level);
  }
}

TEST(SemiRegular, CallbacksPlaceVerticesAndSetErrors) {
  // Project new vertices onto the unit sphere: an icosphere-like refinement of the icosahedron.
  TriMesh ico = icosahedron();
  for (glm::vec3& p : ico.positions) p = glm::normalize(p);
  SemiRegularOptions so;
  so.place_vertex = [](const BisectionSplit& s) {
    return glm::normalize(s.positions[s.e0] + s.positions[s.e1]);
  };
  so.node_error = [](const BisectionSplit& s) {
    const glm::vec3 mid = (s.positions[s.e0] + s.positions[s.e1]) * 0.5f;
    return glm::length(s.positions[s.mid] - mid);  // how far the chord is from the sphere
  };
  SemiRegularInfo info;
  const Mt mt = build_semiregular_mt(ico, 4, so, &info);
  mt.validate();
  for (VertexId v = 0; v < mt.num_vertices(); ++v) EXPECT_NEAR(glm::length(mt.position(v)), 1.0f, 1e-5f);
  for (NodeId n = 1; n < mt.num_nodes(); ++n) EXPECT_GT(mt.bound(n).error, 0.0f);
  // Errors are nested (saturated) so object_error queries are monotone: coarser threshold, fewer faces.
  std::size_t last = 0;
  for (float t : {0.2f, 0.05f, 0.01f, 0.002f}) {
    MtFront front(mt);
    Query q;
    q.criterion = Criterion::object_error(t);
    extract(front, q);
    front.validate();
    EXPECT_GE(front.num_faces(), last);
    last = front.num_faces();
  }
  EXPECT_EQ(last, ico.num_faces() << 4);
}

// Eq. 4 of Velho-Gomes (section 7.2) counts the fronts that apply whole levels below j and any subset of
// level j: sum_j 2^(nodes of level j). It counts the fronts "all levels < j" twice (as j-1 full and j
// empty) and misses the fronts that mix subsets of several levels, so the exact count is smaller at two
// levels and larger from three on.
TEST(SemiRegular, ExpressivePowerAgainstEq4) {
  struct Small {
    std::string name;
    TriMesh mesh;
    int levels;
  };
  const std::vector<Small> cases{{"tetrahedron", tetrahedron(), 5}, {"square", square(), 4}, {"disc(3,1)", disc(3, 1), 3}};
  for (const Small& s : cases) {
    for (int m = 1; m <= s.levels; ++m) {
      SemiRegularInfo info;
      const Mt mt = build_semiregular_mt(s.mesh, m, {}, &info);
      BigUint eq4;
      for (int j = 1; j <= m; ++j) eq4 += BigUint::pow2(info.splits_per_level[j]);
      const LevelFrontCount lc = count_level_fronts(mt);
      EXPECT_EQ(lc.total, eq4);
      BigUint distinct = eq4;
      distinct -= std::uint64_t(m - 1);
      EXPECT_EQ(lc.distinct, distinct);
      const FrontCount fc = expressive_power(mt);
      ASSERT_TRUE(fc.exact) << s.name << " m=" << m;
      if (mt.num_nodes() <= 21) {
        EXPECT_EQ(fc.value, BigUint(testing::brute_force_fronts(mt))) << s.name << " m=" << m;
      }
      EXPECT_GE(fc.value, lc.distinct);
      std::printf("[eq4] %-12s m=%d nodes/level=", s.name.c_str(), m);
      for (int j = 1; j <= m; ++j) std::printf("%zu%s", info.splits_per_level[j], j < m ? "," : "");
      std::printf("  eq4=%s distinct=%s exact=%s\n", eq4.to_string().c_str(), lc.distinct.to_string().c_str(),
                  fc.value.to_string().c_str());
      if (s.name == "tetrahedron") {
        // The paper's case: level j has 2^j nodes.
        for (int j = 1; j <= m; ++j) EXPECT_EQ(info.splits_per_level[j], std::size_t(1) << j);
        const char* exact[] = {"1", "4", "19", "346", "116101", "13213613868"};
        EXPECT_EQ(fc.value.to_string(), exact[m]);
        if (m == 2) {
          EXPECT_LT(fc.value, lc.total);  // 19 < 20: double counting
        }
        if (m >= 3) {
          EXPECT_GT(fc.value, lc.total);  // mixed-level fronts
        }
      }
    }
  }
}

// The chain growth of mt_metrics.hpp (a constructed reading of Velho-Gomes 3.3, see bisection_test.cpp for
// the tetrahedron): on closed surfaces the structure is layered and every split past the first level has
// two distinct parents, so the largest growth is that of one split, (|K0| + 4) / (|K0| + 2) = (n + 2) /
// (n + 1) with n = |K0| / 2. On a surface with a border that assumption fails: a border split (1 -> 2) has
// one parent, and a chain through border splits exceeds it (by little: it stays below 2).
TEST(SemiRegular, ChainGrowthOfClosedSurfacesIsOneSplits) {
  struct Closed {
    std::string name;
    TriMesh mesh;
    int levels;
  };
  const std::vector<Closed> closed{{"tetrahedron", tetrahedron(), 6}, {"icosahedron", icosahedron(), 5},
                                 {"torus(7,5)", torus(7, 5), 4}, {"torus(3,3)", torus(3, 3), 4}};
  for (const Closed& c : closed)
    for (int m = 1; m <= c.levels; ++m) {
      const Mt mt = build_semiregular_mt(c.mesh, m);
      const double n = static_cast<double>(mt.image_size(Mt::source())) / 2.0;
      const ChainGrowth g = chain_growth(mt);
      ASSERT_TRUE(g.computed);
      EXPECT_DOUBLE_EQ(g.max_growth, (n + 2.0) / (n + 1.0)) << c.name << " m=" << m;
      if (mt.num_nodes() <= 200) {
        EXPECT_DOUBLE_EQ(g.max_growth, testing::brute_force_chain_growth(mt)) << c.name << " m=" << m;
      }
    }
  const Mt open = build_semiregular_mt(square(), 3);
  const double n = static_cast<double>(open.image_size(Mt::source())) / 2.0;
  const ChainGrowth g = chain_growth(open);
  EXPECT_GT(g.max_growth, (n + 2.0) / (n + 1.0));
  EXPECT_LT(g.max_growth, 2.0);
  EXPECT_DOUBLE_EQ(g.max_growth, testing::brute_force_chain_growth(open));
}

TEST(SemiRegular, ZeroLevelsIsTheBaseMesh) {
  const Mt mt = build_semiregular_mt(icosahedron(), 0);
  mt.validate();
  EXPECT_EQ(mt.num_nodes(), 1u);
  EXPECT_EQ(mt.num_faces(), 20u);
}

// Scaled copies of one mesh give the same hierarchy, scaled. Far up, the default node error (the split
// edge's length) and the midpoint were computed in float: their squares and sums overflowed past ~1.8e19 and
// a valid mesh was refused for a "non-finite error" the caller never gave. Far down, the spheres' absolute
// float slack (1e-12) dwarfed a model 1e-20 across and the Mt refused them as "too large to pack".
TEST(SemiRegular, ExtremeScalesScaleTheHierarchy) {
  const TriMesh unit = icosahedron();
  const Mt a = build_semiregular_mt(unit, 3);
  for (const float scale : {1e20f, 1e-20f}) {
    SCOPED_TRACE("scale " + std::to_string(scale));
    TriMesh scaled = unit;
    for (glm::vec3& p : scaled.positions) p *= scale;
    Mt b;
    ASSERT_NO_THROW(b = build_semiregular_mt(scaled, 3));
    b.validate();
    ASSERT_EQ(a.num_nodes(), b.num_nodes());
    ASSERT_EQ(a.num_vertices(), b.num_vertices());
    const float tol = 1e-6f * scale;
    for (std::size_t v = 0; v < a.num_vertices(); ++v)
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(b.position(static_cast<Index>(v))[k], scale * a.position(static_cast<Index>(v))[k], tol) << "vertex " << v;
    for (std::size_t n = 1; n < a.num_nodes(); ++n) {
      const ElementBound bb = b.bound(static_cast<NodeId>(n));
      EXPECT_TRUE(std::isfinite(bb.error));
      EXPECT_NEAR(bb.error, scale * a.bound(static_cast<NodeId>(n)).error, tol) << "node " << n;
      EXPECT_TRUE(std::isfinite(bb.radius));
    }
  }
}

TEST(SemiRegular, BadInputThrowsNamingTheCulprit) {
  auto expect_message = [](const std::function<void()>& fn, const std::string& needle, std::uint64_t element) {
    try {
      fn();
      ADD_FAILURE() << "no exception; expected one mentioning '" << needle << "'";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      if (element != InvalidInput::kNoElement) {
        EXPECT_EQ(e.element(), element) << e.what();
      }
    }
  };
  expect_message([] { build_semiregular_mt(TriMesh{}, 2); }, "empty", InvalidInput::kNoElement);
  expect_message([] { build_semiregular_mt(square(), -1); }, "levels", InvalidInput::kNoElement);
  // 2 faces * 2^30 = 2^31: one face too many. Checked before any allocation.
  EXPECT_EQ(max_semiregular_levels(2), 29);
  EXPECT_EQ(max_semiregular_levels(1000), 21);
  EXPECT_EQ(max_semiregular_levels(std::size_t(1) << 31), -1);
  expect_message([] { build_semiregular_mt(square(), 30); }, "levels", InvalidInput::kNoElement);
  expect_message([] { build_semiregular_mt(torus(25, 20), 22); }, "2^31", InvalidInput::kNoElement);
  expect_message([] { build_semiregular_mt(square(), 1000); }, "levels", InvalidInput::kNoElement);
  // Within 2^31 faces but beyond the machine's memory (2 x 2^29 faces: ~97 GB for the FourKMesh, ~280 GB
  // with the Mt): refused by name before anything is allocated, not ended by bad_alloc or the OOM killer.
  if (physical_memory_bytes() > 0.0 && physical_memory_bytes() < 90e9) {
    expect_message([] { build_semiregular_fourk(square(), 29); }, "GB; this machine has", InvalidInput::kNoElement);
    expect_message([] { build_semiregular_mt(square(), 29); }, "GB; this machine has", InvalidInput::kNoElement);
  }
  TriMesh degenerate = icosahedron();
  degenerate.indices[3 * 7 + 1] = degenerate.indices[3 * 7];
  expect_message([&] { build_semiregular_mt(degenerate, 1); }, "face 7", 7);
  TriMesh fin = square();  // a third face on the diagonal 0-2
  fin.positions.push_back({0.5f, 0.5f, 1.0f});
  fin.indices.insert(fin.indices.end(), {0, 2, 4});
  expect_message([&] { build_semiregular_mt(fin, 1); }, "non-manifold", 2);
  expect_message([&] { match_dual_faces(fin); }, "non-manifold", 2);
  TriMesh nan = square();
  nan.positions[3].y = NAN;
  EXPECT_THROW(build_semiregular_mt(nan, 1), InvalidInput);
  TriMesh out = square();
  out.indices[2] = 17;
  EXPECT_THROW(build_semiregular_mt(out, 1), InvalidInput);
  SemiRegularOptions so;
  so.place_vertex = [](const BisectionSplit&) { return glm::vec3(INFINITY, 0.0f, 0.0f); };
  EXPECT_THROW(build_semiregular_mt(square(), 1, so), InvalidInput);
  so = {};
  so.node_error = [](const BisectionSplit&) { return -1.0f; };
  EXPECT_THROW(build_semiregular_mt(square(), 1, so), InvalidInput);
}

// --- real meshes (../shared/data) ----------------------------------------------------------------------

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Matching (maximum by certificate, leftovers on the border), the 4-k hierarchy to `fourk_levels` (its
// invariants, the finest mesh's valences and topology) and the Mt to `mt_levels` (valid, valences at every
// level, refine-all / coarsen-all). Prints the figures quoted in the report.
void check_real_mesh(const std::string& path, int fourk_levels, int mt_levels, bool closed, bool check_geometry) {
  const TriMesh base = read_mesh(path);
  const std::size_t n = base.num_faces();
  const long chi = euler(base);
  auto t0 = std::chrono::steady_clock::now();
  const DualMatching dm = match_dual_faces(base, true);
  const double t_match = seconds_since(t0);
  check_dual_matching(base, dm, false);
  if (closed) {
    EXPECT_EQ(dm.num_leftovers, 0u);
  }

  double t_fourk = 0.0, fk_bytes_per_face = 0.0;
  if (fourk_levels > 0) {  // 0: skip (the sanitizer build is slow on the bunny)
    t0 = std::chrono::steady_clock::now();
    SemiRegularInfo finfo;
    const FourKMesh fk = build_semiregular_fourk(base, fourk_levels, {}, &finfo);
    t_fourk = seconds_since(t0);
    fk.validate();
    const TriMesh finest = fk.current_mesh();
    EXPECT_EQ(finest.num_faces(), n << fourk_levels);
    EXPECT_EQ(euler(finest), chi);
    check_level_valences(finest, {}, finfo.vertex_level, fourk_levels);
    fk_bytes_per_face = double(fk.memory_bytes()) / double(fk.num_current_faces());
  }

  double t_mt = 0.0;
  MtMetrics met;
  if (mt_levels > 0) {  // 0: skip
    t0 = std::chrono::steady_clock::now();
    SemiRegularInfo info;
    SemiRegularOptions so;
    so.build.check_geometry = check_geometry;
    const Mt mt = build_semiregular_mt(base, mt_levels, so, &info);
    t_mt = seconds_since(t0);
    mt.validate();
    EXPECT_EQ(info.matching.num_pairs, dm.num_pairs);
    met = compute_metrics(mt);
    EXPECT_EQ(met.finest_faces, n << mt_levels);
    EXPECT_EQ(met.depth, std::size_t(mt_levels));
    check_valences(mt, info, mt_levels);
    MtFront front(mt);
    for (NodeId v = 1; v < mt.num_nodes(); ++v) front.apply(v);
    front.validate();
    EXPECT_EQ(euler(front.to_mesh()), chi);
    for (NodeId v = static_cast<NodeId>(mt.num_nodes()); v-- > 1;) front.undo(v);
    EXPECT_EQ(front.num_faces(), n);
  }
  std::printf("[semiregular] %s: %zu faces, %zu border faces; matching %zu pairs (greedy %zu, augmenting %zu), "
              "%zu leftovers (moved to the border: %zu), %.3f s; FourKMesh depth %d: %zu faces in %.3f s, %.1f "
              "bytes/finest face; Mt depth %d: %zu faces, %zu nodes, %.3f s, %.1f bytes/finest face\n",
              path.substr(path.find_last_of('/') + 1).c_str(), n, dm.num_border_faces, dm.num_pairs,
              dm.graph.greedy_pairs, dm.graph.augmentations, dm.num_leftovers, dm.graph.moved, t_match, fourk_levels,
              n << fourk_levels, t_fourk, fk_bytes_per_face, mt_levels,
              met.finest_faces, met.nodes, t_mt, met.bytes_per_face);
}

TEST(SemiRegularSharedData, Cow) {
  VARMESH_REQUIRE_SHARED(path, "meshes/cow_cgal_2904v.off");
  check_real_mesh(path, 2, 2, true, true);
}

TEST(SemiRegularSharedData, Bunny) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bun_zipper_35947v.obj");
#ifdef VARMESH_ENABLE_ASSERTS
  // The sanitizer build (where MtBuilder alone takes ~10 s on the bunny): the 4-k hierarchy only; the Mt
  // path is the same code as for the cow and the fandisk.
  check_real_mesh(path, 1, 0, false, true);
#else
  check_real_mesh(path, 2, 2, false, true);
#endif
}

TEST(SemiRegularSharedData, Fandisk) {
  VARMESH_REQUIRE_SHARED(path, "meshes/fandisk_6475v.obj");
  check_real_mesh(path, 1, 1, true, true);
}

}  // namespace
}  // namespace varmesh
