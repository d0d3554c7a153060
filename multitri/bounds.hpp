#pragma once
/// Bounds of the elements of a variable-resolution structure (MT nodes, PM vertices) and focus sets.
///
/// The query API (query.hpp) sees an element only through its ElementBound: a bounding sphere of the
/// region the element changes, the approximation error left if the element is NOT refined (object units),
/// and a cone containing the normals of that region. Builders make bounds nested (a child's sphere lies in
/// its parent's, a child's error is at most its parent's): with nested bounds every ready-made criterion is
/// monotone, and update() returns exactly what extract() returns.
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "multitri/camera.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh {

/// Cone of normals: every normal n of the region satisfies dot(n, axis) >= cos_half_angle.
/// cos_half_angle <= -1 means "any direction" (no information).
struct NormalCone {
  glm::vec3 axis{0.0f, 0.0f, 1.0f};
  float cos_half_angle = -1.0f;
  bool is_full() const noexcept { return cos_half_angle <= -1.0f; }
};

struct ElementBound {
  glm::vec3 center{0.0f};
  float radius = 0.0f;  ///< bounding sphere radius, >= 0
  float error = 0.0f;   ///< approximation error if the element is not refined (object units), >= 0
  NormalCone cone;
};

struct Sphere {
  glm::vec3 center{0.0f};
  float radius = 0.0f;
};

/// Smallest sphere (approximately: Ritter-style growth) containing both spheres.
Sphere enclose(const Sphere& a, const Sphere& b) noexcept;
/// A sphere containing the points (centre of their box, radius to the farthest point).
Sphere bounding_sphere(const glm::vec3* points, std::size_t count) noexcept;
/// A cone containing both cones (full when they cannot be merged below 180 degrees).
NormalCone enclose(const NormalCone& a, const NormalCone& b) noexcept;

inline bool sphere_intersects_box(const glm::vec3& c, float r, const Box3& box) noexcept {
  const glm::vec3 q = glm::clamp(c, box.lo, box.hi);
  const glm::vec3 d = c - q;
  return glm::dot(d, d) <= r * r;
}

/// Where a query evaluates its adaptation function (DESIGN.md; Velho-Gomes 9.1). The union of the listed
/// shapes; an empty focus set means "everywhere".
struct FocusSet {
  std::vector<Box3> boxes;
  std::vector<Sphere> spheres;
  std::vector<Frustum> frusta;
  std::vector<glm::vec3> points;  ///< a point meets an element whose sphere contains it (+ point_radius)
  float point_radius = 0.0f;  ///< >= 0

  /// Throws InvalidInput naming the shape (its index in its list) when a box corner, a sphere, a point or a
  /// frustum plane is not finite (Frustum::validate), or a sphere's radius or point_radius is negative. A NaN
  /// shape would otherwise meet every element (or none) without a word. A box with lo > hi is allowed (it
  /// meets nothing). O(number of shapes); extract() and update() (query.hpp) call it through
  /// Query::validate().
  void validate() const;

  bool everywhere() const noexcept {
    return boxes.empty() && spheres.empty() && frusta.empty() && points.empty();
  }
  bool intersects(const glm::vec3& c, float r) const noexcept {
    if (everywhere()) return true;
    for (const auto& b : boxes)
      if (sphere_intersects_box(c, r, b)) return true;
    for (const auto& s : spheres) {
      const float rr = r + s.radius;
      const glm::vec3 d = c - s.center;
      if (glm::dot(d, d) <= rr * rr) return true;
    }
    for (const auto& f : frusta)
      if (f.intersects_sphere(c, r)) return true;
    for (const auto& p : points) {
      const float rr = r + point_radius;
      const glm::vec3 d = c - p;
      if (glm::dot(d, d) <= rr * rr) return true;
    }
    return false;
  }
};

}  // namespace varmesh
