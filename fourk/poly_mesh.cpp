#include "fourk/poly_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <unordered_map>

#include "fourk/semiregular.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

void PolyMesh::add_face(std::span<const Index> face_corners) {
  corners.insert(corners.end(), face_corners.begin(), face_corners.end());
  face_offsets.push_back(static_cast<Index>(corners.size()));
}

bool PolyMesh::all_quads() const noexcept {
  for (std::size_t f = 0; f < num_faces(); ++f)
    if (face_size(f) != 4) return false;
  return true;
}

void PolyMesh::validate() const {
  if (face_offsets.empty() || face_offsets.front() != 0)
    throw InvalidInput("polygon mesh: face_offsets must start with 0");
  if (face_offsets.back() != corners.size())
    throw InvalidInput("polygon mesh: face_offsets must end with the number of corners");
  const std::size_t nf = num_faces();
  if (nf == 0) throw InvalidInput("polygon mesh has no face");
  const std::size_t nv = positions.size();
  for (std::size_t v = 0; v < nv; ++v) {
    const glm::dvec3& p = positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InvalidInput("polygon mesh: vertex " + std::to_string(v) + " has a non-finite coordinate", v);
    // The schemes sum a face's or a ring's points before they divide: past 1e300 the sums overflow.
    if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > 1e300)
      throw InvalidInput("polygon mesh: vertex " + std::to_string(v) + " has a coordinate beyond 1e300 in size", v);
  }
  // find_topology_problem refuses these too, in its own words; said here as the polygon mesh's.
  for (std::size_t f = 0; f < nf; ++f) {
    if (face_offsets[f + 1] < face_offsets[f] || face_offsets[f + 1] > corners.size())
      throw InvalidInput("polygon mesh: face_offsets decrease or run past the corners at face " + std::to_string(f), f);
    const std::size_t k = face_size(f);
    if (k < 3) throw InvalidInput("polygon mesh: face " + std::to_string(f) + " has fewer than 3 corners", f);
    for (Index c : face(f))
      if (c >= nv)
        throw InvalidInput("polygon mesh: face " + std::to_string(f) + " uses vertex " + std::to_string(c) +
                               " out of range (" + std::to_string(nv) + " vertices)",
                           f);
  }
  const TopologyProblem problem = find_topology_problem(*this, kPolyMeshRules);
  if (problem) throw InvalidInput("polygon mesh: " + describe_topology_problem(problem), problem.element());
}

Index TopologyProblem::element() const noexcept {
  switch (rule) {
    case TopologyRule::kNone: return kInvalid;
    case TopologyRule::kRepeatedCorner: return faces.empty() ? kInvalid : faces[0];
    case TopologyRule::kNonManifoldEdge: return faces.size() < 3 ? kInvalid : faces[2];
    case TopologyRule::kInconsistentOrientation:
    case TopologyRule::kDoubledFace: return faces.size() < 2 ? kInvalid : faces[1];
    case TopologyRule::kNonManifoldVertex: return vertices[0];
  }
  return kInvalid;
}

