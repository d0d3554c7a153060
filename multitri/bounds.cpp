#include "multitri/bounds.hpp"

#include <algorithm>
#include <cmath>

namespace varmesh {

Sphere enclose(const Sphere& a, const Sphere& b) noexcept {
  const glm::vec3 d = b.center - a.center;
  const float dist = glm::length(d);
  // A contained sphere still inflates the result by a relative 1e-6: nested spheres must stay nested
  // after float rounding of the distances computed from them (monotone criteria depend on it).
  if (dist + b.radius <= a.radius) return {a.center, a.radius * (1.0f + 1e-6f) + 1e-12f};
  if (dist + a.radius <= b.radius) return {b.center, b.radius * (1.0f + 1e-6f) + 1e-12f};
  const float r = 0.5f * (dist + a.radius + b.radius);
  // Centre moves from a towards b so that both spheres touch the new one from inside; a tiny relative
  // slack keeps containment true after float rounding.
  const glm::vec3 c = a.center + d * ((r - a.radius) / dist);
  return {c, r * (1.0f + 1e-6f) + 1e-12f};
}

Sphere bounding_sphere(const glm::vec3* points, std::size_t count) noexcept {
  if (count == 0) return {};
  Box3 box;
  for (std::size_t i = 0; i < count; ++i) box.add(points[i]);
  const glm::vec3 c = box.center();
  float r2 = 0.0f;
  for (std::size_t i = 0; i < count; ++i) {
    const glm::vec3 d = points[i] - c;
    r2 = std::max(r2, glm::dot(d, d));
  }
  return {c, std::sqrt(r2) * (1.0f + 1e-6f)};
}

NormalCone enclose(const NormalCone& a, const NormalCone& b) noexcept {
  if (a.is_full() || b.is_full()) return {};
  const float ang_a = std::acos(std::clamp(a.cos_half_angle, -1.0f, 1.0f));
  const float ang_b = std::acos(std::clamp(b.cos_half_angle, -1.0f, 1.0f));
  const float between = std::acos(std::clamp(glm::dot(a.axis, b.axis), -1.0f, 1.0f));
  if (between + ang_b <= ang_a) return a;
  if (between + ang_a <= ang_b) return b;
  const float half = 0.5f * (between + ang_a + ang_b);
  if (half >= 3.14159f * 0.5f) return {};  // cones wider than a hemisphere are useless for culling
  // Rotate a.axis towards b.axis by (half - ang_a) in the plane they span.
  const float t = half - ang_a;
  glm::vec3 perp = b.axis - a.axis * glm::dot(a.axis, b.axis);
  const float len = glm::length(perp);
  if (len < 1e-12f) return {a.axis, std::cos(half)};
  perp /= len;
  const glm::vec3 axis = glm::normalize(a.axis * std::cos(t) + perp * std::sin(t));
  return {axis, std::cos(half) - 1e-6f};
}

}  // namespace varmesh
