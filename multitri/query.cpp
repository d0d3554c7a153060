#include "multitri/query.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kPi = 3.14159265f;

// Angle between the cone axis and the direction from the eye to the sphere, widened by the cone's and the
// sphere's angular radii: the region is entirely back-facing when
// theta + alpha + beta < 90 degrees, theta = angle(axis, c - eye) (every normal points away from every
// viewing ray), with alpha the cone half-angle and beta = asin(r / |c - eye|) (Shirman and Abi-Ezzi 1993;
// Hoppe 1997). Without trigonometry (this runs for every candidate of every frame): with
// gamma = 90 - (alpha + beta), the test is alpha + beta < 90 (cos(alpha + beta) > 0) and
// theta < gamma, i.e. cos(theta) > cos(gamma) = sin(alpha + beta) = sin(alpha) cos(beta) + cos(alpha) sin(beta).
//
// With `margin`, also how far the eye may move before the answer can change (QueryCoherence). The answer
// flips only when theta + alpha + beta crosses 90 degrees; cos is 1-Lipschitz, so that sum is at least
// |cos(theta) - sin(alpha + beta)| away from it (and at least |cos(alpha + beta)| when alpha + beta >= 90,
// which must first drop below 90). Moving the eye by delta <= h = (dist - r) / 2 turns c - eye by at most
// asin(delta / dist) (the half-angle under which c sees the ball of radius delta around the eye), and
// asin(x) <= (pi / 2) x on [0, 1] (asin is convex there, asin(1) = pi / 2). It changes beta by at most
// delta times the largest |d beta / d dist| = r / (D sqrt(D^2 - r^2)) on [dist - h, dist + h], at
// D = (dist + r) / 2; since D^2 - r^2 = (dist - r)(dist + 3r) / 4 >= h^2, r / (D h) bounds it without a second
// square root. Both |cos(theta) - sin(alpha + beta)| and cos(alpha + beta) have partial derivatives of at most
// 1 in theta and beta, so they too move by at most that rate times delta: at the moved eye the decision is
// still as far from its boundary as the slack below.
//
// The slack covers rounding, in units of cos(theta) - sin(alpha + beta), both in the margin's own cos_theta,
// sin_sum and cos_sum and in entirely_facing()'s squared form at the moved eye. cos_half_angle^2 rounds by up
// to 2^-25 near 1, which moves sin(alpha) and the squared form's verdict by up to about 8e-7 each (worst
// near alpha = 1 degree); the other terms are a few float epsilons, except with the eye just outside the
// sphere, where cos(beta) = sqrt(1 - (r / dist)^2), cos^2(alpha) dist^2 > r^2 and dist^2 - r^2 lose a few
// epsilons divided by cos(beta) (measured: float decisions wrong up to 5e-8 / cos(beta) from the boundary).
// Hence 1e-5 / cos(beta). A fixed 1e-5 is not enough there: d = c - eye jumps to a neighbouring float under
// eye moves far smaller than any margin, and answers flipped (test FacingMarginsHoldForWorstCaseMoves).
//
// The same decision without any square root (for is_fine, which runs for every candidate of every frame).
// alpha + beta < 90 is cos(alpha) > sin(beta), i.e. cos^2(alpha) dist^2 > r^2; and
// multiplying cos(theta) > sin(alpha) cos(beta) + cos(alpha) sin(beta) by dist gives
// along - cos(alpha) r > sin(alpha) sqrt(dist^2 - r^2) >= 0, which squares to
// (along - cos(alpha) r)^2 > (1 - cos^2(alpha)) (dist^2 - r^2) when its left side is positive.
// A cone axis that does not point away from the eye (along <= 0) is never entirely facing.
inline bool entirely_facing(const ElementBound& b, const glm::vec3& eye, float sign) {
  const float ca = std::min(b.cone.cos_half_angle, 1.0f);  // this order keeps a NaN (never facing)
  if (b.cone.is_full() || !(ca > 0.0f)) return false;
  const glm::vec3 d = b.center - eye;
  const float along = sign * glm::dot(b.cone.axis, d);
  if (!(along > 0.0f)) return false;
  const float r2 = b.radius * b.radius;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > r2) || !(ca * ca * dist2 > r2)) return false;
  const float lhs = along - ca * b.radius;
  return lhs > 0.0f && lhs * lhs > (1.0f - ca * ca) * (dist2 - r2);
}

