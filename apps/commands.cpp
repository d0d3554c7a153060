#include "apps/commands.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <cctype>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "apps/cli_util.hpp"
#include "apps/compare.hpp"
#include "apps/demo.hpp"
#include "apps/hierarchy_cmds.hpp"
#include "apps/render.hpp"
#include "apps/subdiv_cmd.hpp"
#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/query.hpp"

namespace varmesh::app {

std::vector<float> parse_floats(const std::string& text, const std::string& option, std::size_t count) {
  std::vector<float> out;
  const char* p = text.data();
  const char* end = p + text.size();
  while (p < end) {
    float v = 0.0f;
    auto [next, ec] = std::from_chars(p, end, v);
    if (ec != std::errc() || !std::isfinite(v))
      throw InvalidInput(option + ": '" + text + "' is not a comma-separated list of numbers");
    out.push_back(v);
    p = next;
    if (p < end) {
      if (*p != ',') throw InvalidInput(option + ": expected ',' in '" + text + "'");
      ++p;
    }
  }
  if (out.size() != count)
    throw InvalidInput(option + ": expected " + std::to_string(count) + " numbers, got " + std::to_string(out.size()));
  return out;
}

glm::vec3 parse_vec3(const std::string& text, const std::string& option) {
  const auto v = parse_floats(text, option, 3);
  return {v[0], v[1], v[2]};
}

void add_error_and_camera_criteria(float error, const std::string& camera, float pixels, float viewport,
                                   std::vector<Criterion>& parts) {
  if (!(error < 0.0f)) {  // NaN counts as given: it must not pass for "no --error"
    if (!std::isfinite(error)) throw InvalidInput("--error must be finite");
    parts.push_back(Criterion::object_error(error));
  }
  if (camera.empty()) return;
  const auto c = parse_floats(camera, "--camera", 7);
  Camera cam;
  cam.eye = {c[0], c[1], c[2]};
  cam.target = {c[3], c[4], c[5]};
  cam.fov_y_deg = c[6];
  if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f))
    throw InvalidInput("--camera: the field of view must be in (0, 180) degrees");
  if (cam.eye == cam.target) throw InvalidInput("--camera: eye and target coincide");
  if (!(pixels > 0.0f) || !(viewport > 0.0f)) throw InvalidInput("--pixels and --viewport must be > 0");
  // Both planes relative to the viewing distance: an absolute far plane (1e7) culled every node of a model
  // in large units (a bunny scaled by 1e9 came back as its base mesh), and at small scales the far/near
  // ratio lost the frustum's precision. The far plane is meant to cull nothing.
  const float distance = glm::length(cam.eye - cam.target);
  cam.z_near = 1e-4f * distance;
  cam.z_far = 1e8f * distance;
  if (!std::isfinite(cam.z_far)) throw InvalidInput("--camera: eye and target are too far apart");
  parts.push_back(Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                     Criterion::screen_error(cam, viewport, pixels)}));
}

void parse_collapse_cost(const std::string& text, CollapseCost& cost, bool& preserve_volume) {
  cost = CollapseCost::kQuadric;
  preserve_volume = true;
  if (text == "quadric-plain") preserve_volume = false;
  else if (text == "lindstrom-turk") cost = CollapseCost::kLindstromTurk;
  else if (text != "quadric") throw InvalidInput("--cost: unknown '" + text + "' (known: quadric, quadric-plain, lindstrom-turk)");
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

bool is_mesh_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".obj" || ext == ".off" || ext == ".ply";
}

void require_mesh_output(const std::string& path, const char* command, const char* option) {
  if (!is_mesh_file(path))
    throw InvalidInput(std::string(command) + ": " + option + " must end in .obj, .ply or .off, not '" + path + "'");
}

void require_png(const std::string& path, const char* command, const char* option) {
  if (!path.empty() && lower_extension(path) != ".png")
    throw InvalidInput(std::string(command) + ": " + option + " must end in .png, not '" + path + "'");
}

namespace {
std::string check_sign(const std::string& text, bool zero_ok) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') return "'" + text + "' is not a number";
  if (std::isnan(v)) return "";  // named by the command, with what it means there
  // The options are floats: a value past FLT_MAX (1e39) would become inf when CLI11 stores it.
  if (std::isinf(v) || std::abs(v) > double(std::numeric_limits<float>::max())) return "must be a finite number, not " + text;
  if (zero_ok ? v < 0.0 : !(v > 0.0)) return std::string("must be ") + (zero_ok ? ">= 0" : "> 0") + ", not " + text;
  return "";
}
}  // namespace

