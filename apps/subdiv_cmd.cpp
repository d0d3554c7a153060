// `varmesh subdiv` (see subdiv_cmd.hpp).
//
// Schemes: 4-8 subdivision (Velho and Zorin, "4-8 Subdivision", CAGD 2001), Catmull-Clark (1978) as two
// binary 4-8 steps, linear 4-8 refinement, quasi 4-8 (Velho, "Quasi 4-8 subdivision", CAGD 2001: 4-8
// refinement of a triangle mesh whose triangles are paired into blocks; our stand-in runs the 4-8 rules of
// fourk/subdiv.hpp on the paired mesh, not Velho's quasi 4-8 smoothing rules), Zwart-Powell mid-edge steps
// (Peters and Reif 1997) and Doo-Sabin (1978), fourk/subdiv_dual.hpp. Figure 19 of Velho and Gomes,
// "Variable resolution 4-k meshes" (CGF 2000), compares them on one model; --figure draws its analogue.
#include "apps/subdiv_cmd.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <unordered_map>

#include <CLI/CLI.hpp>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>

#include "apps/cli_util.hpp"
#include "apps/file_faces.hpp"
#include "apps/render.hpp"
#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "fourk/subdiv_dual.hpp"
#include "multitri/errors.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"

namespace varmesh::app {

namespace {

namespace fs = std::filesystem;

enum class Scheme { kFourEight, kZwartPowell, kCatmullClark, kDooSabin, kQuasi48, kLinear };

struct SchemeInfo {
  Scheme scheme;
  const char* name;   // the --scheme value
  const char* title;  // for reports
  int steps_per_level;
  bool dual;
};

// One level = one dyadic refinement (faces x4): two binary 4-8 steps, two Zwart-Powell (sqrt 2) steps or
// one Doo-Sabin step.
constexpr SchemeInfo kSchemes[] = {
    {Scheme::kFourEight, "48", "4-8 (Velho-Zorin)", 2, false},
    {Scheme::kZwartPowell, "zwart-powell", "Zwart-Powell (mid-edge)", 2, true},
    {Scheme::kCatmullClark, "catmull-clark", "Catmull-Clark", 2, false},
    {Scheme::kDooSabin, "doo-sabin", "Doo-Sabin", 1, true},
    {Scheme::kQuasi48, "quasi48", "quasi 4-8 (4-8 rules on paired triangles)", 2, false},
    {Scheme::kLinear, "linear", "linear 4-8", 2, false},
};

const SchemeInfo& scheme_info(Scheme s) {
  for (const SchemeInfo& i : kSchemes)
    if (i.scheme == s) return i;
  throw InvalidInput("subdiv: unknown scheme");
}

const SchemeInfo& parse_scheme(const std::string& name) {
  const std::string n = name.empty() ? "48" : name;
  for (const SchemeInfo& i : kSchemes)
    if (n == i.name) return i;
  throw InvalidInput("subdiv: unknown --scheme '" + name +
                     "' (48, zwart-powell, catmull-clark, doo-sabin, quasi48, linear)");
}

SubdivScheme primal(Scheme s) {
  switch (s) {
    case Scheme::kCatmullClark: return SubdivScheme::kCatmullClark;
    case Scheme::kLinear: return SubdivScheme::kLinear;
    default: return SubdivScheme::kFourEight;
  }
}

// The input: the polygon mesh the schemes run on and the triangle mesh quasi48 pairs.
struct Input {
  enum class Source { kBuiltin, kPolygonFile, kTriangleFile };
  std::string name;  // "cube", "torus" or the file's stem (picture names)
  Source source = Source::kBuiltin;
  PolyMesh poly;      // built-in quads, a file's polygons, or a triangle file's triangles paired into quads
  TriMesh triangles;  // the file as read, or the built-in quads triangulated along their 4-8 diagonals
  std::string description;  // how `poly` was made, for the report
};

// The option the user gave the step count with, for the advice to lower it: a user who typed --steps
// looks for --steps in the message.
const char* count_option(const SubdivArgs& a) { return a.steps_given ? "--steps" : "--levels"; }

// The library refuses a step count that would make 2^32 elements or more, or need more than the machine's
// memory, as "subdivision: 18 steps would need about 73 GB, more than the 25 GB of memory here (steps)
// (element 18)": the parameter's name and InvalidInput's element index speak to its callers, and the user
// read "(steps) (element 18)". Returns that refusal in the command's words, advising to lower
// `count_option`; nothing for any other error.
std::optional<std::string> steps_refusal(const InvalidInput& e, const char* count_option) {
  if (e.element() == InvalidInput::kNoElement) return std::nullopt;
  const std::string r = e.what();
  const std::string head = "subdivision: ", tail = " (steps) (element " + std::to_string(e.element()) + ")";
  if (r.size() < head.size() + tail.size() || r.compare(0, head.size(), head) != 0 ||
      r.compare(r.size() - tail.size(), tail.size(), tail) != 0)
    return std::nullopt;
  return "subdiv: " + r.substr(head.size(), r.size() - head.size() - tail.size()) + ": lower " + count_option;
}

// The library's step-count refusal in the command's words; other errors as they are.
template <class Fn>
auto refusing_steps(const char* count_option, Fn&& fn) {
  try {
    return fn();
  } catch (const InvalidInput& e) {
    if (const std::optional<std::string> r = steps_refusal(e, count_option)) throw InvalidInput(*r);
    throw;
  }
}

// Errors of the library name a vertex or face; say which mesh they are in. (what() already ends with the
// element, so the new error does not repeat it.) A refused step count is not the mesh's fault: it passes
// unchanged, for refusing_steps around this call to say.
template <class Fn>
auto about(const std::string& what, Fn&& fn) {
  try {
    return fn();
  } catch (const InvalidInput& e) {
    if (steps_refusal(e, "")) throw;
    throw InvalidInput(what + ": " + e.what());
  }
}

// The readers fan-triangulate polygons: corners (c0, c1, ..., ck) arrive as the consecutive triangles
// (c0, c(i-1), c(i)), i = 2..k (multitri/mesh_io.hpp), and ReadInfo only counts the polygons. This undoes
// the fans up to quads: a triangle (a, x, y) right after a triangle (a, w, x) (y not in it) makes the quad
// (a, w, x, y). So a file of quads (and triangles) comes back exactly, except that two of its own triangles
// in that pattern become a quad (as pairing would make); a k-gon, k > 4, comes back as quads and at most
// one triangle. Merging two triangles across their shared edge keeps the mesh a valid polygon mesh, and the
// merge is made only when no other face uses that edge: merging would hide a non-manifold edge from
// validate() (a file with four faces on one edge passed when it also held a quad).
PolyMesh quads_from_fans(const TriMesh& t) {
  PolyMesh p;
  p.positions.reserve(t.num_vertices());
  for (const glm::vec3& v : t.positions) p.positions.emplace_back(v);
  std::unordered_map<std::uint64_t, std::uint32_t> uses;  // undirected edge -> faces on it
  auto key = [](Index u, Index v) { return (std::uint64_t{std::min(u, v)} << 32) | std::max(u, v); };
  for (std::size_t f = 0; f < t.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) ++uses[key(t.corner(f, k), t.corner(f, (k + 1) % 3))];
  std::vector<Index> poly;
  for (std::size_t f = 0; f < t.num_faces(); ++f) {
    const Index a = t.corner(f, 0), x = t.corner(f, 1), y = t.corner(f, 2);
    if (poly.size() == 3 && poly[0] == a && poly[2] == x && y != poly[0] && y != poly[1] && y != poly[2] &&
        uses[key(a, x)] == 2) {
      poly.push_back(y);
      continue;
    }
    if (!poly.empty()) p.add_face(poly);
    poly = {a, x, y};
  }
  if (!poly.empty()) p.add_face(poly);
  return p;
}

std::string face_summary(const PolyMesh& m) {
  std::size_t tris = 0, quads = 0;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    tris += m.face_size(f) == 3;
    quads += m.face_size(f) == 4;
  }
  std::string s = count_noun(m.num_faces(), "face") + " (" + count_noun(quads, "quad");
  if (tris) s += ", " + count_noun(tris, "triangle");
  if (m.num_faces() > tris + quads) s += ", " + count_noun(m.num_faces() - tris - quads, "larger polygon");
  return s + ")";
}

PolyMesh paired(const std::string& name, const TriMesh& t, std::string* description) {
  std::size_t left = 0;
  PolyMesh p = about(name, [&] { return pair_triangles(t, &left); });
  *description = count_noun(p.num_vertices(), "vertex") + ", " + count_noun(t.num_faces(), "triangle") + " paired into " +
                 count_noun((t.num_faces() - left) / 2, "quad") + ", " + std::to_string(left) + " left";
  return p;
}

bool is_builtin(const std::string& in) { return in == "cube" || in == "torus"; }

// The input's name in picture file names: the built-in's name or the file's stem.
std::string input_name(const std::string& in) { return is_builtin(in) ? in : fs::path(in).stem().string(); }

Input load_input(const std::string& in) {
  Input r;
  if (is_builtin(in)) {
    r.name = in;
    r.poly = in == "cube" ? make_quad_cube() : make_quad_torus(16, 8);
    r.triangles = triangulate(r.poly);
    r.description = count_noun(r.poly.num_vertices(), "vertex") + ", " + face_summary(r.poly);
    return r;
  }
  if (!is_mesh_file(in)) throw InvalidInput("subdiv: INPUT must be a mesh (.obj, .off, .ply) or cube | torus, not '" + in + "'");
  r.name = input_name(in);
  ReadInfo info;
  r.triangles = read_input_mesh(in, &info);
  r.triangles.normals.clear();
  r.triangles.texcoords.clear();
  r.triangles.colors.clear();
  try {
    if (info.polygons_triangulated > 0) {
      r.source = Input::Source::kPolygonFile;
      r.poly = quads_from_fans(r.triangles);
      r.description = count_noun(r.poly.num_vertices(), "vertex") + ", " + face_summary(r.poly) + ", rebuilt from the " +
                      count_noun(r.triangles.num_faces(), "triangle") + " the reader made of the file's faces";
    } else {
      r.source = Input::Source::kTriangleFile;
      r.poly = paired(in, r.triangles, &r.description);
    }
    about(in, [&] { r.poly.validate(); return 0; });
  } catch (const InvalidInput&) {
    // The library names a face of the quads rebuilt from the fans (or of the paired triangles) and vertices
    // from 0: "edge 0-1 of face 1" was the file's third face, on OBJ vertices 1 and 2. Said again in the
    // file's terms, from the provenance of a second read that asks for it (a polygon file; PLY triangle
    // strips are none). The first read did not ask: most inputs are fine and need none of it. A triangle
    // file was paired into quads first, which refuses faces on the same vertices too (FourKMesh's rules).
    if (const std::optional<FileFaces> faces = read_file_faces(in)) {
      TopologyRules rules = kPolyMeshRules;
      rules.distinct_faces = r.source == Input::Source::kTriangleFile;
      std::size_t line = 0;
      const std::string problem = topology_problem(*faces, &line, rules);
      if (!problem.empty()) throw IoError(in, problem, line);
    }
    throw;
  }
  return r;
}

// quasi48 runs on the triangles paired into quads: for a triangle file, the mesh the other schemes get;
// for a polygon file or a built-in quad mesh, its triangulation paired by the matching (which need not
// pair the two triangles of a quad together).
PolyMesh base_for(const Input& in, Scheme s, std::string* description) {
  if (s != Scheme::kQuasi48 || in.source == Input::Source::kTriangleFile) {
    *description = in.description;
    return in.poly;
  }
  return paired(in.name, in.triangles, description);
}

int steps_for(const SchemeInfo& s, const SubdivArgs& a) {
  if (a.levels_given && a.steps_given) throw InvalidInput("subdiv: give --levels or --steps, not both");
  if (a.steps_given) {
    if (a.steps < 0) throw InvalidInput("subdiv: --steps must be >= 0 (got " + std::to_string(a.steps) + ")");
    return a.steps;
  }
  if (!a.levels_given) throw InvalidInput("subdiv: give --levels N (or --steps S)");
  if (a.levels < 0) throw InvalidInput("subdiv: --levels must be >= 0 (got " + std::to_string(a.levels) + ")");
  if (a.levels > 64) throw InvalidInput("subdiv: --levels " + std::to_string(a.levels) + " is absurd (every mesh exceeds 2^31 triangles by level 16)");
  return a.levels * s.steps_per_level;
}

struct Size {
  std::uint64_t vertices = 0, polygons = 0, triangles = 0;
};

constexpr std::uint64_t kSaturated = UINT64_MAX;  // "more than 2^60"

// Counts after `steps` binary steps (fourk/subdiv.hpp: a quadrisection turns V, F, E, C into V + F + E,
// C, 2E + C, 4C; an odd step adds one face point per face and fans each k-gon into k triangles).
Size primal_size(const PolyMesh& base, int steps) {
  std::uint64_t v = base.num_vertices(), f = base.num_faces(), e = count_edges(base).edges, c = base.corners.size();
  for (int s = 1; s < steps; s += 2) {
    // E <= C on a manifold mesh, so nothing below overflows while C <= 2^60.
    if (c > (std::uint64_t{1} << 60)) return {kSaturated, kSaturated, kSaturated};
    v = v + f + e;
    e = 2 * e + c;
    f = c;
    c = 4 * c;
  }
  if (steps % 2 == 1) return {v + f, e, c};
  return {v, f, c - 2 * f};
}

std::string count(std::uint64_t n, std::string_view noun) {
  return n == kSaturated ? "more than 2^60 " + noun_for(n, noun) : count_noun(n, noun);
}

// Memory: a uniform result costs about 80 bytes per triangle at its peak; the Multi-Triangulation of
// --adaptive keeps every level, about 300 bytes per uniform triangle, hence a limit 8 times lower.
constexpr std::uint64_t kAdaptiveLimitDivisor = 8;

// `count_option` is the option the step count came from (count_option(SubdivArgs)), which the advice names.
void check_size(const Size& size, const SchemeInfo& s, int steps, std::uint64_t max_triangles, const char* count_option,
                bool adaptive = false) {
  const std::uint64_t limit = adaptive ? max_triangles / kAdaptiveLimitDivisor : max_triangles;
  if (size.triangles > limit || size.vertices > limit)
    throw InvalidInput("subdiv: " + std::string(s.name) + " with " + count_noun(std::uint64_t(steps), "step") +
                       " would make " + count(size.triangles, "triangle") + ", more than the limit " + std::to_string(limit) +
                       (adaptive ? " (--max-triangles / 8 with --adaptive; lower " : " (--max-triangles; lower ") +
                       count_option + ")");
}

PolyMesh run_dual(const PolyMesh& base, const SchemeInfo& s, int steps, std::uint64_t max_triangles, const char* count_option) {
  const DualScheme d = s.scheme == Scheme::kZwartPowell ? DualScheme::kZwartPowell : DualScheme::kDooSabin;
  const DualMeshSize ds = dual_mesh_size(base, d, steps);
  const std::uint64_t tris = ds.corners == UINT64_MAX ? kSaturated : ds.corners - 2 * ds.faces;
  check_size({ds.vertices, ds.faces, tris}, s, steps, max_triangles, count_option);
  return subdivide_dual(base, d, steps);
}

// A uniform result: the output triangles and, for pictures, the polygons.
struct Result {
  TriMesh triangles;
  PolyMesh polygons;
  std::size_t num_polygons = 0;
  double ms = 0.0;
};

Result run_uniform(const PolyMesh& base, const SchemeInfo& s, int steps, std::uint64_t max_triangles, const char* count_option,
                   bool want_polygons) {
  Result r;
  if (s.dual) {
    Stopwatch watch;
    PolyMesh m = run_dual(base, s, steps, max_triangles, count_option);
    r.ms = watch.ms();
    r.triangles = triangulate(m);
    r.num_polygons = m.num_faces();
    if (want_polygons) r.polygons = std::move(m);
    return r;
  }
  check_size(primal_size(base, steps), s, steps, max_triangles, count_option);
  Stopwatch watch;
  const SubdivMesh m = refusing_steps(count_option, [&] { return subdivide(base, primal(s.scheme), steps); });
  r.ms = watch.ms();
  r.triangles = m.to_tri_mesh();
  r.num_polygons = m.half_step() ? m.topo.num_edges() : m.topo.num_faces;
  if (want_polygons) r.polygons = m.to_poly_mesh();
  return r;
}

// The same criterion as `varmesh query` (hierarchy_cmds.cpp): --error and the camera combined with all_of.
Criterion adaptive_criterion(const SubdivArgs& a) {
  std::vector<Criterion> parts;
  add_error_and_camera_criteria(a.error, a.camera, a.pixels, a.viewport, parts);
  if (parts.empty()) throw InvalidInput("subdiv --adaptive: give --error E, --camera ..., or both");
  return parts.size() == 1 ? parts[0] : Criterion::all_of(parts);
}

// Pictures: one camera for every image of a run. It looks at the reference mesh (its referenced vertices)
// from `--view` (default: the 3/4 view from above of default_camera_for, around `--up`) and stands as
// close as it can with every vertex inside the frame.
Camera picture_camera(const TriMesh& reference, const SubdivArgs& a, float aspect) {
  const glm::vec3 up = a.up.empty() ? glm::vec3(0.0f, 0.0f, 1.0f) : parse_direction(a.up, "--up");
  const glm::vec3 to_eye = a.view.empty() ? glm::vec3(0.0f) : parse_direction(a.view, "--view");
  return picture_camera_for(reference, up, to_eye, aspect);
}

// Edges are drawn when the picture has at least this many pixels per polygon (denser wireframes turn it
// black).
constexpr int kPixelsPerWireFace = 40;

// Flat shading (facets honest) with the polygon edges drawn on top, so quads show as quads.
Image render_polygons(const PolyMesh& m, const Camera& cam, int width, int height) {
  const TriMesh t = triangulate(m);
  std::vector<Segment3> edges;
  if (m.num_faces() * kPixelsPerWireFace <= std::size_t(width) * std::size_t(height)) {
    edges.reserve(m.corners.size());
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      const auto c = m.face(f);
      for (std::size_t i = 0; i < c.size(); ++i) {
        const Index a = c[i], b = c[(i + 1) % c.size()];
        edges.push_back({glm::vec3(m.positions[a]), glm::vec3(m.positions[b]), {0.08f, 0.08f, 0.1f}});
      }
    }
  }
  RenderOptions o;
  o.width = width;
  o.height = height;
  o.smooth = false;
  o.supersample = 2;
  return render_mesh(t, cam, o, edges);
}