// The decision of entirely_facing() (which is_fine() uses) and how far the eye may move before it can
// change. The margin is measured in the angle form above; where rounding makes that form disagree with the
// square-root-free decision, the element sits on the boundary and gets no margin.
bool facing(const ElementBound& b, const glm::vec3& eye, float sign, float& margin) {
  const bool result = entirely_facing(b, eye, sign);
  const float ca = b.cone.cos_half_angle;
  if (b.cone.is_full() || !(ca > 0.0f)) {  // never facing, wherever the eye is
    margin = kInf;
    return result;
  }
  const glm::vec3 d = b.center - eye;
  const float along = sign * glm::dot(b.cone.axis, d);
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > b.radius * b.radius)) {
    margin = 0.0f;
    return result;
  }
  const float dist = std::sqrt(dist2);
  const float sb = std::min(1.0f, b.radius / dist);
  const float cb = std::sqrt(std::max(0.0f, 1.0f - sb * sb));
  const float cac = std::min(1.0f, ca);
  const float sa = std::sqrt(std::max(0.0f, 1.0f - cac * cac));
  const float cos_sum = cac * cb - sa * sb;  // cos(alpha + beta)
  const float cos_theta = along / dist;
  const float sin_sum = sa * cb + cac * sb;  // sin(alpha + beta)
  const bool angle_form = cos_sum > 0.0f && cos_theta > sin_sum;
  const float angle = (cos_sum > 0.0f ? std::fabs(cos_theta - sin_sum) : -cos_sum) - 1e-5f / cb;  // cb = 0: -inf
  const float h = 0.5f * (dist - b.radius), dd = 0.5f * (dist + b.radius);
  const float rate = 0.5f * kPi / dist + b.radius / std::max(1e-30f, dd * h);
  margin = angle > 0.0f && angle_form == result ? std::min(h, angle / rate) : 0.0f;
  return result;
}

// Screen-space error test: the error seen from `eye` at the sphere's nearest point is at most the pixel
// threshold; ratio = (pixels per unit at distance one) / threshold. A zero error is fine from everywhere;
// otherwise the sphere must be at least error * ratio away, |c - eye| - r >= error * ratio, compared squared.
inline bool screen_fine(const ElementBound& b, const glm::vec3& eye, float ratio) {
  if (b.error <= 0.0f) return true;
  const glm::vec3 d = b.center - eye;
  const float need = b.radius + b.error * ratio;
  return glm::dot(d, d) >= need * need;
}

// Rounding slack for margins computed from lengths of about `scale`.
float rounding(float scale) { return 1e-5f * scale + 1e-30f; }

void check_point(const glm::vec3& p, const char* what, std::uint64_t element = InvalidInput::kNoElement) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    throw InvalidInput(std::string(what) + " is not finite", element);
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
  camera.validate();
  if (!(max_pixels > 0.0f)) throw InvalidInput("screen_error: the pixel threshold must be > 0");
  if (!(viewport_height > 0.0f) || !std::isfinite(viewport_height))
    throw InvalidInput("screen_error: the viewport height must be > 0 and finite");
  Criterion c;
  c.kind_ = Kind::kScreenError;
  c.value_ = max_pixels;
  c.scale_ = camera.pixels_per_unit_at_distance_one(viewport_height);
  c.ratio_ = c.scale_ / c.value_;
  c.point_ = camera.eye;
  return c;
}

Criterion Criterion::outside_frustum(const Frustum& frustum) {
  frustum.validate();
  Criterion c;
  c.kind_ = Kind::kOutsideFrustum;
  c.frustum_ = frustum;
  return c;
}

