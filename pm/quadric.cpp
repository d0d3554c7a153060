// Quadric error metrics.
// Papers: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997
// (GH97); M. Garland, P. Heckbert, "Simplifying surfaces with color and texture using
// quadric error metrics", IEEE Visualization 1998 (GH98).
#include "pm/quadric.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Dense>
#include <glm/geometric.hpp>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

template <int N>
using Mat = Eigen::Matrix<double, N, N>;
template <int N>
using Vec = Eigen::Matrix<double, N, 1>;

// The dense form the solvers work on; both public types convert to it.
template <int N>
struct Dense {
  Mat<N> A;
  Vec<N> b;
  double c = 0;
  double eval(const Vec<N>& x) const { return std::max(0.0, x.dot(A * x) + 2.0 * b.dot(x) + c); }
};

template <int N>
struct Optimum {
  Vec<N> x;
  double error = 0;
  bool solved = false;
};

// A x = -b through the eigendecomposition of A: the eigenvalues give the conditioning test for free, and a
// PSD A can have no negative eigenvalue worth trusting, so the smallest one alone decides (GH97
// inverts A only when it is invertible; a relative threshold makes the test independent of model scale).
template <int N>
std::optional<Vec<N>> solve(const Dense<N>& q) {
  // 3x3: the closed-form (trigonometric) eigensolver, about 10x faster than the iterative one; its
  // precision (~1e-12 relative here) is far inside the kMinEigenRatio test.
  Eigen::SelfAdjointEigenSolver<Mat<N>> es;
  if constexpr (N == 3) es.computeDirect(q.A); else es.compute(q.A);
  if (es.info() != Eigen::Success) return std::nullopt;
  const Vec<N>& l = es.eigenvalues();  // ascending
  if (!(l(N - 1) > 0.0) || !(l(0) >= kMinEigenRatio * l(N - 1))) return std::nullopt;
  const Vec<N> x = -(es.eigenvectors() * (es.eigenvectors().transpose() * q.b).cwiseQuotient(l));
  if (!x.allFinite()) return std::nullopt;
  return x;
}

template <int N, class P, class ToVec>
Optimum<N> optimal_impl(const Dense<N>& q, std::span<const P> candidates, ToVec to_vec) {
  if (candidates.empty()) throw InvalidInput("quadric optimal(): no fallback candidates");
  if (auto x = solve(q)) return {*x, q.eval(*x), true};
  Optimum<N> best{to_vec(candidates[0]), 0.0, false};
  best.error = q.eval(best.x);
  for (std::size_t i = 1; i < candidates.size(); ++i) {
    const Vec<N> x = to_vec(candidates[i]);
    if (const double e = q.eval(x); e < best.error) best = {x, e, false};
  }
  return best;
}

// On x0 + t d, t in [0, 1], Q is Q(x0) + 2 t d.(A x0 + b) + t^2 d^T A d: clamp the 1D minimiser. The ends
// are compared too, which covers d^T A d = 0 (Q linear along the segment) and rounding.
template <int N>
Optimum<N> segment_impl(const Dense<N>& q, const Vec<N>& x0, const Vec<N>& x1) {
  if (auto x = solve(q)) return {*x, q.eval(*x), true};
  const Vec<N> d = x1 - x0;
  const double dad = d.dot(q.A * d), gd = d.dot(q.A * x0 + q.b);
  const double t = dad > 0.0 ? std::clamp(-gd / dad, 0.0, 1.0) : 0.0;
  Optimum<N> best{x0 + t * d, 0.0, false};
  best.error = q.eval(best.x);
  for (const Vec<N>* end : {&x0, &x1}) {
    if (const double e = q.eval(*end); e < best.error) best = {*end, e, false};
  }
  return best;
}

