#include "multitri/mesh_io.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>

#include "multitri/detail/mesh_io_formats.hpp"
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

// The first lone CR (one not followed by LF) in `text`, or npos. LF files have no CR at all, and memchr
// says so at memory speed. From the first CR on, bytes are tested in blocks with no exit inside a block,
// a loop the compiler vectorizes, so that a CRLF file costs about what an LF file costs (a memchr call
// per line, to look at the byte after each CR, took three times as long on a 47 MB OBJ).
std::size_t find_lone_cr(std::string_view text) {
  const std::size_t first = text.find('\r');
  if (first == std::string_view::npos) return first;
  const char* p = text.data();
  const std::size_t last = text.size() - 1;  // a CR there has no byte after it: it is lone
  constexpr std::size_t kBlock = 256;
  for (std::size_t i = first; i < last; i += kBlock) {
    const std::size_t end = std::min(i + kBlock, last);
    unsigned char lone = 0;
    for (std::size_t j = i; j < end; ++j) lone |= static_cast<unsigned char>((p[j] == '\r') & (p[j + 1] != '\n'));
    if (lone != 0)
      for (std::size_t j = i;; ++j)
        if (p[j] == '\r' && p[j + 1] != '\n') return j;
  }
  return p[last] == '\r' ? last : std::string_view::npos;
}

// Returns `data` with every lone CR turned into LF: `data` itself when there is none (LF and CRLF files
// are read in place), else a copy in `storage`. Bytes keep their places, so line numbers count each line
// end once and byte offsets stay those of the file. ply_io.cpp has a copy of both functions, for PLY
// headers and ascii bodies; detail/text_cursor.hpp would be their shared home.
std::string_view lone_cr_to_lf(std::string_view data, std::string& storage) {
  std::size_t cr = find_lone_cr(data);
  if (cr == std::string_view::npos) return data;
  storage.assign(data);
  for (; cr != std::string::npos; cr = storage.find('\r', cr + 1))
    if (cr + 1 == storage.size() || storage[cr + 1] != '\n') storage[cr] = '\n';
  return storage;
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
  return read_mesh_data(path, read_file(path), info);
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
  if (format != MeshFormat::kPly) data = lone_cr_to_lf(data, unified);
  ReadInfo local;
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
  if (info != nullptr) *info = local;
  return mesh;
}

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