Image render_triangles(const TriMesh& m, const Camera& cam, int width, int height) {
  RenderOptions o;
  o.width = width;
  o.height = height;
  o.smooth = false;
  o.supersample = 2;
  o.wireframe = m.num_faces() * kPixelsPerWireFace <= 2 * std::size_t(width) * std::size_t(height);
  return render_mesh(m, cam, o);
}

// Cells of equal size side by side, `columns` per row, separated by grey lines; missing cells stay white.
Image grid_image(const std::vector<std::optional<Image>>& cells, std::size_t columns, std::size_t w, std::size_t h) {
  constexpr std::size_t kGap = 4;
  const std::size_t rows = (cells.size() + columns - 1) / columns;
  Image out;
  out.width = columns * w + (columns - 1) * kGap;
  out.height = rows * h + (rows - 1) * kGap;
  out.channels = 3;
  out.pixels.assign(out.width * out.height * 3, 200);
  for (std::size_t i = 0; i < rows * columns; ++i) {
    const std::size_t x0 = (i % columns) * (w + kGap), y0 = (i / columns) * (h + kGap);
    for (std::size_t y = 0; y < h; ++y) std::fill_n(&out.pixels[((y0 + y) * out.width + x0) * 3], w * 3, std::uint8_t{255});
    if (i >= cells.size() || !cells[i]) continue;
    const Image& c = *cells[i];
    for (std::size_t y = 0; y < std::min(h, c.height); ++y)
      std::copy_n(&c.pixels[y * c.width * 3], std::min(w, c.width) * 3, &out.pixels[((y0 + y) * out.width + x0) * 3]);
  }
  return out;
}

