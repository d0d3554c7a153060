#pragma once
/// Reading and writing triangle meshes: OBJ, OFF and PLY.
///
/// Readers validate everything they read and throw IoError naming the file and the 1-based line (text) or
/// byte offset (binary) with the reason: truncated files, indices out of range, NaN/Inf coordinates, counts
/// larger than the file can hold, unsupported properties or formats, meshes with no face. Polygons are
/// fan-triangulated. Writers write to a temporary file in the same folder and rename it over the target,
/// so a failed write leaves no partial file.
///
/// Supported:
/// - OBJ: v (optionally with r g b colour after xyz), vt, vn, f with v, v/vt, v//vn, v/vt/vn and negative
///   (relative) indices; other statements (o, g, s, usemtl, mtllib, l, p) are ignored. Vertices are the `v`
///   statements, in file order, referenced or not; when corners give one vertex different vt/vn, the first
///   one wins and ReadInfo::attribute_conflicts counts the others.
/// - OFF (also COFF/NOFF headers with per-vertex colour/normal), comments with '#'.
/// - PLY: ascii, binary_little_endian, binary_big_endian; element vertex with x y z (any numeric type),
///   optional nx ny nz, red green blue (uchar or float), u v / s t / texture_u texture_v; element face with
///   a list property vertex_indices or vertex_index; element tristrips with a list property vertex_indices
///   where -1 restarts a strip (alternating orientation, degenerate triangles dropped). Other elements and
///   properties are skipped (their sizes are honoured).
#include <cstddef>
#include <string>

#include "multitri/tri_mesh.hpp"

namespace varmesh {

enum class MeshFormat { kObj, kOff, kPly };

/// What a reader noticed and repaired on the way (never silently).
struct ReadInfo {
  std::size_t polygons_triangulated = 0;   ///< faces with more than 3 corners
  std::size_t attribute_conflicts = 0;     ///< OBJ corners whose vt/vn disagreed with the vertex's first one
  std::size_t strip_degenerates_dropped = 0;  ///< PLY tristrip triangles with a repeated vertex
};

/// Chooses the format from the extension (.obj, .off, .ply, case-insensitive); throws IoError otherwise.
MeshFormat mesh_format_from_path(const std::string& path);

/// Reads a mesh; throws IoError as described above. `info` (optional) receives repair counts.
TriMesh read_mesh(const std::string& path, ReadInfo* info = nullptr);

struct WriteOptions {
  bool binary = true;  ///< PLY only: binary little endian (true) or ascii (false)
};

/// Writes a mesh in the format given by the extension, atomically (temporary file + rename). Writes
/// normals, texcoords and colours when present and the format supports them. Throws IoError.
void write_mesh(const std::string& path, const TriMesh& mesh, const WriteOptions& options = {});

}  // namespace varmesh
