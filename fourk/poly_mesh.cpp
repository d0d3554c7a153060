#include "fourk/poly_mesh.hpp"

#include <algorithm>

#include <cmath>
#include <numbers>
#include <string>
#include <unordered_map>

#include "fourk/semiregular.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

namespace {


}  // namespace

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
  std::vector<Index> used_by(nv, kInvalid);  // the face that last used each vertex: repeated corners in O(k)
  // Directed edge -> corner slot (the corner where the edge starts).
  std::unordered_map<std::uint64_t, Index> directed;
  directed.reserve(corners.size() * 2);
  std::vector<Index> corners_at(nv, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    if (face_offsets[f + 1] < face_offsets[f] || face_offsets[f + 1] > corners.size())
      throw InvalidInput("polygon mesh: face_offsets decrease or run past the corners at face " + std::to_string(f), f);
    const std::size_t k = face_size(f);
    if (k < 3) throw InvalidInput("polygon mesh: face " + std::to_string(f) + " has fewer than 3 corners", f);
    const auto fc = face(f);
    for (std::size_t i = 0; i < k; ++i) {
      if (fc[i] >= nv)
        throw InvalidInput("polygon mesh: face " + std::to_string(f) + " uses vertex " + std::to_string(fc[i]) +
                               " out of range (" + std::to_string(nv) + " vertices)",
                           f);
      if (used_by[fc[i]] == f)
        throw InvalidInput("polygon mesh: face " + std::to_string(f) + " repeats vertex " + std::to_string(fc[i]), f);
      used_by[fc[i]] = static_cast<Index>(f);
    }
    for (std::size_t i = 0; i < k; ++i) {
      const Index a = fc[i], b = fc[(i + 1) % k];
      ++corners_at[a];
      if (!directed.emplace(directed_edge_key(a, b), static_cast<Index>(face_offsets[f] + i)).second)
        throw InvalidInput("polygon mesh: edge " + std::to_string(a) + "-" + std::to_string(b) + " of face " +
                               std::to_string(f) +
                               " is used twice in the same direction (non-manifold edge or inconsistent orientation)",
                           f);
    }
  }
  // Corner slot -> face, to step around vertices.
  std::vector<Index> slot_face(corners.size());
  for (std::size_t f = 0; f < nf; ++f)
    for (Index s = face_offsets[f]; s < face_offsets[f + 1]; ++s) slot_face[s] = static_cast<Index>(f);
  auto next_slot = [&](Index s) {
    const Index f = slot_face[s];
    return s + 1 == face_offsets[f + 1] ? face_offsets[f] : s + 1;
  };
  auto prev_slot = [&](Index s) {
    const Index f = slot_face[s];
    return s == face_offsets[f] ? face_offsets[f + 1] - 1 : s - 1;
  };
  // One fan per vertex: walk from the first corner of each vertex both ways and count the corners met.
  std::vector<std::uint8_t> seen(nv, 0);
  for (Index s0 = 0; s0 < corners.size(); ++s0) {
    const Index v = corners[s0];
    if (seen[v]) continue;
    seen[v] = 1;
    std::size_t count = 1;
    bool closed = false;
    // Clockwise: the face across the outgoing edge v -> n holds the directed edge n -> v.
    for (Index s = s0;;) {
      const Index n = corners[next_slot(s)];
      auto it = directed.find(directed_edge_key(n, v));
      if (it == directed.end()) break;
      s = next_slot(it->second);  // corner of v in the neighbouring face
      if (s == s0) {
        closed = true;
        break;
      }
      if (++count > corners_at[v]) break;
    }
    if (!closed) {
      // Counter-clockwise from s0: the face across the incoming edge p -> v holds v -> p.
      for (Index s = s0;;) {
        const Index p = corners[prev_slot(s)];
        auto it = directed.find(directed_edge_key(v, p));
        if (it == directed.end()) break;
        s = it->second;
        if (++count > corners_at[v]) break;
      }
    }
    if (count != corners_at[v])
      throw InvalidInput("polygon mesh: the faces around vertex " + std::to_string(v) +
                             " form more than one fan (non-manifold vertex)",
                         v);
  }
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
