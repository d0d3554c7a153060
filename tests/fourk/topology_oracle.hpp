#pragma once
// A slow, literal reading of find_topology_problem's contract (fourk/poly_mesh.hpp) for small meshes, to hold
// the fast code (sorted sides, union-find) to: each rule by brute force over the faces, and the edge rules'
// order by asking, side by side in face order, whether the faces up to that side already break a rule. And
// the damaged meshes to hold them to (damaged_grid), shared by the tests of the builders that check the rules.
#include <algorithm>
#include <cstddef>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"

namespace varmesh::testing {

using FaceList = std::vector<std::vector<Index>>;

// Side i of face f: the directed edge from corner i to corner i + 1.
inline std::pair<Index, Index> side(const std::vector<Index>& f, std::size_t i) { return {f[i], f[(i + 1) % f.size()]}; }

// Does face f have the edge a-b, and which way: +1 a -> b, -1 b -> a, 0 not at all.
inline int runs(const std::vector<Index>& f, Index a, Index b) {
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (side(f, i) == std::pair(a, b)) return 1;
    if (side(f, i) == std::pair(b, a)) return -1;
  }
  return 0;
}

inline TopologyProblem slow_topology_problem(const FaceList& faces, const TopologyRules& rules) {
  TopologyProblem p;
  const std::size_t nf = faces.size();
  // 1. The first face with a repeated vertex; the vertex whose second appearance comes first.
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t j = 0; j < faces[f].size(); ++j)
      for (std::size_t i = 0; i < j; ++i)
        if (faces[f][i] == faces[f][j]) {
          p.rule = TopologyRule::kRepeatedCorner;
          p.faces = {Index(f)};
          p.vertices[0] = faces[f][j];
          return p;
        }
  // 2. The first side, in face and corner order, at which the faces so far give its edge a third face or
  // run it twice the same way.
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t i = 0; i < faces[f].size(); ++i) {
      const auto [a, b] = side(faces[f], i);
      int so_far = 1;
      bool same_way = false;
      for (std::size_t g = 0; g < f; ++g) {
        const int r = runs(faces[g], a, b);
        so_far += r != 0;
        same_way = same_way || r == 1;
      }
      if (so_far < 3 && !same_way) continue;
      for (std::size_t g = 0; g < nf; ++g)
        if (runs(faces[g], a, b) != 0) p.faces.push_back(Index(g));
      p.rule = p.faces.size() >= 3 ? TopologyRule::kNonManifoldEdge : TopologyRule::kInconsistentOrientation;
      const bool forward = runs(faces[p.faces[0]], a, b) == 1;
      p.vertices = forward ? std::array<Index, 2>{a, b} : std::array<Index, 2>{b, a};
      return p;
    }
  // 3. The first face on the vertices of an earlier one, and the first such earlier face.
  if (rules.distinct_faces)
    for (std::size_t f = 0; f < nf; ++f)
      for (std::size_t g = 0; g < f; ++g) {
        std::vector<Index> x = faces[f], y = faces[g];
        std::sort(x.begin(), x.end());
        std::sort(y.begin(), y.end());
        if (x != y) continue;
        p.rule = TopologyRule::kDoubledFace;
        p.faces = {Index(g), Index(f)};
        return p;
      }
  // 4. The lowest vertex whose faces, joined when they share an edge at it, fall into several groups.
  if (rules.one_fan_per_vertex) {
    Index nv = 0;
    for (const auto& f : faces)
      for (Index c : f) nv = std::max(nv, c + 1);
    for (Index v = 0; v < nv; ++v) {
      std::vector<std::size_t> at;  // faces with a corner at v, in order
      for (std::size_t f = 0; f < nf; ++f)
        if (std::find(faces[f].begin(), faces[f].end(), v) != faces[f].end()) at.push_back(f);
      std::vector<std::size_t> group(at.size());
      for (std::size_t i = 0; i < at.size(); ++i) group[i] = i;
      // Relabel until stable: quadratic passes, fine for tiny meshes.
      for (bool changed = true; changed;) {
        changed = false;
        for (std::size_t i = 0; i < at.size(); ++i)
          for (std::size_t j = 0; j < at.size(); ++j) {
            if (group[j] >= group[i]) continue;
            bool share = false;
            for (Index x : faces[at[i]])
              if (x != v && runs(faces[at[i]], v, x) != 0 && runs(faces[at[j]], v, x) != 0) share = true;
            if (share) {
              group[i] = group[j];
              changed = true;
            }
          }
      }
      std::vector<Index> firsts;  // the first face of each group
      std::vector<std::size_t> seen;
      for (std::size_t i = 0; i < at.size(); ++i)
        if (std::find(seen.begin(), seen.end(), group[i]) == seen.end()) {
          seen.push_back(group[i]);
          firsts.push_back(Index(at[i]));
        }
      if (firsts.size() < 2) continue;
      p.rule = TopologyRule::kNonManifoldVertex;
      p.faces = firsts;
      p.vertices[0] = v;
      return p;
    }
  }
  return p;
}

