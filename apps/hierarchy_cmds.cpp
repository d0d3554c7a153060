// `varmesh build` and `varmesh query` (see hierarchy_cmds.hpp).
#include "apps/hierarchy_cmds.hpp"


#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>

#include "apps/cli_util.hpp"
#include "apps/file_faces.hpp"
#include "apps/render.hpp"
#include "fourk/adaptive.hpp"
#include "fourk/semiregular.hpp"
#include "fourk/simplify4k.hpp"
#include "multitri/errors.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/mesh_distance.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/mt_io.hpp"
#include "multitri/mt_metrics.hpp"
#include "multitri/query.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"

namespace varmesh::app {

void add_build_options(CLI::App& sub, BuildArgs& a) {
  sub.add_option("INPUT", a.input, "mesh (.obj/.off/.ply), height field (.pgm/.png/.raw/.f32), or torus | saddle | implicit-torus")->required();
  sub.add_option("-o,--output", a.output, "output hierarchy (.vrm)")->required();
  sub.add_option("--method", a.method, "semiregular (default) | adaptive | simplify4k")->check(check_not_empty);
  sub.add_option("--levels", a.levels,
                 "semiregular: binary refinement levels (default 4); simplify4k: most levels (0: all); adaptive: deepest "
                 "bisection level, 1-48 (default 40)")
      ->check(CLI::Range(0, 64));
  sub.add_option("--tolerance", a.tolerance,
                 "adaptive only: geometric tolerance, > 0 (default: 1% of the height range of a height field; torus "
                 "0.0685, saddle 0.002, implicit-torus 0.046, the paper's figures)")
      ->check(check_positive);
  sub.add_option("--raw-size", a.raw_size, "adaptive on a .raw/.f32 float32 height field: W,H")->check(check_not_empty);
  sub.add_option("--spacing", a.spacing, "adaptive on a height field: distance between samples (default 1), as in terrain")
      ->each([&a](const std::string&) { a.heightfield_scale_given = true; });
  sub.add_option("--z-scale", a.z_scale, "adaptive on a height field: multiply heights by this factor (default 1)")
      ->each([&a](const std::string&) { a.heightfield_scale_given = true; });
  sub.add_option("--max-triangles", a.max_triangles,
                 "semiregular: refuse, before the build, a hierarchy whose finest mesh would have more faces than "
                 "this (base faces x 2^levels; default 2^22 = 4194304, about 1 GB and 10 s; at most 2^31)")
      ->option_text("N")
      ->check(check_count)  // CLI11 took -1 for 2^64 - 1 and printed that back
      ->each([&a](const std::string&) { a.max_triangles_given = true; });
  auto* pictures = sub.add_option("--pictures", a.pictures, "write PNGs of the levels (or of the adaptive result) into this folder")
                       ->check(check_file_name);
  // The option text replaces CLI11's "TEXT Needs: --pictures", which ran into the description.
  sub.add_option("--up", a.up, "with --pictures: x,y,z up axis (default 0,0,1)")
      ->option_text("X,Y,Z")
      ->check(check_not_empty)
      ->needs(pictures);
  sub.add_option("--view", a.view, "with --pictures: x,y,z direction from the model towards the eye")
      ->option_text("X,Y,Z")
      ->check(check_not_empty)
      ->needs(pictures);
  sub.add_flag("--quiet", a.quiet, "no progress on stderr");
}

namespace {

void add_view_query_options(CLI::App& sub, ViewQueryArgs& a, const char* hierarchy) {
  sub.add_option("HIERARCHY", a.input, hierarchy)->required();
  sub.add_option("-o,--output", a.output, "output mesh (.obj, .ply, .off)")->required();
  sub.add_option("--error", a.error, "largest node error allowed (object units)")->check(check_non_negative);
  auto* camera = sub.add_option("--camera", a.camera, "ex,ey,ez,tx,ty,tz,fov_degrees: frustum + back faces + screen-space error")
                     ->check(check_not_empty);
  add_screen_error_options(sub, a.pixels, a.viewport, camera);
  sub.add_option("--budget", a.budget, "triangle budget")->check(check_count);
  auto* png = sub.add_option("--png", a.png, "also render the result to this PNG")->check(check_file_name);
  sub.add_option("--up", a.up, "with --png: x,y,z up axis (default 0,0,1)")->option_text("X,Y,Z")->check(check_not_empty)->needs(png);
  sub.add_option("--view", a.view, "with --png: x,y,z direction from the model towards the eye")
      ->option_text("X,Y,Z")
      ->check(check_not_empty)
      ->needs(png);
}

}  // namespace

void add_query_options(CLI::App& sub, QueryArgs& a) {
  add_view_query_options(sub, a, ".vrm file from varmesh build");
  sub.add_option("--ramp", a.ramp, "x0,y0,z0,x1,y1,z1,s0,s1: triangle size grows linearly from s0 at p0 to s1 at p1")
      ->check(check_not_empty);
  sub.add_flag("--measure", a.measure, "report the RMS and max distance from the finest mesh's vertices to the result "
                                      "(for semiregular hierarchies the finest mesh is a flat subdivision of the base, not the input)");
}

void add_pm_build_options(CLI::App& sub, PmBuildArgs& a) {
  sub.add_option("INPUT", a.input, "mesh (.obj, .off, .ply)")->required();
  sub.add_option("-o,--output", a.output, "output hierarchy (.vmh)")->required();
  sub.add_option("--cost", a.cost,
                 "quadric (Garland-Heckbert order, volume-preserving placement; default), quadric-plain (vs at the "
                 "quadric's minimiser) or lindstrom-turk");
  sub.add_option("--lt-finish", a.lt_finish,
                 "quadric costs with --faces or --vertices: from this many times the target on, order and place the "
                 "collapses by Lindstrom-Turk costs (0 or a factor > 1; default 4; 0: quadrics to the end, better for "
                 "models with thin parts taken down to tens of faces: the cow at 58 faces has half the error)")
      ->each([&a](const std::string&) { a.lt_finish_given = true; });
  // Option texts instead of CLI11's "UINT Excludes: ...", which pushed the descriptions onto a line of their own.
  auto* faces = sub.add_option("--faces", a.faces,
                               "stop at this many faces (default: the smallest base mesh; not with --vertices)")
                    ->option_text("N")
                    ->check(check_count);
  sub.add_option("--vertices", a.vertices, "stop at this many vertices (instead of --faces)")
      ->option_text("N")
      ->check(check_count)
      ->excludes(faces);
  sub.add_option("--max-error", a.max_error, "no collapse whose error exceeds this (object units): those are skipped, the others go on")
      ->check(check_non_negative);
  sub.add_flag("--colors", a.colors, "colour quadrics (GH98): the mesh must have vertex colours; --cost quadric only");
  sub.add_option("--non-manifold", a.non_manifold, "split (default): cut non-manifold edges and vertices into sheets; "
                                                    "lock: also keep the copies from collapsing");
  sub.add_option("--threads", a.threads,
                 "parts simplified at once, a thread each (default 1; 0: one per hardware thread): faster, and a "
                 "different hierarchy of about the same error, the same for the same count (--cost quadric or "
                 "quadric-plain, no --colors; at least 16,384 faces per part)")
      ->check(check_count)
      ->each([&a](const std::string&) { a.threads_given = true; });
  sub.add_flag("--measure", a.measure, "report the RMS and max distance from the input's vertices to the base mesh");
  sub.add_flag("--quiet", a.quiet, "no progress on stderr");
}

void add_pm_query_options(CLI::App& sub, PmQueryArgs& a) {
  add_view_query_options(sub, a, ".vmh file from varmesh pm build");
  sub.add_option("--scheme", a.scheme, "kim-lee (default), hoppe97 or xia-varshney: the dependency rules of the refinement");
  sub.add_flag("--measure", a.measure, "report the RMS and max distance from the input's vertices to the result");
}

namespace {

// The builder refuses a tolerance it cannot meet in terms of its own parameters (max_level, max_faces) and
// a face id; restated here in the options the user typed.
template <class Build>
AdaptiveHierarchy restate_adaptive_refusal(const AdaptiveOptions& o, bool levels_given, Build&& build) {
  try {
    return build();
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    char tol[32];
    std::snprintf(tol, sizeof tol, "%g", static_cast<double>(o.tolerance));
    if (what.find("not met at max_level") != std::string::npos)
      throw InvalidInput("build --method adaptive: --tolerance " + std::string(tol) + " is not met within " +
                         count_noun(std::uint64_t(o.max_level), "level") + (levels_given ? "" : " (the default --levels)") +
                         ": raise --levels (at most 48) or --tolerance, or check that the surface is continuous");
    if (what.find("max_faces") != std::string::npos)
      throw InvalidInput("build --method adaptive: --tolerance " + std::string(tol) + " needs more than " +
                         std::to_string(o.max_faces) + " faces: raise --tolerance");
    throw;
  }
}

AdaptiveHierarchy build_adaptive(const BuildArgs& a) {
  AdaptiveOptions o;
  o.tolerance = a.tolerance;  // <= 0: not given (the option itself refuses values <= 0)
  if (a.levels >= 0) {
    if (a.levels < 1 || a.levels > 48) throw InvalidInput("build: --levels must be in 1..48 for --method adaptive, not " + std::to_string(a.levels));
    o.max_level = a.levels;
  }
  HeightFieldReadOptions ro;
  apply_raw_size(a.raw_size, a.input, ro);  // refuses --raw-size for anything but a .raw height field
  ro.z_scale = a.z_scale;
  if (a.heightfield_scale_given && (a.input == "torus" || a.input == "saddle" || a.input == "implicit-torus"))
    throw InvalidInput("build: --spacing and --z-scale are for a height field, not the built-in " + a.input);
  if (a.input == "torus" || a.input == "saddle") {
    const ParametricSurface s = a.input == "torus" ? torus_parametric() : saddle_parametric();
    if (o.tolerance <= 0.0f) o.tolerance = a.input == "torus" ? 0.0685f : 0.002f;
    return restate_adaptive_refusal(o, a.levels >= 0, [&] { return build_adaptive_parametric(s, o); });
  }
  if (a.input == "implicit-torus") {
    if (o.tolerance <= 0.0f) o.tolerance = 0.046f;
    return restate_adaptive_refusal(o, a.levels >= 0, [&] { return build_adaptive_implicit(torus_implicit(), o); });
  }
  if (is_mesh_file(a.input)) throw InvalidInput("build --method adaptive: give a height field or torus | saddle | implicit-torus, not a mesh");
  // Checked here (named: the file, its size, its span), not left to the builder: a span past float's reach
  // made the default tolerance infinite ("tolerance must be finite and > 0, got inf").
  const HeightField field = read_checked_heightfield(a.input, ro, a.spacing);
  if (o.tolerance <= 0.0f) {
    const auto [lo, hi] = std::minmax_element(field.z.begin(), field.z.end());
    o.tolerance = std::max(1e-6f, 0.01f * (*hi - *lo));
  }
  return restate_adaptive_refusal(o, a.levels >= 0, [&] { return build_adaptive_heightfield(field, o); });
}

void print_metrics(const Mt& mt, bool semiregular = false) {
  const MtMetrics m = compute_metrics(mt);
  std::printf("hierarchy: %s, %s (%zu coarsest, %zu finest), %s, depth %zu, growth %.3f, %.1f bytes per finest face\n",
              count_noun(m.nodes, "node").c_str(), count_noun(m.faces, "face").c_str(), m.coarsest_faces, m.finest_faces,
              count_noun(mt.num_vertices(), "vertex").c_str(), m.depth, m.growth_rate,
              double(mt.memory_bytes()) / double(std::max<std::size_t>(1, m.finest_faces)));
  // Semi-regular 4-8 structures: the chain growth of mt_metrics.hpp beside eq. 5's value with n = |K0|/2
  // (README: a constructed reading of Velho-Gomes 3.3; not the paper's own n).
  if (!semiregular) return;
  if (const ChainGrowth g = chain_growth(mt); g.computed && m.nodes > 0) {
    const double n = static_cast<double>(m.coarsest_faces) / 2.0;
    std::printf("chain growth %.6f (a chain of %zu, closure %zu); (n+2)/(n+1) with n = |K0|/2 = %g: %.6f\n", g.max_growth,
                g.argmax_length, g.argmax_closure, n, (n + 2.0) / (n + 1.0));
  }
}

// The magics of the two hierarchy files (pm/hierarchy_io.cpp, multitri/mt_io.cpp).
const std::string kVmhMagic = "VMPMHIER";
const std::string kVrmMagic("VMSHMT\r\n", 8);

// The first 8 bytes of `path`; 8 zero bytes when it cannot be opened, is shorter or is not a regular file (a
// FIFO would block the open; the loaders then say what it is).
std::string file_magic(const std::string& path) {
  char magic[8] = {};
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::string(magic, sizeof magic);
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(magic, sizeof magic)) std::fill(std::begin(magic), std::end(magic), '\0');
  return std::string(magic, sizeof magic);
}

// query and pm query read one kind of hierarchy each: the other kind is named, with the command that reads
// it (the loaders said only "bad magic").
void refuse_other_hierarchy(const std::string& path, bool pm) {
  const std::string m = file_magic(path);
  if (!pm && m == kVmhMagic)
    throw IoError(path, "a progressive-mesh vertex hierarchy (.vmh, from varmesh pm build), not a Multi-Triangulation "
                        "(.vrm): use varmesh pm query");
  if (pm && m == kVrmMagic)
    throw IoError(path, "a Multi-Triangulation (.vrm, from varmesh build), not a progressive-mesh vertex hierarchy "
                        "(.vmh): use varmesh query");
}

// `varmesh info` on a hierarchy file, told by its magic (not its extension).
bool hierarchy_info(const std::string& path) {
  // The magic decides; a file too short for one (or unreadable) is a hierarchy file when its extension
  // says so, and then the loader names the problem (truncated, cannot open).
  std::string m = file_magic(path);
  const std::string ext = lower_extension(path);
  if (m != kVmhMagic && m != kVrmMagic) {
    if (m != std::string(8, '\0')) return false;
    if (ext == ".vmh") m = kVmhMagic;
    else if (ext != ".vrm") return false;
  }
  std::error_code ec;
  const auto file_bytes = std::filesystem::file_size(path, ec);
  Stopwatch watch;
  if (m == kVmhMagic) {
    const VertexHierarchy h = read_vertex_hierarchy(path);
    const double ms = watch.ms();
    const InputRepairReport& r = h.repair_report();
    std::printf("%s: progressive-mesh vertex hierarchy (.vmh, format %u, %zu bytes), loaded and validated in %.1f ms\n",
                path.c_str(), kVertexHierarchyFormatVersion, static_cast<std::size_t>(file_bytes), ms);
    std::printf("input %s, %s; repaired: %s, %zu degenerate and %zu duplicate faces dropped, %s added (%s, %s), %zu "
                "locked\n",
                count_noun(r.input_vertices, "vertex").c_str(), count_noun(r.input_faces, "face").c_str(),
                count_noun(r.unreferenced_vertices, "unreferenced vertex").c_str(), r.degenerate_faces, r.duplicate_faces,
                count_noun(r.added_vertex_copies, "vertex copy").c_str(),
                count_noun(r.nonmanifold_edge_faces, "non-manifold edge face").c_str(),
                count_noun(r.nonmanifold_vertices, "non-manifold vertex").c_str(), r.locked_vertices);
    std::printf("%s, %s, %s (%s) down to a base mesh of %s, %s; %s, depth %d; colours %s; %.1f bytes per original face "
                "in memory\n",
                count_noun(h.num_leaves(), "leaf").c_str(), count_noun(h.num_faces(), "face").c_str(),
                count_noun(h.num_collapses(), "collapse").c_str(), count_noun(h.num_nodes(), "node").c_str(),
                count_noun(h.num_roots(), "vertex").c_str(), count_noun(h.base_faces().size(), "face").c_str(),
                count_noun(h.num_roots(), "tree").c_str(), h.max_depth(), h.has_colors() ? "yes" : "no",
                double(h.memory_bytes()) / double(std::max<std::size_t>(1, h.num_faces())));
    Box3 box;
    for (std::size_t v = 0; v < h.num_leaves(); ++v) box.add(h.position(static_cast<Index>(v)));
    const double diag = glm::length(glm::dvec3(box.hi) - glm::dvec3(box.lo));
    float worst = 0.0f;
    for (Index root : h.roots()) worst = std::max(worst, h.bound(root).error);
    // The node error accumulates the collapses' local moves up the tree (qem_analysis.hpp): it errs on the
    // high side, by far at the coarse levels (the bunny's 21-face base: 149 % of the diagonal, 4.5 times the
    // largest distance pm build --measure finds), though it is not a strict bound. Printed as e-4 of the
    // diagonal it read "14876.23 e-4".
    std::printf("node error of the base mesh (largest root): %.6g = %.3g %% of the bounding-box diagonal %.6g; a "
                "conservative estimate of the distance to the input (each collapse adds its local move to its children's "
                "largest error): usually well above the measured distance (pm build --measure), not a strict bound\n",
                double(worst), diag > 0.0 ? 100.0 * double(worst) / diag : 0.0, diag);
    return true;
  }
  const Mt mt = read_mt(path);
  const double ms = watch.ms();
  std::printf("%s: Multi-Triangulation (.vrm, %zu bytes), loaded and checked in %.1f ms\n", path.c_str(),
              static_cast<std::size_t>(file_bytes), ms);
  std::size_t kinds[4] = {0, 0, 0, 0};
  for (NodeId n = 1; n < mt.num_nodes(); ++n) ++kinds[static_cast<int>(mt.kind(n)) & 3];
  std::printf("nodes: %zu split, %zu swap, %zu generic\n", kinds[1], kinds[2], kinds[3]);
  print_metrics(mt);
  return true;
}

// The pictures' camera: the default 3/4 view, or picture_camera_for when --up or --view is given.
Camera chosen_camera(const TriMesh& reference, const std::string& up, const std::string& view) {
  if (up.empty() && view.empty()) return default_camera_for(reference, 4.0f / 3.0f);
  const glm::vec3 u = up.empty() ? glm::vec3(0.0f, 0.0f, 1.0f) : parse_direction(up, "--up");
  const glm::vec3 v = view.empty() ? glm::vec3(0.0f) : parse_direction(view, "--view");
  return picture_camera_for(reference, u, v, 4.0f / 3.0f);
}

// The --png of query and pm query: 1024 x 768, wireframe below 60k faces; empty when no --png is asked for.
Image query_picture(const TriMesh& mesh, const ViewQueryArgs& a) {
  if (a.png.empty()) return {};
  RenderOptions o;
  o.width = 1024;
  o.height = 768;
  o.wireframe = mesh.num_faces() < 60000;
  return render_mesh(mesh, chosen_camera(mesh, a.up, a.view), o);
}

// The common end of query and pm query: the query of `parts` (all of them; none: the finest mesh) under
// --budget, extracted on `front`, and its mesh written with its --png (both or neither).
struct Extracted {
  QueryStats stats;
  TriMesh mesh;
  double ms = 0.0;
  std::optional<SurfaceDistance> distance;  ///< --measure, taken before anything is written
};
// `measure_from`: with --measure, the mesh whose vertices are measured against the result (built only then).
template <class Front>
Extracted extract_and_write(Front& front, const std::vector<Criterion>& parts, const ViewQueryArgs& a,
                            const std::function<TriMesh()>& measure_from) {
  Query q;
  // No criterion (--budget alone): nothing is fine, so the finest mesh is the goal and the budget the only
  // limit. object_error(0) took nodes of error 0 (exact collapses of flat regions) for fine and stopped short.
  q.criterion = parts.empty()         ? Criterion::custom([](const ElementBound&) { return false; })
                : parts.size() == 1 ? parts[0]
                                    : Criterion::all_of(parts);
  q.triangle_budget = a.budget;
  Extracted r;
  Stopwatch watch;
  r.stats = extract(front, q);
  r.ms = watch.ms();
  r.mesh = front.to_mesh();
  // The picture is rendered and the distance measured before anything is written, so a bad --png, --up or
  // --view, or a measurement that fails, leaves no file.
  const Image picture = query_picture(r.mesh, a);
  if (a.measure) r.distance = vertex_to_surface_distance(measure_from(), r.mesh);
  write_mesh_and_picture(a.output, r.mesh, a.png, a.png.empty() ? nullptr : &picture);
  return r;
}

// The pictures of `--pictures`, rendered as the build goes and written once the hierarchy is: a failed run
// leaves neither the hierarchy nor pictures.
struct Picture {
  std::string name;  ///< file name inside the pictures folder
  Image image;
  std::size_t faces;
};

void add_level_picture(std::vector<Picture>& pictures, const std::string& name, const TriMesh& mesh, const Camera& cam) {
  RenderOptions o;
  o.width = 640;
  o.height = 480;
  o.wireframe = mesh.num_faces() < 30000;
  o.smooth = false;
  pictures.push_back({name, render_mesh(mesh, cam, o), mesh.num_faces()});
}

bool is_builtin_surface(const std::string& input) {
  return input == "torus" || input == "saddle" || input == "implicit-torus";
}

// The pictures' names that a build of `a` writes, as far as they are known before it runs (simplify4k's levels
// are not).
std::vector<std::string> planned_picture_names(const BuildArgs& a) {
  if (a.method == "adaptive") return {"adaptive_surface.png", "adaptive_domain.png"};
  std::vector<std::string> names;
  if (a.method == "semiregular")
    for (int level = 0; level <= (a.levels < 0 ? 4 : a.levels); ++level)
      names.push_back("semiregular_level" + std::to_string(level) + ".png");
  return names;
}

// Every output of the build against each other and against the input, before any work.
void check_build_outputs(const BuildArgs& a) {
  check_output_file(a.output);  // a folder, FIFO or device at -o: refused now, not after the build
  if (!is_builtin_surface(a.input)) refuse_same_file(a.input, "the input", a.output, "-o");
  if (a.pictures.empty()) return;
  // The folder at the hierarchy's path (or around it) would stop the hierarchy's rename at the very end,
  // after the pictures had been moved into place.
  if (path_within(a.pictures, a.output))
    throw InvalidInput("build: --pictures '" + a.pictures + "' and -o '" + a.output + "' are the same place (or the folder "
                       "would be inside the file): give the pictures folder another name");
  const std::vector<std::string> names = planned_picture_names(a);
  StagedFolder::check_targets(a.pictures, names);
  if (!is_builtin_surface(a.input))
    for (const std::string& name : names)
      refuse_same_file(a.input, "the input", (std::filesystem::path(a.pictures) / name).string(), "--pictures' picture");
  check_picture_axes(a.up, a.view);
}

// The semi-regular build's size, refused before the build when the finest mesh (every base face bisected
// `levels` times: base faces x 2^levels, the border's lone faces included) would have more than
// --max-triangles faces. The library refuses only what exceeds 2^31 faces or the machine's memory, and the
// cow's 5804 faces at --levels 12 (23.8M faces, 6 GB) took a minute to build.
void check_semiregular_size(const BuildArgs& a, std::size_t base_faces, int levels) {
  const double limit = double(a.max_triangles);
  const double finest = std::ldexp(double(base_faces), levels);
  if (finest <= limit) return;
  int fits = -1;  // the most levels within the limit
  while (fits < 64 && std::ldexp(double(base_faces), fits + 1) <= limit) ++fits;
  const std::string given = a.levels < 0 ? "the default --levels 4" : "--levels " + std::to_string(levels);
  char count[48];
  std::snprintf(count, sizeof count, "%.4g", finest);
  std::string text = "build: " + given + " on the " + count_noun(base_faces, "face") + " of '" + a.input +
                     "' would make " + count + " faces in the finest mesh (" + std::to_string(base_faces) + " x 2^" +
                     std::to_string(levels) + "), more than --max-triangles " + std::to_string(a.max_triangles) +
                     " (about 250 bytes each at the peak): lower --levels";
  if (fits >= 0) text += " (at most " + std::to_string(fits) + " here)";
  throw InvalidInput(text + " or raise --max-triangles (at most 2^31)");
}

// Rethrows the library's refusal `e` of the mesh read from `path` as an IoError naming the file. When the
// refusal was one of the manifold rules (`rules`: those of the code that refused), the problem is said again
// in the file's terms, as subdiv does (apps/file_faces.hpp): the library numbers the reader's triangles and
// the vertices from 0, the user knows the file's faces, lines and vertex numbers. A topology problem that
// shows only on the triangles the reader made of a polygon (a fan's diagonal on a third face) keeps the
// library's words.
[[noreturn]] void refuse_in_file_terms(const std::string& path, const TriMesh& mesh, const InvalidInput& e,
                                       const TopologyRules& rules) {
  bool topological = false;
  try {
    topological = bool(find_topology_problem(mesh, rules));
  } catch (const InvalidInput&) {
    // indices out of range: the refusal was base.validate()'s
  }
  if (topological)
    if (const std::optional<FileFaces> faces = read_file_faces(path)) {
      std::size_t line = 0;
      const std::string problem = topology_problem(*faces, &line, rules);
      if (!problem.empty()) throw IoError(path, problem, line);
    }
  throw IoError(path, e.what());
}

// Writes the hierarchy `a.output` and its pictures, all or nothing: the hierarchy goes to a temporary name
// beside its target, the pictures to a staging folder inside `a.pictures` (StagedFolder), then the pictures
// are moved into place and the hierarchy renamed last. A failure on the way leaves the output and the folder
// as they were, an earlier run's files included (removing what this run wrote had deleted them). Two
// renames cannot be one step: should the hierarchy's own rename fail after the pictures are in place (a
// target made read-only in between; a folder there is refused up front), the new pictures stay beside the
// old file.
void write_hierarchy_and_pictures(const BuildArgs& a, const Mt& mt, const std::vector<Picture>& pictures) {
  if (a.pictures.empty()) {
    write_mt(a.output, mt);
    return;
  }
  namespace fs = std::filesystem;
  // The names are all known now (simplify4k's levels included): the same checks as before the work.
  std::vector<std::string> names;
  for (const Picture& p : pictures) names.push_back(p.name);
  StagedFolder::check_targets(a.pictures, names);
  if (!is_builtin_surface(a.input))
    for (const std::string& name : names) refuse_same_file(a.input, "the input", (fs::path(a.pictures) / name).string(), "--pictures' picture");
  write_staged(a.output, [&](const std::string& staged) { write_mt(staged, mt); },
               [&] {
                 StagedFolder folder(a.pictures);
                 for (const Picture& p : pictures) write_png(folder.path(p.name), p.image);
                 folder.commit();
               });
  for (const Picture& p : pictures)
    std::printf("  %s: %s\n", (fs::path(a.pictures) / p.name).string().c_str(), count_noun(p.faces, "face").c_str());
}

}  // namespace

