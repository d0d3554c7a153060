#pragma once
/// Distances from points to a triangle mesh: the one metric the tools and benches report for a simplified
/// mesh (RMS and max distance from the original vertices to the simplified surface, the measure of issue 3
/// and of the peers' papers).
///
/// TriangleBvh holds a triangle soup in a median-split bounding-volume hierarchy (leaves of at most four
/// triangles) and answers nearest-distance queries by a best-first walk that skips boxes farther than the
/// best triangle so far: O(log n) per query on ordinary meshes, never worse than a scan. Corners are read
/// as float and measured in double.
#include <cstddef>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/tri_mesh.hpp"

namespace varmesh {

/// Squared distance from p to the closed triangle abc. A degenerate or nearly degenerate triangle (the sine
/// of its angle at a below 1e-5: collinear or repeated corners, slivers) is measured as the union of its
/// edges, which lie within its width of every point of it (the closest-point regions are unreliable there).
/// Non-finite input gives an unspecified result.
double point_triangle_distance_sq(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                  const glm::dvec3& c) noexcept;

class TriangleBvh {
 public:
  /// The triangles (indices[3t], indices[3t+1], indices[3t+2]) of `positions`. Throws InvalidInput when an
  /// index is out of range or a corner is not finite.
  TriangleBvh(std::span<const glm::vec3> positions, std::span<const Index> indices);
  explicit TriangleBvh(const TriMesh& mesh) : TriangleBvh(mesh.positions, mesh.indices) {}
  /// Squared distance from p to the nearest triangle; +infinity when there is none. p must be finite.
  double nearest_sq(const glm::dvec3& p) const noexcept;
  std::size_t num_triangles() const noexcept { return tri_.size() / 3; }

 private:
  struct Node {
    glm::vec3 lo, hi;
    Index first = 0, count = 0;  // leaf: triangles [first, first + count); inner: count == 0
    Index left = 0, right = 0;   // inner: children
  };
  Index build(std::vector<Index>& order, std::size_t begin, std::size_t end, const std::vector<glm::vec3>& centroid,
              std::span<const glm::vec3> positions, std::span<const Index> indices);
  std::vector<Node> nodes_;
  std::vector<glm::dvec3> tri_;  // corners in leaf order
};

/// Distance from the vertices of one mesh to the surface of another.
struct SurfaceDistance {
  double rms = 0.0, max = 0.0;  ///< object units
  double diagonal = 0.0;        ///< bounding-box diagonal of the measured vertices (for relative figures)
  std::size_t points = 0;       ///< vertices measured
};

/// Every vertex that a face of `from` uses, measured to the nearest triangle of `to`. A `to` without faces
/// gives infinite distances. Throws InvalidInput naming the vertex when an index is out of range or a
/// measured vertex or a corner of `to` is not finite. O(V log F).
SurfaceDistance vertex_to_surface_distance(const TriMesh& from, const TriMesh& to);

}  // namespace varmesh