void check_output_paths(const SubdivArgs& a) {
  if (a.output.empty()) throw InvalidInput("subdiv: give -o OUT (.obj, .ply, .off) or --figure DIR");
  require_mesh_output(a.output, "subdiv");
  require_png(a.png, "subdiv");
  if (!is_builtin(a.input)) {
    refuse_same_file(a.input, "the input", a.output, "-o");
    refuse_same_file(a.input, "the input", a.png, "--png");
  }
  refuse_same_output(a.output, "-o", a.png, "--png");
}

void check_limits(const SubdivArgs& a) {
  if (a.max_triangles == 0 || a.max_triangles > SubdivArgs::kHardMaxTriangles)
    throw InvalidInput("subdiv: --max-triangles must be in 1 .. 2^31, not " + std::to_string(a.max_triangles));
}

int run_figure(const SubdivArgs& a) {
  if (!a.output.empty() || !a.png.empty() || a.adaptive || !a.scheme.empty())
    throw InvalidInput("subdiv --figure: runs every scheme and writes pictures only; drop -o, --png, --adaptive and --scheme");
  // Grid order: the quad input and the primal schemes, then the dual schemes and the triangle input with
  // quasi48.
  struct Cell {
    std::string label;
    std::optional<Scheme> scheme;  // none: an input
  };
  const std::vector<Cell> cells = {{"base", std::nullopt},           {"linear", Scheme::kLinear},
                                   {"48", Scheme::kFourEight},        {"catmull-clark", Scheme::kCatmullClark},
                                   {"zwart-powell", Scheme::kZwartPowell}, {"doo-sabin", Scheme::kDooSabin},
                                   {"triangles", std::nullopt},      {"quasi48", Scheme::kQuasi48}};
  // The pictures are written all or nothing (a staging folder inside the figure folder); what would stop
  // one, or a picture that would replace the input, is refused before any work.
  std::vector<std::string> names;
  for (const Cell& c : cells) names.push_back(input_name(a.input) + "_" + c.label + ".png");
  names.push_back(input_name(a.input) + "_grid.png");
  StagedFolder::check_targets(a.figure, names);
  if (!is_builtin(a.input))
    for (const std::string& name : names) refuse_same_file(a.input, "the input", (fs::path(a.figure) / name).string(), "--figure's picture");
  check_picture_axes(a.up, a.view);
  const Input in = load_input(a.input);
  constexpr int kW = 640, kH = 480;
  const Camera cam = picture_camera(in.triangles, a, float(kW) / float(kH));
  std::vector<std::optional<Image>> images;
  // The report goes out once everything has worked.
  std::string report;
  auto add = [&report](const char* fmt, auto... args) {
    char line[512];
    std::snprintf(line, sizeof line, fmt, args...);
    report += line;
  };
  add("%s: %s\n", in.name.c_str(), in.description.c_str());
  if (in.source != Input::Source::kTriangleFile) {
    std::string quasi;
    base_for(in, Scheme::kQuasi48, &quasi);
    add("quasi48 input: %s\n", quasi.c_str());
  }
  add("%-14s %6s %10s %10s %10s %9s\n", "scheme", "steps", "vertices", "polygons", "triangles", "ms");
  for (const Cell& c : cells) {
    if (!c.scheme) {
      images.push_back(c.label == "base" ? render_polygons(in.poly, cam, kW, kH) : render_triangles(in.triangles, cam, kW, kH));
      continue;
    }
    const SchemeInfo& s = scheme_info(*c.scheme);
    const int steps = steps_for(s, a);
    std::string unused;
    const Result r = run_uniform(base_for(in, s.scheme, &unused), s, steps, a.max_triangles, count_option(a), true);
    add("%-14s %6d %10zu %10zu %10zu %9.2f\n", s.name, steps, r.triangles.num_vertices(), r.num_polygons,
        r.triangles.num_faces(), r.ms);
    images.push_back(render_polygons(r.polygons, cam, kW, kH));
  }
  StagedFolder folder(a.figure);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (!images[i]) continue;
    write_png(folder.path(names[i]), *images[i]);
    add("  %s\n", (fs::path(a.figure) / names[i]).string().c_str());
  }
  write_png(folder.path(names.back()), grid_image(images, 4, kW, kH));
  folder.commit();
  add("  %s (top: base, linear, 48, catmull-clark; bottom: zwart-powell, doo-sabin, triangles, quasi48)\n",
      (fs::path(a.figure) / names.back()).string().c_str());
  std::fputs(report.c_str(), stdout);
  return 0;
}

}  // namespace


