#pragma once
/// The faces of a mesh file as the file lists them, for messages that name a face the user can find.
///
/// The readers (multitri/mesh_io.hpp) fan-triangulate polygons and number vertices from 0, and the commands
/// rebuild polygons from the fans (subdiv), so an error of the library names a face of a mesh the file never
/// held ("face 1" of the rebuilt quads was the file's third face, and OBJ vertex 1 was "vertex 0"). These
/// helpers find the file's own faces again from the provenance the readers report on request
/// (ReadInfo::want_sources): each face's corner count, line and triangles, each vertex's line.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "fourk/poly_mesh.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh::app {

/// A file's faces in file order. Face f has the corners corners[offsets[f] .. offsets[f + 1]) (vertex ids as
/// read_mesh numbers them, from 0) and sits on the 1-based line lines[f]; vertex v sits on vertex_lines[v].
/// The file itself calls vertex v "v + first_vertex": OBJ counts from 1, OFF and PLY from 0. Lines are 0 in a
/// binary PLY.
struct FileFaces {
  std::vector<std::size_t> offsets{0};
  std::vector<Index> corners;
  std::vector<std::size_t> lines;
  std::vector<std::size_t> vertex_lines;
  Index first_vertex = 0;

  std::size_t num_faces() const { return offsets.size() - 1; }
};

/// The faces of the file that read_mesh read as `mesh`, with `info` filled by the same call with want_sources
/// set: the corners are taken from the mesh's fans, lines from `info`. Nothing when the file holds PLY
/// triangle strips (which are not polygons) or when `info` does not describe `mesh` (no provenance asked for,
/// or another read's).
std::optional<FileFaces> file_faces(const TriMesh& mesh, const ReadInfo& info);

/// Reads the mesh file `path` with provenance and returns its faces; nothing when it cannot be read or as
/// file_faces. For messages after a first read found a problem: the common read asks for no provenance.
std::optional<FileFaces> read_file_faces(const std::string& path);

/// find_topology_problem() (fourk/poly_mesh.hpp) over the file's faces: faces numbered from 0 in file order,
/// vertices as read_mesh numbers them. `rules` are those of the code that refused the mesh: kPolyMeshRules
/// (PolyMesh::validate()) or kFourKMeshRules (FourKMesh, simplify4k).
TopologyProblem find_topology_problem(const FileFaces& faces, const TopologyRules& rules = kPolyMeshRules);

/// `problem`, found by find_topology_problem(faces, ...), in the file's words: faces named by their number in
/// the file (from 1) and line (none when the line is 0: a binary PLY), vertices by the file's numbers.
/// `line` receives the line the problem shows on (the face found last, or the vertex's line; 0 in a binary
/// PLY). Empty for no problem.
std::string describe_topology_problem(const FileFaces& faces, const TopologyProblem& problem, std::size_t* line = nullptr);

/// The first reason, in the file's words, why `faces` break `rules`: for kPolyMeshRules, why they do not make
/// a manifold, consistently oriented polygon mesh (a face that repeats a vertex, an edge of more than two
/// faces, two faces that run an edge in the same direction, a vertex whose faces form more than one fan).
/// The two functions above in one; empty when there is no problem.
std::string topology_problem(const FileFaces& faces, std::size_t* line = nullptr,
                             const TopologyRules& rules = kPolyMeshRules);

}  // namespace varmesh::app
