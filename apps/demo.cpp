#include "apps/demo.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "apps/cli_util.hpp"
#include "apps/render.hpp"
#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

namespace varmesh::app {
namespace {

// The frustum's outline from the near plane to `far_dist`, as 12 segments (for the overview picture).
std::vector<Segment3> frustum_outline(const Camera& cam, float far_dist, const glm::vec3& color) {
  const glm::vec3 f = cam.forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, cam.up));
  const glm::vec3 u = glm::cross(r, f);
  const float th = std::tan(glm::radians(cam.fov_y_deg) * 0.5f);
  auto corner = [&](float d, float sx, float sy) { return cam.eye + f * d + r * (sx * th * cam.aspect * d) + u * (sy * th * d); };
  const float dn = std::max(cam.z_near, far_dist * 0.002f);
  glm::vec3 n[4] = {corner(dn, -1, -1), corner(dn, 1, -1), corner(dn, 1, 1), corner(dn, -1, 1)};
  glm::vec3 fa[4] = {corner(far_dist, -1, -1), corner(far_dist, 1, -1), corner(far_dist, 1, 1), corner(far_dist, -1, 1)};
  std::vector<Segment3> s;
  for (int i = 0; i < 4; ++i) {
    s.push_back({n[i], n[(i + 1) % 4], color});
    s.push_back({fa[i], fa[(i + 1) % 4], color});
    s.push_back({cam.eye, fa[i], color});
  }
  return s;
}

std::string format_number(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", double(v));
  return text;
}

// Rounds x > 0 up to 1, 2 or 5 times a power of ten.
double round_up_nice(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / p;
  return (m <= 1.0 ? 1.0 : m <= 2.0 ? 2.0 : m <= 5.0 ? 5.0 : 10.0) * p;
}

// A height field read with spacing 1 whose heights span more than half its width (a DEM: heights in metres
// on samples tens of metres apart) is a needle: Fuji's 3737 m over 511 samples drew a spike and, from the
// view camera, a dark streak. Such a field gets a round spacing that makes the relief about a fifth of the
// width, and a note saying so. Returns the note; empty (and `field` unchanged) when the proportions are
// already drawable.
std::string spread_samples(HeightField& field) {
  const auto [lo, hi] = std::minmax_element(field.z.begin(), field.z.end());
  const double range = double(*hi) - double(*lo);
  const double extent = double(std::max(field.width, field.height) - 1);
  if (!(extent > 0.0) || !(range > 0.5 * extent)) return {};
  const double spacing = round_up_nice(range / (0.2 * extent));
  if (!(spacing * extent < 1e18)) return {};  // far beyond any terrain; read_checked_heightfield's limit is 1.8e19
  field.spacing_x = field.spacing_y = static_cast<float>(spacing);
  char note[400];
  std::snprintf(note, sizeof note,
                "note: no --spacing: the heights span %.6g, %.3g times the width at spacing 1; the samples are "
                "placed %g apart here (relief %.2f of the width). Give --spacing D, the distance between samples in "
                "height units, for true proportions\n",
                range, range / extent, spacing, range / (spacing * extent));
  return note;
}

// The files the demo writes into its folder.
const std::vector<std::string> kOutputs = {"uniform.obj", "view.obj", "uniform.png", "view_camera.png",
                                           "uniform_topdown.png", "view_topdown.png"};

}  // namespace

void add_demo_options(CLI::App& demo, DemoArgs& a) {
  demo.add_option("--out", a.out_dir, "output folder (default varmesh_demo)")->option_text("DIR")->check(check_file_name);
  // Option texts instead of CLI11's "TEXT Excludes: ..." and "Needs: ...", which ran into the descriptions.
  auto* size = demo.add_option("--size", a.size, "samples per side of the generated terrain, 17..8193 (default 1025)")
                   ->option_text("N")
                   ->check(CLI::Range(17, 8193));
  demo.add_option("--error", a.error, "uniform mesh: max vertical error (default 0.5% of the height range)")
      ->option_text("E")
      ->check(check_non_negative);
  demo.add_option("--pixels", a.pixels, "view-dependent mesh: screen-space error in pixels (default 1)")
      ->option_text("P")
      ->check(check_positive);
  auto* field = demo.add_option("--heightfield", a.heightfield,
                                "use this height field instead of the generated terrain (not with --size): .pgm, .png, "
                                ".raw/.f32 (float32 LE, give --raw-size)")
                    ->option_text("FILE")
                    ->check(check_file_name)
                    ->excludes(size);
  demo.add_option("--raw-size", a.raw_size, "with --heightfield: W,H of a headerless .raw/.f32 file")
      ->option_text("W,H")
      ->check(check_not_empty)
      ->needs(field);
  demo.add_option("--spacing", a.spacing,
                  "with --heightfield: distance between samples, as terrain --spacing (default 1; with neither "
                  "--spacing nor --z-scale, heights that span more than half the width get a round spacing that "
                  "makes the relief about a fifth of the width, said in the output)")
      ->option_text("D")
      ->needs(field)
      ->each([&a](const std::string&) { a.spacing_given = true; });
  demo.add_option("--z-scale", a.z_scale, "with --heightfield: multiply heights by this factor, as terrain --z-scale")
      ->option_text("S")
      ->needs(field)
      ->each([&a](const std::string&) { a.z_scale_given = true; });
  demo.add_flag("--quiet", a.quiet, "no progress on stderr");
}

