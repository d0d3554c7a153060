#include "multitri/mesh_io.hpp"

#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include "multitri/detail/mesh_io_formats.hpp"
#include "multitri/detail/text_cursor.hpp"
#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"

namespace varmesh {
namespace {

bool ends_with_ci(const std::string& s, const char* suffix) {
  const std::string_view suf(suffix);
  if (s.size() < suf.size()) return false;
  for (std::size_t i = 0; i < suf.size(); ++i) {
    char c = s[s.size() - suf.size() + i];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != suf[i]) return false;
  }
  return true;
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// TriMesh::validate covers indices, sizes and positions; the writers also need finite attributes and
// colours in [0, 1], or they would write files the readers reject.
void validate_for_writing(const TriMesh& mesh) {
  mesh.validate();
  for (std::size_t v = 0; v < mesh.normals.size(); ++v)
    if (!finite(mesh.normals[v])) throw InvalidInput("vertex normal is not finite", v);
  for (std::size_t v = 0; v < mesh.texcoords.size(); ++v)
    if (!std::isfinite(mesh.texcoords[v].x) || !std::isfinite(mesh.texcoords[v].y))
      throw InvalidInput("vertex texcoord is not finite", v);
  for (std::size_t v = 0; v < mesh.colors.size(); ++v) {
    if (!is_unit_color(mesh.colors[v]))
      throw InvalidInput("vertex colour is outside [0, 1]", v);
  }
}

}  // namespace

MeshFormat mesh_format_from_path(const std::string& path) {
  if (ends_with_ci(path, ".obj")) return MeshFormat::kObj;
  if (ends_with_ci(path, ".off")) return MeshFormat::kOff;
  if (ends_with_ci(path, ".ply")) return MeshFormat::kPly;
  throw IoError(path, "unknown mesh format (expected the extension .obj, .off or .ply)");
}

TriMesh read_mesh(const std::string& path, ReadInfo* info) {
  mesh_format_from_path(path);  // an unknown extension is refused before the file is read
  return read_mesh_data(path, read_file_bytes(path), info);
}

TriMesh read_mesh_data(const std::string& path, std::string_view data, ReadInfo* info) {
  const MeshFormat format = mesh_format_from_path(path);
  // Editors on Windows start UTF-8 text with a byte-order mark; in front of the first statement of an OBJ
  // or the OFF keyword it would hide them. (PLY's magic must be the first bytes, and its binary bodies
  // are reported by byte offset, so a PLY with a mark stays an error.)
  constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";
  if (format != MeshFormat::kPly && data.substr(0, kUtf8Bom.size()) == kUtf8Bom) data.remove_prefix(kUtf8Bom.size());
  // LF (Unix), CRLF (Windows) and a lone CR (classic Mac OS) each end one line, also mixed in one file, as
  // happens when pieces from different systems are pasted together. The text cursor ends lines at LF
  // and takes a CR for a blank, which is right for CRLF but would join lines that end in a lone CR. PLY
  // does this itself, for its header and ascii bodies only: a binary body must not be touched.
  std::string unified;
  if (format != MeshFormat::kPly) data = detail::lone_cr_to_lf(data, unified);
  ReadInfo local;
  local.want_sources = info != nullptr && info->want_sources;
  TriMesh mesh;
  switch (format) {
    case MeshFormat::kObj: mesh = detail::read_obj(path, data, local); break;
    case MeshFormat::kOff: mesh = detail::read_off(path, data, local); break;
    case MeshFormat::kPly: mesh = detail::read_ply(path, data, local); break;
  }
  // The readers already reject what validate() would; this keeps the promise if a reader slips.
  if (mesh.num_faces() == 0) throw IoError(path, "no faces (empty mesh)");
  try {
    mesh.validate();
  } catch (const InvalidInput& e) {
    throw IoError(path, std::string("invalid mesh: ") + e.what());
  }
  if (info != nullptr) *info = std::move(local);
  return mesh;
}

namespace detail {

void add_face_source(const std::string& path, ReadInfo& info, std::size_t line, std::uint64_t corners,
                     std::size_t triangles) {
  const std::size_t face = info.face_lines.size();
  // Face numbers are 32-bit like vertex ids; only a file of more than 4 billion faces gets here, and only
  // when provenance was asked for.
  if (face >= kInvalid || corners >= kInvalid)
    throw IoError(path, "too many faces for 32-bit face numbers", line);
  info.face_lines.push_back(line);
  info.face_corners.push_back(static_cast<Index>(corners));
  info.triangle_face.insert(info.triangle_face.end(), triangles, static_cast<Index>(face));
}

}  // namespace detail

void write_mesh(const std::string& path, const TriMesh& mesh, const WriteOptions& options) {
  const MeshFormat format = mesh_format_from_path(path);
  validate_for_writing(mesh);
  std::string contents;
  switch (format) {
    case MeshFormat::kObj: contents = detail::format_obj(mesh); break;
    case MeshFormat::kOff: contents = detail::format_off(mesh); break;
    case MeshFormat::kPly: contents = detail::format_ply(mesh, options.binary); break;
  }
  write_file_atomically(path, contents);
}

}  // namespace varmesh
