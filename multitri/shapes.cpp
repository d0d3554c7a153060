#include "multitri/shapes.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <unordered_map>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"

namespace varmesh {

TriMesh make_icosphere(int levels) {
  if (levels < 0 || levels > 10) throw InvalidInput("make_icosphere: levels must be in [0, 10], not " + std::to_string(levels));
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  TriMesh m;
  m.positions = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  m.indices = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8,
               3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
  for (auto& p : m.positions) p = glm::normalize(p);
  for (int l = 0; l < levels; ++l) {
    std::unordered_map<std::uint64_t, Index> mid;
    auto midpoint = [&](Index a, Index b) {
      const std::uint64_t key = undirected_edge_key(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.positions.push_back(glm::normalize(m.positions[a] + m.positions[b]));
      const Index v = static_cast<Index>(m.positions.size() - 1);
      mid.emplace(key, v);
      return v;
    };
    std::vector<Index> next;
    next.reserve(4 * m.indices.size());
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      const Index a = m.indices[3 * f], b = m.indices[3 * f + 1], c = m.indices[3 * f + 2];
      const Index ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    m.indices = std::move(next);
  }
  return m;
}

TriMesh make_torus(int n, int m, float major_radius, float minor_radius, float bump) {
  if (n < 3 || m < 3 || static_cast<long long>(n) * m > (1LL << 24))
    throw InvalidInput("make_torus: n and m must be at least 3 and n * m at most 2^24, not " + std::to_string(n) + " x " +
                       std::to_string(m));
  if (!std::isfinite(major_radius) || !(major_radius > 0.0f) || !std::isfinite(minor_radius) ||
      !(minor_radius > 0.0f) || !std::isfinite(bump))
    throw InvalidInput("make_torus: the radii must be finite and positive and bump finite, not " +
                       std::to_string(major_radius) + ", " + std::to_string(minor_radius) + ", " + std::to_string(bump));
  TriMesh g;
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  g.positions.reserve(static_cast<std::size_t>(n) * static_cast<std::size_t>(m));
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      const float u = two_pi * static_cast<float>(i) / static_cast<float>(n), v = two_pi * static_cast<float>(j) / static_cast<float>(m);
      const float r = minor_radius * (1.0f + bump * std::sin(3.0f * u));
      g.positions.push_back({(major_radius + r * std::cos(v)) * std::cos(u), (major_radius + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
      const glm::vec3& p = g.positions.back();
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw InvalidInput("make_torus: the radii overflow float (vertex " + std::to_string(g.positions.size() - 1) + ")",
                           g.positions.size() - 1);
    }
  auto id = [&](int i, int j) { return static_cast<Index>(((j + m) % m) * n + (i + n) % n); };
  g.indices.reserve(6 * g.positions.size());
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      g.indices.insert(g.indices.end(), {a, b, c, a, c, d});
    }
  return g;
}

}  // namespace varmesh
