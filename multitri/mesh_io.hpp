#pragma once
/// Reading and writing triangle meshes: OBJ, OFF and PLY.
///
/// Readers validate everything they read and throw IoError naming the file and the 1-based line (text, and
/// PLY headers) or byte offset (binary PLY bodies) with the reason: truncated files, indices out of range,
/// NaN/Inf coordinates, counts larger than the file can hold (checked before anything is allocated),
/// unsupported properties or formats, meshes with no face ("no faces (empty mesh)"). Polygons are
/// fan-triangulated: corners (c0, c1, c2, ..., ck) give (c0, c(i-1), c(i)) for i = 2..k. The result passes
/// TriMesh::validate(). A UTF-8 byte-order mark at the start of an OBJ or OFF file is skipped. In text (OBJ,
/// OFF, PLY headers and ascii PLY bodies) LF, CRLF and a lone CR (classic Mac OS) each end one line, also
/// mixed in one file; line numbers count them so. A binary PLY body starts after the end_header line's line
/// end (LF, CRLF or a lone CR; in a header with no LF at all, a CR LF after end_header is the lone CR line
/// end followed by a body byte 10) and must end with the last element: data after it is refused, at its
/// line (ascii) or byte offset with the number of extra bytes (binary). Writers write to a temporary file
/// in the same folder and rename it over the target, so a failed write leaves no partial file.
///
/// Supported:
/// - OBJ: v (optionally with r g b colour in [0, 1] after xyz, on every v or on none; a 4th number w is
///   accepted and ignored), vt, vn, f with v, v/vt, v//vn, v/vt/vn and negative (relative) indices;
///   other statements (o, g, s, usemtl, mtllib, l, p, ...) and '#' comments are ignored. Vertices are the
///   `v` statements, in file order, referenced or not; when corners give one vertex different vt/vn, the
///   first one wins and ReadInfo::attribute_conflicts counts the others. Vertices no corner gives a vt/vn
///   get (0, 0) / (0, 0, 0) when the mesh has texcoords / normals at all. A backslash with only blanks
///   after it on its line continues the statement on the next line (a comment is not continued; a backslash
///   anywhere else is an error); an error names the physical line of the bad token, or the statement's first
///   line when the whole statement is at fault (too few numbers or corners).
/// - OFF: headers OFF, COFF, NOFF, CNOFF (and STOFF variants with s t last), comments with '#'. Vertex
///   colours are 3 or 4 numbers, integers 0..255 or floats 0..1 (a '.' or exponent marks floats); face
///   colours are ignored.
/// - PLY: ascii, binary_little_endian, binary_big_endian; any of the scalar types char/uchar/short/ushort/
///   int/uint/float/double and int8/.../float64. Element vertex with x y z (any numeric type), optional
///   nx ny nz, red green blue (uchar 0..255, ushort 0..65535, other integers 0..255, or float/double
///   0..1), u v / s t / texture_u texture_v; element face with a list property vertex_indices or
///   vertex_index; element tristrips with a list property vertex_indices where -1 restarts a strip: strip
///   triangle i is (s[i], s[i+1], s[i+2]) for even i and (s[i+1], s[i], s[i+2]) for odd i, and
///   triangles with a repeated vertex are dropped (ReadInfo::strip_degenerates_dropped). Other elements
///   and properties are skipped (their sizes are honoured, lists included).
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "multitri/tri_mesh.hpp"

namespace varmesh {

enum class MeshFormat { kObj, kOff, kPly };

/// What a reader noticed and repaired on the way (never silently), and, on request, where each triangle
/// came from in the file.
///
/// Provenance is opt-in: set want_sources before the call and the reader fills the vectors below; left
/// false, they stay empty and the reader does no extra work beyond one test per face and per vertex. A
/// file face is a polygon as the file lists it (OBJ f statement, OFF face line, PLY face list) or a PLY
/// triangle strip, numbered from 0 in file order (PLY: face and tristrips elements in header order). A
/// polygon of k corners (c0, ..., c(k-1)) gives the k - 2 consecutive triangles (c0, c(i-1), c(i)), i = 2..k,
/// so face f's corners are c0 and c1 of its first triangle followed by c2 of each of its triangles (the
/// readers drop no polygon: a repeated corner is kept, as the file has it). A strip gives its triangles
/// after dropping those with a repeated vertex (strip_degenerates_dropped), so its triangles do not rebuild
/// it: face_corners is 0 for a strip, and a strip all of whose triangles were dropped owns none.
struct ReadInfo {
  std::size_t polygons_triangulated = 0;   ///< faces with more than 3 corners
  std::size_t attribute_conflicts = 0;     ///< OBJ corners whose vt/vn disagreed with the vertex's first one
  std::size_t strip_degenerates_dropped = 0;  ///< PLY tristrip triangles with a repeated vertex
  /// What the file calls vertex 0: 1 in OBJ (which counts from 1), 0 in OFF and PLY. Always set.
  Index first_vertex_number = 0;

  /// Set to true before reading to receive the provenance below; it stays set in the result.
  bool want_sources = false;
  /// Per output triangle: the file face it came from. Non-decreasing (faces give their triangles in order).
  std::vector<Index> triangle_face;
  /// Per file face: its corner count (3 or more; 0 for a PLY triangle strip).
  std::vector<Index> face_corners;
  /// Per file face: the 1-based line where it starts (OBJ: the f statement's first line, also when
  /// continued; OFF and ascii PLY: the line of its first number). 0 in a binary PLY body, which has no
  /// lines.
  std::vector<std::size_t> face_lines;
  /// Per vertex: the 1-based line where it starts, as face_lines (0 in a binary PLY body).
  std::vector<std::size_t> vertex_lines;
};

/// Chooses the format from the extension (.obj, .off, .ply, case-insensitive); throws IoError otherwise.
MeshFormat mesh_format_from_path(const std::string& path);

/// Reads a mesh; throws IoError as described above. `info` (optional) receives repair counts, and the
/// provenance when info->want_sources is set on entry (see ReadInfo); it is left as it was when reading
/// fails.
TriMesh read_mesh(const std::string& path, ReadInfo* info = nullptr);

/// Reads a mesh from a file's contents already in memory (a member of an archive, say): `name` gives the
/// format by its extension and names the file in errors. Otherwise as read_mesh.
TriMesh read_mesh_data(const std::string& name, std::string_view data, ReadInfo* info = nullptr);

struct WriteOptions {
  bool binary = true;  ///< PLY only: binary little endian (true) or ascii (false)
};

/// Writes a mesh in the format given by the extension, atomically (temporary file + rename). Writes
/// normals, texcoords and colours when present and the format supports them (OFF has no texcoords; PLY
/// stores colours as uchar, so they come back rounded to k/255). Floats are written in the shortest form
/// that reads back to the same float. Throws InvalidInput, before touching the file system, when the mesh
/// fails TriMesh::validate() or has a non-finite attribute or a colour outside [0, 1]; throws IoError for an
/// unknown extension or a failed write (the target is then left as it was).
void write_mesh(const std::string& path, const TriMesh& mesh, const WriteOptions& options = {});

}  // namespace varmesh