void add_subdiv_options(CLI::App& sub, SubdivArgs& a) {
  sub.add_option("INPUT", a.input,
                 "mesh (.obj/.off/.ply) or cube | torus (quad meshes). A file with polygons keeps its quads (the "
                 "readers fan-triangulate polygons; subdiv rebuilds the quads from the fans; larger polygons come "
                 "back as quads and a triangle); a file of triangles only is paired into quads by a maximum "
                 "matching of its dual graph (unpaired triangles stay triangles)")
      ->required();
  sub.add_option("-o,--output", a.output, "output mesh (.obj, .ply, .off), as triangles")->check(check_file_name);
  sub.add_option("--scheme", a.scheme,
                 "48 (4-8, Velho-Zorin; default) | catmull-clark | linear (4-8 refinement, no smoothing) | "
                 "zwart-powell | doo-sabin | quasi48: the 4-8 rules on the input's triangles paired into quads, our "
                 "stand-in for Velho's quasi 4-8 subdivision (its pairing, not its smoothing rules); on a triangle "
                 "file it equals 48, on a polygon file or cube/torus it re-pairs their triangulation")
      ->check(check_not_empty);
  sub.add_option("--levels", a.levels,
                 "dyadic levels (faces x4 each; this or --steps is required): 2 binary 4-8 steps (48, catmull-clark, "
                 "linear, quasi48), 2 Zwart-Powell steps, 1 Doo-Sabin step")
      ->each([&a](const std::string&) { a.levels_given = true; });
  sub.add_option("--steps", a.steps, "elementary steps instead: binary 4-8 steps (odd allowed), Zwart-Powell or Doo-Sabin steps")
      ->each([&a](const std::string&) { a.steps_given = true; });
  sub.add_flag("--adaptive", a.adaptive,
               "build the Multi-Triangulation of the binary steps and extract a front (primal schemes)");
  sub.add_option("--error", a.error, "with --adaptive: largest node error (object units; 0 = refine wherever anything moves)")
      ->check(check_non_negative);
  auto* camera = sub.add_option("--camera", a.camera, "with --adaptive: ex,ey,ez,tx,ty,tz,fov_degrees: frustum + back faces + screen-space error")
                     ->check(check_not_empty);
  add_screen_error_options(sub, a.pixels, a.viewport, camera);
  sub.add_option("--png", a.png, "also render the result to this PNG (flat shading, polygon edges)")->check(check_file_name);
  sub.add_option("--figure", a.figure,
                 "write every scheme on INPUT into this folder (one PNG each, same camera, plus a grid): "
                 "instead of -o")
      ->check(check_file_name);
  sub.add_option("--view", a.view, "pictures: x,y,z direction from the model towards the eye")->check(check_not_empty);
  sub.add_option("--up", a.up, "pictures: x,y,z up axis (default 0,0,1)")->check(check_not_empty);
  sub.add_option("--max-triangles", a.max_triangles,
                 "refuse results with more triangles or vertices, checked before running (default 2^25, about 2.7 GB "
                 "at the peak; at most 2^31); --adaptive stores every level: it refuses 8 times fewer")
      ->option_text("N")
      ->check(check_count);  // CLI11 took -1 for 2^64 - 1
}