std::string check_non_negative(const std::string& text) { return check_sign(text, true); }
std::string check_positive(const std::string& text) { return check_sign(text, false); }

void apply_raw_size(const std::string& text, const std::string& path, HeightFieldReadOptions& options) {
  if (text.empty()) return;
  const std::string ext = lower_extension(path);
  if (ext != ".raw" && ext != ".f32") throw InvalidInput("--raw-size is for a .raw or .f32 height field, not '" + path + "'");
  const auto wh = parse_floats(text, "--raw-size", 2);
  if (wh[0] < 1 || wh[1] < 1 || wh[0] != std::floor(wh[0]) || wh[1] != std::floor(wh[1]))
    throw InvalidInput("--raw-size: expected two positive integers W,H");
  options.raw_width = static_cast<std::size_t>(wh[0]);
  options.raw_height = static_cast<std::size_t>(wh[1]);
}

namespace {

TriMesh checked_extent(TriMesh mesh, const std::string& path) {
  Box3 box;
  for (Index i : mesh.indices) box.add(mesh.positions[i]);
  if (!std::isfinite(box.diagonal()))
    throw IoError(path, "the coordinates span more than about 1.8e19: squared distances overflow float (the "
                        "bounding box's diagonal cannot be measured); scale the model down");
  return mesh;
}

}  // namespace

TriMesh read_input_mesh(const std::string& path, ReadInfo* info) { return checked_extent(read_mesh(path, info), path); }

TriMesh read_input_mesh_data(const std::string& name, std::string_view data) {
  return checked_extent(read_mesh_data(name, data), name);
}

void write_staged(const std::string& target, const std::function<void(const std::string& staged)>& write,
                  const std::function<void()>& then_) {
  namespace fs = std::filesystem;
  const fs::path t(target);
  std::error_code ec;
  // Checked first: the rename at the end would fail after the rest (the pictures) had been written.
  if (fs::is_directory(fs::symlink_status(t, ec))) throw IoError(target, "is a folder: the file cannot be put there");
  const fs::path staged = t.parent_path() / ("." + t.stem().string() + ".partial-" + std::to_string(::getpid()) + t.extension().string());
  try {
    write(staged.string());
  } catch (const IoError& e) {
    fs::remove(staged, ec);
    throw IoError(target, e.reason());  // the user's name, not the staging one
  } catch (...) {
    fs::remove(staged, ec);
    throw;
  }
  try {
    then_();
  } catch (...) {
    fs::remove(staged, ec);
    throw;
  }
  fs::rename(staged, t, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(staged, ec);
    throw IoError(target, "cannot move the written file into place: " + why);
  }
}

void write_mesh_and_picture(const std::string& mesh_path, const TriMesh& mesh, const std::string& png_path,
                            const Image* picture) {
  if (!picture) {
    write_mesh(mesh_path, mesh);
    return;
  }
  // The mesh is moved into place after the picture is written: a picture that cannot be written leaves
  // whatever was at mesh_path as it was (removing the new mesh instead had deleted a file the user had).
  write_staged(mesh_path, [&](const std::string& staged) { write_mesh(staged, mesh); },
               [&] { write_png(png_path, *picture); });
}

StagedFolder::StagedFolder(const std::string& folder) : folder_(folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // symlink_status: a dangling link is the user's, not a folder to make (or to take back).
  for (fs::path p = fs::absolute(folder).lexically_normal(); !p.empty(); p = p.parent_path()) {
    if (fs::exists(fs::symlink_status(p, ec))) break;
    made_.push_back(p.string());
    if (p == p.parent_path()) break;
  }
  try {
    fs::create_directories(folder);
    // A name no one else uses: a folder left by a killed run (same pid in a container) is not ours to fill
    // or to remove.
    const unsigned long long salt =
        static_cast<unsigned long long>(std::chrono::steady_clock::now().time_since_epoch().count());
    for (unsigned attempt = 0; stage_.empty(); ++attempt) {
      const fs::path p = fs::path(folder) / (".varmesh-partial-" + std::to_string(::getpid()) + "-" +
                                             std::to_string((salt + attempt) % 1000000007ull));
      if (fs::create_directory(p)) stage_ = p.string();
      else if (attempt > 100) throw IoError(folder, "cannot make a staging folder in it");
    }
  } catch (const fs::filesystem_error& e) {
    for (const std::string& p : made_) fs::remove(p, ec);
    throw IoError(folder, e.code().message());
  }
}