TopologyProblem find_topology_problem(std::span<const Index> face_offsets, std::span<const Index> corners,
                                      std::size_t num_vertices, const TopologyRules& rules,
                                      std::vector<Index>* opposite) {
  if (face_offsets.empty() || face_offsets.front() != 0 || face_offsets.back() != corners.size())
    throw InvalidInput("find_topology_problem: face_offsets must start with 0 and end with the number of corners");
  if (corners.size() >= kInvalid) throw InvalidInput("find_topology_problem: 2^32 corners or more");
  const std::size_t nf = face_offsets.size() - 1, nc = corners.size();
  // Corner slot -> face, checking the offsets and the corners on the way.
  std::vector<Index> slot_face(nc);
  for (std::size_t f = 0; f < nf; ++f) {
    const Index b = face_offsets[f], e = face_offsets[f + 1];
    if (e < b || e > nc)
      throw InvalidInput("find_topology_problem: face_offsets decrease or run past the corners at face " +
                             std::to_string(f),
                         f);
    if (e - b < 3) throw InvalidInput("find_topology_problem: face " + std::to_string(f) + " has fewer than 3 corners", f);
    for (Index s = b; s < e; ++s) {
      if (corners[s] >= num_vertices)
        throw InvalidInput("find_topology_problem: face " + std::to_string(f) + " uses vertex " +
                               std::to_string(corners[s]) + " out of range (" + std::to_string(num_vertices) +
                               " vertices)",
                           f);
      slot_face[s] = static_cast<Index>(f);
    }
  }
  auto next = [&](Index s) { return s + 1 == face_offsets[slot_face[s] + 1] ? face_offsets[slot_face[s]] : s + 1; };
  TopologyProblem p;

  // 1. Repeated corners, face by face: the last face to use each vertex tells in O(k).
  {
    std::vector<Index> used_by(num_vertices, kInvalid);
    for (Index s = 0; s < nc; ++s) {
      const Index v = corners[s];
      if (used_by[v] == slot_face[s]) {
        p.rule = TopologyRule::kRepeatedCorner;
        p.faces = {slot_face[s]};
        p.vertices[0] = v;
        return p;
      }
      used_by[v] = slot_face[s];
    }
  }

  // 2. Edges, grouped without a global sort: the sides bucketed by their lower vertex (a stable counting
  // sort, so the slots stay in face order), each bucket (about a valence long) sorted by the upper vertex,
  // then slot. Along one edge the sides then come in face order, so each group's problem shows at a known
  // slot: the second side when it runs the way of the first (a third side, if any, comes later), else the
  // third side. With distinct corners a face has an edge once at most.
  std::vector<Index> to(nc);  // where the side from slot s ends
  for (Index s = 0; s < nc; ++s) to[s] = corners[next(s)];
  auto low = [&](Index s) { return std::min(corners[s], to[s]); };
  auto high = [&](Index s) { return std::max(corners[s], to[s]); };
  auto same_edge = [&](Index s, Index t) { return low(s) == low(t) && high(s) == high(t); };
  std::vector<Index> by_edge(nc);
  {
    std::vector<Index> start(num_vertices + 1, 0);
    for (Index s = 0; s < nc; ++s) ++start[low(s) + 1];
    for (std::size_t v = 0; v < num_vertices; ++v) start[v + 1] += start[v];
    std::vector<Index> fill(start.begin(), start.end() - 1);
    for (Index s = 0; s < nc; ++s) by_edge[fill[low(s)]++] = s;
    for (std::size_t v = 0; v < num_vertices; ++v)
      if (start[v + 1] - start[v] > 1)
        std::sort(by_edge.begin() + start[v], by_edge.begin() + start[v + 1],
                  [&](Index x, Index y) { return high(x) != high(y) ? high(x) < high(y) : x < y; });
  }
  {
    Index shows_first = kInvalid;
    std::size_t group = 0, group_end = 0;
    for (std::size_t i = 0; i < nc;) {
      std::size_t j = i + 1;
      while (j < nc && same_edge(by_edge[j], by_edge[i])) ++j;
      Index shows = kInvalid;
      if (j - i >= 2 && corners[by_edge[i]] == corners[by_edge[i + 1]]) shows = by_edge[i + 1];
      else if (j - i >= 3) shows = by_edge[i + 2];
      if (shows < shows_first) {
        shows_first = shows;
        group = i;
        group_end = j;
      }
      i = j;
    }
    if (shows_first != kInvalid) {
      p.rule = group_end - group >= 3 ? TopologyRule::kNonManifoldEdge : TopologyRule::kInconsistentOrientation;
      for (std::size_t i = group; i < group_end; ++i) p.faces.push_back(slot_face[by_edge[i]]);
      p.vertices = {corners[by_edge[group]], to[by_edge[group]]};
      return p;
    }
  }
  // Every edge has one side now, or two opposite ones: adjacent in by_edge.
  if (opposite) {
    opposite->assign(nc, kInvalid);
    for (std::size_t i = 0; i + 1 < nc; ++i)
      if (same_edge(by_edge[i], by_edge[i + 1])) {
        (*opposite)[by_edge[i]] = by_edge[i + 1];
        (*opposite)[by_edge[i + 1]] = by_edge[i];
      }
  }

  // 3. Doubled faces. Faces on the same vertices have the same lowest one: the faces bucketed by it (stably,
  // in face order), each bucket sorted by the sorted corners, then number; a run of equal sets starts with
  // its two first faces.
  if (rules.distinct_faces) {
    std::vector<Index> sorted(corners.begin(), corners.end());
    for (std::size_t f = 0; f < nf; ++f) std::sort(sorted.begin() + face_offsets[f], sorted.begin() + face_offsets[f + 1]);
    auto set_of = [&](Index f) {
      return std::span<const Index>(sorted.data() + face_offsets[f], face_offsets[f + 1] - face_offsets[f]);
    };
    auto same_set = [&](Index f, Index g) { return std::ranges::equal(set_of(f), set_of(g)); };
    std::vector<Index> start(num_vertices + 1, 0);
    for (std::size_t f = 0; f < nf; ++f) ++start[sorted[face_offsets[f]] + 1];
    for (std::size_t v = 0; v < num_vertices; ++v) start[v + 1] += start[v];
    std::vector<Index> fill(start.begin(), start.end() - 1), by_low(nf);
    for (std::size_t f = 0; f < nf; ++f) by_low[fill[sorted[face_offsets[f]]]++] = static_cast<Index>(f);
    Index later = kInvalid, earlier = kInvalid;
    for (std::size_t v = 0; v < num_vertices; ++v) {
      const auto first = by_low.begin() + start[v], last = by_low.begin() + start[v + 1];
      if (last - first < 2) continue;
      std::sort(first, last, [&](Index f, Index g) {
        const auto x = set_of(f), y = set_of(g);
        if (x.size() != y.size()) return x.size() < y.size();
        const auto [ix, iy] = std::ranges::mismatch(x, y);
        return ix != x.end() ? *ix < *iy : f < g;
      });
      for (auto it = first; it + 1 != last; ++it)
        if ((it == first || !same_set(it[-1], it[0])) && same_set(it[0], it[1]) && it[1] < later) {
          earlier = it[0];
          later = it[1];
        }
    }
    if (later != kInvalid) {
      p.rule = TopologyRule::kDoubledFace;
      p.faces = {earlier, later};
      return p;
    }
  }

  // 4. Fans: the corners of a vertex joined across the edges at it (union-find over slots). Face f runs
  // a -> b from slot s and face g runs b -> a from slot t: the corners of a are s and next(t), those of b
  // next(s) and t.
  if (rules.one_fan_per_vertex) {
    std::vector<Index> parent(nc);
    for (Index s = 0; s < nc; ++s) parent[s] = s;
    auto find = [&parent](Index x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (std::size_t i = 0; i + 1 < nc; ++i)
      if (same_edge(by_edge[i], by_edge[i + 1])) {
        const Index s = by_edge[i], t = by_edge[i + 1];
        parent[find(s)] = find(next(t));
        parent[find(next(s))] = find(t);
      }
    std::vector<Index> fan_of(num_vertices, kInvalid);  // the root of the fan of the vertex's first corner
    Index worst = kInvalid;
    for (Index s = 0; s < nc; ++s) {
      const Index v = corners[s], root = find(s);
      if (fan_of[v] == kInvalid) fan_of[v] = root;
      else if (fan_of[v] != root) worst = std::min(worst, v);
    }
    if (worst != kInvalid) {
      // The slots come in face order, so each fan's first slot met is in its first face.
      std::vector<Index> roots;
      for (Index s = 0; s < nc; ++s)
        if (corners[s] == worst && std::find(roots.begin(), roots.end(), find(s)) == roots.end()) {
          roots.push_back(find(s));
          p.faces.push_back(slot_face[s]);
        }
      p.rule = TopologyRule::kNonManifoldVertex;
      p.vertices[0] = worst;
      return p;
    }
  }
  return p;
}

TopologyProblem find_topology_problem(const PolyMesh& mesh, const TopologyRules& rules) {
  return find_topology_problem(mesh.face_offsets, mesh.corners, mesh.num_vertices(), rules);
}

TopologyProblem find_topology_problem(const TriMesh& mesh, const TopologyRules& rules, std::vector<Index>* opposite) {
  if (mesh.indices.size() % 3 != 0) throw InvalidInput("find_topology_problem: the index count is not a multiple of 3");
  if (mesh.indices.size() >= kInvalid) throw InvalidInput("find_topology_problem: 2^32 corners or more");
  std::vector<Index> offsets(mesh.num_faces() + 1);
  for (std::size_t f = 0; f < offsets.size(); ++f) offsets[f] = static_cast<Index>(3 * f);
  return find_topology_problem(offsets, mesh.indices, mesh.num_vertices(), rules, opposite);
}

namespace {

std::string str(std::uint64_t x) { return std::to_string(x); }

// "faces 0, 1 and 2".
std::string face_list(const std::vector<Index>& faces) {
  std::string s = faces.size() == 1 ? "face " : "faces ";
  for (std::size_t i = 0; i < faces.size(); ++i) s += (i == 0 ? "" : i + 1 == faces.size() ? " and " : ", ") + str(faces[i]);
  return s;
}

}  // namespace

std::string describe_topology_problem(const TopologyProblem& p) {
  const std::string edge = "(" + str(p.vertices[0]) + ", " + str(p.vertices[1]) + ")";
  switch (p.rule) {
    case TopologyRule::kNone: return {};
    case TopologyRule::kRepeatedCorner:
      return "face " + str(p.faces[0]) + " repeats vertex " + str(p.vertices[0]) + " (a degenerate face)";
    case TopologyRule::kNonManifoldEdge:
      return "the edge " + edge + " belongs to " + str(p.faces.size()) + " faces, " + face_list(p.faces) +
             " (non-manifold edge)";
    case TopologyRule::kInconsistentOrientation:
      return "face " + str(p.faces[1]) + " uses the edge " + edge + " in the same direction as face " + str(p.faces[0]) +
             " (inconsistent orientation)";
    case TopologyRule::kDoubledFace:
      return "face " + str(p.faces[1]) + " has the same vertices as face " + str(p.faces[0]) + " (a doubled face)";
    case TopologyRule::kNonManifoldVertex:
      return "the faces around vertex " + str(p.vertices[0]) + " form " + str(p.faces.size()) +
             " fans that share no edge there, " + face_list(p.faces) +
             " lie in different ones (non-manifold vertex)";
  }
  return {};
}

PolyEdgeCount count_edges(const PolyMesh& mesh) {
  std::unordered_map<std::uint64_t, int> seen;
  seen.reserve(mesh.corners.size());
  PolyEdgeCount c;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    const auto fc = mesh.face(f);
    for (std::size_t i = 0; i < fc.size(); ++i) {
      Index a = fc[i], b = fc[(i + 1) % fc.size()];
      if (a > b) std::swap(a, b);
      ++seen[directed_edge_key(a, b)];
    }
  }
  c.edges = seen.size();
  for (const auto& [key, n] : seen)
    if (n == 1) ++c.border_edges;
  return c;
}

