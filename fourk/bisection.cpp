// Uniform newest-vertex bisection as a Multi-Triangulation.
//
// Papers: L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000): 5.1 (binary 4-8 refinement: split
// the edges, link the new vertex to the opposite corners), 6.2 (semi-regular 4-8 meshes over an arbitrary
// base), 7.2 (the split node, 2 -> 4). The marking rule (children mark the edge opposite the new vertex) is
// newest-vertex bisection (Mitchell 1991); with a compatible initial marking every level pairs the faces
// two by two across their marked edges, which is the "independent set of two-face clusters that completely
// cover the mesh" of 7.2.
#include "fourk/bisection.hpp"

#include <algorithm>
#include <string>
#include <unordered_map>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

namespace {


std::string edge_name(VertexId a, VertexId b) { return "(" + std::to_string(a) + ", " + std::to_string(b) + ")"; }

// A face of the current level: (apex, e0, e1) counter-clockwise as stored, marked edge e0 -> e1.
struct LevelFace {
  FaceId id;
  VertexId apex, e0, e1;
};

void check_input(const TriMesh& base, std::span<const std::uint8_t> refinement_edge, int levels) {
  base.validate();
  const std::size_t nf = base.num_faces();
  if (nf == 0) throw InvalidInput("build_bisection_mt: the base mesh has no face");
  if (refinement_edge.size() != nf)
    throw InvalidInput("build_bisection_mt: " + std::to_string(refinement_edge.size()) + " refinement edges for " +
                       std::to_string(nf) + " faces");
  if (levels < 0) throw InvalidInput("build_bisection_mt: negative number of levels");
  if (levels > 30 || (std::uint64_t(nf) << levels) >= (std::uint64_t(1) << 31))
    throw InvalidInput("build_bisection_mt: " + std::to_string(nf) + " faces * 2^" + std::to_string(levels) +
                       " exceeds 2^31 faces");
  for (std::size_t f = 0; f < nf; ++f)
    if (refinement_edge[f] > 2)
      throw InvalidInput("build_bisection_mt: face " + std::to_string(f) + ": refinement edge " +
                             std::to_string(refinement_edge[f]) + " is not 0, 1 or 2",
                         f);
  // The base's rules are a FourKMesh's: the bisection hierarchy is a 4-k one. The opposite sides found on the
  // way give each marked edge's twin.
  std::vector<Index> opposite;
  if (const TopologyProblem problem = find_topology_problem(base, kFourKMeshRules, &opposite))
    throw InvalidInput("build_bisection_mt: " + describe_topology_problem(problem), problem.element());
  for (std::size_t f = 0; f < nf; ++f) {
    const int k = refinement_edge[f];
    const Index twin = opposite[3 * f + static_cast<std::size_t>(k)];
    if (twin == kInvalid) continue;  // border edge: a 1 -> 2 split
    const VertexId a = base.corner(f, k), b = base.corner(f, (k + 1) % 3);
    const FaceId g = twin / 3;
    const int kg = refinement_edge[g];
    if (twin % 3 != static_cast<Index>(kg)) {
      const VertexId ga = base.corner(g, kg), gb = base.corner(g, (kg + 1) % 3);
      throw InvalidInput("build_bisection_mt: face " + std::to_string(f) + " marks edge " + edge_name(a, b) +
                             ", shared with face " + std::to_string(g) + " which marks edge " + edge_name(ga, gb) +
                             " (incompatible marking)",
                         f);
    }
  }
}

}  // namespace

