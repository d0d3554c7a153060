// Geomview OFF reading and writing.
//
// Header keyword [ST][C][N]OFF; a vertex line is x y z, then nx ny nz (N), then a colour (C), then s t
// (ST), in that order (Geomview's OFF page). Colours come as 3 or 4 numbers: integers 0..255 or floats
// 0..1, told apart by their spelling (a '.' or exponent means float). Face lines are
// "n i0 ... i(n-1) [colour]"; the face colour is ignored. '#' starts a comment anywhere.
#include <cstdint>
#include <string>
#include <vector>

#include "multitri/detail/mesh_io_formats.hpp"
#include "multitri/detail/number_format.hpp"
#include "multitri/detail/text_cursor.hpp"
#include "multitri/errors.hpp"

namespace varmesh::detail {
namespace {

bool looks_like_float(std::string_view tok) {
  for (char c : tok)
    if (c == '.' || c == 'e' || c == 'E' || c == 'n' || c == 'N' || c == 'i' || c == 'I') return true;
  return false;
}

std::uint64_t read_count(TextCursor& cur, const char* what) {
  const std::string_view tok = cur.token_any_line();
  std::int64_t v = 0;
  const NumberStatus s = tok.empty() ? NumberStatus::kMalformed : parse_int(tok, v);
  if (s != NumberStatus::kOk) cur.fail_number(s, tok, what);
  if (v < 0) cur.fail(std::string("negative ") + what + ": " + quote(tok));
  return static_cast<std::uint64_t>(v);
}

glm::vec3 read_color(TextCursor& cur, std::string_view* toks, int n) {
  if (n != 3 && n != 4) cur.fail("vertex colour has " + std::to_string(n) + " components (expected 3 or 4)");
  bool is_float = false;
  for (int k = 0; k < n; ++k) is_float = is_float || looks_like_float(toks[k]);
  float c[3];
  for (int k = 0; k < 3; ++k) {
    if (is_float) {
      const NumberStatus s = parse_float(toks[k], c[k]);
      if (s != NumberStatus::kOk) cur.fail_number(s, toks[k], "colour component");
      if (!(c[k] >= 0.0f && c[k] <= 1.0f)) cur.fail("float colour component outside [0, 1]: " + quote(toks[k]));
    } else {
      std::int64_t i = 0;
      const NumberStatus s = parse_int(toks[k], i);
      if (s != NumberStatus::kOk) cur.fail_number(s, toks[k], "colour component");
      if (i < 0 || i > 255) cur.fail("integer colour component outside 0..255: " + quote(toks[k]));
      c[k] = static_cast<float>(i) / 255.0f;
    }
  }
  // Alpha, when present, must still be a number.
  if (n == 4) {
    float a = 0.0f;
    const NumberStatus s = parse_float(toks[3], a);
    if (s != NumberStatus::kOk) cur.fail_number(s, toks[3], "colour alpha");
  }
  return {c[0], c[1], c[2]};
}

}  // namespace

TriMesh read_off(const std::string& path, std::string_view data, ReadInfo& info) {
  // read_mesh_data has turned lone CRs (classic Mac line ends) into LF, so lines end at LF here.
  TextCursor cur(data, path, '#');
  if (!cur.skip_empty_lines()) throw IoError(path, "empty file (expected an OFF header)", 1);
  const std::string_view header = cur.token();
  bool has_st = false, has_color = false, has_normal = false;
  {
    std::string_view h = header;
    if (h.substr(0, 2) == "ST") {
      has_st = true;
      h.remove_prefix(2);
    }
    if (h.substr(0, 1) == "C") {
      has_color = true;
      h.remove_prefix(1);
    }
    if (h.substr(0, 1) == "N") {
      has_normal = true;
      h.remove_prefix(1);
    }
    if (h != "OFF") {
      if (header.find("OFF") != std::string_view::npos)
        cur.fail("unsupported OFF variant " + quote(header) + " (supported: [ST][C][N]OFF)");
      cur.fail("not an OFF file: header " + quote(header) + " (expected OFF, COFF, NOFF or CNOFF)");
    }
  }
  {
    TextCursor peek = cur;
    if (peek.token_any_line() == "BINARY") cur.fail("binary OFF is not supported");
  }
  const std::uint64_t nv = read_count(cur, "vertex count");
  const std::size_t counts_line = cur.line();
  const std::uint64_t nf = read_count(cur, "face count");
  if (!cur.at_eol()) read_count(cur, "edge count");  // unused, but must be a number
  if (!cur.at_eol()) cur.fail("unexpected text after the counts: " + quote(cur.token()));
  cur.next_line();

  // Before allocating: every vertex needs at least its numbers, each one character and a separator;
  // every face at least "3 a b c". A header promising more than the file holds is rejected here.
  const std::uint64_t numbers_per_vertex = 3 + (has_normal ? 3 : 0) + (has_color ? 3 : 0) + (has_st ? 2 : 0);
  const std::uint64_t min_bytes = sat_add(sat_mul(nv, 2 * numbers_per_vertex), sat_mul(nf, 8));
  if (min_bytes > cur.remaining() + 1)
    throw IoError(path,
                  "counts larger than the file can hold: " + std::to_string(nv) + " vertices and " +
                      std::to_string(nf) + " faces need at least " + std::to_string(min_bytes) + " bytes, " +
                      std::to_string(cur.remaining()) + " remain",
                  counts_line);
  if (nv >= kInvalid)
    throw IoError(path, "vertex count " + std::to_string(nv) + " exceeds 32-bit indices", counts_line);
  if (nf == 0) throw IoError(path, "no faces (empty mesh): the face count is 0", counts_line);

  TriMesh mesh;
  info.first_vertex_number = 0;
  mesh.positions.resize(nv);
  if (has_normal) mesh.normals.resize(nv);
  if (has_color) mesh.colors.resize(nv);
  if (has_st) mesh.texcoords.resize(nv);
  std::string_view extra[8];
  for (std::uint64_t v = 0; v < nv; ++v) {
    if (!cur.skip_empty_lines())
      cur.fail("truncated: expected " + std::to_string(nv) + " vertices, found " + std::to_string(v));
    if (info.want_sources) info.vertex_lines.push_back(cur.line());
    glm::vec3& p = mesh.positions[v];
    p.x = cur.read_float("vertex x");
    p.y = cur.read_float("vertex y");
    p.z = cur.read_float("vertex z");
    if (has_normal) {
      glm::vec3& n = mesh.normals[v];
      n.x = cur.read_float("normal x");
      n.y = cur.read_float("normal y");
      n.z = cur.read_float("normal z");
    }
    if (has_color || has_st) {
      int n = 0;
      while (!cur.at_eol()) {
        if (n == 8) cur.fail("too many numbers on a vertex line");
        extra[n++] = cur.token();
      }
      const int st_count = has_st ? 2 : 0;
      if (n < st_count) cur.fail("missing texture coordinates s t");
      if (has_color) mesh.colors[v] = read_color(cur, extra, n - st_count);
      else if (n != st_count) cur.fail("unexpected text on a vertex line: " + quote(extra[st_count]));
      if (has_st) {
        glm::vec2& t = mesh.texcoords[v];
        NumberStatus s = parse_float(extra[n - 2], t.x);
        if (s != NumberStatus::kOk) cur.fail_number(s, extra[n - 2], "texture s");
        s = parse_float(extra[n - 1], t.y);
        if (s != NumberStatus::kOk) cur.fail_number(s, extra[n - 1], "texture t");
      }
    } else if (!cur.at_eol()) {
      cur.fail("unexpected text on a vertex line: " + quote(cur.token()) + " (a colour needs the COFF header)");
    }
    cur.next_line();
  }

  mesh.indices.reserve(static_cast<std::size_t>(nf) * 3);
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!cur.skip_empty_lines())
      cur.fail("truncated: expected " + std::to_string(nf) + " faces, found " + std::to_string(f));
    const std::size_t face_line = cur.line();
    const std::int64_t n = cur.read_int("face corner count");
    if (n < 3) cur.fail("face has " + std::to_string(n) + " corners (at least 3 needed)");
    if (n > 3) ++info.polygons_triangulated;
    Index first = 0, prev = 0;
    for (std::int64_t k = 0; k < n; ++k) {
      const std::string_view tok = cur.token();
      std::int64_t i = 0;
      const NumberStatus s = tok.empty() ? NumberStatus::kMalformed : parse_int(tok, i);
      if (s != NumberStatus::kOk) {
        if (tok.empty())
          cur.fail("face has " + std::to_string(k) + " vertex indices but announces " + std::to_string(n));
        cur.fail_number(s, tok, "vertex index");
      }
      if (i < 0 || static_cast<std::uint64_t>(i) >= nv)
        cur.fail("vertex index " + std::to_string(i) + " out of range (" + std::to_string(nv) + " vertices)");
      const Index idx = static_cast<Index>(i);
      if (k == 0) {
        first = idx;
      } else if (k >= 2) {
        mesh.indices.push_back(first);
        mesh.indices.push_back(prev);
        mesh.indices.push_back(idx);
      }
      prev = idx;
    }
    if (info.want_sources)
      add_face_source(path, info, face_line, static_cast<std::uint64_t>(n), static_cast<std::size_t>(n - 2));
    // The rest of the line is an optional face colour, which TriMesh does not store.
    cur.next_line();
  }
  return mesh;
}

std::string format_off(const TriMesh& mesh) {
  std::string out;
  out.reserve(mesh.num_vertices() * 40 + mesh.num_faces() * 24 + 64);
  if (mesh.has_colors()) out += 'C';
  if (mesh.has_normals()) out += 'N';
  out += "OFF\n";
  append_uint(out, mesh.num_vertices());
  out += ' ';
  append_uint(out, mesh.num_faces());
  out += " 0\n";
  for (std::size_t v = 0; v < mesh.num_vertices(); ++v) {
    append_vec3(out, mesh.positions[v]);
    if (mesh.has_normals()) {
      out += ' ';
      append_vec3(out, mesh.normals[v]);
    }
    if (mesh.has_colors()) {
      // Float RGBA, spelled as floats so that a reader cannot take them for 0..255 integers.
      const glm::vec3& c = mesh.colors[v];
      out += ' ';
      append_float_literal(out, c.x);
      out += ' ';
      append_float_literal(out, c.y);
      out += ' ';
      append_float_literal(out, c.z);
      out += " 1.0";
    }
    out += '\n';
  }
  append_triangle_lines(out, mesh);
  return out;
}

}  // namespace varmesh::detail