StagedFolder::~StagedFolder() {
  if (committed_) return;
  std::error_code ec;
  if (!stage_.empty()) std::filesystem::remove_all(stage_, ec);
  for (const std::string& p : made_) std::filesystem::remove(p, ec);  // deepest first; only if empty
}

std::string StagedFolder::path(const std::string& name) {
  names_.push_back(name);
  return (std::filesystem::path(stage_) / name).string();
}

void StagedFolder::commit() {
  namespace fs = std::filesystem;
  // What would stop a move is looked for before the first move, so that nothing is moved when one cannot be.
  for (const std::string& name : names_) {
    std::error_code ec;
    if (fs::is_directory(fs::symlink_status(fs::path(folder_) / name, ec)))
      throw IoError((fs::path(folder_) / name).string(), "is a folder: the file cannot be put there");
  }
  for (const std::string& name : names_) {
    std::error_code ec;
    fs::rename(fs::path(stage_) / name, fs::path(folder_) / name, ec);
    if (ec) throw IoError((fs::path(folder_) / name).string(), "cannot move the written file into place: " + ec.message());
  }
  std::error_code ec;
  fs::remove(stage_, ec);
  committed_ = true;
}

Step::Step(const char* what, bool quiet) : what_(what), quiet_(quiet) {
  if (!quiet_) std::fprintf(stderr, "[varmesh] %s ...\n", what_);
}

Step::~Step() {
  const double t = watch_.ms();
  if (!quiet_ && t > 1000.0) std::fprintf(stderr, "[varmesh] %s done in %.1f s\n", what_, t / 1000.0);
}

