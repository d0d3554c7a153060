// The faces of a mesh file as the file lists them (see file_faces.hpp).
#include "apps/file_faces.hpp"

#include <algorithm>
#include <cstdint>

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

TopologyProblem find_topology_problem(const FileFaces& ff, const TopologyRules& rules) {
  std::size_t num_vertices = ff.vertex_lines.size();
  for (Index c : ff.corners) num_vertices = std::max<std::size_t>(num_vertices, std::size_t{c} + 1);
  if (ff.corners.size() >= kInvalid) throw InvalidInput("topology check: 2^32 corners or more");
  const std::vector<Index> offsets(ff.offsets.begin(), ff.offsets.end());  // each <= corners.size()
  return varmesh::find_topology_problem(offsets, ff.corners, num_vertices, rules);
}

std::string describe_topology_problem(const FileFaces& ff, const TopologyProblem& p, std::size_t* line) {
  auto vertex = [&ff](Index v) { return std::to_string(std::uint64_t{v} + ff.first_vertex); };
  auto at = [line](std::size_t l, std::string text) {
    if (line) *line = l;
    return text;
  };
  const std::vector<std::size_t> faces(p.faces.begin(), p.faces.end());
  const Index a = p.vertices[0], b = p.vertices[1];
  switch (p.rule) {
    case TopologyRule::kNone: return {};
    case TopologyRule::kRepeatedCorner:
      return at(ff.lines[faces[0]],
                name_faces(ff, faces) + " lists vertex " + vertex(a) + " twice: a face needs distinct corners");
    case TopologyRule::kNonManifoldEdge:
      return at(ff.lines[faces[2]], "the edge " + vertex(std::min(a, b)) + "-" + vertex(std::max(a, b)) + " belongs to " +
                                        std::to_string(faces.size()) + " faces, " + name_faces(ff, faces) +
                                        ": a non-manifold edge (at most two faces may share an edge)");
    case TopologyRule::kInconsistentOrientation:
      return at(ff.lines[faces[1]], name_faces(ff, faces) + " both run the edge " + vertex(a) + "-" + vertex(b) + " from " +
                                        vertex(a) + " to " + vertex(b) +
                                        ": their orientations disagree (faces that share an edge must run it in "
                                        "opposite directions)");
    case TopologyRule::kDoubledFace:
      return at(ff.lines[faces[1]], name_faces(ff, faces) +
                                        " have the same vertices: a doubled face (no two faces may lie on the same "
                                        "vertices)");
    case TopologyRule::kNonManifoldVertex:
      return at(a < ff.vertex_lines.size() ? ff.vertex_lines[a] : 0,
                "the faces at vertex " + vertex(a) + " form " + std::to_string(faces.size()) +
                    " fans that share no edge there, e.g. " + name_faces(ff, faces) +
                    ": a non-manifold vertex (the faces around a vertex must form one fan)");
  }
  return {};
}

std::string topology_problem(const FileFaces& ff, std::size_t* line, const TopologyRules& rules) {
  return describe_topology_problem(ff, find_topology_problem(ff, rules), line);
}

}  // namespace varmesh::app
