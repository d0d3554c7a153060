#include "multitri/mesh_distance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "multitri/spatial_query.hpp"

namespace varmesh {

namespace {

double point_segment_sq(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) noexcept {
  const glm::dvec3 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  const glm::dvec3 d = p - (a + t * ab);
  return glm::dot(d, d);
}

double box_sq(const glm::vec3& lo, const glm::vec3& hi, const glm::dvec3& p) noexcept {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double l = lo[k], h = hi[k];
    const double d = p[k] < l ? l - p[k] : (p[k] > h ? p[k] - h : 0.0);
    s += d * d;
  }
  return s;
}

}  // namespace

double point_triangle_distance_sq(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                  const glm::dvec3& c) noexcept {
  // Degenerate and nearly degenerate triangles (sin of the angle at a below 1e-5): the region tests of the
  // closest-point method lose their signs to rounding there and can return a far point, while the edges
  // are within the sliver's width (< 1e-5 of its edges) of every point of it.
  const glm::dvec3 ab = b - a, ac = c - a;
  const glm::dvec3 n = glm::cross(ab, ac);
  if (!(glm::dot(n, n) > 1e-10 * glm::dot(ab, ab) * glm::dot(ac, ac)))
    return std::min({point_segment_sq(p, a, b), point_segment_sq(p, b, c), point_segment_sq(p, c, a)});
  const glm::dvec3 d = p - closest_point_on_triangle(p, a, b, c);
  return glm::dot(d, d);
}

TriangleBvh::TriangleBvh(std::span<const glm::vec3> positions, std::span<const Index> indices) {
  const std::size_t nt = indices.size() / 3;
  for (std::size_t i = 0; i < 3 * nt; ++i) {
    if (indices[i] >= positions.size())
      throw InvalidInput("TriangleBvh: face " + std::to_string(i / 3) + " uses vertex " + std::to_string(indices[i]) +
                         " of " + std::to_string(positions.size()));
    const glm::vec3& q = positions[indices[i]];
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      throw InvalidInput("TriangleBvh: vertex " + std::to_string(indices[i]) + " of face " + std::to_string(i / 3) +
                         " is not finite");
  }
  std::vector<Index> order(nt);
  std::iota(order.begin(), order.end(), Index{0});
  std::vector<glm::vec3> centroid(nt);
  for (std::size_t t = 0; t < nt; ++t)
    centroid[t] = (positions[indices[3 * t]] + positions[indices[3 * t + 1]] + positions[indices[3 * t + 2]]) / 3.0f;
  nodes_.reserve(2 * nt / 4 + 2);
  if (nt > 0) build(order, 0, nt, centroid, positions, indices);
  tri_.reserve(3 * nt);
  for (Index t : order)
    for (std::size_t k = 0; k < 3; ++k) tri_.push_back(glm::dvec3(positions[indices[3 * t + k]]));
}

Index TriangleBvh::build(std::vector<Index>& order, std::size_t begin, std::size_t end,
                         const std::vector<glm::vec3>& centroid, std::span<const glm::vec3> positions,
                         std::span<const Index> indices) {
  const Index id = static_cast<Index>(nodes_.size());
  nodes_.push_back({});
  Node n;
  n.lo = glm::vec3(std::numeric_limits<float>::max());
  n.hi = glm::vec3(std::numeric_limits<float>::lowest());
  glm::vec3 clo = n.lo, chi = n.hi;
  for (std::size_t i = begin; i < end; ++i) {
    const Index t = order[i];
    for (std::size_t k = 0; k < 3; ++k) {
      const glm::vec3& q = positions[indices[3 * t + k]];
      n.lo = glm::min(n.lo, q);
      n.hi = glm::max(n.hi, q);
    }
    clo = glm::min(clo, centroid[t]);
    chi = glm::max(chi, centroid[t]);
  }
  if (end - begin <= 4) {
    n.first = static_cast<Index>(begin);
    n.count = static_cast<Index>(end - begin);
    nodes_[id] = n;
    return id;
  }
  const glm::vec3 ext = chi - clo;
  const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
  const std::size_t mid = (begin + end) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(end),
                   [&](Index x, Index y) { return centroid[x][axis] < centroid[y][axis]; });
  n.left = build(order, begin, mid, centroid, positions, indices);
  n.right = build(order, mid, end, centroid, positions, indices);
  nodes_[id] = n;
  return id;
}

double TriangleBvh::nearest_sq(const glm::dvec3& p) const noexcept {
  double best = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return best;
  // Median splits halve the triangles per level: the depth is below 40 for any Index-sized soup, and the
  // walk keeps at most one deferred sibling per level.
  Index stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (box_sq(n.lo, n.hi, p) >= best) continue;
    if (n.count > 0) {
      for (Index t = n.first; t < n.first + n.count; ++t)
        best = std::min(best, point_triangle_distance_sq(p, tri_[3 * t], tri_[3 * t + 1], tri_[3 * t + 2]));
      continue;
    }
    const double dl = box_sq(nodes_[n.left].lo, nodes_[n.left].hi, p), dr = box_sq(nodes_[n.right].lo, nodes_[n.right].hi, p);
    // The farther child goes on the stack first, so the nearer one is visited next.
    const Index near = dl < dr ? n.left : n.right, far = dl < dr ? n.right : n.left;
    if (std::max(dl, dr) < best) stack[top++] = far;
    if (std::min(dl, dr) < best) stack[top++] = near;
  }
  return best;
}

SurfaceDistance vertex_to_surface_distance(const TriMesh& from, const TriMesh& to) {
  std::vector<std::uint8_t> used(from.num_vertices(), 0);
  for (Index v : from.indices) {
    if (v >= used.size()) throw InvalidInput("vertex_to_surface_distance: a face uses vertex " + std::to_string(v) +
                                             " of " + std::to_string(used.size()));
    used[v] = 1;
  }
  const TriangleBvh bvh(to);
  SurfaceDistance d;
  Box3 box;
  double sum = 0.0, max_sq = 0.0;
  for (std::size_t v = 0; v < used.size(); ++v) {
    if (!used[v]) continue;
    const glm::vec3& q = from.positions[v];
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      throw InvalidInput("vertex_to_surface_distance: vertex " + std::to_string(v) + " is not finite");
    box.add(q);
    const double d2 = bvh.nearest_sq(glm::dvec3(from.positions[v]));
    sum += d2;
    max_sq = std::max(max_sq, d2);
    ++d.points;
  }
  d.diagonal = d.points > 0 ? glm::length(glm::dvec3(box.hi) - glm::dvec3(box.lo)) : 0.0;  // double: no overflow
  d.rms = d.points > 0 ? std::sqrt(sum / static_cast<double>(d.points)) : 0.0;
  d.max = std::sqrt(max_sq);
  return d;
}

}  // namespace varmesh
