#pragma once
/// An indexed triangle mesh: the currency between readers, builders, extractors, writers and the renderer.
///
/// Invariants (checked by validate()):
/// - indices.size() is a multiple of 3; face f has corners indices[3f], indices[3f+1], indices[3f+2];
/// - every index is < positions.size();
/// - each optional per-vertex attribute array is either empty or has positions.size() entries;
/// - positions (and attributes) are finite.
/// Faces may be degenerate, duplicated or non-manifold: that is data (see mesh_report.hpp), not an error.
#include <cstddef>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "multitri/detail/assert.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Axis-aligned box; empty when lo > hi in any coordinate.
struct Box3 {
  glm::vec3 lo{1e30f, 1e30f, 1e30f};
  glm::vec3 hi{-1e30f, -1e30f, -1e30f};

  bool empty() const noexcept { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void add(const glm::vec3& p) noexcept;
  glm::vec3 center() const noexcept { return lo * 0.5f + hi * 0.5f; }  // no overflow near FLT_MAX
  glm::vec3 extent() const noexcept { return hi - lo; }
  /// Length of the diagonal; 0 for an empty box.
  float diagonal() const noexcept;
};

/// Whether every component of an RGB colour lies in [0, 1] (false for NaN): what the mesh writers, the readers
/// and the hierarchy files take.
inline bool is_unit_color(const glm::vec3& c) noexcept {
  return c.x >= 0.0f && c.x <= 1.0f && c.y >= 0.0f && c.y <= 1.0f && c.z >= 0.0f && c.z <= 1.0f;
}

struct TriMesh {
  std::vector<glm::vec3> positions;
  std::vector<Index> indices;  ///< 3 per face
  std::vector<glm::vec3> normals;    ///< optional, per vertex
  std::vector<glm::vec2> texcoords;  ///< optional, per vertex
  std::vector<glm::vec3> colors;     ///< optional, per vertex, RGB in [0, 1]

  std::size_t num_vertices() const noexcept { return positions.size(); }
  std::size_t num_faces() const noexcept { return indices.size() / 3; }
  bool has_normals() const noexcept { return !normals.empty(); }
  bool has_texcoords() const noexcept { return !texcoords.empty(); }
  bool has_colors() const noexcept { return !colors.empty(); }

  /// Unchecked: 3 * face + k < indices.size(), 0 <= k < 3 (as vector::operator[]).
  Index corner(std::size_t face, int k) const noexcept {
    VARMESH_ASSERT(k >= 0 && k < 3 && 3 * face + static_cast<std::size_t>(k) < indices.size());
    return indices[3 * face + static_cast<std::size_t>(k)];
  }

  /// Throws InvalidInput naming the first element that breaks an invariant above.
  void validate() const;
  /// Bounding box of the positions referenced or not.
  Box3 bounds() const noexcept;
};

/// Area-weighted vertex normals (unit length; zero for vertices with no non-degenerate face). Throws
/// InvalidInput when indices.size() is not a multiple of 3 or a face refers to a missing vertex (naming the
/// face). O(faces + vertices).
std::vector<glm::vec3> compute_vertex_normals(const TriMesh& mesh);

/// Sum of triangle areas. Throws InvalidInput as compute_vertex_normals does. O(faces).
double surface_area(const TriMesh& mesh);

}  // namespace varmesh
