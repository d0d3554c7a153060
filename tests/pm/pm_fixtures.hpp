#pragma once
// Small generated meshes for the pm tests: runnable anywhere (no shared data needed).
#include <cmath>
#include <map>
#include <utility>

#include <glm/geometric.hpp>

#include "multitri/shapes.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh::testing {

using varmesh::make_icosphere;
using varmesh::make_torus;

/// Regular grid of (n+1) x (m+1) vertices on z = f(x, y) over [0,1]^2, alternating diagonals; has a border.
inline TriMesh make_grid(int n, int m, float bump = 0.2f) {
  TriMesh g;
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = static_cast<float>(i) / static_cast<float>(n), y = static_cast<float>(j) / static_cast<float>(m);
      g.positions.push_back({x, y, bump * std::sin(3.0f * x) * std::cos(2.0f * y) + 0.05f * x * y});
    }
  auto id = [&](int i, int j) { return static_cast<Index>(j * (n + 1) + i); };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2 == 0) g.indices.insert(g.indices.end(), {a, b, c, a, c, d});
      else g.indices.insert(g.indices.end(), {a, b, d, b, c, d});
    }
  return g;
}

/// Concatenation of two meshes (several components).
inline TriMesh concat(const TriMesh& a, const TriMesh& b, glm::vec3 offset) {
  TriMesh m = a;
  const Index base = static_cast<Index>(m.positions.size());
  for (const auto& p : b.positions) m.positions.push_back(p + offset);
  for (Index i : b.indices) m.indices.push_back(base + i);
  return m;
}

}  // namespace varmesh::testing