int run_build(const BuildArgs& a) {
  if (lower_extension(a.output) != ".vrm") throw InvalidInput("build: -o must end in .vrm, not '" + a.output + "'");
  if (a.max_triangles == 0 || a.max_triangles > BuildArgs::kHardMaxTriangles)
    throw InvalidInput("build: --max-triangles must be in 1 .. 2^31, not " + std::to_string(a.max_triangles));
  if (!std::isfinite(a.tolerance)) throw InvalidInput("build: --tolerance must be a finite number");
  if (a.method != "adaptive" && a.method != "semiregular" && a.method != "simplify4k")
    throw InvalidInput("build: unknown --method '" + a.method + "' (semiregular, adaptive, simplify4k)");
  if (a.method != "adaptive") {
    if (a.tolerance > 0.0f) throw InvalidInput("build: --tolerance is for --method adaptive, not " + a.method);
    if (!a.raw_size.empty()) throw InvalidInput("build: --raw-size is for --method adaptive on a .raw height field");
    if (a.heightfield_scale_given) throw InvalidInput("build: --spacing and --z-scale are for --method adaptive on a height field");
  }
  if (a.method != "semiregular" && a.max_triangles_given)
    throw InvalidInput("build: --max-triangles is for --method semiregular (adaptive refines to its --tolerance, simplify4k coarsens)");
  check_build_outputs(a);
  Stopwatch watch;
  Mt mt;
  std::vector<Picture> pictures;
  if (a.method == "adaptive") {
    AdaptiveHierarchy h = build_adaptive(a);
    std::printf("adaptive: %s, %s at the tolerance, max level %d\n", count_noun(h.num_base_faces, "base face").c_str(),
                count_noun(h.num_finest_faces, "face").c_str(), h.max_level);
    if (!a.pictures.empty()) {
      MtFront fine(h.mt);
      for (NodeId n = 1; n < h.mt.num_nodes(); ++n) fine.refine(n);
      const TriMesh mesh = fine.to_mesh();
      add_level_picture(pictures, "adaptive_surface.png", mesh, chosen_camera(mesh, a.up, a.view));
      if (!h.domain.empty()) {
        const TriMesh dom = adaptive_domain_mesh(h);
        Camera top = default_camera_for(dom, 4.0f / 3.0f);
        const glm::vec3 c = dom.bounds().center();
        top.target = c;
        top.eye = c + glm::vec3(0.0f, 0.0f, 1.25f * dom.bounds().diagonal());
        top.up = {0.0f, 1.0f, 0.0f};
        top.z_near = 0.1f * dom.bounds().diagonal();
        top.z_far = 10.0f * dom.bounds().diagonal();
        add_level_picture(pictures, "adaptive_domain.png", dom, top);
      }
    }
    mt = std::move(h.mt);
  } else if (a.method == "semiregular") {
    if (!is_mesh_file(a.input)) throw InvalidInput("build --method semiregular: INPUT must be a mesh (.obj, .off, .ply)");
    const TriMesh base = read_input_mesh(a.input);
    SemiRegularInfo info;
    const int levels = a.levels < 0 ? 4 : a.levels;
    check_semiregular_size(a, base.num_faces(), levels);
    try {
      mt = build_semiregular_mt(base, levels, {}, &info);
    } catch (const InvalidInput& e) {
      refuse_in_file_terms(a.input, base, e, kFourKMeshRules);
    }
    // The faces left over by the matching are split 1 -> 2 on their own; said only when there are some.
    const std::string leftovers = info.matching.num_leftovers == 0
                                      ? std::string()
                                      : " (" + std::to_string(info.matching.num_leftovers) + " left over, split 1->2 on the border)";
    std::printf("semiregular: %s paired into %s%s, %s\n", count_noun(base.num_faces(), "base face").c_str(),
                count_noun(info.matching.num_pairs, "block").c_str(), leftovers.c_str(),
                count_noun(std::uint64_t(levels), "level").c_str());
    if (!a.pictures.empty()) {
      const Camera cam = chosen_camera(base, a.up, a.view);
      MtFront front(mt);
      std::vector<NodeId> by_level;
      for (int level = 0; level <= levels; ++level) {
        for (NodeId n = 1; n < mt.num_nodes(); ++n)
          if (info.node_level[n] == level) front.refine(n);
        add_level_picture(pictures, "semiregular_level" + std::to_string(level) + ".png", front.to_mesh(), cam);
      }
    }
  } else if (a.method == "simplify4k") {
    if (!is_mesh_file(a.input)) throw InvalidInput("build --method simplify4k: INPUT must be a mesh (.obj, .off, .ply)");
    const TriMesh input = read_input_mesh(a.input);
    Simplify4kOptions so;
    so.max_levels = a.levels > 0 ? a.levels : 64;  // 0 or unset: as many levels as it can
    Simplify4kResult r = [&] {
      try {
        return simplify4k(input, so);
      } catch (const InvalidInput& e) {
        refuse_in_file_terms(a.input, input, e, kFourKMeshRules);  // simplify4k checks FourKMesh's rules itself
      }
    }();
    std::printf("simplify4k: %s, %s, %s; faces per level:", count_noun(r.num_levels(), "level").c_str(),
                count_noun(r.num_split_nodes, "split node").c_str(), count_noun(r.num_swap_nodes, "swap node").c_str());
    for (const Simplify4kLevel& l : r.levels) std::printf(" %zu", l.faces);
    std::printf("\n");
    if (!a.pictures.empty()) {
      const Camera cam = chosen_camera(input, a.up, a.view);
      // The levels nearest to the face counts of Velho-Gomes Figure 21, plus the input.
      std::vector<std::size_t> levels{0};
      for (std::size_t target : {1200u, 700u, 400u, 300u, 200u}) levels.push_back(simplify4k_closest_level(r, target));
      levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
      for (std::size_t level : levels)
        add_level_picture(pictures, "simplify4k_level" + std::to_string(level) + ".png", simplify4k_level_mesh(r, level), cam);
    }
    mt = std::move(r.mt);
  } else {
    throw InvalidInput("build: unknown --method '" + a.method + "' (semiregular, adaptive, simplify4k)");
  }
  const double ms = watch.ms();
  write_hierarchy_and_pictures(a, mt, pictures);
  print_metrics(mt, a.method == "semiregular");
  std::printf("built in %.1f ms -> %s\n", ms, a.output.c_str());
  return 0;
}

