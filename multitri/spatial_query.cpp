// Spatial queries on variable-resolution meshes (Velho-Gomes 2000, section 9; Floriani-Puppo level-of-detail
// operations). Predicates: Moller-Trumbore 1997 (ray/triangle), Akenine-Moller 2001 (triangle/box SAT),
// Ericson 2005, 5.1.5 (closest point on a triangle).
#include "multitri/spatial_query.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

// Barycentric slack: a point on a shared edge must land in at least one face although each face computes
// its coordinates with its own rounding. Double coordinates of float corners are good to ~1e-15 relative
// for any face that is not seen edge-on, so 1e-9 absorbs rounding and grows a face by a negligible rim.
constexpr double kBaryEps = 1e-9;
// Depths within this relative distance are one depth: the faces around a hit edge report the same point.
constexpr double kDepthEps = 1e-9;

bool lex_less(const glm::vec3& p, const glm::vec3& q) noexcept {
  return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
}

// Geometry-only identity of a face, independent of the front's key and corner order.
struct CanonicalFace {
  double area = 0.0;
  std::array<glm::vec3, 3> sorted{};
};

CanonicalFace canonical(const FaceHit& h) noexcept {
  CanonicalFace f;
  f.sorted = {h.a, h.b, h.c};
  std::sort(f.sorted.begin(), f.sorted.end(), lex_less);
  const glm::dvec3 a(f.sorted[0]), b(f.sorted[1]), c(f.sorted[2]);
  f.area = 0.5 * glm::length(glm::cross(b - a, c - a));
  return f;
}

bool canonical_less(const CanonicalFace& f, const CanonicalFace& g) noexcept {
  if (f.area != g.area) return f.area < g.area;
  return std::lexicographical_compare(f.sorted.begin(), f.sorted.end(), g.sorted.begin(), g.sorted.end(), lex_less);
}

}  // namespace

std::optional<double> intersect_ray_triangle(const Ray& ray, const glm::vec3& a, const glm::vec3& b,
                                             const glm::vec3& c) noexcept {
  const glm::dvec3 o(ray.origin), d(ray.direction), pa(a);
  const glm::dvec3 e1 = glm::dvec3(b) - pa, e2 = glm::dvec3(c) - pa;
  const glm::dvec3 p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  // Parallel (or degenerate) when det is tiny relative to its factors: a ray in the face's plane misses it
  // and hits the faces around it instead.
  const double size = glm::length(e1) * glm::length(e2) * glm::length(d);
  if (!(std::abs(det) > 1e-12 * size)) return std::nullopt;
  const double inv = 1.0 / det;
  const glm::dvec3 s = o - pa;
  const double u = glm::dot(s, p) * inv;
  if (u < -kBaryEps || u > 1.0 + kBaryEps) return std::nullopt;
  const glm::dvec3 qv = glm::cross(s, e1);
  const double v = glm::dot(d, qv) * inv;
  if (v < -kBaryEps || u + v > 1.0 + kBaryEps) return std::nullopt;
  const double t = glm::dot(e2, qv) * inv;
  if (!(t >= 0.0)) return std::nullopt;
  return t;
}

std::optional<double> locate_in_xy(const glm::vec2& xy, const glm::vec3& a, const glm::vec3& b,
                                   const glm::vec3& c) noexcept {
  // Each edge function uses only its own two corners, so the faces on both sides of an edge evaluate it
  // with the same products and opposite signs: the point is never lost between them.
  const double px = xy.x, py = xy.y;
  const double ax = double(a.x) - px, ay = double(a.y) - py;
  const double bx = double(b.x) - px, by = double(b.y) - py;
  const double cx = double(c.x) - px, cy = double(c.y) - py;
  const double wa = bx * cy - cx * by;  // twice the signed area of (p, b, c): weight of a
  const double wb = cx * ay - ax * cy;  // (p, c, a): weight of b
  const double wc = ax * by - bx * ay;  // (p, a, b): weight of c
  const double sum = wa + wb + wc;      // twice the signed area of (a, b, c)
  const double ex = bx - ax, ey = by - ay, fx = cx - ax, fy = cy - ay;
  const double size = std::sqrt((ex * ex + ey * ey) * (fx * fx + fy * fy));
  if (!(std::abs(sum) > 1e-12 * size)) return std::nullopt;  // vertical face: no xy-interior
  const double la = wa / sum, lb = wb / sum, lc = wc / sum;
  if (la < -kBaryEps || lb < -kBaryEps || lc < -kBaryEps) return std::nullopt;
  return la * double(a.z) + lb * double(b.z) + lc * double(c.z);
}

