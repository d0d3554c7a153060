#pragma once
// Small generated meshes shared by several test suites (tests that must run without ../shared/data).
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "multitri/shapes.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh::testing {

/// A closed torus (major radius 2, minor 0.7) sampled on an nu x nv grid, each quad cut along the
/// diagonal from its corner (i, j) to (i+1, j+1): 2 nu nv consistently oriented faces, genus 1.
inline TriMesh torus_grid(int nu, int nv) { return make_torus(nu, nv, 2.0f, 0.7f); }

/// Signed volume enclosed by a closed mesh (positive when its faces are oriented outwards).
inline double signed_volume(const TriMesh& m) {
  double v = 0.0;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const glm::dvec3 a(m.positions[m.indices[3 * f]]), b(m.positions[m.indices[3 * f + 1]]), c(m.positions[m.indices[3 * f + 2]]);
    v += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  return v;
}

/// The convex hull of a few points in convex position (no four coplanar), faces turned outwards: brute
/// force over all triples, for tiny meshes only.
inline TriMesh convex_hull_mesh(const std::vector<glm::vec3>& points) {
  TriMesh m;
  m.positions = points;
  const auto n = static_cast<Index>(points.size());
  for (Index i = 0; i < n; ++i)
    for (Index j = i + 1; j < n; ++j)
      for (Index k = j + 1; k < n; ++k) {
        const glm::vec3 nrm = glm::cross(points[j] - points[i], points[k] - points[i]);
        int above = 0, below = 0;
        for (Index l = 0; l < n; ++l) {
          if (l == i || l == j || l == k) continue;
          const float s = glm::dot(nrm, points[l] - points[i]);
          above += s > 1e-4f;
          below += s < -1e-4f;
        }
        if (above != 0 && below != 0) continue;  // not a hull face
        if (above == 0) m.indices.insert(m.indices.end(), {i, j, k});  // the others behind (i, j, k)
        else m.indices.insert(m.indices.end(), {i, k, j});
      }
  return m;
}

/// The regular tetrahedron on alternate corners of the cube [-1, 1]^3: 4 faces.
inline TriMesh tetrahedron_mesh() {
  return convex_hull_mesh({{1.0f, 1.0f, 1.0f}, {1.0f, -1.0f, -1.0f}, {-1.0f, 1.0f, -1.0f}, {-1.0f, -1.0f, 1.0f}});
}

/// The regular icosahedron on (0, +-1, +-t) and its cyclic permutations, t the golden ratio: 20 faces.
inline TriMesh icosahedron_mesh() {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<glm::vec3> p;
  for (float a : {-1.0f, 1.0f})
    for (float b : {-t, t}) {
      p.push_back({0.0f, a, b});
      p.push_back({a, b, 0.0f});
      p.push_back({b, 0.0f, a});
    }
  return convex_hull_mesh(p);
}

}  // namespace varmesh::testing
