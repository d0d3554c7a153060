#pragma once
/// Per-format readers and writers behind read_mesh / write_mesh (mesh_io.hpp). Internal.
///
/// Readers parse the whole file `data` (already in memory) and throw IoError naming `path` with a line
/// (text) or byte offset (binary) and a reason, including "no faces" for a mesh without any face. The
/// caller runs TriMesh::validate afterwards. `info` has been reset by the caller, with want_sources as the
/// caller asked; readers add to it and set first_vertex_number.
/// Writers return the complete file contents; the caller validates the mesh first and writes atomically.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "multitri/mesh_io.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh::detail {

/// read_obj and read_off expect every lone CR in `data` to be an LF already: read_mesh_data passes OBJ
/// and OFF text through lone_cr_to_lf (detail/text_cursor.hpp) first, and the text cursor ends lines at LF
/// only, so a lone CR left in would join two lines. read_ply takes the file as it is and does this itself,
/// for its header and ascii bodies only, since a binary body must keep its bytes.
TriMesh read_obj(const std::string& path, std::string_view data, ReadInfo& info);
TriMesh read_off(const std::string& path, std::string_view data, ReadInfo& info);
TriMesh read_ply(const std::string& path, std::string_view data, ReadInfo& info);

/// Records one file face of ReadInfo's provenance, for readers asked for it (info.want_sources): its
/// line, its corner count (0 for a strip) and the `triangles` triangles it gave, the last ones added to the
/// mesh. Throws IoError naming `path` and `line` when the face count leaves 32-bit numbers.
void add_face_source(const std::string& path, ReadInfo& info, std::size_t line, std::uint64_t corners,
                     std::size_t triangles);

std::string format_obj(const TriMesh& mesh);
/// OFF, COFF, NOFF or CNOFF by the attributes present; texcoords are not written.
std::string format_off(const TriMesh& mesh);
/// Binary little endian (binary = true) or ascii PLY.
std::string format_ply(const TriMesh& mesh, bool binary);

}  // namespace varmesh::detail