bool triangle_overlaps_box(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const Box3& box) noexcept {
  if (box.empty()) return false;
  const glm::dvec3 lo(box.lo), hi(box.hi);
  const glm::dvec3 center = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const glm::dvec3 v0 = glm::dvec3(a) - center, v1 = glm::dvec3(b) - center, v2 = glm::dvec3(c) - center;
  // Box face normals: the triangle's bounding box against the box.
  for (int k = 0; k < 3; ++k) {
    if (std::min({v0[k], v1[k], v2[k]}) > h[k] || std::max({v0[k], v1[k], v2[k]}) < -h[k]) return false;
  }
  // An axis separates when the triangle's projection lies beyond the box's projection radius.
  auto separates = [&](const glm::dvec3& axis) {
    const double p0 = glm::dot(v0, axis), p1 = glm::dot(v1, axis), p2 = glm::dot(v2, axis);
    const double r = h.x * std::abs(axis.x) + h.y * std::abs(axis.y) + h.z * std::abs(axis.z);
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  const std::array<glm::dvec3, 3> edges{v1 - v0, v2 - v1, v0 - v2};
  if (separates(glm::cross(edges[0], edges[1]))) return false;
  for (const glm::dvec3& e : edges) {
    // cross(x, e), cross(y, e), cross(z, e); a zero axis (e parallel to it) never separates.
    if (separates({0.0, -e.z, e.y}) || separates({e.z, 0.0, -e.x}) || separates({-e.y, e.x, 0.0})) return false;
  }
  return true;
}

bool triangle_may_meet_frustum(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                               const Frustum& frustum) noexcept {
  for (const Plane& p : frustum.planes)
    if (p.signed_distance(a) < 0.0f && p.signed_distance(b) < 0.0f && p.signed_distance(c) < 0.0f) return false;
  return true;
}

glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                     const glm::dvec3& c) noexcept {
  // Voronoi regions of the corners, then the edges, then the interior (Ericson 5.1.5).
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + ab * (d1 / (d1 - d3));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double sum = va + vb + vc;
  if (!(sum > 0.0)) return a;  // degenerate face: every region test failed only through rounding
  return a + ab * (vb / sum) + ac * (vc / sum);
}

FaceAdjacency FaceAdjacency::build(std::vector<Index> keys_in, std::vector<glm::vec3> corners_in) {
  if (corners_in.size() != 3 * keys_in.size())
    throw InvalidInput("FaceAdjacency: " + std::to_string(corners_in.size()) + " corners for " +
                       std::to_string(keys_in.size()) + " faces");
  FaceAdjacency adj;
  adj.keys = std::move(keys_in);
  adj.corners = std::move(corners_in);
  const std::size_t n = adj.keys.size();
  adj.by_key.resize(n);
  std::iota(adj.by_key.begin(), adj.by_key.end(), Index{0});
  std::sort(adj.by_key.begin(), adj.by_key.end(), [&](Index i, Index j) { return adj.keys[i] < adj.keys[j]; });
  for (std::size_t i = 1; i < n; ++i)
    if (adj.keys[adj.by_key[i]] == adj.keys[adj.by_key[i - 1]])
      throw InvalidInput("FaceAdjacency: face key repeats", adj.keys[adj.by_key[i]]);

  // Weld corners with equal positions by sorting them.
  std::vector<Index> order(3 * n);
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index i, Index j) { return lex_less(adj.corners[i], adj.corners[j]); });
  adj.vertices.assign(3 * n, kInvalid);
  Index next = 0;
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i > 0 && lex_less(adj.corners[order[i - 1]], adj.corners[order[i]])) ++next;
    adj.vertices[order[i]] = next;
  }
  adj.num_vertices = n == 0 ? 0 : std::size_t(next) + 1;

  // Edges as (low vertex, high vertex, face, slot), sorted: equal runs are the faces sharing an edge.
  struct Edge {
    Index lo, hi, face, slot;
  };
  std::vector<Edge> edges;
  edges.reserve(3 * n);
  for (std::size_t f = 0; f < n; ++f)
    for (Index k = 0; k < 3; ++k) {
      const Index u = adj.vertices[3 * f + k], v = adj.vertices[3 * f + (k + 1) % 3];
      if (u != v) edges.push_back({std::min(u, v), std::max(u, v), static_cast<Index>(f), k});
    }
  std::sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) {
    return std::tie(x.lo, x.hi, x.face, x.slot) < std::tie(y.lo, y.hi, y.face, y.slot);
  });
  adj.across.assign(3 * n, kInvalid);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    if (j - i == 1) {
      ++adj.num_border_edges;
    } else if (j - i == 2) {
      const Edge& x = edges[i];
      const Edge& y = edges[i + 1];
      if (x.face != y.face) {  // the same face twice: folded (degenerate), left unlinked
        adj.across[3 * x.face + x.slot] = y.face;
        adj.across[3 * y.face + y.slot] = x.face;
      }
    } else {
      ++adj.num_nonmanifold_edges;
    }
    i = j;
  }
  return adj;
}