int run_demo(const DemoArgs& a) {
  namespace fs = std::filesystem;
  if (std::isnan(a.error)) throw InvalidInput("demo: --error must be a number, not NaN");
  if (!(a.pixels > 0.0f) || !std::isfinite(a.pixels)) throw InvalidInput("demo: --pixels must be finite and > 0");
  if (a.out_dir.empty()) throw InvalidInput("demo: --out: empty folder name");
  // The checks of terrain's --z-scale and --spacing, before any work.
  if (!std::isfinite(a.z_scale)) throw InvalidInput("demo: --z-scale must be a finite number");
  if (!(a.spacing > 0.0f) || !std::isfinite(a.spacing)) throw InvalidInput("demo: --spacing must be finite and > 0");
  // Before any work: what is in the way of an output, and an output that would replace the input.
  StagedFolder::check_targets(a.out_dir, kOutputs);
  for (const std::string& name : kOutputs) refuse_same_file(a.heightfield, "--heightfield", (fs::path(a.out_dir) / name).string(), "--out's file");
  HeightFieldReadOptions ro;
  ro.z_scale = a.z_scale;
  if (!a.heightfield.empty()) apply_raw_size(a.raw_size, a.heightfield, ro);
  const bool quiet = a.quiet;

  HeightField field;
  std::string layout_note;
  {
    Step step("making the terrain", quiet);
    if (a.heightfield.empty()) {
      field = make_fractal_terrain(a.size, a.size, 2026, 0.18f * float(a.size));
    } else {
      field = read_checked_heightfield(a.heightfield, ro, a.spacing);
      if (!a.spacing_given && !a.z_scale_given) layout_note = spread_samples(field);
    }
  }
  const auto [zmin_at, zmax_at] = std::minmax_element(field.z.begin(), field.z.end());
  const float zmin = *zmin_at, zmax = *zmax_at;
  const float range = zmax - zmin;
  const float error = a.error >= 0.0f ? a.error : 0.005f * range;

  Stopwatch build_watch;
  std::unique_ptr<Grid48> grid;
  {
    Step step("building the 4-8 hierarchy", quiet);
    try {
      grid = std::make_unique<Grid48>(field);
    } catch (const InvalidInput& e) {
      if (a.heightfield.empty()) throw;
      throw IoError(a.heightfield, e.what());  // name the file (e.g. fewer than 2 x 2 samples)
    }
  }
  const double build_ms = build_watch.ms();

  struct Row {
    const char* name;
    std::size_t triangles;
    double max_error;
    double ms;
  };
  std::vector<Row> rows;

  // 1. Uniform error.
  Grid48Front uniform(*grid);
  Query qu;
  qu.criterion = Criterion::object_error(error);
  Stopwatch wu;
  const TriMesh mu = uniform.extract_mesh(qu);
  const double tu = wu.ms();
  double eu;
  {
    Step step("measuring the uniform mesh's error over every sample", quiet);
    eu = grid->max_vertical_error(mu);
  }
  rows.push_back({"uniform error", mu.num_faces(), eu, tu});

  // 2. View-dependent: a camera on the terrain's edge looking across it, 1 pixel on a 1080p screen. Its
  // planes come from the terrain's box, height range included.
  const float w = float(field.width - 1) * field.spacing_x, h = float(field.height - 1) * field.spacing_y;
  const float diagonal = std::sqrt(w * w + h * h + range * range);
  Camera cam;
  cam.eye = {0.05f * w, -0.08f * h, zmax + 0.08f * range};
  cam.target = {0.55f * w, 0.6f * h, zmin + 0.3f * range};
  cam.fov_y_deg = 50.0f;
  cam.aspect = 16.0f / 9.0f;
  cam.z_near = 0.001f * diagonal;
  cam.z_far = 4.0f * diagonal;
  // A needle (heights spanning 1e17 widths, which spread_samples leaves alone) is seen straight down: +z
  // is then no up for the picture (the renderer refused it, after all the work), and another axis is taken.
  cam.up = cam.view_up();
  Grid48Front view(*grid);
  Query qv;
  qv.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080.0f, a.pixels)});
  Stopwatch wv;
  const TriMesh mv = view.extract_mesh(qv);
  const double tv = wv.ms();
  double ev;
  {
    Step step("measuring the view-dependent mesh's error over every sample", quiet);
    ev = grid->max_vertical_error(mv);
  }
  rows.push_back({"view-dependent", mv.num_faces(), ev, tv});

  // Every picture is rendered before the folder is made or anything is written, so that a failure (a camera
  // that cannot frame the terrain) leaves no partial output.
  Image uniform_png, view_png, uniform_topdown_png, view_topdown_png;
  {
    Step step("rendering PNG pictures", quiet);
    RenderOptions o;
    o.width = 1280;
    o.height = 960;
    o.height_ramp = true;
    const Camera overview = default_camera_for(mu, 4.0f / 3.0f);
    uniform_png = render_mesh(mu, overview, o);
    RenderOptions ov = o;
    ov.width = 1280;
    ov.height = 720;
    ov.wireframe = true;
    ov.wire_color = {0.2f, 0.2f, 0.2f};
    view_png = render_mesh(mv, cam, ov);
    // Top-down pictures of coarser versions, so that single triangles are visible at this resolution. The
    // eye stands above the highest sample (it stood 1.75 widths above the lowest: inside a tall relief),
    // far enough for the whole rectangle to fit the 45-degree view.
    const float side = std::max(w, h);
    Camera top;
    top.target = {0.5f * w, 0.5f * h, zmin};
    top.eye = {0.5f * w, 0.5f * h, zmax + 1.5f * side};
    top.up = {0.0f, 1.0f, 0.0f};
    top.fov_y_deg = 45.0f;
    top.aspect = 1.0f;
    top.z_near = 0.05f * side;
    top.z_far = 2.5f * side + range;
    RenderOptions ot;
    ot.width = ot.height = 1024;
    ot.height_ramp = true;
    ot.wireframe = true;
    ot.wire_color = {0.1f, 0.1f, 0.1f};
    Grid48Front coarse(*grid);
    Query qc;
    qc.criterion = Criterion::object_error(8.0f * error);
    coarse.extract_fast(qc);
    uniform_topdown_png = render_mesh(coarse.to_mesh(), top, ot);
    Query qcv;
    qcv.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080.0f, 8.0f * a.pixels)});
    coarse.extract_fast(qcv);
    view_topdown_png = render_mesh(coarse.to_mesh(), top, ot,
                                   frustum_outline(cam, 1.5f * glm::length(cam.target - cam.eye), {0.9f, 0.1f, 0.1f}));
  }
  {
    Step step("writing OBJ files and PNG pictures", quiet);
    StagedFolder out(a.out_dir);  // all six files or none (a failed write left the first ones behind)
    write_mesh(out.path(kOutputs[0]), mu);
    write_mesh(out.path(kOutputs[1]), mv);
    write_png(out.path(kOutputs[2]), uniform_png);
    write_png(out.path(kOutputs[3]), view_png);
    write_png(out.path(kOutputs[4]), uniform_topdown_png);
    write_png(out.path(kOutputs[5]), view_topdown_png);
    out.commit();
  }

  const std::string apart = field.spacing_x == 1.0f ? std::string() : " " + format_number(field.spacing_x) + " apart";
  std::printf("terrain %zu x %zu samples%s, height range %.2f; 4-8 hierarchy built in %.1f ms (%.1f bytes/sample)\n",
              field.width, field.height, apart.c_str(), double(range), build_ms,
              double(grid->memory_bytes()) / double(field.width * field.height));
  std::fputs(layout_note.c_str(), stdout);
  std::printf("%-16s %12s %22s %16s\n", "mesh", "triangles", "max vertical error", "extract+mesh ms");
  for (const auto& r : rows) std::printf("%-16s %12zu %22.4f %16.2f\n", r.name, r.triangles, r.max_error, r.ms);
  std::printf("uniform mesh: error asked %.4f, measured %.4f over all %zu samples (%s)\n", double(error), eu,
              field.width * field.height, eu <= double(error) ? "bound holds" : "BOUND VIOLATED");
  std::printf("view-dependent mesh: %.1f px on a 1080-line screen inside the frustum, coarse outside\n", double(a.pixels));
  std::printf("wrote %s/{uniform,view}.obj and uniform.png, view_camera.png, uniform_topdown.png (error x8),"
              " view_topdown.png (%.0f px, frustum in red)\n",
              a.out_dir.c_str(), double(8.0f * a.pixels));
  return eu <= double(error) ? 0 : 3;
}

}  // namespace varmesh::app
