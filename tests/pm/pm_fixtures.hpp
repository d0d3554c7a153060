#pragma once
// Small generated meshes for the pm tests: runnable anywhere (no shared data needed).
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

#include "multitri/shapes.hpp"
#include "multitri/tri_mesh.hpp"
#include "pm/dual_pieces.hpp"
#include "pm/sr_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh::testing {

using varmesh::make_icosphere;
using varmesh::make_torus;

/// "" when the SrMesh's faces are exactly those its active set defines through dual pieces (pm/dual_pieces.hpp:
/// the same original faces on the same corners, in the same cyclic order); else what differs first.
inline std::string differs_from_dual_pieces(const SrMesh& sr) {
  const VertexHierarchy& h = sr.hierarchy();
  std::vector<std::uint8_t> active(h.num_nodes(), 0);
  for (Index v : sr.active_vertices()) active[v] = 1;
  const auto ref = dual_piece_mesh(h, active_ancestors(h, active));
  if (ref.size() != sr.num_faces()) return "face count " + std::to_string(sr.num_faces()) + " vs " + std::to_string(ref.size());
  auto rot = [](std::array<Index, 3> c) {
    while (c[0] > c[1] || c[0] > c[2]) c = {c[1], c[2], c[0]};
    return c;
  };
  for (const DualPieceFace& f : ref) {
    if (!sr.face_active(f.original)) return "face " + std::to_string(f.original) + " inactive";
    if (rot(sr.face(f.original)) != rot(f.corners)) return "face " + std::to_string(f.original) + " corners differ";
  }
  return "";
}

/// The arrays a hierarchy was assembled from, read back through the public accessors (for edits that
/// VertexHierarchyBuilder::finish is then given).
inline VertexHierarchyBuilder::Raw raw_of(const VertexHierarchy& h) {
  VertexHierarchyBuilder::Raw raw;
  raw.num_leaves = h.num_leaves();
  raw.positions.assign(h.positions().begin(), h.positions().end());
  raw.colors.assign(h.colors().begin(), h.colors().end());
  for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) {
    raw.records.push_back(h.record(static_cast<Index>(v)));
    const auto ring = h.stored_ring(static_cast<Index>(v));
    raw.ring_items.insert(raw.ring_items.end(), ring.begin(), ring.end());
    raw.ring_offsets.push_back(static_cast<Index>(raw.ring_items.size()));
  }
  raw.faces.assign(h.face_corners().begin(), h.face_corners().end());
  for (std::size_t v = 0; v < h.num_nodes(); ++v) raw.bounds.push_back(h.bound(static_cast<Index>(v)));
  raw.leaf_to_input.assign(h.leaf_to_input().begin(), h.leaf_to_input().end());
  raw.face_to_input.assign(h.face_to_input().begin(), h.face_to_input().end());
  raw.repair = h.repair_report();
  return raw;
}

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