// 3x3 fast path of solve(): A x = -b by cofactors, with the conditioning test decided from the invariants
// of A where they are conclusive. For PSD A with eigenvalues l1 <= l2 <= l3, trace T, sum of principal 2x2
// minors M and determinant D: l2 l3 <= M <= 3 l2 l3 and T / 3 <= l3 <= T, so l1 / l3 = D / (l2 l3 l3) lies
// in [D / (M T), 9 D / (M T)]. Only a ratio inside that band near kMinEigenRatio needs the eigenvalues
// (rare); elsewhere the answer is the same as solve()'s at a fraction of the cost.
enum class Conditioning { kGood, kBad, kUnsure };
struct Solve3 {
  Conditioning c = Conditioning::kUnsure;
  glm::dvec3 x{0.0};
};
Solve3 solve3(const Quadric& q) {
  const double c00 = q.a11 * q.a22 - q.a12 * q.a12, c01 = q.a02 * q.a12 - q.a01 * q.a22,
               c02 = q.a01 * q.a12 - q.a02 * q.a11;
  const double c11 = q.a00 * q.a22 - q.a02 * q.a02, c12 = q.a01 * q.a02 - q.a00 * q.a12,
               c22 = q.a00 * q.a11 - q.a01 * q.a01;
  const double t = q.a00 + q.a11 + q.a22, m = c00 + c11 + c22;
  const double det = q.a00 * c00 + q.a01 * c01 + q.a02 * c02;
  if (!std::isfinite(t) || !std::isfinite(m) || !std::isfinite(det)) return {Conditioning::kUnsure, {}};
  if (!(t > 0.0)) return {Conditioning::kBad, {}};
  // l1 <= l2 <= 3 M / T, so a small M settles it even when D is pure rounding (rank <= 1, flat regions).
  if (9.0 * m < kMinEigenRatio * t * t) return {Conditioning::kBad, {}};
  // Here the rounding of D (~1e-15 T^3) is far below kMinEigenRatio M T / 9 (>= ~1e-14 T^3): D's sign is
  // meaningful, and a non-positive D is a rank-2 A (a straight crease, a cylinder).
  const double mt = m * t;
  if (!(det > 0.0) || 9.0 * det < kMinEigenRatio * mt) return {Conditioning::kBad, {}};
  if (det < kMinEigenRatio * mt) return {Conditioning::kUnsure, {}};
  // Adjugate (symmetric) times -b over det.
  const double inv = -1.0 / det;
  const glm::dvec3 x{inv * (c00 * q.b0 + c01 * q.b1 + c02 * q.b2), inv * (c01 * q.b0 + c11 * q.b1 + c12 * q.b2),
                     inv * (c02 * q.b0 + c12 * q.b1 + c22 * q.b2)};
  if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z)) return {Conditioning::kUnsure, {}};
  return {Conditioning::kGood, x};
}

Vec<3> to_eigen(const glm::dvec3& p) { return {p.x, p.y, p.z}; }
glm::dvec3 to_glm(const Vec<3>& x) { return {x(0), x(1), x(2)}; }

Dense<3> dense(const Quadric& q) {
  Dense<3> d;
  d.A << q.a00, q.a01, q.a02, q.a01, q.a11, q.a12, q.a02, q.a12, q.a22;
  d.b << q.b0, q.b1, q.b2;
  d.c = q.c;
  return d;
}
QuadricOptimum to_public(const Optimum<3>& o) { return {to_glm(o.x), o.error, o.solved}; }

constexpr int kN = AttributeQuadric::kDim;
constexpr int packed(int i, int j) {  // upper-triangle index, i <= j
  return i * kN - i * (i - 1) / 2 + (j - i);
}
Vec<kN> to_eigen(const AttributePoint& p) {
  Vec<kN> x;
  x << p.position.x, p.position.y, p.position.z, p.color.r, p.color.g, p.color.b;
  return x;
}
AttributePoint to_point(const Vec<kN>& x) { return {{x(0), x(1), x(2)}, {x(3), x(4), x(5)}}; }
Dense<kN> dense(const AttributeQuadric& q) {
  Dense<kN> d;
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j < kN; ++j) d.A(i, j) = q.entry(i, j);
    d.b(i) = q.b[static_cast<std::size_t>(i)];
  }
  d.c = q.c;
  return d;
}
AttributeOptimum to_public(const Optimum<kN>& o) { return {to_point(o.x), o.error, o.solved}; }

}  // namespace