namespace {
// The outputs of query and pm query, and the picture's axes, checked before the hierarchy is read.
void check_view_query_outputs(const ViewQueryArgs& a, const char* command) {
  require_mesh_output(a.output, command);
  require_png(a.png, command);
  refuse_same_file(a.input, "the input hierarchy", a.output, "-o");
  refuse_same_file(a.input, "the input hierarchy", a.png, "--png");
  refuse_same_output(a.output, "-o", a.png, "--png");
  check_picture_axes(a.up, a.view);
}

// The metric of BENCHMARKS.md (issue 3): every original vertex to the nearest triangle.
void print_distance(const char* what, const SurfaceDistance& d, const char* from) {
  const double rel = d.diagonal > 0.0 ? 1e4 / d.diagonal : 0.0;
  std::printf("%s: distance from the %zu %s vertices: RMS %.6g, max %.6g (%.2f / %.2f e-4 of the bounding-box "
              "diagonal %.6g)\n", what, d.points, from, d.rms, d.max, d.rms * rel, d.max * rel, d.diagonal);
}

// A triangle budget below the coarsest mesh cannot be met: the query returns that mesh, which the summary
// line ("0 nodes refined, budget reached") leaves the user to work out.
void note_budget_below_base(std::size_t budget, std::size_t faces) {
  if (budget == 0 || faces <= budget) return;
  std::fprintf(stderr, "note: --budget %zu is below the base mesh's %s: nothing is coarser, so the result is the base mesh\n",
               budget, count_noun(faces, "triangle").c_str());
}
}  // namespace

