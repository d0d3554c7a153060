#pragma once
// Test fixture shared by mt_front_test.cpp and query_test.cpp: a Multi-Triangulation of the square
// [0, n]^2 built in code by newest-vertex bisection (the 4-8 hierarchy, Velho-Gomes section 4).
//
// Base: n x n unit squares, each split by a random diagonal into two right isosceles triangles whose
// hypotenuse is the diagonal. Each level bisects every current triangle: triangles sharing a hypotenuse
// form a diamond, replaced by one split node (2 -> 4, or 1 -> 2 on the domain border). A diamond may first
// be flipped by a swap node (2 -> 2, the other diagonal of its quad); the split then removes the swapped
// pair and creates the same four triangles. Heights z = height(x, y) make a terrain (planar if empty), so
// the projection of any front on the xy plane tiles the square: signed areas sum to n^2.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"

namespace varmesh::testing {

struct GridMtOptions {
  int n = 2;                     ///< base squares per side
  int levels = 4;                ///< bisection levels (each doubles the finest face count)
  double swap_probability = 0.0; ///< chance that an interior diamond is swapped before its split
  enum class Errors { kDecreasing, kRandom } errors = Errors::kDecreasing;
  bool jitter = true;            ///< false: every node of a level has error 0.6^level exactly (many ties)
  bool saturate = true;
  std::function<float(float, float)> height;  ///< empty: planar (z = 0)
  std::uint32_t seed = 1;
};

struct GridMt {
  Mt mt;
  double domain_area = 0.0;
  std::size_t num_swaps = 0;
};

inline GridMt make_grid_mt(const GridMtOptions& o) {
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  MtBuilder b;
  // Lattice coordinates scaled so that every midpoint down to `levels` bisections is an integer.
  const int scale = 1 << ((o.levels + 1) / 2 + 1);
  std::map<std::pair<int, int>, VertexId> vertex_of;
  std::vector<std::pair<int, int>> lattice;
  auto vertex = [&](int ix, int iy) {
    const auto key = std::make_pair(ix, iy);
    if (auto it = vertex_of.find(key); it != vertex_of.end()) return it->second;
    const float x = static_cast<float>(ix) / static_cast<float>(scale);
    const float y = static_cast<float>(iy) / static_cast<float>(scale);
    const VertexId v = b.add_vertex({x, y, o.height ? o.height(x, y) : 0.0f});
    vertex_of.emplace(key, v);
    lattice.push_back(key);
    return v;
  };
  // (apex, h0, h1) counter-clockwise; the hypotenuse is h0-h1.
  struct Tri {
    FaceId id;
    VertexId apex, h0, h1;
  };
  std::vector<Tri> current;
  auto add_tri = [&](VertexId a, VertexId h0, VertexId h1) { return Tri{b.add_face(a, h0, h1), a, h0, h1}; };
  for (int j = 0; j < o.n; ++j)
    for (int i = 0; i < o.n; ++i) {
      const VertexId p00 = vertex(i * scale, j * scale), p10 = vertex((i + 1) * scale, j * scale);
      const VertexId p11 = vertex((i + 1) * scale, (j + 1) * scale), p01 = vertex(i * scale, (j + 1) * scale);
      if (rng() & 1u) {
        current.push_back(add_tri(p10, p11, p00));
        current.push_back(add_tri(p01, p00, p11));
      } else {
        current.push_back(add_tri(p00, p10, p01));
        current.push_back(add_tri(p11, p01, p10));
      }
    }
  std::vector<FaceId> base;
  for (const Tri& t : current) base.push_back(t.id);
  b.set_base(base);

  GridMt out;
  auto node_error = [&](int level) {
    if (o.errors == GridMtOptions::Errors::kRandom) return 0.01f + u01(rng);
    if (!o.jitter) return std::pow(0.6f, static_cast<float>(level));
    return std::pow(0.6f, static_cast<float>(level)) * (0.8f + 0.4f * u01(rng));
  };
  for (int level = 0; level < o.levels; ++level) {
    std::map<std::pair<VertexId, VertexId>, std::vector<Tri>> diamonds;
    for (const Tri& t : current) diamonds[std::minmax(t.h0, t.h1)].push_back(t);
    std::vector<Tri> next;
    for (auto& [edge, tris] : diamonds) {
      const Tri& t1 = tris[0];
      const auto [x0, y0] = lattice[t1.h0];
      const auto [x1, y1] = lattice[t1.h1];
      const VertexId m = vertex((x0 + x1) / 2, (y0 + y1) / 2);
      const VertexId a = t1.apex, v1 = t1.h0, v2 = t1.h1;
      if (tris.size() == 1) {
        const Tri c0 = add_tri(m, a, v1), c1 = add_tri(m, v2, a);
        const FaceId removed[] = {t1.id}, created[] = {c0.id, c1.id};
        b.add_node(NodeKind::kSplit, removed, created, node_error(level));
        next.push_back(c0);
        next.push_back(c1);
        continue;
      }
      const Tri& t2 = tris[1];  // (b, v2, v1)
      const VertexId bv = t2.apex;
      FaceId removed[] = {t1.id, t2.id};
      if (u01(rng) < o.swap_probability) {
        // Quad a, v1, b, v2 (counter-clockwise); flip v1-v2 to a-b.
        const Tri s1 = add_tri(v1, bv, a), s2 = add_tri(v2, a, bv);
        const FaceId created[] = {s1.id, s2.id};
        b.add_node(NodeKind::kSwap, removed, created, node_error(level));
        removed[0] = s1.id;
        removed[1] = s2.id;
        ++out.num_swaps;
      }
      const Tri c0 = add_tri(m, a, v1), c1 = add_tri(m, v2, a), c2 = add_tri(m, bv, v2), c3 = add_tri(m, v1, bv);
      const FaceId created[] = {c0.id, c1.id, c2.id, c3.id};
      b.add_node(NodeKind::kSplit, removed, created, node_error(level));
      next.insert(next.end(), {c0, c1, c2, c3});
    }
    current = std::move(next);
  }
  MtBuilder::Options bo;
  bo.saturate = o.saturate;
  out.mt = std::move(b).build(bo);
  out.domain_area = static_cast<double>(o.n) * o.n;
  return out;
}

/// A smooth terrain used where normals must vary (back-facing and silhouette criteria).
inline float hills(float x, float y) { return 0.35f * std::sin(2.1f * x) * std::cos(1.7f * y) + 0.1f * x; }

/// The applied flags of a front, for comparisons.
inline std::vector<char> applied_set(const MtFront& f) {
  std::vector<char> s(f.mt().num_nodes());
  for (NodeId n = 0; n < s.size(); ++n) s[n] = f.is_applied(n) ? 1 : 0;
  return s;
}

/// Signed area of the current faces projected on the xy plane.
inline double projected_area(const MtFront& f) {
  double sum = 0.0;
  f.for_each_face_geometry([&](FaceId, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    sum += 0.5 * ((double(b.x) - a.x) * (double(c.y) - a.y) - (double(c.x) - a.x) * (double(b.y) - a.y));
  });
  return sum;
}

}  // namespace varmesh::testing
