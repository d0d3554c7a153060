// The faces of a mesh file as the file lists them (see file_faces.hpp).
#include "apps/file_faces.hpp"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

#include "apps/cli_util.hpp"
#include "multitri/errors.hpp"

namespace varmesh::app {

namespace {

// "face 3 (line 12)", "faces 1 and 3 (lines 10 and 12)", "faces 1, 3 and 4 (lines 10, 12 and 13)".
std::string name_faces(const FileFaces& ff, const std::vector<std::size_t>& faces) {
  std::string numbers, lines;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const char* sep = i == 0 ? "" : i + 1 == faces.size() ? " and " : ", ";
    numbers += sep + std::to_string(faces[i] + 1);
    lines += sep + std::to_string(ff.lines[faces[i]]);
  }
  const std::string named = noun_for(faces.size(), "face") + " " + numbers;
  // A binary PLY has no lines to name (they are all 0).
  if (ff.lines[faces[0]] == 0) return named;
  return named + " (" + noun_for(faces.size(), "line") + " " + lines + ")";
}

std::uint64_t edge_key(Index a, Index b) { return (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b); }

}  // namespace

std::optional<FileFaces> file_faces(const TriMesh& mesh, const ReadInfo& info) {
  const std::size_t nf = info.face_corners.size();
  if (info.triangle_face.size() != mesh.num_faces() || info.face_lines.size() != nf ||
      info.vertex_lines.size() != mesh.num_vertices())
    return std::nullopt;
  FileFaces ff;
  ff.first_vertex = info.first_vertex_number;
  ff.vertex_lines = info.vertex_lines;
  ff.lines = info.face_lines;
  ff.offsets.reserve(nf + 1);
  ff.corners.reserve(mesh.num_faces() + 2 * nf);
  // Face f of k corners (c0, ..., c(k-1)) was read as the k - 2 triangles (c0, c(i-1), c(i)), i = 2..k, in
  // file order: the corners come back from the fans. A strip (0 corners) is no polygon, and a triangle that
  // does not continue its fan means `info` belongs to another mesh.
  std::size_t t = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const std::size_t k = info.face_corners[f];
    if (k < 3 || t + (k - 2) > mesh.num_faces() || info.triangle_face[t] != f ||
        info.triangle_face[t + (k - 3)] != f)
      return std::nullopt;
    const Index c0 = mesh.corner(t, 0);
    ff.corners.insert(ff.corners.end(), {c0, mesh.corner(t, 1), mesh.corner(t, 2)});
    for (std::size_t i = 1; i + 2 < k; ++i) {
      if (mesh.corner(t + i, 0) != c0 || mesh.corner(t + i, 1) != ff.corners.back()) return std::nullopt;
      ff.corners.push_back(mesh.corner(t + i, 2));
    }
    t += k - 2;
    ff.offsets.push_back(ff.corners.size());
  }
  if (t != mesh.num_faces()) return std::nullopt;
  return ff;
}

std::optional<FileFaces> read_file_faces(const std::string& path) {
  ReadInfo info;
  info.want_sources = true;
  TriMesh mesh;
  try {
    mesh = read_mesh(path, &info);
  } catch (const IoError&) {
    return std::nullopt;  // gone or changed since the first read: the caller keeps the library's words
  }
  return file_faces(mesh, info);
}

