// Wavefront OBJ reading and writing (the geometry subset: v, vt, vn, f).
//
// OBJ indexes positions, texcoords and normals separately per corner, while TriMesh has one set of
// attributes per vertex. We keep the `v` statements as the vertices (so vertex ids match the file) and
// give each vertex the vt/vn of the first corner that uses it; later corners that disagree are counted in
// ReadInfo::attribute_conflicts rather than silently dropped or turned into split vertices.
//
// A backslash at the end of a line continues the statement on the next line, as the OBJ specification
// allows, whatever the statement (the cursor's continuations, detail/text_cursor.hpp): it reads as a blank,
// so "f 1 2 \" + "3" and "f 1 2\" + "3" are both "f 1 2 3". A comment is not continued, and a backslash
// with more than blanks after it on its line is an ordinary character (which no number or index accepts).
// Errors count physical lines. One about a token (a bad number or index, one number too many) names the
// line that token is on; one about the statement as a whole (too few numbers or corners, a colour, the
// vertex count) names the line where the statement starts.
#include <charconv>
#include <cstdint>
#include <string>
#include <vector>

#include "multitri/detail/mesh_io_formats.hpp"
#include "multitri/detail/number_format.hpp"
#include "multitri/detail/text_cursor.hpp"
#include "multitri/errors.hpp"

namespace varmesh::detail {
namespace {

// One face corner that names a texcoord or a normal; kInvalid marks "not given".
struct AttributeCorner {
  Index v;
  Index vt;
  Index vn;
};

// The largest 1-based index referenced so far and the line that first referenced it: positive indices
// may point forward, so their range is checked once the whole file has been read.
struct MaxRef {
  std::int64_t value = 0;
  std::size_t line = 0;
  void note(std::int64_t one_based, std::size_t at_line) {
    if (one_based > value) {
      value = one_based;
      line = at_line;
    }
  }
};

class ObjParser {
 public:
  ObjParser(const std::string& path, std::string_view data, ReadInfo& info)
      : path_(path), cur_(data, path, '#', true), info_(info) {}

  TriMesh run() {
    info_.first_vertex_number = 1;
    while (cur_.skip_empty_lines()) {
      cur_.begin_statement();
      last_line_ = cur_.line();
      const std::string_view key = cur_.token();
      if (key == "v") {
        parse_v();
      } else if (key == "f") {
        parse_f();
      } else if (key == "vt") {
        parse_vt();
      } else if (key == "vn") {
        parse_vn();
      }
      // Anything else (o, g, s, usemtl, mtllib, l, p, vp, curves...) carries no triangle geometry: it is
      // skipped with the lines it continues onto.
      cur_.next_statement();
    }
    finish();
    return std::move(mesh_);
  }

 private:
  void parse_v() {
    glm::vec3 p;
    p.x = cur_.read_float("vertex x");
    p.y = cur_.read_float("vertex y");
    p.z = cur_.read_float("vertex z");
    float extra[4];
    int n = 0;
    while (!cur_.at_eol()) {
      if (n == 4) cur_.fail("v statement has more than 7 numbers (expected x y z [w] or x y z r g b)");
      extra[n++] = cur_.read_float("vertex colour or weight");
    }
    if (n != 0 && n != 1 && n != 3)
      cur_.fail_statement("v statement has " + std::to_string(3 + n) + " numbers (expected 3, 4 or 6)");
    const bool has_color = n == 3;
    // Colours must be on every v or on none: TriMesh attributes are all-or-nothing.
    if (has_color && uncoloured_ > 0) cur_.fail_statement("v has a colour but earlier v statements do not");
    if (!has_color && !mesh_.colors.empty()) cur_.fail_statement("v has no colour but earlier v statements do");
    if (has_color) {
      for (int k = 0; k < 3; ++k)
        if (!(extra[k] >= 0.0f && extra[k] <= 1.0f)) cur_.fail_statement("vertex colour component is outside [0, 1]");
      mesh_.colors.emplace_back(extra[0], extra[1], extra[2]);
    } else {
      ++uncoloured_;
    }
    // A 4th number is the rational weight w, meaningful for curves only.
    if (mesh_.positions.size() + 1 >= kInvalid) cur_.fail_statement("too many vertices for 32-bit indices");
    mesh_.positions.push_back(p);
    if (info_.want_sources) info_.vertex_lines.push_back(cur_.statement_line());
  }

