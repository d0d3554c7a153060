// Repair of user meshes into an oriented 2-manifold with border (see manifold_input.hpp). Detection is
// static and sort-based so that the result does not depend on hash order: a face conflicts on a directed
// edge when an earlier kept face already uses that directed edge.
#include "pm/manifold_input.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

namespace {


struct UnionFind {
  std::vector<Index> p;
  explicit UnionFind(std::size_t n) : p(n) { std::iota(p.begin(), p.end(), Index{0}); }
  Index find(Index x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
  }
  void unite(Index a, Index b) { p[find(a)] = find(b); }
};

}  // namespace

ManifoldInput make_manifold_input(const TriMesh& mesh, NonManifoldPolicy policy) {
  if (policy != NonManifoldPolicy::kSplit && policy != NonManifoldPolicy::kLock)
    throw InvalidInput("make_manifold_input: non-manifold policy " + std::to_string(static_cast<int>(policy)) +
                       " is not one of kSplit, kLock");
  mesh.validate();
  ManifoldInput out;
  InputRepairReport& rep = out.report;
  rep.input_vertices = mesh.num_vertices();
  rep.input_faces = mesh.num_faces();

  // Steps 2-3: degenerate and duplicate faces.
  std::vector<Index> kept;  // input face ids
  kept.reserve(mesh.num_faces());
  {
    std::vector<std::pair<std::array<Index, 3>, Index>> sorted;
    sorted.reserve(mesh.num_faces());
    for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
      std::array<Index, 3> c{mesh.corner(f, 0), mesh.corner(f, 1), mesh.corner(f, 2)};
      if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) {
        ++rep.degenerate_faces;
        continue;
      }
      std::sort(c.begin(), c.end());
      sorted.push_back({c, static_cast<Index>(f)});
    }
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < sorted.size(); ++i) {
      if (i > 0 && sorted[i].first == sorted[i - 1].first) {
        ++rep.duplicate_faces;
        continue;
      }
      kept.push_back(sorted[i].second);
    }
    std::sort(kept.begin(), kept.end());
  }
  if (kept.empty()) throw InvalidInput("mesh has no non-degenerate face");

  // Step 1 + leaves: one leaf per referenced input vertex, in order of first use.
  std::vector<Index> leaf_of(mesh.num_vertices(), kInvalid);
  std::vector<Index> corners(kept.size() * 3);
  auto new_leaf = [&](Index input_vertex) {
    out.leaf_to_input.push_back(input_vertex);
    return static_cast<Index>(out.leaf_to_input.size() - 1);
  };
  for (std::size_t i = 0; i < kept.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const Index v = mesh.corner(kept[i], k);
      if (leaf_of[v] == kInvalid) leaf_of[v] = new_leaf(v);
      corners[3 * i + static_cast<std::size_t>(k)] = leaf_of[v];
    }
  const std::size_t referenced = out.leaf_to_input.size();
  rep.unreferenced_vertices = mesh.num_vertices() - referenced;
  std::vector<std::uint8_t> touched;  // leaves involved in a split

  // Step 4: a directed edge used a second time gets fresh corners.
  {
    std::vector<std::pair<std::uint64_t, Index>> edges;
    edges.reserve(corners.size());
    for (std::size_t i = 0; i < kept.size(); ++i)
      for (int k = 0; k < 3; ++k)
        edges.push_back({directed_edge_key(corners[3 * i + k], corners[3 * i + (k + 1) % 3]), static_cast<Index>(3 * i + k)});
    std::sort(edges.begin(), edges.end());
    std::vector<std::uint8_t> conflict(corners.size(), 0);  // per corner slot k: edge k conflicts
    for (std::size_t i = 1; i < edges.size(); ++i)
      if (edges[i].first == edges[i - 1].first) conflict[edges[i].second] = 1;
    for (std::size_t i = 0; i < kept.size(); ++i) {
      bool any = false;
      std::array<bool, 3> copy{false, false, false};
      for (int k = 0; k < 3; ++k)
        if (conflict[3 * i + k]) copy[k] = copy[(k + 1) % 3] = any = true;
      if (!any) continue;
      ++rep.nonmanifold_edge_faces;
      for (int k = 0; k < 3; ++k) {
        if (!copy[k]) continue;
        Index& c = corners[3 * i + k];
        touched.resize(out.leaf_to_input.size() + 1, 0);
        touched[c] = 1;
        c = new_leaf(out.leaf_to_input[c]);
        touched.resize(out.leaf_to_input.size(), 0);
        touched[c] = 1;
        ++rep.added_vertex_copies;
      }
    }
  }

  // Step 5: split vertices with several fans. Corners are united across every edge used in both directions.
  {
    std::vector<std::pair<std::uint64_t, Index>> edges;
    edges.reserve(corners.size());
    for (std::size_t i = 0; i < kept.size(); ++i)
      for (int k = 0; k < 3; ++k)
        edges.push_back({directed_edge_key(corners[3 * i + k], corners[3 * i + (k + 1) % 3]), static_cast<Index>(3 * i + k)});
    std::sort(edges.begin(), edges.end());
    auto find_edge = [&](Index a, Index b) -> Index {
      const auto it = std::lower_bound(edges.begin(), edges.end(), std::pair<std::uint64_t, Index>{directed_edge_key(a, b), 0});
      return (it != edges.end() && it->first == directed_edge_key(a, b)) ? it->second : kInvalid;
    };
    UnionFind uf(corners.size());
    for (std::size_t i = 0; i < kept.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const Index a = corners[3 * i + k], b = corners[3 * i + (k + 1) % 3];
        const Index twin = find_edge(b, a);  // slot of edge b->a: corners twin (b) and twin's next (a)
        if (twin == kInvalid) continue;
        const Index tf = twin / 3, tk = twin % 3;
        uf.unite(static_cast<Index>(3 * i + k), 3 * tf + (tk + 1) % 3);              // corner a
        uf.unite(static_cast<Index>(3 * i + (k + 1) % 3), 3 * tf + tk);              // corner b
      }
    // First fan seen keeps the leaf; each further fan gets a copy.
    std::vector<Index> fan_of_leaf(out.leaf_to_input.size(), kInvalid);
    std::vector<std::pair<Index, Index>> fan_copy;  // (fan root, copy leaf), sorted by root for lookup
    std::vector<Index> copy_of_root(corners.size(), kInvalid);
    std::vector<std::uint8_t> counted(out.leaf_to_input.size(), 0);
    for (std::size_t s = 0; s < corners.size(); ++s) {
      const Index leaf = corners[s];
      const Index root = uf.find(static_cast<Index>(s));
      if (fan_of_leaf[leaf] == kInvalid) fan_of_leaf[leaf] = root;
      if (fan_of_leaf[leaf] == root) continue;
      if (copy_of_root[root] == kInvalid) {
        if (!counted[leaf]) {
          counted[leaf] = 1;
          ++rep.nonmanifold_vertices;
        }
        touched.resize(out.leaf_to_input.size() + 1, 0);
        touched[leaf] = 1;
        copy_of_root[root] = new_leaf(out.leaf_to_input[leaf]);
        touched.resize(out.leaf_to_input.size(), 0);
        touched[copy_of_root[root]] = 1;
        ++rep.added_vertex_copies;
      }
      corners[s] = copy_of_root[root];
    }
  }

  const std::size_t nl = out.leaf_to_input.size();
  out.positions.resize(nl);
  for (std::size_t l = 0; l < nl; ++l) out.positions[l] = mesh.positions[out.leaf_to_input[l]];
  if (mesh.has_colors()) {
    out.colors.resize(nl);
    for (std::size_t l = 0; l < nl; ++l) out.colors[l] = mesh.colors[out.leaf_to_input[l]];
  }
  out.faces = std::move(corners);
  out.face_to_input = std::move(kept);
  out.locked.assign(nl, 0);
  if (policy == NonManifoldPolicy::kLock) {
    touched.resize(nl, 0);
    for (std::size_t l = 0; l < nl; ++l)
      if (touched[l]) {
        out.locked[l] = 1;
        ++rep.locked_vertices;
      }
  }
  return out;
}

}  // namespace varmesh
