#include "multitri/shapes.hpp"

#include <cmath>
#include <cstdint>
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

}  // namespace varmesh