int run_subdiv(const SubdivArgs& a) {
  check_limits(a);
  if (!a.adaptive && (!(a.error < 0.0f) || !a.camera.empty())) throw InvalidInput("subdiv: --error and --camera need --adaptive");
  if ((!a.view.empty() || !a.up.empty()) && a.png.empty() && a.figure.empty())
    throw InvalidInput("subdiv: --view and --up place the pictures' camera: give --png or --figure");
  if (!a.figure.empty()) return run_figure(a);
  check_output_paths(a);
  check_picture_axes(a.up, a.view);
  const SchemeInfo& s = parse_scheme(a.scheme);
  const int steps = steps_for(s, a);
  if (a.adaptive && s.dual) throw InvalidInput("subdiv --adaptive: needs a primal scheme (48, catmull-clark, linear, quasi48), not " + std::string(s.name));
  const std::optional<Criterion> criterion = a.adaptive ? std::optional<Criterion>(adaptive_criterion(a)) : std::nullopt;
  const Input in = load_input(a.input);
  std::string description;
  const PolyMesh base = base_for(in, s.scheme, &description);
  // The report goes out once everything has worked (an error is then the only thing printed).
  const std::string report = "input " + in.name + ": " + description;
  char line[512];

  TriMesh out;
  PolyMesh picture;  // uniform runs: the polygons, drawn with their edges
  if (a.adaptive) {
    check_size(primal_size(base, steps), s, steps, a.max_triangles, count_option(a), true);
    SubdivMtInfo info;
    Stopwatch build_watch;
    const Mt mt = refusing_steps(count_option(a), [&] {
      return about(in.name, [&] { return build_subdivision_mt(base, primal(s.scheme), steps, &info); });
    });
    const double build_ms = build_watch.ms();
    Query q;
    q.criterion = *criterion;
    MtFront front(mt);
    Stopwatch watch;
    const QueryStats st = extract(front, q);
    const double ms = watch.ms();
    out = front.to_mesh();
    // "0 nodes refined" read as a failure; the front is then the base mesh, which met the criterion as it was.
    const std::string refined = st.refined == 0 ? "no node needed refining" : count_noun(st.refined, "node") + " refined";
    std::snprintf(line, sizeof line, "%s, %s, adaptive: %s built in %.1f ms; front %s, %s of %zu uniform (%s) in %.2f ms",
                  s.title, count_noun(std::uint64_t(steps), "binary step").c_str(), count_noun(mt.num_nodes(), "node").c_str(),
                  build_ms, count_noun(out.num_vertices(), "vertex").c_str(), count_noun(out.num_faces(), "triangle").c_str(),
                  info.uniform_faces, refined.c_str(), ms);
  } else {
    Result r = run_uniform(base, s, steps, a.max_triangles, count_option(a), !a.png.empty());
    out = std::move(r.triangles);
    picture = std::move(r.polygons);
    std::snprintf(line, sizeof line, "%s, %s: %s, %s -> %s, %s, %s in %.2f ms", s.title,
                  count_noun(std::uint64_t(steps), s.dual ? "step" : "binary step").c_str(),
                  count_noun(base.num_vertices(), "vertex").c_str(), count_noun(base.num_faces(), "face").c_str(),
                  count_noun(out.num_vertices(), "vertex").c_str(), count_noun(r.num_polygons, "polygon").c_str(),
                  count_noun(out.num_faces(), "triangle").c_str(), r.ms);
  }
  std::optional<Image> image;
  if (!a.png.empty()) {
    const Camera cam = picture_camera(out, a, 4.0f / 3.0f);
    image = a.adaptive ? render_triangles(out, cam, 1024, 768) : render_polygons(picture, cam, 1024, 768);
  }
  write_mesh_and_picture(a.output, out, a.png, image ? &*image : nullptr);
  std::printf("%s\n%s\n-> %s%s%s\n", report.c_str(), line, a.output.c_str(), image ? ", " : "", a.png.c_str());
  return 0;
}

}  // namespace varmesh::app