Criterion Criterion::back_facing(const glm::vec3& eye) {
  check_point(eye, "back_facing: the eye");
  Criterion c;
  c.kind_ = Kind::kBackFacing;
  c.point_ = eye;
  return c;
}

Criterion Criterion::away_from_silhouette(const glm::vec3& eye) {
  check_point(eye, "away_from_silhouette: the eye");
  Criterion c;
  c.kind_ = Kind::kAwayFromSilhouette;
  c.point_ = eye;
  return c;
}

Criterion Criterion::away_from_points(std::vector<glm::vec3> points, float radius) {
  if (!(radius >= 0.0f) || !std::isfinite(radius))
    throw InvalidInput("away_from_points: the radius must be >= 0 and finite");
  for (std::size_t i = 0; i < points.size(); ++i) check_point(points[i], "away_from_points: a point", i);
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

namespace {
// Evaluation cost rank of a part inside all_of / any_of: cheap and often deciding first.
int cost_rank(Criterion::Kind k) {
  switch (k) {
    case Criterion::Kind::kObjectError: return 0;
    case Criterion::Kind::kOutsideFrustum: return 1;
    case Criterion::Kind::kScreenError: return 2;
    case Criterion::Kind::kAwayFromPoints: return 3;
    case Criterion::Kind::kBackFacing: return 4;
    case Criterion::Kind::kAwayFromSilhouette: return 5;
    case Criterion::Kind::kAllOf:
    case Criterion::Kind::kAnyOf: return 6;
    case Criterion::Kind::kCustom: return 7;
  }
  return 7;
}
}  // namespace

Criterion Criterion::combine(Kind kind, std::vector<Criterion> parts) {
  // The answer does not depend on the parts' order, so evaluate the cheap ones first. The sort is stable
  // and depends only on the kinds, so the same criterion for a moved camera lines up part by part
  // (motion_to).
  std::stable_sort(parts.begin(), parts.end(),
                   [](const Criterion& a, const Criterion& b) { return cost_rank(a.kind_) < cost_rank(b.kind_); });
  Criterion c;
  c.kind_ = kind;
  c.parts_ = std::move(parts);
  return c;
}

Criterion Criterion::all_of(std::vector<Criterion> parts) {
  if (parts.empty()) throw InvalidInput("all_of: no parts");
  return combine(Kind::kAllOf, std::move(parts));
}

Criterion Criterion::any_of(std::vector<Criterion> parts) {
  if (parts.empty()) throw InvalidInput("any_of: no parts");
  return combine(Kind::kAnyOf, std::move(parts));
}

inline bool Criterion::leaf_is_fine(const ElementBound& b) const {
  switch (kind_) {
    case Kind::kObjectError:
      return b.error <= value_;
    case Kind::kScreenError:
      return screen_fine(b, point_, ratio_);
    case Kind::kOutsideFrustum:
      return !frustum_.intersects_sphere(b.center, b.radius);
    case Kind::kBackFacing:
      return entirely_facing(b, point_, 1.0f);
    case Kind::kAwayFromSilhouette:
      return entirely_facing(b, point_, 1.0f) || entirely_facing(b, point_, -1.0f);
    case Kind::kAwayFromPoints: {
      const float rr = b.radius + value_;
      for (const auto& p : points_) {
        const glm::vec3 d = b.center - p;
        if (glm::dot(d, d) <= rr * rr) return false;
      }
      return true;
    }
    case Kind::kCustom:
      return custom_(b);
    case Kind::kAllOf:
    case Kind::kAnyOf:
      break;  // not leaves
  }
  return is_fine(b);
}

inline bool Criterion::part_is_fine(const ElementBound& b) const {
  return kind_ == Kind::kAllOf || kind_ == Kind::kAnyOf ? is_fine(b) : leaf_is_fine(b);
}

bool Criterion::is_fine(const ElementBound& b) const {
  if (kind_ == Kind::kAllOf) {
    for (const auto& p : parts_)
      if (!p.part_is_fine(b)) return false;
    return true;
  }
  if (kind_ == Kind::kAnyOf) {
    for (const auto& p : parts_)
      if (p.part_is_fine(b)) return true;
    return false;
  }
  return leaf_is_fine(b);
}

inline bool Criterion::leaf_is_fine_with_margin(const ElementBound& b, float& margin) const {
  // Each leaf decides exactly as is_fine() does and measures its margin from the same quantities.
  switch (kind_) {
    case Kind::kObjectError:
    case Kind::kAwayFromPoints:
      margin = kInf;  // motion_to() refuses a change of threshold or points
      return leaf_is_fine(b);
    case Kind::kScreenError: {
      if (b.error <= 0.0f) {
        margin = kInf;  // fine from everywhere
        return true;
      }
      const bool fine = screen_fine(b, point_, ratio_);
      const float dist = glm::length(b.center - point_) - b.radius;
      // Fine iff dist >= t (t > 0), dist being 1-Lipschitz in the eye.
      const float t = b.error * ratio_;
      const float m = std::fabs(dist - t) - rounding(dist + 2.0f * b.radius + t);
      margin = ((dist >= t) == fine && m > 0.0f) ? m : 0.0f;
      return fine;
    }
    case Kind::kOutsideFrustum: {
      // Outside iff some plane has signed distance < -r (Frustum::intersects_sphere): it stays outside while
      // that plane moves less than its gap; inside (or straddling) while every plane moves less than its gap.
      // The rounding slack scales with |c|; |x| + |y| + |z| >= |c| bounds it without a square root.
      float scale = std::fabs(b.center.x) + std::fabs(b.center.y) + std::fabs(b.center.z) + b.radius;
      float inside = kInf, outside = -1.0f;
      for (const Plane& p : frustum_.planes) {
        const float sd = p.signed_distance(b.center);
        scale = std::max(scale, std::fabs(p.d));
        if (sd < -b.radius) outside = std::max(outside, -(sd + b.radius));
        else inside = std::min(inside, sd + b.radius);
      }
      const bool fine = outside >= 0.0f;
      const float m = (fine ? outside : inside) - rounding(scale);
      margin = m > 0.0f ? m : 0.0f;
      return fine;
    }
    case Kind::kBackFacing:
      return facing(b, point_, 1.0f, margin);
    case Kind::kAwayFromSilhouette: {
      float mb = 0.0f, mf = 0.0f;
      const bool back = facing(b, point_, 1.0f, mb), front = facing(b, point_, -1.0f, mf);
      const bool fine = back || front;
      margin = fine ? std::max(back ? mb : 0.0f, front ? mf : 0.0f) : std::min(mb, mf);
      return fine;
    }
    case Kind::kCustom:
      margin = 0.0f;
      return custom_(b);
    case Kind::kAllOf:
    case Kind::kAnyOf:
      break;  // not leaves
  }
  return is_fine_with_margin(b, margin);
}

inline bool Criterion::part_is_fine_with_margin(const ElementBound& b, float& margin) const {
  return kind_ == Kind::kAllOf || kind_ == Kind::kAnyOf ? is_fine_with_margin(b, margin)
                                                        : leaf_is_fine_with_margin(b, margin);
}

bool Criterion::is_fine_with_margin(const ElementBound& b, float& margin) const {
  if (kind_ != Kind::kAllOf && kind_ != Kind::kAnyOf) return leaf_is_fine_with_margin(b, margin);
  // The answer holds while a part that decides it keeps its answer: for a fine any_of (a not-fine all_of)
  // the first deciding part suffices (stopping there, like is_fine(), gives a smaller but still
  // conservative margin than the best deciding part); otherwise every part counts.
  const bool any = kind_ == Kind::kAnyOf;
  float keep_all = kInf;
  for (const auto& p : parts_) {
    float m = 0.0f;
    if (p.part_is_fine_with_margin(b, m) == any) {
      margin = m;
      return any;
    }
    keep_all = std::min(keep_all, m);
  }
  margin = keep_all;
  return !any;
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