Quadric Quadric::from_plane(const glm::dvec3& n, double d, double weight) {
  const double len = glm::length(n);
  if (!(len > 0.0) || !std::isfinite(len) || !std::isfinite(d))
    throw InvalidInput("Quadric::from_plane: plane normal is zero or not finite, or offset not finite");
  if (!(weight >= 0.0) || !std::isfinite(weight))
    throw InvalidInput("Quadric::from_plane: weight is negative or not finite");
  // GH97: K_p = p p^T for the plane p = (a, b, c, d), a^2 + b^2 + c^2 = 1.
  const glm::dvec3 u = n / len;
  const double e = d / len;
  Quadric q;
  q.a00 = weight * u.x * u.x, q.a01 = weight * u.x * u.y, q.a02 = weight * u.x * u.z;
  q.a11 = weight * u.y * u.y, q.a12 = weight * u.y * u.z, q.a22 = weight * u.z * u.z;
  q.b0 = weight * e * u.x, q.b1 = weight * e * u.y, q.b2 = weight * e * u.z;
  q.c = weight * e * e;
  return q;
}

Quadric Quadric::from_triangle(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2) {
  const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
  const double len = glm::length(n);
  if (!(len > 0.0) || !std::isfinite(len) || !std::isfinite(glm::dot(n, p0))) return {};
  return from_plane(n / len, -glm::dot(n, p0) / len, 0.5 * len);
}

Quadric Quadric::from_border_edge(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p_opposite,
                                  double penalty) {
  if (!(penalty >= 0.0) || !std::isfinite(penalty))
    throw InvalidInput("Quadric::from_border_edge: penalty is negative or not finite");
  const glm::dvec3 e = p1 - p0;
  const glm::dvec3 m = glm::cross(e, glm::cross(e, p_opposite - p0));  // in the face plane, normal to e
  const double len = glm::length(m);
  if (!(len > 0.0) || !std::isfinite(len) || !std::isfinite(glm::dot(m, p0))) return {};
  return from_plane(m / len, -glm::dot(m, p0) / len, penalty * glm::dot(e, e));
}

Quadric Quadric::scaled(double s) const noexcept {
  return {s * a00, s * a01, s * a02, s * a11, s * a12, s * a22, s * b0, s * b1, s * b2, s * c};
}

double Quadric::evaluate(const glm::dvec3& p) const noexcept {
  const double x = p.x, y = p.y, z = p.z;
  const double v = a00 * x * x + a11 * y * y + a22 * z * z + 2.0 * (a01 * x * y + a02 * x * z + a12 * y * z) +
                   2.0 * (b0 * x + b1 * y + b2 * z) + c;
  return std::max(0.0, v);
}

QuadricOptimum Quadric::optimal(std::span<const glm::dvec3> candidates) const {
  if (candidates.empty()) throw InvalidInput("quadric optimal(): no fallback candidates");
  const Solve3 s = solve3(*this);
  if (s.c == Conditioning::kGood) return {s.x, evaluate(s.x), true};
  if (s.c == Conditioning::kUnsure)
    return to_public(optimal_impl(dense(*this), candidates, [](const glm::dvec3& p) { return to_eigen(p); }));
  QuadricOptimum best{candidates[0], evaluate(candidates[0]), false};
  for (std::size_t i = 1; i < candidates.size(); ++i)
    if (const double e = evaluate(candidates[i]); e < best.error) best = {candidates[i], e, false};
  return best;
}