int run_query(const QueryArgs& a) {
  check_view_query_outputs(a, "query");
  refuse_other_hierarchy(a.input, false);
  if (a.error < 0.0f && a.camera.empty() && a.ramp.empty() && a.budget == 0)
    throw InvalidInput("query: give --error E, --camera ..., --ramp ... or --budget N");
  std::vector<Criterion> parts;
  add_error_and_camera_criteria(a.error, a.camera, a.pixels, a.viewport, parts);
  if (!a.ramp.empty()) {
    const auto r = parse_floats(a.ramp, "--ramp", 8);
    const glm::vec3 p0{r[0], r[1], r[2]}, p1{r[3], r[4], r[5]};
    const float s0 = r[6], s1 = r[7];
    if (!(s0 > 0.0f) || !(s1 > 0.0f)) throw InvalidInput("--ramp: sizes must be > 0");
    // In double: with points far apart the float squared length and dot product overflow to infinity, and
    // t = inf / inf (NaN) refined everything.
    const glm::dvec3 q0(p0), axis = glm::dvec3(p1) - q0;
    const double len2 = glm::dot(axis, axis);
    if (!(len2 > 0.0)) throw InvalidInput("--ramp: the two points coincide");
    // Figure 22 c/d of Velho-Gomes: a node is fine when its region (bounding-sphere diameter) is no larger
    // than the size the ramp asks for at its centre.
    parts.push_back(Criterion::custom([=](const ElementBound& b) {
      const double t = std::clamp(glm::dot(glm::dvec3(b.center) - q0, axis) / len2, 0.0, 1.0);
      return 2.0 * double(b.radius) <= double(s0) + t * double(s1 - s0);
    }));
  }
  const Mt mt = read_mt(a.input);
  // read_mt keeps any finite coordinates; the meshes extracted from them must be measurable, as every
  // mesh the commands read (read_input_mesh). A file edited or damaged with a valid checksum wrote a mesh
  // varmesh could not read back, and --png failed with "render: camera needs 0 < z_near < z_far".
  Box3 box;
  for (const glm::vec3& p : mt.positions()) box.add(p);
  if (!std::isfinite(box.diagonal()))
    throw IoError(a.input, "the coordinates span more than about 1.8e19: squared distances overflow float (the "
                           "bounding box's diagonal cannot be measured, and varmesh could not read the extracted "
                           "mesh back)");
  MtFront front(mt);
  const auto [st, mesh, ms, distance] = extract_and_write(front, parts, a, [&] {
    MtFront finest(mt);  // every node applied: nodes are numbered parents first
    for (NodeId n = 0; n < mt.num_nodes(); ++n)
      if (!finest.is_applied(n)) finest.apply(n);
    return finest.to_mesh();
  });
  std::printf("front: %s, %s (%s refined%s) in %.2f ms -> %s\n", count_noun(mesh.num_faces(), "triangle").c_str(),
              count_noun(mesh.num_vertices(), "vertex").c_str(), count_noun(st.refined, "node").c_str(),
              st.budget_reached ? ", budget reached" : "", ms, a.output.c_str());
  note_budget_below_base(a.budget, mesh.num_faces());
  if (distance) print_distance("result", *distance, "finest mesh");
  return 0;
}