// A small grid of quads, or of triangles only, damaged at random: faces reversed, doubled as they are or
// reversed, fins on edges, faces dropped, corners repeated, vertices glued, lone triangles and pillows
// added, then the faces shuffled and their corners rotated. Most such meshes break a rule, some several,
// some none. Vertices are numbered below num_vertices; some may be unreferenced.
struct DamagedGrid {
  FaceList faces;
  Index num_vertices = 0;
  bool triangles_only = false;
};

inline DamagedGrid damaged_grid(std::mt19937& rng) {
  auto pick = [&rng](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  const std::size_t w = 1 + pick(4), h = 1 + pick(3);
  const bool triangles_only = pick(2) == 0;
  Index nv = Index((w + 1) * (h + 1));
  FaceList faces;
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) {
      const Index a = Index(y * (w + 1) + x), b = a + 1, c = b + Index(w + 1), d = a + Index(w + 1);
      if (triangles_only || pick(3) == 0) {
        faces.push_back({a, b, c});
        faces.push_back({a, c, d});
      } else {
        faces.push_back({a, b, c, d});
      }
    }
  const std::size_t damages = pick(4);
  for (std::size_t k = 0; k < damages; ++k) {
    std::vector<Index>& f = faces[pick(faces.size())];
    switch (pick(8)) {
      case 0: std::reverse(f.begin(), f.end()); break;
      case 1: {
        std::vector<Index> copy = faces[pick(faces.size())];
        if (pick(2) == 0) std::reverse(copy.begin(), copy.end());
        faces.push_back(copy);
        break;
      }
      case 2: {
        const std::size_t i = pick(f.size());
        faces.push_back({f[(i + 1) % f.size()], f[i], nv++});
        break;
      }
      case 3:
        if (faces.size() > 1) faces.erase(faces.begin() + std::ptrdiff_t(pick(faces.size())));
        break;
      case 4:
        if (!triangles_only) f[pick(f.size())] = f[pick(f.size())];
        break;
      case 5: {  // glue two vertices: bow-ties, and sometimes worse
        const Index from = Index(pick(nv)), to = Index(pick(nv));
        for (auto& g : faces)
          for (Index& c : g)
            if (c == from) c = to;
        break;
      }
      case 6: {  // a lone triangle touching the grid at one corner
        faces.push_back({f[0], nv, nv + 1});
        nv += 2;
        break;
      }
      default: {  // a pillow: a triangle and its reverse, on one grid corner or apart
        const Index a = pick(2) == 0 ? f[0] : nv++;
        faces.push_back({a, nv, nv + 1});
        faces.push_back({nv + 1, nv, a});
        nv += 2;
        break;
      }
    }
  }
  // Gluing can leave a triangle with a repeated corner in a triangles-only mesh: that is a case too.
  std::shuffle(faces.begin(), faces.end(), rng);
  for (auto& f : faces) std::rotate(f.begin(), f.begin() + std::ptrdiff_t(pick(f.size())), f.end());
  return {std::move(faces), nv, triangles_only};
}

// The faces as a TriMesh (all triangles) over num_vertices vertices spread on a 5-wide sheet, bent a little.
inline TriMesh triangles_of(const FaceList& faces, Index num_vertices) {
  TriMesh t;
  for (Index v = 0; v < num_vertices; ++v) t.positions.emplace_back(float(v % 5), float(v / 5), 0.25f * float(v % 3));
  for (const auto& f : faces) t.indices.insert(t.indices.end(), f.begin(), f.end());
  return t;
}

// The words of the refusal of `problem` by the function `who` (its InvalidInput's what()).
inline std::string refusal(const std::string& who, const TopologyProblem& problem) {
  return InvalidInput(who + ": " + describe_topology_problem(problem), problem.element()).what();
}

inline bool same_problem(const TopologyProblem& a, const TopologyProblem& b) {
  return a.rule == b.rule && a.faces == b.faces && a.vertices == b.vertices;
}

}  // namespace varmesh::testing