namespace {

int cmd_info(const std::string& path) {
  if (print_hierarchy_info(path)) return 0;
  ReadInfo info;
  const TriMesh mesh = read_mesh(path, &info);
  const MeshReport report = analyze_mesh(mesh);
  std::printf("%s\n%s", path.c_str(), format_report(report).c_str());
  if (info.polygons_triangulated) std::printf("polygons triangulated: %zu\n", info.polygons_triangulated);
  if (info.attribute_conflicts) std::printf("attribute conflicts (first kept): %zu\n", info.attribute_conflicts);
  if (info.strip_degenerates_dropped) std::printf("degenerate strip triangles dropped: %zu\n", info.strip_degenerates_dropped);
  return 0;
}

struct TerrainArgs {
  std::string input, output, png, camera;
  float error = -1.0f;
  float pixels = 1.0f;
  float viewport = 1080.0f;
  std::size_t budget = 0;
  float z_scale = 1.0f;
  float spacing = 1.0f;
  std::string raw_size;
  bool terrain_rgb = false;
  bool fast_bound = false;
  bool measure = false;
  bool quiet = false;
};

int cmd_terrain(const TerrainArgs& a) {
  if (std::isnan(a.error)) throw InvalidInput("terrain: --error must be a number, not NaN");
  if (a.error < 0.0f && a.camera.empty()) throw InvalidInput("terrain: give --error E, --camera ..., or both");
  require_mesh_output(a.output, "terrain");
  require_png(a.png, "terrain");
  HeightFieldReadOptions ro;
  ro.decoding = a.terrain_rgb ? PixelDecoding::kTerrainRgb : PixelDecoding::kGray;
  if (!std::isfinite(a.z_scale)) throw InvalidInput("terrain: --z-scale must be a finite number");
  if (!(a.spacing > 0.0f) || !std::isfinite(a.spacing)) throw InvalidInput("terrain: --spacing must be finite and > 0");
  ro.z_scale = a.z_scale;
  apply_raw_size(a.raw_size, a.input, ro);
  HeightField field = read_heightfield(a.input, ro);
  field.spacing_x = field.spacing_y = a.spacing;
  Grid48Options go;
  go.exact_errors = !a.fast_bound;
  Stopwatch build_watch;
  // The grid's own checks (e.g. fewer than 2 x 2 samples) name no file: add it.
  const Grid48 grid = [&] {
    try {
      return Grid48(field, go);
    } catch (const InvalidInput& e) {
      throw IoError(a.input, e.what());
    }
  }();
  const double build_ms = build_watch.ms();
  Query q;
  std::vector<Criterion> parts;
  if (!a.camera.empty()) {
    const auto c = parse_floats(a.camera, "--camera", 7);
    Camera cam;
    cam.eye = {c[0], c[1], c[2]};
    cam.target = {c[3], c[4], c[5]};
    cam.fov_y_deg = c[6];
    if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f)) throw InvalidInput("--camera: the field of view must be in (0, 180) degrees");
    if (cam.eye == cam.target) throw InvalidInput("--camera: eye and target coincide");
    // Near and far planes from the terrain's own size (a fixed far plane of 1e7 made the answer depend on
    // the units: the same scene scaled by 1e5 lost triangles).
    const glm::vec3 lo(0.0f, 0.0f, *std::min_element(field.z.begin(), field.z.end()));
    const glm::vec3 hi(float(field.width - 1) * a.spacing, float(field.height - 1) * a.spacing,
                       *std::max_element(field.z.begin(), field.z.end()));
    const float reach = glm::length(cam.eye - 0.5f * (lo + hi)) + glm::length(hi - lo);
    cam.z_near = std::min(0.1f * a.spacing, 1e-3f * reach);
    cam.z_far = std::max(2.0f * reach, 10.0f * cam.z_near);
    if (!(a.pixels > 0.0f) || !std::isfinite(a.pixels) || !(a.viewport > 0.0f) || !std::isfinite(a.viewport))
      throw InvalidInput("terrain: --pixels and --viewport must be finite and > 0");
    parts.push_back(Criterion::outside_frustum(cam.frustum()));
    parts.push_back(Criterion::screen_error(cam, a.viewport, a.pixels));
  }
  if (a.error >= 0.0f) parts.push_back(Criterion::object_error(a.error));
  q.criterion = parts.size() == 1 ? parts[0] : Criterion::any_of(parts);
  q.triangle_budget = a.budget;
  Grid48Front front(grid);
  Stopwatch extract_watch;
  TriMesh mesh = front.extract_mesh(q);  // the front and its mesh in one pass where the query allows
  // The budget counts the hierarchy's triangles, and clipping them to the grid's rectangle (a grid that is
  // not 2^k + 1 samples wide) splits some: ask again for less until the clipped mesh fits (528 triangles
  // for --budget 500 on Jacksboro before).
  for (int round = 0; a.budget > 0 && mesh.num_faces() > a.budget && q.triangle_budget > 1 && round < 16; ++round) {
    const std::size_t over = mesh.num_faces() - a.budget;
    q.triangle_budget = q.triangle_budget > over + 1 ? q.triangle_budget - over : 1;
    mesh = front.extract_mesh(q);
  }
  const double extract_ms = extract_watch.ms();
  // The picture is rendered before anything is written, and a failed PNG write takes the mesh with it: a failed
  // run leaves no output.
  Image picture;
  if (!a.png.empty()) {
    RenderOptions o;
    o.width = 1024;
    o.height = 768;
    o.height_ramp = true;
    o.wireframe = mesh.num_faces() < 40000;  // denser wireframes turn black at this size
    picture = render_mesh(mesh, default_camera_for(mesh, 4.0f / 3.0f), o);
  }
  write_mesh_and_picture(a.output, mesh, a.png, a.png.empty() ? nullptr : &picture);
  std::printf("grid %zux%zu (lattice %zux%zu, tile %zu), hierarchy %.1f MB built in %.1f ms\n", field.width, field.height,
              grid.lattice_width(), grid.lattice_height(), grid.tile_size(), double(grid.memory_bytes()) / 1e6, build_ms);
  std::printf("extracted %zu triangles, %zu vertices in %.2f ms (mesh included) -> %s\n", mesh.num_faces(), mesh.num_vertices(),
              extract_ms, a.output.c_str());
  if (a.budget > 0 && mesh.num_faces() > a.budget)
    std::printf("note: the coarsest mesh of this grid has %zu triangles, more than --budget %zu\n", mesh.num_faces(), a.budget);
  if (a.measure) std::printf("measured max vertical error over all samples: %.6g\n", grid.max_vertical_error(mesh));
  return 0;
}

struct RenderArgs {
  std::string input, output, eye, target;
  int width = 1024, height = 768;
  float fov = 40.0f;
  bool wireframe = false, flat = false, ramp = false;
};