  void parse_vt() {
    glm::vec2 t(0.0f);
    t.x = cur_.read_float("texcoord u");
    if (!cur_.at_eol()) t.y = cur_.read_float("texcoord v");
    if (!cur_.at_eol()) cur_.read_float("texcoord w");
    if (!cur_.at_eol()) cur_.fail("vt statement has more than 3 numbers");
    texcoords_.push_back(t);
  }

  void parse_vn() {
    glm::vec3 n;
    n.x = cur_.read_float("normal x");
    n.y = cur_.read_float("normal y");
    n.z = cur_.read_float("normal z");
    if (!cur_.at_eol()) cur_.fail("vn statement has more than 3 numbers");
    normals_.push_back(n);
  }

  // Resolves one index of a corner: 1-based, or negative = relative to the count so far.
  Index resolve(std::int64_t idx, std::size_t count, MaxRef& max_ref, const char* kind) {
    if (idx > 0) {
      if (idx >= static_cast<std::int64_t>(kInvalid))
        cur_.fail(std::string(kind) + " index out of range: " + std::to_string(idx));
      max_ref.note(idx, cur_.line());
      return static_cast<Index>(idx - 1);
    }
    if (idx == 0) cur_.fail(std::string(kind) + " index 0 is invalid (OBJ indices start at 1)");
    if (idx < -static_cast<std::int64_t>(count))  // not -idx: negating INT64_MIN overflows
      cur_.fail(std::string("relative ") + kind + " index " + std::to_string(idx) + " is out of range (only " +
                std::to_string(count) + " defined so far)");
    return static_cast<Index>(static_cast<std::int64_t>(count) + idx);
  }

  // Parses "v", "v/vt", "v//vn" or "v/vt/vn". An empty slot means "not given", as exporters write it:
  // "1//" and "1/" are "1", "1/2/" is "1/2". A slot that is not empty must be an index, and there are at
  // most three slots ("1///" and "1/2/3/4" are refused).
  void parse_corner(std::string_view tok, Index& v, Index& vt, Index& vn) {
    const char* p = tok.data();
    const char* end = p + tok.size();
    auto parse_index = [&](const char* what) {
      std::int64_t value = 0;
      const char* first = (p != end && *p == '+') ? p + 1 : p;
      const auto r = std::from_chars(first, end, value);
      if (r.ec != std::errc() || r.ptr == first)
        cur_.fail(std::string("bad ") + what + " index in face corner " + quote(tok));
      p = r.ptr;
      return value;
    };
    v = resolve(parse_index("vertex"), mesh_.positions.size(), max_v_, "vertex");
    vt = kInvalid;
    vn = kInvalid;
    if (p == end) return;
    if (*p != '/') cur_.fail("bad face corner " + quote(tok));
    ++p;
    if (p != end && *p != '/') vt = resolve(parse_index("texcoord"), texcoords_.size(), max_vt_, "texcoord");
    if (p == end) return;
    if (*p != '/') cur_.fail("bad face corner " + quote(tok));
    ++p;
    if (p == end) return;
    vn = resolve(parse_index("normal"), normals_.size(), max_vn_, "normal");
    if (p != end) cur_.fail("bad face corner " + quote(tok));
  }

  void parse_f() {
    polygon_.clear();
    // token() is empty at the statement's end: asking at_eol() first would look at each corner twice.
    for (std::string_view tok = cur_.token(); !tok.empty(); tok = cur_.token()) {
      Index v, vt, vn;
      parse_corner(tok, v, vt, vn);
      polygon_.push_back(v);
      if (vt != kInvalid || vn != kInvalid) attribute_corners_.push_back({v, vt, vn});
    }
    if (polygon_.size() < 3)
      cur_.fail_statement("face has " + std::to_string(polygon_.size()) + " corners (at least 3 needed)");
    if (polygon_.size() > 3) ++info_.polygons_triangulated;
    for (std::size_t k = 2; k < polygon_.size(); ++k) {
      mesh_.indices.push_back(polygon_[0]);
      mesh_.indices.push_back(polygon_[k - 1]);
      mesh_.indices.push_back(polygon_[k]);
    }
    if (info_.want_sources) add_face_source(path_, info_, cur_.statement_line(), polygon_.size(), polygon_.size() - 2);
  }

