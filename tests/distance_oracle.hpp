#pragma once
// Point-to-surface distances for tests, written plainly (projection onto the plane, else the nearest edge)
// and independently of the library's own distance code (multitri/bounds, the benches' BVH).
#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace varmesh::testing {

inline double point_segment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 ab = b - a;
  const double l2 = glm::dot(ab, ab);
  const double t = l2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / l2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

/// Distance from p to the triangle abc: to its plane when p projects inside, else to the nearest edge.
inline double point_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double nn = glm::dot(n, n);
  if (nn > 0.0) {
    const glm::dvec3 q = p - n * (glm::dot(p - a, n) / nn);
    const double s0 = glm::dot(glm::cross(b - a, q - a), n), s1 = glm::dot(glm::cross(c - b, q - b), n),
                 s2 = glm::dot(glm::cross(a - c, q - c), n);
    if (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) return std::abs(glm::dot(p - a, n)) / std::sqrt(nn);
  }
  return std::min({point_segment(p, a, b), point_segment(p, b, c), point_segment(p, c, a)});
}

}  // namespace varmesh::testing