Mt build_bisection_mt(const TriMesh& base, std::span<const std::uint8_t> refinement_edge, int levels,
                      const BisectionOptions& options, BisectionInfo* info) {
  check_input(base, refinement_edge, levels);
  const std::size_t nf = base.num_faces();

  MtBuilder builder;
  std::vector<glm::vec3> positions = base.positions;  // mirror of the builder's vertices, for the callbacks
  std::vector<std::uint16_t> vertex_level(positions.size(), 0);
  for (const glm::vec3& p : base.positions) builder.add_vertex(p);
  std::vector<FaceId> base_faces(nf);
  std::vector<LevelFace> current(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    base_faces[f] = builder.add_face(base.corner(f, 0), base.corner(f, 1), base.corner(f, 2));
    const int k = refinement_edge[f];
    current[f] = {base_faces[f], base.corner(f, (k + 2) % 3), base.corner(f, k), base.corner(f, (k + 1) % 3)};
  }
  builder.set_base(base_faces);

  std::vector<std::uint16_t> level_of_builder_node{0};
  std::vector<LevelFace> next;
  std::unordered_map<std::uint64_t, std::size_t> by_edge;
  std::vector<std::uint8_t> done;
  for (int level = 1; level <= levels; ++level) {
    by_edge.clear();
    by_edge.reserve(current.size());
    for (std::size_t i = 0; i < current.size(); ++i) by_edge.emplace(directed_edge_key(current[i].e0, current[i].e1), i);
    done.assign(current.size(), 0);
    next.clear();
    next.reserve(2 * current.size());
    for (std::size_t i = 0; i < current.size(); ++i) {
      if (done[i]) continue;
      const LevelFace& t = current[i];
      // Compatibility is inherited from the base (see bisection.hpp), so the twin across the marked edge,
      // if any, marks it too.
      const auto twin = by_edge.find(directed_edge_key(t.e1, t.e0));
      const LevelFace* u = twin == by_edge.end() ? nullptr : &current[twin->second];
      done[i] = 1;
      if (u) done[twin->second] = 1;

      BisectionSplit split;
      split.level = level;
      split.e0 = t.e0;
      split.e1 = t.e1;
      split.apex = {t.apex, u ? u->apex : kInvalid};
      split.positions = positions;
      const glm::vec3 p = options.place_vertex ? options.place_vertex(split)
                                               : (positions[t.e0] + positions[t.e1]) * 0.5f;
      const VertexId m = builder.add_vertex(p);
      positions.push_back(p);
      vertex_level.push_back(static_cast<std::uint16_t>(level));
      split.mid = m;
      split.positions = positions;
      const float error = options.node_error ? options.node_error(split) : 0.0f;

      std::array<FaceId, 2> removed{t.id, kInvalid};
      std::array<FaceId, 4> created{};
      std::size_t nc = 0;
      auto bisect = [&](const LevelFace& f) {
        const FaceId c0 = builder.add_face(m, f.apex, f.e0);
        const FaceId c1 = builder.add_face(m, f.e1, f.apex);
        created[nc++] = c0;
        created[nc++] = c1;
        next.push_back({c0, m, f.apex, f.e0});
        next.push_back({c1, m, f.e1, f.apex});
      };
      bisect(t);
      if (u) {
        removed[1] = u->id;
        bisect(*u);
      }
      builder.add_node(NodeKind::kSplit, std::span<const FaceId>(removed.data(), u ? 2 : 1),
                       std::span<const FaceId>(created.data(), nc), error);
      level_of_builder_node.push_back(static_cast<std::uint16_t>(level));
    }
    current.swap(next);
  }

  std::vector<NodeId> new_to_old;
  Mt mt = std::move(builder).build(options.build, &new_to_old);
  if (info) {
    info->node_level.resize(new_to_old.size());
    for (std::size_t n = 0; n < new_to_old.size(); ++n) info->node_level[n] = level_of_builder_node[new_to_old[n]];
    info->vertex_level = std::move(vertex_level);
  }
  return mt;
}

std::vector<std::uint8_t> mark_longest_edges(const TriMesh& mesh) {
  std::vector<std::uint8_t> mark(mesh.num_faces(), 0);
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    double best_len = -1.0;
    std::uint64_t best_key = 0;
    for (int k = 0; k < 3; ++k) {
      VertexId a = mesh.corner(f, k), b = mesh.corner(f, (k + 1) % 3);
      if (b < a) std::swap(a, b);  // same arithmetic on both sides of a shared edge: ties agree
      const glm::dvec3 d = glm::dvec3(mesh.positions[b]) - glm::dvec3(mesh.positions[a]);
      const double len = d.x * d.x + d.y * d.y + d.z * d.z;
      const std::uint64_t key = directed_edge_key(a, b);
      if (len > best_len || (len == best_len && key < best_key)) {
        best_len = len;
        best_key = key;
        mark[f] = static_cast<std::uint8_t>(k);
      }
    }
  }
  return mark;
}

std::vector<std::uint8_t> mark_edges(const TriMesh& mesh, std::span<const std::array<VertexId, 2>> edges) {
  std::vector<std::uint64_t> keys;
  keys.reserve(edges.size());
  for (const auto& e : edges) keys.push_back(undirected_edge_key(e[0], e[1]));
  std::sort(keys.begin(), keys.end());
  std::vector<std::uint8_t> mark(mesh.num_faces(), 0);
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    int found = 0;
    for (int k = 0; k < 3; ++k)
      if (std::binary_search(keys.begin(), keys.end(), undirected_edge_key(mesh.corner(f, k), mesh.corner(f, (k + 1) % 3)))) {
        mark[f] = static_cast<std::uint8_t>(k);
        ++found;
      }
    if (found != 1)
      throw InvalidInput("mark_edges: face " + std::to_string(f) + " contains " + std::to_string(found) +
                             " of the given edges (needs exactly one)",
                         f);
  }
  return mark;
}

}  // namespace varmesh
