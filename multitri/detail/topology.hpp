#pragma once
/// Small building blocks for topology queries over flat index arrays (used by mesh_report.cpp).
///
/// - DisjointSets: union-find over 0..n-1 in one flat array (path halving, link to the smaller root, so the
///   root of a set is its smallest element and results do not depend on the order of unions);
/// - exactly_collinear(): exact test that three float points lie on one line (zero-area triangle);
/// - counts_to_offsets(): the offsets half of an offsets+items table built by counting sort.
/// Header-only; no allocation beyond the arrays the caller asks for.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/types.hpp"

namespace varmesh::detail {

/// Union-find over the integers 0..n-1.
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n = 0) { reset(n); }

  /// Makes every element its own set again (reuses the storage).
  void reset(std::size_t n) {
    parent_.resize(n);
    for (std::size_t i = 0; i < n; ++i) parent_[i] = static_cast<Index>(i);
  }

  Index find(Index x) noexcept {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];  // path halving
      x = parent_[x];
    }
    return x;
  }

  /// Joins the sets of a and b; returns true when they were different sets.
  bool unite(Index a, Index b) noexcept {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b) std::swap(a, b);
    parent_[a] = b;
    return true;
  }

  bool is_root(Index x) const noexcept { return parent_[x] == x; }
  std::size_t size() const noexcept { return parent_.size(); }

 private:
  std::vector<Index> parent_;
};

namespace exact {

/// Knuth's TwoSum: s + err == a + b exactly (round-to-nearest, no -ffast-math).
inline void two_sum(double a, double b, double& s, double& err) noexcept {
  s = a + b;
  const double bb = s - a;
  err = (a - (s - bb)) + (b - bb);
}

/// Exact sign test: is t[0] + ... + t[n-1] == 0 for doubles t (no overflow)?
/// A floating-point filter decides almost every call; the rest grows a nonoverlapping expansion
/// (Shewchuk 1997, "Adaptive precision floating-point arithmetic", Grow-Expansion, Theorem 10), whose sum is
/// zero exactly when every component is zero.
template <std::size_t N>
bool sum_is_zero(const double (&t)[N]) noexcept {
  double s = 0.0, m = 0.0;
  for (double x : t) {
    s += x;
    m += std::fabs(x);
  }
  if (m == 0.0) return true;
  // Recursive summation of N terms errs by at most (N-1)u * sum|t| (u = 2^-53); 2^-48 leaves a wide margin
  // for N <= 8 and for the rounding of m itself.
  if (std::fabs(s) > m * 0x1p-48) return false;
  double e[N];
  std::size_t n = 0;
  for (double x : t) {
    double q = x;
    for (std::size_t i = 0; i < n; ++i) {
      double sum = 0.0, err = 0.0;
      two_sum(q, e[i], sum, err);
      e[i] = err;
      q = sum;
    }
    e[n++] = q;
  }
  for (std::size_t i = 0; i < n; ++i)
    if (e[i] != 0.0) return false;
  return true;
}

}  // namespace exact

/// True when p, q, r are exactly collinear (the triangle has zero area in exact arithmetic), including when
/// two or three of them coincide. Each cross-product component of (q-p) x (r-p) is written as the cyclic sum
/// p_i q_j - p_j q_i + q_i r_j - q_j r_i + r_i p_j - r_j p_i; a product of two floats is exact in double
/// (24+24 bits, exponents within range), so only the six-term sum needs care.
inline bool exactly_collinear(const glm::vec3& p, const glm::vec3& q, const glm::vec3& r) noexcept {
  constexpr int kAxes[3][2] = {{1, 2}, {2, 0}, {0, 1}};
  for (const auto& ax : kAxes) {
    const int i = ax[0], j = ax[1];
    const double pi = p[i], pj = p[j], qi = q[i], qj = q[j], ri = r[i], rj = r[j];
    const double t[6] = {pi * qj, -(pj * qi), qi * rj, -(qj * ri), ri * pj, -(rj * pi)};
    if (!exact::sum_is_zero(t)) return false;
  }
  return true;
}

/// Offsets of a bucketed table: given counts[k] (size n), turns it in place into offsets of size n+1 with
/// offsets[k] = sum of counts before k. Returns the total.
inline Index counts_to_offsets(std::vector<Index>& counts) {
  counts.push_back(0);
  Index sum = 0;
  for (auto& c : counts) {
    const Index n = c;
    c = sum;
    sum += n;
  }
  return sum;
}

}  // namespace varmesh::detail