int cmd_render(const RenderArgs& a) {
  if (a.output.empty()) throw InvalidInput("render: -o must end in .png");
  require_png(a.output, "render", "-o");
  const TriMesh mesh = read_input_mesh(a.input);
  const float aspect = float(a.width) / float(a.height);
  Camera cam = default_camera_for(mesh, aspect);
  if (!a.eye.empty()) cam.eye = parse_vec3(a.eye, "--eye");
  if (!a.target.empty()) cam.target = parse_vec3(a.target, "--target");
  cam.fov_y_deg = a.fov;
  if (!a.eye.empty() || !a.target.empty()) {
    // Near and far planes around the mesh's bounding sphere seen from the eye (they were measured from the
    // target, so a target away from the mesh put the mesh past the far plane: a blank picture).
    Box3 box;
    for (Index i : mesh.indices) box.add(mesh.positions[i]);
    const glm::vec3 c = box.center();
    const float r = std::max(0.5f * box.diagonal(), 1e-3f * std::max(1.0f, glm::length(c)));
    const float d = glm::length(cam.eye - c);
    cam.z_far = d + r;
    cam.z_near = std::max(1e-4f * (d + r), d - r);
    if (!(cam.z_near < cam.z_far) || !std::isfinite(cam.z_far))
      throw InvalidInput("render: --eye " + a.eye + " is too far from the mesh to see it (" + std::to_string(d) + " units away)");
  }
  cam.up = cam.view_up();  // a top view with the default +z up: another axis, as Camera::view() does
  RenderOptions o;
  o.width = a.width;
  o.height = a.height;
  o.wireframe = a.wireframe;
  o.smooth = !a.flat;
  o.height_ramp = a.ramp;
  write_png(a.output, render_mesh(mesh, cam, o));
  std::printf("rendered %zu triangles -> %s\n", mesh.num_faces(), a.output.c_str());
  return 0;
}

}  // namespace

