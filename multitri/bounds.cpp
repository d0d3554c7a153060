#include "multitri/bounds.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

namespace {
bool finite3(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

void FocusSet::validate() const {
  auto fail = [](const char* shape, std::size_t i, const char* why) {
    throw InvalidInput(std::string("focus set: ") + shape + " " + std::to_string(i) + " " + why, i);
  };
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (!finite3(boxes[i].lo) || !finite3(boxes[i].hi)) fail("box", i, "has a corner that is not finite");
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    if (!finite3(spheres[i].center)) fail("sphere", i, "has a centre that is not finite");
    if (!std::isfinite(spheres[i].radius) || !(spheres[i].radius >= 0.0f))
      fail("sphere", i, "has a radius that is negative or not finite");
  }
  for (std::size_t i = 0; i < frusta.size(); ++i) {
    try {
      frusta[i].validate();
    } catch (const InvalidInput& e) {
      throw InvalidInput("focus set: frustum " + std::to_string(i) + ": " + e.what(), i);
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!finite3(points[i])) fail("point", i, "is not finite");
  if (!std::isfinite(point_radius) || !(point_radius >= 0.0f))
    throw InvalidInput("focus set: point_radius " + std::to_string(point_radius) + " is negative or not finite");
}

// Distances in double, results in float: |d|^2 of float vectors overflows past coordinates of ~1.8e19 (and
// would make every sphere of a model that large infinite).
Sphere enclose(const Sphere& a, const Sphere& b) noexcept {
  const glm::dvec3 d = glm::dvec3(b.center) - glm::dvec3(a.center);
  const double dist = glm::length(d);
  // A contained sphere still inflates the result by a relative 1e-6: nested spheres must stay nested
  // after float rounding of the distances computed from them (monotone criteria depend on it).
  if (dist + b.radius <= a.radius) return {a.center, a.radius * (1.0f + 1e-6f) + 1e-12f};
  if (dist + a.radius <= b.radius) return {b.center, b.radius * (1.0f + 1e-6f) + 1e-12f};
  const double r = 0.5 * (dist + a.radius + b.radius);
  // Centre moves from a towards b so that both spheres touch the new one from inside; a tiny relative
  // slack keeps containment true after float rounding.
  const glm::vec3 c(glm::dvec3(a.center) + d * ((r - a.radius) / dist));
  return {c, static_cast<float>(r) * (1.0f + 1e-6f) + 1e-12f};
}

Sphere bounding_sphere(const glm::vec3* points, std::size_t count) noexcept {
  if (count == 0) return {};
  Box3 box;
  for (std::size_t i = 0; i < count; ++i) box.add(points[i]);
  const glm::vec3 c = box.center();
  double r2 = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const glm::dvec3 d = glm::dvec3(points[i]) - glm::dvec3(c);
    r2 = std::max(r2, glm::dot(d, d));
  }
  return {c, static_cast<float>(std::sqrt(r2)) * (1.0f + 1e-6f)};
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
