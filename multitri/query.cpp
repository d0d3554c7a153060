#include "multitri/query.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

// Angle between the cone axis and the direction from the eye to the sphere, widened by the cone's and the
// sphere's angular radii: the region is entirely back-facing when
// theta + alpha + beta < 90 degrees, theta = angle(axis, c - eye) (every normal points away from every
// viewing ray), with alpha the cone half-angle and beta = asin(r / |c - eye|) (Shirman and Abi-Ezzi 1993;
// Hoppe 1997). Without trigonometry (this runs for every candidate of every frame): with
// gamma = 90 - (alpha + beta), the test is alpha + beta < 90 (cos(alpha + beta) > 0) and
// theta < gamma, i.e. cos(theta) > cos(gamma) = sin(alpha + beta) = sin(alpha) cos(beta) + cos(alpha) sin(beta).
bool entirely_facing(const ElementBound& b, const glm::vec3& eye, float sign) {
  const float ca = b.cone.cos_half_angle;
  if (b.cone.is_full() || !(ca > 0.0f)) return false;  // alpha >= 90 degrees
  const glm::vec3 d = b.center - eye;
  const float dist = glm::length(d);
  if (dist <= b.radius) return false;
  const float sb = std::min(1.0f, b.radius / dist);
  const float cb = std::sqrt(std::max(0.0f, 1.0f - sb * sb));
  const float sa = std::sqrt(std::max(0.0f, 1.0f - std::min(1.0f, ca) * std::min(1.0f, ca)));
  if (!(ca * cb - sa * sb > 0.0f)) return false;  // alpha + beta >= 90 degrees
  return sign * glm::dot(b.cone.axis, d) / dist > sa * cb + std::min(1.0f, ca) * sb;
}

}  // namespace

Criterion Criterion::object_error(float max_error) {
  if (!(max_error >= 0.0f)) throw InvalidInput("object_error: the threshold must be >= 0");
  Criterion c;
  c.kind_ = Kind::kObjectError;
  c.value_ = max_error;
  return c;
}

Criterion Criterion::screen_error(const Camera& camera, float viewport_height, float max_pixels) {
  if (!(max_pixels > 0.0f)) throw InvalidInput("screen_error: the pixel threshold must be > 0");
  if (!(viewport_height > 0.0f)) throw InvalidInput("screen_error: the viewport height must be > 0");
  Criterion c;
  c.kind_ = Kind::kScreenError;
  c.value_ = max_pixels;
  c.scale_ = camera.pixels_per_unit_at_distance_one(viewport_height);
  c.point_ = camera.eye;
  return c;
}

Criterion Criterion::outside_frustum(const Frustum& frustum) {
  Criterion c;
  c.kind_ = Kind::kOutsideFrustum;
  c.frustum_ = frustum;
  return c;
}

Criterion Criterion::back_facing(const glm::vec3& eye) {
  Criterion c;
  c.kind_ = Kind::kBackFacing;
  c.point_ = eye;
  return c;
}

Criterion Criterion::away_from_silhouette(const glm::vec3& eye) {
  Criterion c;
  c.kind_ = Kind::kAwayFromSilhouette;
  c.point_ = eye;
  return c;
}

Criterion Criterion::away_from_points(std::vector<glm::vec3> points, float radius) {
  if (!(radius >= 0.0f)) throw InvalidInput("away_from_points: the radius must be >= 0");
  Criterion c;
  c.kind_ = Kind::kAwayFromPoints;
  c.points_ = std::move(points);
  c.value_ = radius;
  return c;
}

Criterion Criterion::custom(std::function<bool(const ElementBound&)> is_fine) {
  if (!is_fine) throw InvalidInput("custom: empty function");
  Criterion c;
  c.kind_ = Kind::kCustom;
  c.custom_ = std::move(is_fine);
  return c;
}

Criterion Criterion::all_of(std::vector<Criterion> parts) {
  if (parts.empty()) throw InvalidInput("all_of: no parts");
  Criterion c;
  c.kind_ = Kind::kAllOf;
  c.parts_ = std::move(parts);
  return c;
}

Criterion Criterion::any_of(std::vector<Criterion> parts) {
  if (parts.empty()) throw InvalidInput("any_of: no parts");
  Criterion c;
  c.kind_ = Kind::kAnyOf;
  c.parts_ = std::move(parts);
  return c;
}

bool Criterion::is_fine(const ElementBound& b) const {
  switch (kind_) {
    case Kind::kObjectError:
      return b.error <= value_;
    case Kind::kScreenError: {
      // Distance from the eye to the nearest point of the sphere; error * scale / distance <= pixels.
      const float dist = glm::length(b.center - point_) - b.radius;
      if (dist <= 0.0f) return b.error <= 0.0f;
      return b.error * scale_ <= value_ * dist;
    }
    case Kind::kOutsideFrustum:
      return !frustum_.intersects_sphere(b.center, b.radius);
    case Kind::kBackFacing:
      return entirely_facing(b, point_, 1.0f);
    case Kind::kAwayFromSilhouette:
      return entirely_facing(b, point_, 1.0f) || entirely_facing(b, point_, -1.0f);
    case Kind::kAwayFromPoints: {
      for (const auto& p : points_) {
        const glm::vec3 d = b.center - p;
        const float rr = b.radius + value_;
        if (glm::dot(d, d) <= rr * rr) return false;
      }
      return true;
    }
    case Kind::kCustom:
      return custom_(b);
    case Kind::kAllOf:
      for (const auto& p : parts_)
        if (!p.is_fine(b)) return false;
      return true;
    case Kind::kAnyOf:
      for (const auto& p : parts_)
        if (p.is_fine(b)) return true;
      return false;
  }
  return true;
}

bool Criterion::is_monotone() const {
  if (kind_ == Kind::kCustom) return false;
  for (const auto& p : parts_)
    if (!p.is_monotone()) return false;
  return true;
}

bool Criterion::has_screen_leaf() const {
  if (kind_ == Kind::kScreenError) return true;
  for (const auto& p : parts_)
    if (p.has_screen_leaf()) return true;
  return false;
}

float Criterion::priority(const ElementBound& b) const {
  if (kind_ == Kind::kScreenError) {
    const float dist = glm::length(b.center - point_) - b.radius;
    if (dist <= 0.0f) return b.error > 0.0f ? 3.0e38f : 0.0f;
    return b.error * scale_ / dist;
  }
  if (kind_ == Kind::kAllOf || kind_ == Kind::kAnyOf) {
    float best = -1.0f;
    for (const auto& p : parts_)
      if (p.has_screen_leaf()) best = std::max(best, p.priority(b));
    if (best >= 0.0f) return best;
  }
  return b.error;
}

}  // namespace varmesh