std::string topology_problem(const FileFaces& ff, std::size_t* line) {
  const std::size_t nf = ff.num_faces();
  std::size_t num_vertices = 0;
  for (Index c : ff.corners) num_vertices = std::max<std::size_t>(num_vertices, std::size_t{c} + 1);
  auto vertex = [&ff](Index v) { return std::to_string(std::uint64_t{v} + ff.first_vertex); };
  auto at = [line](std::size_t l, std::string text) {
    if (line) *line = l;
    return text;
  };
  // Corner slots: the face of each, and the slot after each in its face.
  std::vector<std::size_t> face_of(ff.corners.size());
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t s = ff.offsets[f]; s < ff.offsets[f + 1]; ++s) face_of[s] = f;
  auto next = [&](std::size_t s) { return s + 1 == ff.offsets[face_of[s] + 1] ? ff.offsets[face_of[s]] : s + 1; };

  std::vector<std::size_t> used_by(num_vertices, SIZE_MAX);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t s = ff.offsets[f]; s < ff.offsets[f + 1]; ++s) {
      if (used_by[ff.corners[s]] == f)
        return at(ff.lines[f], name_faces(ff, {f}) + " lists vertex " + vertex(ff.corners[s]) +
                                   " twice: a face needs distinct corners");
      used_by[ff.corners[s]] = f;
    }

  // Each edge's slots in file order: the slot where a face's side along it starts.
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> edges;
  edges.reserve(ff.corners.size());
  for (std::size_t s = 0; s < ff.corners.size(); ++s) edges[edge_key(ff.corners[s], ff.corners[next(s)])].push_back(s);
  // Of the edges that break a rule, the one whose last face comes first in the file, so that the message
  // does not depend on the hash map's order.
  auto first_edge = [&](auto&& breaks) {
    const std::vector<std::size_t>* found = nullptr;
    for (const auto& [key, slots] : edges)
      if (breaks(slots) && (!found || face_of[slots.back()] < face_of[found->back()] ||
                            (face_of[slots.back()] == face_of[found->back()] && slots.front() < found->front())))
        found = &slots;
    return found;
  };
  if (const auto* slots = first_edge([](const std::vector<std::size_t>& s) { return s.size() > 2; })) {
    std::vector<std::size_t> faces;
    for (std::size_t s : *slots) faces.push_back(face_of[s]);
    const Index a = std::min(ff.corners[slots->front()], ff.corners[next(slots->front())]);
    const Index b = std::max(ff.corners[slots->front()], ff.corners[next(slots->front())]);
    return at(ff.lines[faces[2]], "the edge " + vertex(a) + "-" + vertex(b) + " belongs to " +
                                      std::to_string(faces.size()) + " faces, " + name_faces(ff, faces) +
                                      ": a non-manifold edge (at most two faces may share an edge)");
  }
  const auto* same = first_edge([&](const std::vector<std::size_t>& s) {
    return s.size() == 2 && ff.corners[s[0]] == ff.corners[s[1]];
  });
  if (same) {
    const std::size_t s = same->front();
    const std::size_t g = face_of[same->back()];
    return at(ff.lines[g], name_faces(ff, {face_of[s], g}) + " both run the edge " + vertex(ff.corners[s]) + "-" +
                               vertex(ff.corners[next(s)]) + " from " + vertex(ff.corners[s]) + " to " +
                               vertex(ff.corners[next(s)]) +
                               ": their orientations disagree (faces that share an edge must run it in opposite "
                               "directions)");
  }

  // Every edge now has one face, or two that run it in opposite directions. The corners of a vertex fall into
  // fans joined across the edges at it; more than one fan is a non-manifold vertex.
  std::vector<std::size_t> parent(ff.corners.size());
  for (std::size_t s = 0; s < parent.size(); ++s) parent[s] = s;
  auto find = [&parent](std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& [key, slots] : edges)
    if (slots.size() == 2) {
      // Face f runs a -> b from slot s, face g runs b -> a from slot t: the corners of a are s and next(t).
      const std::size_t s = slots[0], t = slots[1];
      parent[find(s)] = find(next(t));
      parent[find(next(s))] = find(t);
    }
  std::vector<std::size_t> first_slot(num_vertices, SIZE_MAX), other_slot(num_vertices, SIZE_MAX);
  for (std::size_t s = 0; s < ff.corners.size(); ++s) {
    const Index v = ff.corners[s];
    if (first_slot[v] == SIZE_MAX) first_slot[v] = s;
    else if (other_slot[v] == SIZE_MAX && find(s) != find(first_slot[v])) other_slot[v] = s;
  }
  for (Index v = 0; v < num_vertices; ++v) {
    if (other_slot[v] == SIZE_MAX) continue;
    std::vector<std::size_t> roots;
    for (std::size_t s = 0; s < ff.corners.size(); ++s)
      if (ff.corners[s] == v) roots.push_back(find(s));
    std::sort(roots.begin(), roots.end());
    const std::size_t fans = static_cast<std::size_t>(std::unique(roots.begin(), roots.end()) - roots.begin());
    const std::size_t v_line = v < ff.vertex_lines.size() ? ff.vertex_lines[v] : 0;
    return at(v_line, "the faces at vertex " + vertex(v) + " form " + std::to_string(fans) +
                          " fans that share no edge there, e.g. " +
                          name_faces(ff, {face_of[first_slot[v]], face_of[other_slot[v]]}) +
                          ": a non-manifold vertex (the faces around a vertex must form one fan)");
  }
  return {};
}

}  // namespace varmesh::app