PolyMesh poly_from_triangles(const TriMesh& mesh) {
  PolyMesh out;
  out.positions.assign(mesh.positions.begin(), mesh.positions.end());
  out.corners.assign(mesh.indices.begin(), mesh.indices.end());
  out.face_offsets.resize(mesh.num_faces() + 1);
  for (std::size_t f = 0; f <= mesh.num_faces(); ++f) out.face_offsets[f] = static_cast<Index>(3 * f);
  return out;
}

PolyMesh pair_triangles(const TriMesh& mesh, std::size_t* num_leftovers) {
  const DualMatching m = match_dual_faces(mesh);
  PolyMesh out;
  out.positions.assign(mesh.positions.begin(), mesh.positions.end());
  out.corners.reserve(mesh.indices.size() + 1);
  out.face_offsets.reserve(mesh.num_faces() + 1);
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    const Index g = m.mate[f];
    const int k = m.refinement_edge[f];
    const Index a = mesh.corner(f, k), b = mesh.corner(f, (k + 1) % 3), x = mesh.corner(f, (k + 2) % 3);
    if (g == kInvalid) {
      const Index tri[3] = {a, b, x};
      out.add_face(tri);
      continue;
    }
    if (g < f) continue;  // emitted with its mate
    // The mate holds the directed edge b -> a; its third corner y lies across a-b.
    const int kg = m.refinement_edge[g];
    const Index y = mesh.corner(g, (kg + 2) % 3);
    // Face f = (a, b, x) with a -> b the shared edge; the quad in orientation order is (a, y, b, x),
    // corners 0 and 2 = a and b.
    const Index quad[4] = {a, y, b, x};
    out.add_face(quad);
  }
  if (num_leftovers) *num_leftovers = m.num_leftovers;
  return out;
}

