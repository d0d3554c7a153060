#include "multitri/query.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kHalfPi = 1.57079632679f;

// Margin of a back-facing decision (sign +1) or front-facing one (sign -1), in eye displacement. With
// slack = 90 deg - (theta + alpha + beta) in radians, the region is entirely facing iff dist > r and slack
// > 0. Moving the eye by delta <= h = (dist - r) / 2 turns c - eye by at most asin(delta / dist) <=
// (pi / 2) delta / dist and changes beta = asin(r / dist) by at most delta times its derivative's largest
// magnitude on [dist - h, dist + h], r / (D sqrt(D^2 - r^2)) at D = (dist + r) / 2. So the decision holds
// while delta < min(h, |slack| / (pi / (2 dist) + r / (D sqrt(D^2 - r^2)))); 1e-4 rad absorbs rounding.
float facing_margin(const ElementBound& b, const glm::vec3& eye, float sign, bool facing) {
  const float ca = b.cone.cos_half_angle;
  if (b.cone.is_full() || !(ca > 0.0f)) return kInf;  // never facing, wherever the eye is
  const glm::vec3 d = b.center - eye;
  const float dist = glm::length(d);
  if (dist <= b.radius * 1.0001f + 1e-6f) return 0.0f;
  const float alpha = std::acos(std::min(1.0f, ca));
  const float beta = std::asin(std::min(1.0f, b.radius / dist));
  const float theta = std::acos(std::clamp(sign * glm::dot(b.cone.axis, d) / dist, -1.0f, 1.0f));
  const float slack = kHalfPi - (theta + alpha + beta);
  if ((slack > 0.0f) != facing) return 0.0f;  // at the rounding edge: re-evaluate next time
  const float usable = std::fabs(slack) - 1e-4f;
  if (!(usable > 0.0f)) return 0.0f;
  const float h = 0.5f * (dist - b.radius), dd = 0.5f * (dist + b.radius);
  const float rate = 2.0f * kHalfPi / dist + b.radius / (dd * std::sqrt(std::max(1e-30f, dd * dd - b.radius * b.radius)));
  return std::min(h, usable / rate);
}

// Rounding slack for margins computed from lengths of about `scale`.
float rounding(float scale) { return 1e-5f * scale + 1e-30f; }

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

bool Criterion::is_fine_with_margin(const ElementBound& b, float& margin) const {
  const bool fine = is_fine(b);
  switch (kind_) {
    case Kind::kObjectError:
    case Kind::kAwayFromPoints:
      margin = kInf;  // motion_to() refuses a change of threshold or points
      break;
    case Kind::kScreenError: {
      if (b.error <= 0.0f) {
        margin = kInf;  // fine from everywhere
        break;
      }
      // Fine iff dist >= t (t > 0) with dist = |c - eye| - r, 1-Lipschitz in the eye.
      const float len = glm::length(b.center - point_);
      const float t = b.error * scale_ / value_;
      const float m = std::fabs((len - b.radius) - t) - rounding(len + b.radius + t);
      margin = ((len - b.radius >= t) == fine && m > 0.0f) ? m : 0.0f;
      break;
    }
    case Kind::kOutsideFrustum: {
      // Outside iff some plane has signed distance < -r: it stays outside while that plane moves less than
      // its gap; inside (or straddling) while every plane moves less than its gap.
      float scale = glm::length(b.center) + b.radius, inside = kInf, outside = 0.0f;
      for (const Plane& p : frustum_.planes) {
        const float g = p.signed_distance(b.center) + b.radius;
        scale = std::max(scale, std::fabs(p.d));
        if (g < 0.0f) outside = std::max(outside, -g);
        else inside = std::min(inside, g);
      }
      const float m = (fine ? outside : inside) - rounding(scale);
      margin = ((outside > 0.0f) == fine && m > 0.0f) ? m : 0.0f;
      break;
    }
    case Kind::kBackFacing:
      margin = facing_margin(b, point_, 1.0f, fine);
      break;
    case Kind::kAwayFromSilhouette: {
      const bool back = entirely_facing(b, point_, 1.0f), front = entirely_facing(b, point_, -1.0f);
      const float mb = facing_margin(b, point_, 1.0f, back), mf = facing_margin(b, point_, -1.0f, front);
      margin = fine ? std::max(back ? mb : 0.0f, front ? mf : 0.0f) : std::min(mb, mf);
      break;
    }
    case Kind::kCustom:
      margin = 0.0f;
      break;
    case Kind::kAllOf:
    case Kind::kAnyOf: {
      // The answer holds while every part that decides it keeps its answer: for a fine any_of (or a
      // not-fine all_of) one deciding part suffices (the largest margin), otherwise all parts count.
      const bool one_suffices = (kind_ == Kind::kAnyOf) == fine;
      margin = one_suffices ? 0.0f : kInf;
      for (const auto& p : parts_) {
        float m = 0.0f;
        const bool part_fine = p.is_fine_with_margin(b, m);
        if (one_suffices) {
          if (part_fine == fine) margin = std::max(margin, m);
        } else {
          margin = std::min(margin, m);
        }
      }
      break;
    }
  }
  return fine;
}

bool Criterion::motion_to(const Criterion& next, const glm::vec3& origin, double& turn, double& shift) const {
  if (kind_ != next.kind_ || value_ != next.value_ || scale_ != next.scale_ || parts_.size() != next.parts_.size())
    return false;
  auto eye_moved = [&] { shift = std::max(shift, static_cast<double>(glm::length(next.point_ - point_))); };
  switch (kind_) {
    case Kind::kObjectError:
    case Kind::kCustom:  // margin 0: always re-evaluated
      return true;
    case Kind::kScreenError:
    case Kind::kBackFacing:
    case Kind::kAwayFromSilhouette:
      eye_moved();
      return true;
    case Kind::kOutsideFrustum:
      // signed_distance'(c) - signed_distance(c) = (n' - n).(c - o) + ((n' - n).o + d' - d).
      for (std::size_t k = 0; k < frustum_.planes.size(); ++k) {
        const Plane &a = frustum_.planes[k], &z = next.frustum_.planes[k];
        const glm::vec3 dn = z.n - a.n;
        turn = std::max(turn, static_cast<double>(glm::length(dn)));
        shift = std::max(shift, std::fabs(static_cast<double>(glm::dot(dn, origin)) + double(z.d) - double(a.d)));
      }
      return true;
    case Kind::kAwayFromPoints:
      return points_ == next.points_;
    case Kind::kAllOf:
    case Kind::kAnyOf:
      for (std::size_t i = 0; i < parts_.size(); ++i)
        if (!parts_[i].motion_to(next.parts_[i], origin, turn, shift)) return false;
      return true;
  }
  return false;
}

bool QueryCoherence::begin(const Query& q) {
  if (q.triangle_budget != 0 || !q.focus.everywhere()) {
    invalidate();
    return false;
  }
  double turn = 0.0, shift = 0.0;
  if (valid_ && last_.motion_to(q.criterion, origin_, turn, shift) && std::isfinite(turn) && std::isfinite(shift)) {
    // Rounding of the accumulated sums: a relative 1e-12 is far below the margins' own slack.
    turn_ += turn * (1.0 + 1e-12);
    shift_ += shift * (1.0 + 1e-12);
  } else {
    next_generation();
  }
  last_ = q.criterion;
  valid_ = true;
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