QuadricOptimum Quadric::optimal_on_segment(const glm::dvec3& p0, const glm::dvec3& p1) const noexcept {
  const Solve3 s = solve3(*this);
  if (s.c == Conditioning::kGood) return {s.x, evaluate(s.x), true};
  if (s.c == Conditioning::kUnsure) return to_public(segment_impl(dense(*this), to_eigen(p0), to_eigen(p1)));
  // Same 1D minimisation as segment_impl, without the dense conversion.
  const glm::dvec3 d = p1 - p0;
  const glm::dvec3 ad{a00 * d.x + a01 * d.y + a02 * d.z, a01 * d.x + a11 * d.y + a12 * d.z,
                      a02 * d.x + a12 * d.y + a22 * d.z};
  const glm::dvec3 g{a00 * p0.x + a01 * p0.y + a02 * p0.z + b0, a01 * p0.x + a11 * p0.y + a12 * p0.z + b1,
                     a02 * p0.x + a12 * p0.y + a22 * p0.z + b2};
  const double dad = glm::dot(d, ad), gd = glm::dot(d, g);
  const double t = dad > 0.0 ? std::clamp(-gd / dad, 0.0, 1.0) : 0.0;
  QuadricOptimum best{p0 + t * d, 0.0, false};
  best.error = evaluate(best.point);
  for (const glm::dvec3* end : {&p0, &p1})
    if (const double e = evaluate(*end); e < best.error) best = {*end, e, false};
  return best;
}

AttributeQuadric AttributeQuadric::from_triangle(const AttributePoint& p0, const AttributePoint& p1,
                                                 const AttributePoint& p2) {
  const double area = 0.5 * glm::length(glm::cross(p1.position - p0.position, p2.position - p0.position));
  if (!(area > 0.0) || !std::isfinite(area)) return {};
  // GH98 generalized quadric: orthonormal e1, e2 spanning the triangle's plane in R^6 (Gram-Schmidt), then
  // A = I - e1 e1^T - e2 e2^T, b = (p.e1) e1 + (p.e2) e2 - p, c = p.p - (p.e1)^2 - (p.e2)^2.
  const Vec<kN> p = to_eigen(p0), u = to_eigen(p1) - p, v = to_eigen(p2) - p;
  const Vec<kN> e1 = u.normalized();
  const Vec<kN> w = v - e1.dot(v) * e1;
  if (!(w.norm() > 0.0)) return {};
  const Vec<kN> e2 = w.normalized();
  const Mat<kN> A = Mat<kN>::Identity() - e1 * e1.transpose() - e2 * e2.transpose();
  const double pe1 = p.dot(e1), pe2 = p.dot(e2);
  const Vec<kN> b = pe1 * e1 + pe2 * e2 - p;
  AttributeQuadric q;
  for (int i = 0; i < kN; ++i) {
    for (int j = i; j < kN; ++j) q.a[packed(i, j)] = area * A(i, j);
    q.b[static_cast<std::size_t>(i)] = area * b(i);
  }
  q.c = area * (p.dot(p) - pe1 * pe1 - pe2 * pe2);
  if (!std::isfinite(q.c)) return {};
  return q;
}

AttributeQuadric& AttributeQuadric::operator+=(const AttributeQuadric& q) noexcept {
  for (std::size_t i = 0; i < a.size(); ++i) a[i] += q.a[i];
  for (std::size_t i = 0; i < b.size(); ++i) b[i] += q.b[i];
  c += q.c;
  return *this;
}

AttributeQuadric AttributeQuadric::scaled(double s) const noexcept {
  AttributeQuadric q = *this;
  for (double& x : q.a) x *= s;
  for (double& x : q.b) x *= s;
  q.c *= s;
  return q;
}

double AttributeQuadric::entry(int i, int j) const noexcept {
  return a[static_cast<std::size_t>(i <= j ? packed(i, j) : packed(j, i))];
}

double AttributeQuadric::evaluate(const AttributePoint& p) const noexcept { return dense(*this).eval(to_eigen(p)); }

AttributeOptimum AttributeQuadric::optimal(std::span<const AttributePoint> candidates) const {
  return to_public(optimal_impl(dense(*this), candidates, [](const AttributePoint& p) { return to_eigen(p); }));
}

AttributeOptimum AttributeQuadric::optimal_on_segment(const AttributePoint& p0,
                                                      const AttributePoint& p1) const noexcept {
  return to_public(segment_impl(dense(*this), to_eigen(p0), to_eigen(p1)));
}

}  // namespace varmesh