TriMesh triangulate(const PolyMesh& mesh) {
  if (mesh.face_offsets.empty() || mesh.face_offsets.front() != 0 || mesh.face_offsets.back() != mesh.corners.size())
    throw InvalidInput("triangulate: face_offsets must start with 0 and end with the number of corners");
  const std::size_t nv = mesh.positions.size();
  std::size_t triangles = 0;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    if (mesh.face_offsets[f + 1] < mesh.face_offsets[f] || mesh.face_offsets[f + 1] > mesh.corners.size())
      throw InvalidInput("triangulate: face_offsets decrease or run past the corners at face " + std::to_string(f), f);
    for (Index c : mesh.face(f))
      if (c >= nv)
        throw InvalidInput("triangulate: face " + std::to_string(f) + " uses vertex " + std::to_string(c) +
                               " out of range (" + std::to_string(nv) + " vertices)",
                           f);
    triangles += mesh.face_size(f) >= 3 ? mesh.face_size(f) - 2 : 0;
  }
  TriMesh out;
  out.positions.reserve(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const glm::vec3 p(mesh.positions[v]);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InvalidInput("triangulate: vertex " + std::to_string(v) + " is not finite in float", v);
    out.positions.push_back(p);
  }
  out.indices.reserve(3 * triangles);
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    const auto fc = mesh.face(f);
    for (std::size_t i = 1; i + 1 < fc.size(); ++i) out.indices.insert(out.indices.end(), {fc[0], fc[i], fc[i + 1]});
  }
  return out;
}

PolyMesh make_quad_cube() {
  PolyMesh m;
  for (int i = 0; i < 8; ++i) m.positions.emplace_back(i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -1.0, i & 4 ? 1.0 : -1.0);
  // Counter-clockwise seen from outside.
  const Index faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) m.add_face(f);
  return m;
}

PolyMesh make_quad_torus(int nu, int nv, double major_radius, double minor_radius) {
  if (nu < 3 || nv < 3) throw InvalidInput("make_quad_torus: nu and nv must be at least 3");
  PolyMesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * i / nu, v = 2 * std::numbers::pi * j / nv;
      const double rr = major_radius + minor_radius * std::cos(v);
      m.positions.emplace_back(rr * std::cos(u), rr * std::sin(u), minor_radius * std::sin(v));
    }
  auto id = [&](int i, int j) { return static_cast<Index>(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const Index q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
      m.add_face(q);
    }
  return m;
}

}  // namespace varmesh