  void check_max(const MaxRef& max_ref, std::size_t count, const char* kind, const char* statement) {
    if (max_ref.value > static_cast<std::int64_t>(count))
      throw IoError(path_,
                    std::string("face refers to ") + kind + " " + std::to_string(max_ref.value) + " but the file has " +
                        std::to_string(count) + " " + statement + " statements (index out of range)",
                    max_ref.line);
  }

  void finish() {
    if (mesh_.indices.empty()) throw IoError(path_, "no faces (empty mesh): the file has no f statement", last_line_);
    const std::size_t nv = mesh_.positions.size();
    check_max(max_v_, nv, "vertex", "v");
    check_max(max_vt_, texcoords_.size(), "texcoord", "vt");
    check_max(max_vn_, normals_.size(), "normal", "vn");

    bool any_vt = false, any_vn = false;
    for (const AttributeCorner& c : attribute_corners_) {
      any_vt = any_vt || c.vt != kInvalid;
      any_vn = any_vn || c.vn != kInvalid;
    }
    std::vector<Index> first_vt, first_vn;
    if (any_vt) {
      mesh_.texcoords.assign(nv, glm::vec2(0.0f));
      first_vt.assign(nv, kInvalid);
    }
    if (any_vn) {
      mesh_.normals.assign(nv, glm::vec3(0.0f));
      first_vn.assign(nv, kInvalid);
    }
    for (const AttributeCorner& c : attribute_corners_) {
      bool conflict = false;
      if (c.vt != kInvalid) {
        if (first_vt[c.v] == kInvalid) {
          first_vt[c.v] = c.vt;
          mesh_.texcoords[c.v] = texcoords_[c.vt];
        } else if (first_vt[c.v] != c.vt && texcoords_[first_vt[c.v]] != texcoords_[c.vt]) {
          conflict = true;
        }
      }
      if (c.vn != kInvalid) {
        if (first_vn[c.v] == kInvalid) {
          first_vn[c.v] = c.vn;
          mesh_.normals[c.v] = normals_[c.vn];
        } else if (first_vn[c.v] != c.vn && normals_[first_vn[c.v]] != normals_[c.vn]) {
          conflict = true;
        }
      }
      if (conflict) ++info_.attribute_conflicts;
    }
  }

  const std::string& path_;
  TextCursor cur_;
  ReadInfo& info_;
  TriMesh mesh_;
  std::vector<glm::vec2> texcoords_;
  std::vector<glm::vec3> normals_;
  std::vector<AttributeCorner> attribute_corners_;
  std::vector<Index> polygon_;
  std::size_t uncoloured_ = 0;
  std::size_t last_line_ = 1;
  MaxRef max_v_, max_vt_, max_vn_;
};

}  // namespace

TriMesh read_obj(const std::string& path, std::string_view data, ReadInfo& info) {
  // read_mesh_data has turned lone CRs (classic Mac line ends) into LF, so lines end at LF here.
  return ObjParser(path, data, info).run();
}

std::string format_obj(const TriMesh& mesh) {
  std::string out;
  out.reserve(mesh.num_vertices() * 40 + mesh.num_faces() * 24 + 64);
  out += "# varmesh\n";
  for (std::size_t v = 0; v < mesh.num_vertices(); ++v) {
    out += "v ";
    append_vec3(out, mesh.positions[v]);
    if (mesh.has_colors()) {
      out += ' ';
      append_vec3(out, mesh.colors[v]);
    }
    out += '\n';
  }
  for (const glm::vec2& t : mesh.texcoords) {
    out += "vt ";
    append_float(out, t.x);
    out += ' ';
    append_float(out, t.y);
    out += '\n';
  }
  for (const glm::vec3& n : mesh.normals) {
    out += "vn ";
    append_vec3(out, n);
    out += '\n';
  }
  // Attributes are per vertex, so a corner uses the same number for v, vt and vn.
  const bool vt = mesh.has_texcoords(), vn = mesh.has_normals();
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    out += 'f';
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t i = static_cast<std::uint64_t>(mesh.corner(f, k)) + 1;
      out += ' ';
      append_uint(out, i);
      if (vt || vn) {
        out += '/';
        if (vt) append_uint(out, i);
        if (vn) {
          out += '/';
          append_uint(out, i);
        }
      }
    }
    out += '\n';
  }
  return out;
}

}  // namespace varmesh::detail
