// Tests of multitri/mt_metrics.hpp on hand-made MTs whose metrics are known by hand, and of the exact front
// count against a brute-force enumeration on random small MTs.
#include "multitri/mt_metrics.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "mt_oracles.hpp"

#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"

namespace varmesh {
namespace {

// --- BigUint -------------------------------------------------------------------------------------------

TEST(MtMetricsBigUint, Arithmetic) {
  EXPECT_EQ(BigUint().to_string(), "0");
  EXPECT_EQ(BigUint(12345).to_string(), "12345");
  EXPECT_EQ(BigUint::pow2(64).to_string(), "18446744073709551616");
  EXPECT_EQ(BigUint::pow2(128).to_string(), "340282366920938463463374607431768211456");
  BigUint a = BigUint::pow2(64);
  a -= 1;
  EXPECT_EQ(a, BigUint(UINT64_MAX));
  EXPECT_TRUE(a.fits_u64());
  a += BigUint(1);
  EXPECT_EQ(a, BigUint::pow2(64));
  EXPECT_FALSE(a.fits_u64());
  EXPECT_EQ(a * a, BigUint::pow2(128));
  EXPECT_EQ(BigUint(10000000000000000000ull).to_string(), "10000000000000000000");
  EXPECT_EQ((BigUint::pow2(64) * BigUint(10)).to_string(), "184467440737095516160");
  EXPECT_LT(BigUint(3), BigUint::pow2(64));
  EXPECT_GT(BigUint::pow2(65), BigUint::pow2(64) + BigUint(UINT64_MAX));
  EXPECT_EQ(BigUint::pow2(200).bit_width(), 201u);
  EXPECT_DOUBLE_EQ(BigUint::pow2(200).log2(), 200.0);
  EXPECT_NEAR((BigUint::pow2(100) + BigUint::pow2(99)).log2(), 100.0 + std::log2(1.5), 1e-12);
  EXPECT_TRUE(std::isinf(BigUint().log2()));
  BigUint z;
  EXPECT_THROW(z -= 1, InvalidInput);
}

// --- hand-made MTs -------------------------------------------------------------------------------------

// Only the source: one triangle.
Mt single_triangle() {
  MtBuilder b;
  const VertexId a = b.add_vertex({0, 0, 0}), c = b.add_vertex({1, 0, 0}), d = b.add_vertex({0, 1, 0});
  const std::array<FaceId, 1> base{b.add_face(a, c, d)};
  b.set_base(base);
  return std::move(b).build();
}

// The unit square a b c d with diagonal a-c, refined by
//   X: split of the diagonal at its midpoint m (2 -> 4),
//   Y: border split of (a, b, m) at p, the midpoint of a-b (1 -> 2),
//   Z: border split of (m, b, c) at q, the midpoint of b-c (1 -> 2),
//   W: swap of the edge b-m shared by Y's (p, b, m) and Z's (m, b, q) into p-q (2 -> 2).
// DAG: source -> X -> {Y, Z} -> W. Levels 1, 2, 2, 3; depth 3. Faces: 2 + 4 + 2 + 2 + 2 = 12; the finest
// mesh (a, p, m) (p, b, q) (p, q, m) (m, q, c) (a, m, d) (m, c, d) has 6. Fronts: {}, X, XY, XZ, XYZ, XYZW.
Mt square_mt() {
  MtBuilder b;
  const VertexId a = b.add_vertex({0, 0, 0}), bb = b.add_vertex({1, 0, 0}), c = b.add_vertex({1, 1, 0}),
                 d = b.add_vertex({0, 1, 0}), m = b.add_vertex({0.5f, 0.5f, 0}), p = b.add_vertex({0.5f, 0, 0}),
                 q = b.add_vertex({1, 0.5f, 0});
  const FaceId t1 = b.add_face(a, bb, c), t2 = b.add_face(a, c, d);
  const std::array<FaceId, 2> base{t1, t2};
  b.set_base(base);
  const FaceId x0 = b.add_face(a, bb, m), x1 = b.add_face(m, bb, c), x2 = b.add_face(a, m, d), x3 = b.add_face(m, c, d);
  b.add_node(NodeKind::kSplit, base, std::array<FaceId, 4>{x0, x1, x2, x3}, 1.0f);
  const FaceId y0 = b.add_face(a, p, m), y1 = b.add_face(p, bb, m);
  b.add_node(NodeKind::kSplit, std::array<FaceId, 1>{x0}, std::array<FaceId, 2>{y0, y1}, 0.5f);
  const FaceId z0 = b.add_face(m, bb, q), z1 = b.add_face(m, q, c);
  b.add_node(NodeKind::kSplit, std::array<FaceId, 1>{x1}, std::array<FaceId, 2>{z0, z1}, 0.5f);
  const FaceId w0 = b.add_face(p, bb, q), w1 = b.add_face(p, q, m);
  b.add_node(NodeKind::kSwap, std::array<FaceId, 2>{y1, z0}, std::array<FaceId, 2>{w0, w1}, 0.25f);
  return std::move(b).build();
}

// A chain of k border splits: (p, q, r) with q -> r on the border becomes (p, q, m) (p, m, r), and the next
// split takes (p, q, m). Depth k, one node per level, k + 1 fronts, 1 + 2k faces, k + 1 finest faces.
Mt chain_mt(int k) {
  MtBuilder b;
  VertexId p = b.add_vertex({0, 0, 0}), q = b.add_vertex({1, 0, 0}), r = b.add_vertex({0, 1, 0});
  glm::vec3 pq = {1, 0, 0}, pr = {0, 1, 0};
  FaceId t = b.add_face(p, q, r);
  b.set_base(std::array<FaceId, 1>{t});
  for (int i = 0; i < k; ++i) {
    pr = (pq + pr) * 0.5f;
    const VertexId m = b.add_vertex(pr);
    const FaceId c0 = b.add_face(p, q, m), c1 = b.add_face(p, m, r);
    b.add_node(NodeKind::kSplit, std::array<FaceId, 1>{t}, std::array<FaceId, 2>{c0, c1}, 0.0f);
    t = c0;
    r = m;
  }
  return std::move(b).build();
}

// k disjoint triangles, each split once on a border edge: k independent nodes, 2^k fronts.
Mt antichain_mt(int k) {
  MtBuilder b;
  std::vector<FaceId> base;
  std::vector<std::array<VertexId, 3>> tri;
  for (int i = 0; i < k; ++i) {
    const float x = 2.0f * static_cast<float>(i);
    const VertexId v0 = b.add_vertex({x, 0, 0}), v1 = b.add_vertex({x + 1, 0, 0}), v2 = b.add_vertex({x, 1, 0});
    base.push_back(b.add_face(v0, v1, v2));
    tri.push_back({v0, v1, v2});
  }
  b.set_base(base);
  for (int i = 0; i < k; ++i) {
    const float x = 2.0f * static_cast<float>(i);
    const VertexId m = b.add_vertex({x + 0.5f, 0.5f, 0});
    const FaceId c0 = b.add_face(m, tri[i][0], tri[i][1]), c1 = b.add_face(m, tri[i][2], tri[i][0]);
    b.add_node(NodeKind::kSplit, std::array<FaceId, 1>{base[i]}, std::array<FaceId, 2>{c0, c1}, 0.0f);
  }
  return std::move(b).build();
}

TEST(MtMetrics, SourceOnly) {
  const Mt mt = single_triangle();
  const MtMetrics m = compute_metrics(mt);
  EXPECT_EQ(m.nodes, 0u);
  EXPECT_EQ(m.faces, 1u);
  EXPECT_EQ(m.depth, 0u);
  EXPECT_EQ(m.nodes_per_level, (std::vector<std::size_t>{1}));
  EXPECT_EQ(m.coarsest_faces, 1u);
  EXPECT_EQ(m.finest_faces, 1u);
  EXPECT_DOUBLE_EQ(m.growth_rate, 1.0);
  EXPECT_DOUBLE_EQ(m.bytes_per_face, double(mt.memory_bytes()));
  const FrontCount fc = expressive_power(mt);
  EXPECT_TRUE(fc.exact);
  EXPECT_EQ(fc.value, BigUint(1));
  const LevelFrontCount lc = count_level_fronts(mt);
  EXPECT_TRUE(lc.total.is_zero());  // eq. 4 with m = 0: the empty sum
  EXPECT_EQ(lc.distinct, BigUint(1));
}

TEST(MtMetrics, HandMadeSquare) {
  const Mt mt = square_mt();
  mt.validate();
  const MtMetrics m = compute_metrics(mt);
  EXPECT_EQ(m.nodes, 4u);
  EXPECT_EQ(m.faces, 12u);
  EXPECT_EQ(m.depth, 3u);
  EXPECT_EQ(m.nodes_per_level, (std::vector<std::size_t>{1, 1, 2, 1}));
  EXPECT_EQ(m.coarsest_faces, 2u);
  EXPECT_EQ(m.finest_faces, 6u);
  EXPECT_DOUBLE_EQ(m.growth_rate, 2.0);
  EXPECT_EQ(m.memory_bytes, mt.memory_bytes());
  EXPECT_DOUBLE_EQ(m.bytes_per_face, double(mt.memory_bytes()) / 6.0);
  EXPECT_EQ(compute_node_levels(mt), (std::vector<Index>{0, 1, 2, 2, 3}));

  const FrontCount fc = expressive_power(mt);
  ASSERT_TRUE(fc.exact);
  EXPECT_EQ(fc.value, BigUint(6));
  EXPECT_NEAR(fc.log2, std::log2(6.0), 1e-12);
  EXPECT_DOUBLE_EQ(fc.log2_upper, 4.0);
  // Eq. 4: 2^1 + 2^2 + 2^1 = 8 with the two full-level fronts counted twice; 6 distinct, all the fronts.
  const LevelFrontCount lc = count_level_fronts(mt);
  EXPECT_EQ(lc.total, BigUint(8));
  EXPECT_EQ(lc.distinct, BigUint(6));
}

TEST(MtMetrics, ChainOfBorderSplits) {
  for (int k : {1, 2, 5, 40}) {
    const Mt mt = chain_mt(k);
    const MtMetrics m = compute_metrics(mt);
    EXPECT_EQ(m.nodes, std::size_t(k));
    EXPECT_EQ(m.depth, std::size_t(k));
    EXPECT_EQ(m.faces, std::size_t(1 + 2 * k));
    EXPECT_EQ(m.finest_faces, std::size_t(1 + k));
    EXPECT_DOUBLE_EQ(m.growth_rate, double(1 + 2 * k) / double(1 + k));
    const FrontCount fc = expressive_power(mt);
    ASSERT_TRUE(fc.exact);
    EXPECT_EQ(fc.value, BigUint(std::uint64_t(k) + 1));
    EXPECT_EQ(fc.peak_width, k >= 2 ? 1u : 0u);  // the last node has no child: never live
    EXPECT_EQ(count_level_fronts(mt).total, BigUint(2 * std::uint64_t(k)));
    EXPECT_EQ(count_level_fronts(mt).distinct, fc.value);
  }
}

TEST(MtMetrics, AntichainNeedsMoreThan64Bits) {
  const Mt mt = antichain_mt(70);
  const MtMetrics m = compute_metrics(mt);
  EXPECT_EQ(m.depth, 1u);
  EXPECT_EQ(m.nodes_per_level, (std::vector<std::size_t>{1, 70}));
  EXPECT_DOUBLE_EQ(m.growth_rate, 210.0 / 140.0);
  const FrontCount fc = expressive_power(mt);
  ASSERT_TRUE(fc.exact);
  EXPECT_EQ(fc.value, BigUint::pow2(70));
  EXPECT_EQ(fc.value.to_string(), "1180591620717411303424");
  EXPECT_EQ(count_level_fronts(mt).total, BigUint::pow2(70));
}

// --- random MTs against brute force ---------------------------------------------------------------------

// A random sequence of generic modifications on a small grid: 1 -> 3 centroid splits and 2 -> 2 edge swaps
// (the swap needs its new edge absent and its new faces never seen before: non-redundancy).
Mt random_mt(std::mt19937& rng, int num_ops) {
  MtBuilder b;
  std::vector<std::array<VertexId, 3>> faces;  // by builder face id
  std::vector<FaceId> current;
  std::set<std::array<VertexId, 3>> seen;
  auto add_face = [&](VertexId x, VertexId y, VertexId z) {
    std::array<VertexId, 3> key{x, y, z};
    std::sort(key.begin(), key.end());
    seen.insert(key);
    faces.push_back({x, y, z});
    return b.add_face(x, y, z);
  };
  const int n = 2;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) b.add_vertex({float(x), float(y), 0});
  auto id = [&](int x, int y) { return static_cast<VertexId>(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      current.push_back(add_face(id(x, y), id(x + 1, y), id(x + 1, y + 1)));
      current.push_back(add_face(id(x, y), id(x + 1, y + 1), id(x, y + 1)));
    }
  b.set_base(current);
  for (int op = 0; op < num_ops; ++op) {
    if (rng() % 2 == 0) {
      const std::size_t i = rng() % current.size();
      const auto [x, y, z] = faces[current[i]];
      const VertexId c = b.add_vertex({0.1f * float(op), 0, 0});
      const FaceId f = current[i];
      const std::array<FaceId, 3> img{add_face(x, y, c), add_face(y, z, c), add_face(z, x, c)};
      b.add_node(NodeKind::kGeneric, std::array<FaceId, 1>{f}, img, 0.0f);
      current.erase(current.begin() + static_cast<std::ptrdiff_t>(i));
      current.insert(current.end(), img.begin(), img.end());
      continue;
    }
    // Swap: find a random interior edge u -> v of face f = (u, v, w), twin g = (v, u, s).
    bool done = false;
    for (int attempt = 0; attempt < 20 && !done; ++attempt) {
      const std::size_t i = rng() % current.size();
      const int k = static_cast<int>(rng() % 3);
      const auto fv = faces[current[i]];
      const VertexId u = fv[k], v = fv[(k + 1) % 3], w = fv[(k + 2) % 3];
      std::size_t j = current.size();
      VertexId s = kInvalid;
      bool edge_ws = false;
      for (std::size_t t = 0; t < current.size(); ++t) {
        const auto gv = faces[current[t]];
        for (int l = 0; l < 3; ++l) {
          if (gv[l] == v && gv[(l + 1) % 3] == u) {
            j = t;
            s = gv[(l + 2) % 3];
          }
        }
      }
      if (j == current.size() || s == w) continue;
      for (FaceId t : current) {
        const auto gv = faces[t];
        for (int l = 0; l < 3; ++l)
          if ((gv[l] == w && gv[(l + 1) % 3] == s) || (gv[l] == s && gv[(l + 1) % 3] == w)) edge_ws = true;
      }
      std::array<VertexId, 3> k0{u, s, w}, k1{v, w, s};
      std::sort(k0.begin(), k0.end());
      std::sort(k1.begin(), k1.end());
      if (edge_ws || seen.count(k0) || seen.count(k1)) continue;
      // (u, v, w) + (v, u, s) -> (u, s, w) + (v, w, s): same oriented boundary, edge u-v replaced by w-s.
      const FaceId fi = current[i], fj = current[j];
      const std::array<FaceId, 2> img{add_face(u, s, w), add_face(v, w, s)};
      b.add_node(NodeKind::kSwap, std::array<FaceId, 2>{fi, fj}, img, 0.0f);
      current.erase(current.begin() + static_cast<std::ptrdiff_t>(std::max(i, j)));
      current.erase(current.begin() + static_cast<std::ptrdiff_t>(std::min(i, j)));
      current.insert(current.end(), img.begin(), img.end());
      done = true;
    }
  }
  return std::move(b).build();
}

using varmesh::testing::brute_force_fronts;

// Longest path from the source by plain recursion.
Index slow_level(const Mt& mt, NodeId n) {
  Index l = 0;
  for (NodeId p : mt.parents(n)) l = std::max(l, slow_level(mt, p) + 1);
  return l;
}

TEST(MtMetrics, RandomMtsAgainstBruteForce) {
  std::mt19937 rng(7);
  std::size_t nontrivial = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Mt mt = random_mt(rng, 4 + trial % 15);
    mt.validate();
    ASSERT_LE(mt.num_nodes(), 20u);
    const std::uint64_t expected = brute_force_fronts(mt);
    const FrontCount fc = expressive_power(mt);
    ASSERT_TRUE(fc.exact);
    EXPECT_EQ(fc.value, BigUint(expected)) << "trial " << trial;
    const LevelFrontCount lc = count_level_fronts(mt);
    EXPECT_LE(lc.distinct, fc.value);
    const MtMetrics m = compute_metrics(mt);
    std::size_t depth = 0;
    for (NodeId n = 0; n < mt.num_nodes(); ++n) {
      EXPECT_EQ(compute_node_levels(mt)[n], slow_level(mt, n));
      depth = std::max<std::size_t>(depth, slow_level(mt, n));
    }
    EXPECT_EQ(m.depth, depth);
    // Applying every node reaches the finest mesh.
    MtFront front(mt);
    for (NodeId n = 1; n < mt.num_nodes(); ++n) front.apply(n);
    EXPECT_EQ(front.num_faces(), m.finest_faces);
    EXPECT_DOUBLE_EQ(m.growth_rate, double(mt.num_faces()) / double(m.finest_faces));
    if (depth >= 3 && expected > 2 * mt.num_nodes()) ++nontrivial;
  }
  EXPECT_GT(nontrivial, 10u);
}

TEST(MtMetrics, RefusalGivesBounds) {
  const Mt mt = antichain_mt(30);
  FrontCountOptions o;
  o.max_states = 1;  // never hit: an antichain keeps one state
  EXPECT_TRUE(expressive_power(mt, o).exact);
  o.max_nodes = 29;
  const FrontCount fc = expressive_power(mt, o);
  EXPECT_FALSE(fc.exact);
  EXPECT_DOUBLE_EQ(fc.log2, 30.0);  // the one-level bound is exact here
  EXPECT_DOUBLE_EQ(fc.log2_upper, 30.0);
  const Mt sq = square_mt();
  o = {};
  o.max_width = 0;
  const FrontCount w = expressive_power(sq, o);
  EXPECT_FALSE(w.exact);
  EXPECT_NEAR(w.log2, std::log2(6.0), 1e-12);
}


TEST(MtMetrics, AnEmptyMtHasNoFrontToCount) {
  const Mt empty;
  EXPECT_THROW(expressive_power(empty), InvalidInput);
  EXPECT_THROW(count_level_fronts(empty), InvalidInput);
  const MtMetrics m = compute_metrics(empty);
  EXPECT_EQ(m.nodes, 0u);
  EXPECT_EQ(m.faces, 0u);
  EXPECT_EQ(m.depth, 0u);
  EXPECT_FALSE(chain_growth(empty).computed);
}

TEST(BigUint, SubtractingBelowZeroThrowsInvalidInputAndKeepsTheValue) {
  BigUint b(3);
  EXPECT_THROW(b -= 5, InvalidInput);
  EXPECT_EQ(b, BigUint(3));
  BigUint zero;
  EXPECT_THROW(zero -= 1, InvalidInput);
  zero -= 0;
  EXPECT_TRUE(zero.is_zero());
  BigUint big = BigUint::pow2(64);
  big -= 1;
  EXPECT_EQ(big, BigUint(UINT64_MAX));
  big -= UINT64_MAX;
  EXPECT_TRUE(big.is_zero());
}

}  // namespace
}  // namespace varmesh
