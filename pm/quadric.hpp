#pragma once
/// Quadric error metrics for edge-collapse simplification: Garland-Heckbert 1997 ("Surface simplification
/// using quadric error metrics", GH97) for positions, and the generalized quadric of
/// Garland-Heckbert 1998 ("Simplifying surfaces with color and texture using quadric error metrics",
/// GH98) for a position plus an RGB colour. Kim-Lee 2001 orders its edge collapses with these.
///
/// A quadric is plain data in double precision: Q(p) = p^T A p + 2 b.p + c with A symmetric positive
/// semidefinite. Quadrics add (the quadric of a vertex is the sum over its faces, the quadric of a collapse
/// the sum of its two ends' quadrics) and scale. Invariant: every quadric built by these functions and
/// their sums/positive scalings is PSD, so evaluate() is >= 0 (it clamps the rounding noise to 0).
/// Precision: Q(p) is a sum of terms of size ~ trace(A) |p|^2 that cancel near the minimum, so its absolute
/// rounding error is ~1e-16 trace(A) |p|^2. Build quadrics in coordinates centred on the model (or
/// normalised to a unit box) when errors much smaller than the model size matter.
///
/// Minimisation. optimal() solves A x = -b when A is well conditioned: its smallest eigenvalue is at least
/// kMinEigenRatio times its largest. Otherwise the minimiser is undetermined (flat region, straight crease)
/// or dominated by rounding, and optimal() falls back to the best of caller-given candidates (typically the
/// edge's two ends and midpoint) or optimal_on_segment() to the best point of a segment (GH97's own fallback
/// order: best point of the segment, else ends and midpoint).
#include <array>
#include <span>

#include <glm/vec3.hpp>

namespace varmesh {

/// Inverse condition number (smallest / largest eigenvalue of A) below which a quadric's linear system is
/// treated as singular. At 1e-6 a relative perturbation e of the quadric moves the solution by up to 1e6 e
/// times the model size: beyond that the "optimum" is rounding noise sliding along a flat direction.
inline constexpr double kMinEigenRatio = 1e-6;

/// Default penalty of border-edge constraint quadrics (GH97 "preserving boundaries"; QSlim's default
/// boundary weight): the constraint plane counts 1000 times as much as a face of area |edge|^2.
inline constexpr double kDefaultBorderPenalty = 1000.0;

/// A minimiser and its error. `solved` is true when `point` came from the linear solve, false when the
/// system was ill conditioned and `point` is a fallback (a candidate or a point of the segment).
struct QuadricOptimum {
  glm::dvec3 point{0.0};
  double error = 0.0;
  bool solved = false;
};

/// Garland-Heckbert 1997 quadric: Q(p) = p^T A p + 2 b.p + c, A symmetric stored as its upper triangle.
/// The zero quadric (default) evaluates to 0 everywhere.
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;  ///< A, upper triangle
  double b0 = 0, b1 = 0, b2 = 0;                                ///< b
  double c = 0;

  /// weight * (squared distance to the plane n.p + d = 0). `n` need not be unit length (n and d are both
  /// divided by |n|). Throws InvalidInput if |n| is 0 or not finite, or weight is negative or not finite.
  static Quadric from_plane(const glm::dvec3& n, double d, double weight = 1.0);
  /// The plane of triangle (p0, p1, p2) weighted by its area (Garland's 1999 thesis and QSlim), so a
  /// vertex quadric summed over its faces does not depend on the tessellation. A degenerate (zero-area)
  /// triangle gives the zero quadric. O(1), no throw.
  static Quadric from_triangle(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2);
  /// Border constraint for edge (p0, p1) of triangle (p0, p1, p_opposite) (GH97 "preserving boundaries"): the plane
  /// through the edge perpendicular to the triangle, weighted by penalty * |p1 - p0|^2 so that it scales
  /// like the area-weighted face quadrics (as QSlim does). Add it to both ends' quadrics to keep collapses
  /// from pulling the border inwards. A degenerate edge or triangle gives the zero quadric. Throws
  /// InvalidInput if penalty is negative or not finite.
  static Quadric from_border_edge(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p_opposite,
                                  double penalty = kDefaultBorderPenalty);

  Quadric& operator+=(const Quadric& q) noexcept {  // inline: the analysis sums quadrics per candidate edge
    a00 += q.a00, a01 += q.a01, a02 += q.a02, a11 += q.a11, a12 += q.a12, a22 += q.a22;
    b0 += q.b0, b1 += q.b1, b2 += q.b2;
    c += q.c;
    return *this;
  }
  friend Quadric operator+(Quadric p, const Quadric& q) noexcept { return p += q; }
  /// s * this; s >= 0 keeps the quadric PSD.
  Quadric scaled(double s) const noexcept;

  /// Q(p), clamped to >= 0. O(1).
  double evaluate(const glm::dvec3& p) const noexcept;
  /// Minimiser of Q: the solution of A x = -b when A is well conditioned (kMinEigenRatio), else the first
  /// candidate of least error. Throws InvalidInput if `candidates` is empty. O(1 + candidates).
  QuadricOptimum optimal(std::span<const glm::dvec3> candidates) const;
  /// As optimal(), but the fallback is the point of least error on the segment [p0, p1] (exact: Q restricted
  /// to the segment is a 1D quadratic). No throw.
  QuadricOptimum optimal_on_segment(const glm::dvec3& p0, const glm::dvec3& p1) const noexcept;
};

/// A vertex of the attributed surface: position and RGB colour. Colour channels should be scaled to the
/// size of the model (GH98 discusses this scaling): the metric adds squared distances and squared colour differences.
struct AttributePoint {
  glm::dvec3 position{0.0};
  glm::dvec3 color{0.0};
};

/// As QuadricOptimum, for an AttributeQuadric.
struct AttributeOptimum {
  AttributePoint point;
  double error = 0.0;
  bool solved = false;
};

/// Garland-Heckbert 1998 generalized quadric in R^6 = (x, y, z, r, g, b): the area-weighted squared
/// distance from a point of R^6 to the affine plane of a triangle with per-vertex colours.
/// The number of attributes is fixed to 3 (RGB) to keep the type plain and small (28 doubles); other
/// attribute sets would be a new type. A single triangle's A has rank 4; the sum over a vertex's faces is
/// generally full rank.
struct AttributeQuadric {
  static constexpr int kDim = 6;
  std::array<double, kDim*(kDim + 1) / 2> a{};  ///< A, upper triangle, row by row
  std::array<double, kDim> b{};
  double c = 0;

  /// Weighted by the triangle's area in R^3; a triangle of zero area in R^3 gives the zero quadric. No throw.
  static AttributeQuadric from_triangle(const AttributePoint& p0, const AttributePoint& p1,
                                        const AttributePoint& p2);

  AttributeQuadric& operator+=(const AttributeQuadric& q) noexcept;
  friend AttributeQuadric operator+(AttributeQuadric p, const AttributeQuadric& q) noexcept { return p += q; }
  AttributeQuadric scaled(double s) const noexcept;

  /// A(i, j) for 0 <= i, j < 6.
  double entry(int i, int j) const noexcept;
  /// Q(p), clamped to >= 0.
  double evaluate(const AttributePoint& p) const noexcept;
  /// Same rule as Quadric::optimal (6x6 system, kMinEigenRatio). Throws InvalidInput if `candidates` is empty.
  AttributeOptimum optimal(std::span<const AttributePoint> candidates) const;
  /// Same rule as Quadric::optimal_on_segment. No throw.
  AttributeOptimum optimal_on_segment(const AttributePoint& p0, const AttributePoint& p1) const noexcept;
};

}  // namespace varmesh
