#pragma once
/// The faces of a mesh file as the file lists them, for messages that name a face the user can find.
///
/// The readers (multitri/mesh_io.hpp) fan-triangulate polygons and number vertices from 0, and the commands
/// rebuild polygons from the fans (subdiv), so an error of the library names a face of a mesh the file never
/// held ("face 1" of the rebuilt quads was the file's third face, and OBJ vertex 1 was "vertex 0"). These
/// helpers find the file's own faces again: their corner counts and lines from a second look at the text,
/// their corners from the triangles the reader made.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "multitri/tri_mesh.hpp"

namespace varmesh::app {

/// A file's faces in file order. Face f has the corners corners[offsets[f] .. offsets[f + 1]) (vertex ids as
/// read_mesh numbers them, from 0) and sits on the 1-based line lines[f]; vertex v sits on vertex_lines[v].
/// The file itself calls vertex v "v + first_vertex": OBJ counts from 1, OFF from 0.
struct FileFaces {
  std::vector<std::size_t> offsets{0};
  std::vector<Index> corners;
  std::vector<std::size_t> lines;
  std::vector<std::size_t> vertex_lines;
  Index first_vertex = 0;

  std::size_t num_faces() const { return offsets.size() - 1; }
};

/// The faces of the OBJ or OFF file `data` (named `path`, whose extension gives the format) that read_mesh
/// read as `mesh`. The text is scanned for each face's corner count and line (LF, CRLF and a lone CR end a
/// line, '#' starts a comment, as the readers take them), and the corners are taken from the mesh's fans.
/// Nothing for other formats (PLY: its binary bodies would need the reader's header logic again) or when the
/// scan and `mesh` disagree (a file that changed in between, or text the readers take in a way this scan
/// does not follow): the caller then keeps the library's words.
std::optional<FileFaces> file_faces(const std::string& path, std::string_view data, const TriMesh& mesh);

/// The same for the file `path` itself; nothing when it cannot be read.
std::optional<FileFaces> read_file_faces(const std::string& path, const TriMesh& mesh);

/// The first reason, in the file's words, why `faces` do not make a manifold, consistently oriented polygon
/// mesh (what PolyMesh::validate() requires): a face that repeats a vertex, an edge of more than two faces,
/// two faces that run an edge in the same direction, or a vertex whose faces form more than one fan.
/// Faces are named by their number in the file (from 1) and line, vertices by the file's numbers. `line`
/// receives the line the problem shows on (the face or vertex found last); empty when there is no problem.
std::string topology_problem(const FileFaces& faces, std::size_t* line = nullptr);

}  // namespace varmesh::app