int run(int argc, char** argv) {
  CLI::App app{"varmesh: variable-resolution triangle meshes (Multi-Triangulations, 4-k meshes, progressive meshes)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "varmesh 0.1.0");

  std::string info_path;
  auto* info = app.add_subcommand("info", "Print the topology report of a mesh (OBJ, OFF, PLY), or a summary of a hierarchy file (.vmh, .vrm)");
  info->add_option("FILE", info_path, "mesh or hierarchy file")->required();

  TerrainArgs ta;
  auto* terrain = app.add_subcommand("terrain", "Build the 4-8 hierarchy of a height field and extract an adapted mesh");
  terrain->add_option("HEIGHTFIELD", ta.input, "height field: .pgm, .png, .raw/.f32 (float32 LE, give --raw-size)")->required();
  terrain->add_option("-o,--output", ta.output, "output mesh (.obj, .ply, .off)")->required();
  terrain->add_option("--error", ta.error, "largest vertical error allowed (height units); guaranteed over every sample")->check(CLI::NonNegativeNumber);
  auto* terrain_camera = terrain->add_option("--camera", ta.camera, "view-dependent: ex,ey,ez,tx,ty,tz,fov_degrees (world units: x = column * spacing)");
  terrain->add_option("--pixels", ta.pixels, "with --camera: screen-space error in pixels (default 1)")->check(check_positive)->needs(terrain_camera);
  terrain->add_option("--viewport", ta.viewport, "with --camera: viewport height in pixels (default 1080)")->check(check_positive)->needs(terrain_camera);
  terrain->add_option("--budget", ta.budget, "triangle budget (priority-driven, largest error first)")->check(CLI::NonNegativeNumber);
  terrain->add_option("--z-scale", ta.z_scale, "multiply heights by this factor");
  terrain->add_option("--spacing", ta.spacing, "distance between samples (default 1)");
  terrain->add_option("--raw-size", ta.raw_size, "W,H of a .raw/.f32 file");
  terrain->add_flag("--terrain-rgb", ta.terrain_rgb, "decode a Mapbox Terrain-RGB PNG");
  terrain->add_flag("--fast-bound", ta.fast_bound, "looser O(1)-per-node error bounds instead of exact errors (more triangles for the same threshold)");
  terrain->add_flag("--measure", ta.measure, "measure the true max vertical error of the result over all samples");
  terrain->add_option("--png", ta.png, "also render the result to this PNG");

  RenderArgs ra;
  auto* render = app.add_subcommand("render", "Render a mesh to a PNG with a small software rasterizer");
  render->add_option("MESH", ra.input, "mesh file")->required();
  render->add_option("-o,--output", ra.output, "output .png")->required();
  render->add_option("--width", ra.width, "image width in pixels")->check(CLI::Range(1, 16384));
  render->add_option("--height", ra.height, "image height in pixels")->check(CLI::Range(1, 16384));
  render->add_option("--eye", ra.eye, "camera position x,y,z (default: a 3/4 view)");
  render->add_option("--target", ra.target, "camera target x,y,z (default: the bounding sphere centre)");
  render->add_option("--fov", ra.fov, "vertical field of view in degrees")->check(CLI::Range(1.0, 170.0));
  render->add_flag("--wireframe", ra.wireframe, "draw edges");
  render->add_flag("--flat", ra.flat, "flat shading");
  render->add_flag("--height-ramp", ra.ramp, "colour by height (terrains)");

  DemoArgs da;
  auto* demo = app.add_subcommand("demo", "Fractal terrain: build, uniform-error and view-dependent meshes, table, OBJ + PNG");
  demo->add_option("--out", da.out_dir, "output folder (default varmesh_demo)");
  demo->add_option("--size", da.size, "terrain size in samples per side (default 1025)")->check(CLI::Range(17, 8193));
  demo->add_option("--error", da.error, "uniform mesh: max vertical error (default 0.5% of the height range)")->check(check_non_negative);
  demo->add_option("--pixels", da.pixels, "view-dependent mesh: screen-space error in pixels (default 1)")->check(check_positive);
  demo->add_option("--heightfield", da.heightfield, "use this height field instead of the fractal terrain");
  demo->add_option("--raw-size", da.raw_size, "W,H: the size of a headerless .raw/.f32 --heightfield");
  demo->add_flag("--quiet", da.quiet, "no progress on stderr");

  BuildArgs ba;
  auto* build = app.add_subcommand("build", "Build a 4-k hierarchy (semiregular, adaptive, simplify4k) and save it as .vrm");
  add_build_options(*build, ba);
  QueryArgs qa;
  auto* query = app.add_subcommand("query", "Extract a front of a .vrm hierarchy by error, camera, ramp or budget");
  add_query_options(*query, qa);

  PmBuildArgs pba;
  PmQueryArgs pqa;
  auto* pm = app.add_subcommand("pm", "Progressive meshes (Kim-Lee): build a vertex hierarchy (.vmh), query selectively refined meshes");
  pm->require_subcommand(1);
  auto* pm_build = pm->add_subcommand("build", "QEM analysis of a mesh into a vertex hierarchy, saved as .vmh");
  add_pm_build_options(*pm_build, pba);
  auto* pm_query = pm->add_subcommand("query", "Selectively refined mesh of a .vmh hierarchy by error, camera or budget");
  add_pm_query_options(*pm_query, pqa);

  SubdivArgs sa;
  auto* subdiv = app.add_subcommand("subdiv", "Subdivide a polygon mesh: 4-8, Catmull-Clark, Zwart-Powell, Doo-Sabin, quasi 4-8, linear; uniform or adaptive");
  add_subdiv_options(*subdiv, sa);

  CompareArgs ca;
  auto* compare = app.add_subcommand("compare", "Kim-Lee Table 2: three selective refinement schemes on image, terrain and 3D models, table + PNG");
  add_compare_options(*compare, ca);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version print and succeed; every other parse error is one line and status 1, like the
    // errors of the commands themselves (CLI11's own exit codes 100+ and its "Run with --help" line are
    // not what the README promises).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::fprintf(stderr, "varmesh: error: %s (see --help)\n", e.what());
    return 1;
  }
  try {
    if (*info) return cmd_info(info_path);
    if (*terrain) return cmd_terrain(ta);
    if (*render) return cmd_render(ra);
    if (*demo) return run_demo(da);
    if (*compare) return run_compare(ca);
    if (*build) return run_build(ba);
    if (*query) return run_query(qa);
    if (*subdiv) return run_subdiv(sa);
    if (*pm_build) return run_pm_build(pba);
    if (*pm_query) return run_pm_query(pqa);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "varmesh: error: %s\n", e.what());
    return 1;
  }
  return 2;
}

}  // namespace varmesh::app