Index FaceAdjacency::find(Index key) const noexcept {
  const auto it = std::lower_bound(by_key.begin(), by_key.end(), key, [&](Index i, Index k) { return keys[i] < k; });
  return it != by_key.end() && keys[*it] == key ? *it : kInvalid;
}

std::vector<Index> FaceAdjacency::neighbors(Index key) const {
  const Index f = find(key);
  if (f == kInvalid) throw InvalidInput("neighbors: no current face has this key", key);
  std::vector<Index> out;
  for (std::size_t k = 0; k < 3; ++k)
    if (const Index g = across[3 * std::size_t(f) + k]; g != kInvalid) out.push_back(keys[g]);
  return out;
}

void FaceAdjacency::validate() const {
  const std::size_t n = keys.size();
  if (corners.size() != 3 * n || vertices.size() != 3 * n || across.size() != 3 * n || by_key.size() != n)
    throw InvalidInput("FaceAdjacency: array sizes disagree with the face count");
  for (std::size_t f = 0; f < n; ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const Index g = across[3 * f + k];
      if (g == kInvalid) continue;
      if (g >= n || g == f) throw InvalidInput("FaceAdjacency: face links to an invalid neighbour", f);
      bool back = false;
      for (std::size_t m = 0; m < 3; ++m) back = back || across[3 * std::size_t(g) + m] == f;
      if (!back) throw InvalidInput("FaceAdjacency: neighbour does not link back", f);
      int shared = 0;
      for (std::size_t m = 0; m < 3; ++m)
        for (std::size_t l = 0; l < 3; ++l) shared += vertices[3 * f + m] == vertices[3 * std::size_t(g) + l];
      const Index u = vertices[3 * f + k], v = vertices[3 * f + (k + 1) % 3];
      bool has_u = false, has_v = false;
      for (std::size_t l = 0; l < 3; ++l) {
        has_u = has_u || vertices[3 * std::size_t(g) + l] == u;
        has_v = has_v || vertices[3 * std::size_t(g) + l] == v;
      }
      if (shared != 2 || !has_u || !has_v)
        throw InvalidInput("FaceAdjacency: neighbours do not share exactly the linking edge", f);
    }
}

namespace detail {

Query localize(const Query& q, SphereTest meets) {
  Query out = q;
  // "Fine outside the region" OR the query's own criterion: wanted = in q.focus, meets the region, and
  // not fine for q. Monotone on nested bounds because meeting the region is inherited by ancestors.
  // The region test goes first: it is cheap and settles most elements without evaluating q.criterion.
  out.criterion = Criterion::any_of(
      {Criterion::custom([m = std::move(meets)](const ElementBound& b) { return !m(b); }), q.criterion});
  return out;
}

bool sphere_meets_ray(const glm::vec3& c, float r, const Ray& ray) noexcept {
  const glm::dvec3 o(ray.origin), d(ray.direction), cc(c);
  const glm::dvec3 oc = cc - o;
  const double t = std::max(0.0, glm::dot(oc, d) / glm::dot(d, d));
  const glm::dvec3 off = oc - t * d;
  // Slack for the rounding of the closest point: a sphere the ray grazes is kept (conservative).
  const double rr = double(r) * (1.0 + 1e-6) + 1e-9 * glm::length(oc);
  return glm::dot(off, off) <= rr * rr;
}

bool sphere_meets_vertical_line(const glm::vec3& c, float r, const glm::vec2& xy) noexcept {
  const double dx = double(c.x) - double(xy.x), dy = double(c.y) - double(xy.y);
  const double rr = double(r) * (1.0 + 1e-6);
  return dx * dx + dy * dy <= rr * rr;
}

void check_finite(const glm::vec3& v, const char* what) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    throw InvalidInput(std::string(what) + " is not finite");
}

void check_radius(float r, const char* what) {
  if (!(r >= 0.0f) || !std::isfinite(r)) throw InvalidInput(std::string(what) + " must be finite and >= 0");
}

void check_ray(const Ray& ray) {
  check_finite(ray.origin, "ray origin");
  check_finite(ray.direction, "ray direction");
  if (ray.direction.x == 0.0f && ray.direction.y == 0.0f && ray.direction.z == 0.0f)
    throw InvalidInput("ray direction is zero");
}

std::optional<FaceHit> choose_hit(std::span<const HitCandidate> candidates, double scale) {
  if (candidates.empty()) return std::nullopt;
  double nearest = candidates[0].depth;
  for (const HitCandidate& h : candidates) nearest = std::min(nearest, h.depth);
  const double tol = kDepthEps * std::max(scale, std::abs(nearest));
  const HitCandidate* best = nullptr;
  CanonicalFace best_face;
  for (const HitCandidate& h : candidates) {
    if (h.depth > nearest + tol) continue;
    const CanonicalFace f = canonical(h.hit);
    if (best == nullptr || canonical_less(f, best_face)) {
      best = &h;
      best_face = f;
    }
  }
  return best->hit;
}

}  // namespace detail
}  // namespace varmesh