namespace {
// The input mesh as the hierarchy recorded it: its faces on the input's vertex ids (the copies that the
// repair made of non-manifold vertices map back to one vertex, so each input vertex is measured once).
TriMesh input_mesh_of(const VertexHierarchy& h) {
  TriMesh leaves = mesh_after_collapses(h, 0);
  const std::span<const Index> to_input = h.leaf_to_input();
  if (to_input.size() != h.num_leaves()) return leaves;
  // Numbered densely in the order of the input's ids (not by the ids themselves: their range is the file's word).
  std::vector<Index> ids(to_input.begin(), to_input.end());
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  auto dense = [&](Index id) { return static_cast<Index>(std::lower_bound(ids.begin(), ids.end(), id) - ids.begin()); };
  TriMesh m;
  m.positions.resize(ids.size());
  for (Index l = 0; l < to_input.size(); ++l) m.positions[dense(to_input[l])] = leaves.positions[l];
  m.indices.reserve(leaves.indices.size());
  for (Index c : leaves.indices) m.indices.push_back(dense(to_input[c]));
  return m;
}

// The connected pieces of the base mesh (union-find over its faces).
std::size_t base_pieces(const VertexHierarchy& h) {
  const TriMesh base = mesh_after_collapses(h, h.num_collapses());
  std::vector<Index> parent(base.num_vertices());
  for (Index i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&parent](Index x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t f = 0; f < base.num_faces(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(base.corner(f, k))] = find(base.corner(f, 0));
  std::vector<std::uint8_t> counted(parent.size(), 0);
  std::size_t pieces = 0;
  for (Index c : base.indices) {
    const Index r = find(c);
    pieces += counted[r] == 0;
    counted[r] = 1;
  }
  return pieces;
}

// A --faces or --vertices target that the analysis did not reach, said with why: the collapses left all
// failed a legality check (QemStats' counts over the whole run say which checks refused how often), and
// every connected piece keeps at least 4 vertices. (The dragon at --vertices 500 ended at 2469 vertices,
// exit 0 and no word: its repair had cut it into hundreds of pieces.)
void print_target_note(const PmBuildArgs& a, const QemStats& st, const VertexHierarchy& h) {
  // A target the input meets already: say so rather than let "0 collapses" look like a failure.
  if (st.collapses == 0 && ((a.vertices > 0 && st.base_vertices <= a.vertices) || (a.faces > 0 && st.base_faces <= a.faces))) {
    const bool by_vertices = a.vertices > 0;
    std::printf("note: %s %zu is at or above the input's %s: nothing was collapsed, and the hierarchy holds the "
                "input mesh as its base mesh\n",
                by_vertices ? "--vertices" : "--faces", by_vertices ? a.vertices : a.faces,
                count_noun(by_vertices ? st.base_vertices : st.base_faces, by_vertices ? "vertex" : "face").c_str());
    return;
  }
  std::string target;
  if (a.vertices > 0 && st.base_vertices > a.vertices)
    target = "--vertices " + std::to_string(a.vertices) + " not reached: the base mesh has " + std::to_string(st.base_vertices) + " vertices";
  else if (a.faces > 0 && st.base_faces > a.faces)
    target = "--faces " + std::to_string(a.faces) + " not reached: the base mesh has " + std::to_string(st.base_faces) + " faces";
  if (target.empty()) return;
  std::string why;
  auto add = [&why](std::size_t n, const std::string& what) {
    if (n > 0) why += (why.empty() ? "" : ", ") + std::to_string(n) + " " + what;
  };
  add(st.rejected_error, st.rejected_error == 1 ? "was over --max-error" : "were over --max-error");
  add(st.rejected_link, "failed the link condition");
  add(st.rejected_flip, "would flip or degenerate a face");
  add(st.rejected_locked, "touched locked vertices (--non-manifold lock)");
  add(st.rejected_depth, "hit the depth limit of the hierarchy");
  std::string text = "note: " + target + "; no collapse left passes the checks";
  if (!why.empty()) text += " (refused along the way: " + why + ")";
  const std::size_t pieces = base_pieces(h);
  if (pieces > 1) {
    text += "; the base mesh is " + std::to_string(pieces) + " separate pieces";
    if (h.repair_report().added_vertex_copies > 0)
      text += " (the repair cut the input at its non-manifold edges and vertices: " +
              count_noun(h.repair_report().added_vertex_copies, "vertex copy") + ")";
    text += ", and no piece goes below 4 vertices";
  }
  std::printf("%s\n", text.c_str());
}

}  // namespace

int run_pm_build(const PmBuildArgs& a) {
  if (!is_mesh_file(a.input)) throw InvalidInput("pm build: INPUT must be a mesh (.obj, .off, .ply), not '" + a.input + "'");
  if (lower_extension(a.output) != ".vmh") throw InvalidInput("pm build: -o must end in .vmh, not '" + a.output + "'");
  check_output_file(a.output);
  refuse_same_file(a.input, "the input mesh", a.output, "-o");
  QemOptions o;
  parse_collapse_cost(a.cost, o.cost, o.preserve_volume);
  if (a.non_manifold == "lock") o.non_manifold = NonManifoldPolicy::kLock;
  else if (a.non_manifold != "split") throw InvalidInput("--non-manifold: unknown '" + a.non_manifold + "' (known: split, lock)");
  if (std::isnan(a.max_error)) throw InvalidInput("--max-error must be a number >= 0");  // < 0 (not given) otherwise
  if (a.max_error >= 0.0f) o.max_error = a.max_error;
  o.target_faces = a.faces;
  o.target_vertices = a.vertices;
  if (!(a.lt_finish == 0.0 || (a.lt_finish > 1.0 && std::isfinite(a.lt_finish)))) {
    char given[32];
    std::snprintf(given, sizeof given, "%g", a.lt_finish);
    throw InvalidInput(std::string("--lt-finish must be 0 or a number > 1, not ") + given);
  }
  o.lt_finish = a.lt_finish;
  o.use_colors = a.colors;
  // Combinations the analysis would quietly ignore are refused (QemOptions documents what wins).
  if (a.lt_finish_given && a.lt_finish != 0.0) {  // turning it off is harmless anywhere
    if (a.faces == 0 && a.vertices == 0) throw InvalidInput("--lt-finish needs --faces or --vertices (the finish runs up to a target)");
    if (o.cost == CollapseCost::kLindstromTurk) throw InvalidInput("--lt-finish is for --cost quadric or quadric-plain (lindstrom-turk runs all the way)");
    if (a.colors) throw InvalidInput("--lt-finish does not apply with --colors (the colour quadrics run to the end)");
  }
  o.threads = a.threads;
  if (a.threads_given && a.threads != 1) {
    if (o.cost == CollapseCost::kLindstromTurk) throw InvalidInput("--threads is for --cost quadric or quadric-plain (lindstrom-turk runs serially)");
    if (a.colors) throw InvalidInput("--threads does not apply with --colors (the colour quadrics run serially)");
  }
  if (a.colors && a.cost != "quadric")
    throw InvalidInput("--colors orders and places by the colour quadrics: --cost " + a.cost + " would be ignored");
  const TriMesh mesh = read_input_mesh(a.input);
  if (a.colors && !mesh.has_colors()) throw InvalidInput("pm build --colors: '" + a.input + "' has no vertex colours");
  // The progress line is rewritten in place, which only a terminal shows as one line: redirected to a file
  // or a pipe, every update would pile up on a single line of the log, so there it is left out.
  const bool progress = !a.quiet && isatty(fileno(stderr)) == 1;
  if (progress)
    o.progress = [&](std::size_t done, std::size_t left) {
      std::fprintf(stderr, "\r[varmesh] %zu collapses, %zu vertices left   ", done, left);
    };
  QemStats st;
  VertexHierarchy h;
  try {
    h = build_vertex_hierarchy(mesh, o, &st);
  } catch (const InvalidInput& e) {
    throw IoError(a.input, e.what());  // name the file (e.g. "mesh has no non-degenerate face")
  }
  if (progress && st.collapses >= 4096) std::fprintf(stderr, "\n");
  // Measured before the file is written: a measurement that fails leaves no file.
  std::optional<SurfaceDistance> distance;
  if (a.measure) distance = vertex_to_surface_distance(mesh, mesh_after_collapses(h, h.num_collapses()));
  write_vertex_hierarchy(a.output, h);
  const InputRepairReport& r = h.repair_report();
  std::printf("input %s, %s; repaired: %s, %zu degenerate and %zu duplicate faces dropped, %s added\n",
              count_noun(r.input_vertices, "vertex").c_str(), count_noun(r.input_faces, "face").c_str(),
              count_noun(r.unreferenced_vertices, "unreferenced vertex").c_str(), r.degenerate_faces, r.duplicate_faces,
              count_noun(r.added_vertex_copies, "vertex copy").c_str());
  const std::string over = a.max_error >= 0.0f ? ", " + std::to_string(st.rejected_error) + " over --max-error" : "";
  std::printf("%s (rejected: %zu link, %zu flip%s) down to a base mesh of %s, %s; %s, depth %d; %.1f bytes per original "
              "face; %.3f s -> %s\n",
              count_noun(st.collapses, "collapse").c_str(), st.rejected_link, st.rejected_flip, over.c_str(),
              count_noun(st.base_vertices, "vertex").c_str(), count_noun(st.base_faces, "face").c_str(),
              count_noun(h.num_roots(), "tree").c_str(), h.max_depth(), double(h.memory_bytes()) / double(h.num_faces()),
              st.seconds, a.output.c_str());
  if (st.lt_finished && st.collapses == st.lt_finish_from + 1)
    std::printf("collapse %zu ordered and placed by Lindstrom-Turk costs (--lt-finish %g)\n", st.collapses, a.lt_finish);
  else if (st.lt_finished && st.collapses > st.lt_finish_from)
    std::printf("collapses %zu to %zu ordered and placed by Lindstrom-Turk costs (--lt-finish %g)\n", st.lt_finish_from + 1,
                st.collapses, a.lt_finish);
  if (distance) print_distance("base mesh", *distance, "input");
  print_target_note(a, st, h);
  return 0;
}

int run_pm_query(const PmQueryArgs& a) {
  check_view_query_outputs(a, "pm query");
  refuse_other_hierarchy(a.input, true);
  RefinementScheme scheme = RefinementScheme::kKimLee;
  if (a.scheme == "hoppe97") scheme = RefinementScheme::kHoppe97;
  else if (a.scheme == "xia-varshney") scheme = RefinementScheme::kXiaVarshney;
  else if (a.scheme != "kim-lee") throw InvalidInput("--scheme: unknown '" + a.scheme + "' (known: kim-lee, hoppe97, xia-varshney)");
  if (a.error < 0.0f && a.camera.empty() && a.budget == 0) throw InvalidInput("pm query: give --error E, --camera ... or --budget N");
  std::vector<Criterion> parts;
  add_error_and_camera_criteria(a.error, a.camera, a.pixels, a.viewport, parts);
  const VertexHierarchy h = read_vertex_hierarchy(a.input);
  SrMesh sr(h, scheme);
  const auto [st, mesh, ms, distance] = extract_and_write(sr, parts, a, [&] { return input_mesh_of(h); });
  const SrStats& s = sr.stats();
  std::printf("%s: %s, %s (%s, %zu forced, %s, %zu forced, #DC %zu%s) in %.2f ms -> %s\n", scheme_name(scheme),
              count_noun(mesh.num_vertices(), "vertex").c_str(), count_noun(mesh.num_faces(), "triangle").c_str(),
              count_noun(s.vsplits, "vsplit").c_str(), s.forced_vsplits, count_noun(s.ecols, "ecol").c_str(), s.forced_ecols,
              s.degenerate_cases, st.budget_reached ? ", budget reached" : "", ms, a.output.c_str());
  note_budget_below_base(a.budget, mesh.num_faces());
  if (distance) print_distance("result", *distance, "input");
  return 0;
}

bool print_hierarchy_info(const std::string& path) { return hierarchy_info(path); }

}  // namespace varmesh::app
