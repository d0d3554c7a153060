// `varmesh compare`: Kim-Lee 2001 section 5 (Table 2, Figures 8-10) on this library's three schemes.
// Every case builds one vertex hierarchy (pm/qem_analysis.hpp), marks the nodes that need refinement, and
// runs pm/selective_refine.hpp's refine_to_predicate under each scheme from the base mesh; the schemes
// then differ only in their dependency rules (sr_mesh.hpp), which is what the table measures.
#include "apps/compare.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/trigonometric.hpp>

#include "apps/cli_util.hpp"
#include "apps/render.hpp"
#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/shapes.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "multitri/tar_archive.hpp"
#include "multitri/terrain_gen.hpp"
#include "pm/dual_pieces.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/selective_refine.hpp"
#include "pm/sr_mesh.hpp"

namespace varmesh::app {
namespace {

namespace fs = std::filesystem;

// Paper order (Figures 8-9 (b), (c), (d); Table 2 top to bottom).
constexpr std::array<RefinementScheme, 3> kSchemes = {RefinementScheme::kXiaVarshney, RefinementScheme::kHoppe97,
                                                      RefinementScheme::kKimLee};
const std::array<std::string, 5> kKnownCases = {"image", "terrain", "bunny", "cow", "dragon"};

// ---- a 5x7 bitmap font for panel labels (lower case, digits, a few signs) ----

struct Glyph {
  char c;
  const char* rows;  // 7 rows of 5 cells, '#' = ink
};
constexpr Glyph kFont[] = {
    {'a', "...........###.....#.#####...#.####"}, {'b', "#....#....#.##.##..##...##...#####."},
    {'c', "...........###.#....#....#...#.###."}, {'d', "....#....#.##.##..###...##...#.####"},
    {'e', "...........###.#...#######.....###."}, {'f', "..##..#..#.#...###...#....#....#..."},
    {'g', "......#####...##...#.####....#.###."}, {'h', "#....#....#.##.##..##...##...##...#"},
    {'i', "..#........##....#....#....#...###."}, {'j', "...#........##....#....#.#..#..##.."},
    {'k', "#....#....#..#.#.#..##...#.#..#..#."}, {'l', ".##....#....#....#....#....#...###."},
    {'m', "..........##.#.#.#.##.#.##...##...#"}, {'n', "..........#.##.##..##...##...##...#"},
    {'o', "...........###.#...##...##...#.###."}, {'p', "..........####.#...#####.#....#...."},
    {'q', "...........##.##..##.####....#....#"}, {'r', "..........#.##.##..##....#....#...."},
    {'s', "...........###.#.....###.....#####."}, {'t', ".#....#...###...#....#....#..#..##."},
    {'u', "..........#...##...##...##..##.##.#"}, {'v', "..........#...##...##...#.#.#...#.."},
    {'w', "..........#...##...##.#.##.#.#.#.#."}, {'x', "..........#...#.#.#...#...#.#.#...#"},
    {'y', "..........#...##...#.####....#.###."}, {'z', "..........#####...#...#...#...#####"},
    {'0', ".###.#...##..###.#.###..##...#.###."}, {'1', "..#...##....#....#....#....#...###."},
    {'2', ".###.#...#....#...#...#...#...#####"}, {'3', "#####...#...#.....#.....##...#.###."},
    {'4', "...#...##..#.#.#..#.#####...#....#."}, {'5', "######....####.....#....##...#.###."},
    {'6', "..##..#...#....####.#...##...#.###."}, {'7', "#####....#...#...#...#....#....#..."},
    {'8', ".###.#...##...#.###.#...##...#.###."}, {'9', ".###.#...##...#.####....#...#..##.."},
    {'-', "...............#####..............."}, {'=', "..........#####.....#####.........."},
    {'#', ".#.#..#.#.#####.#.#.#####.#.#..#.#."}, {',', ".....................##....#...#..."},
    {'.', "..........................##...##.."}, {':', "......##...##........##...##......."},
    {'(', "...#...#...#....#....#.....#.....#."}, {')', ".#.....#.....#....#....#...#...#..."},
    {'/', ".........#...#...#...#...#........."}, {'%', "##...##..#...#...#...#...#..##...##"},
    {'+', ".......#....#..#####..#....#......."}, {'<', "...#...#...#...#.....#.....#.....#."},
};

const char* glyph_rows(char c) {
  if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  for (const Glyph& g : kFont)
    if (g.c == c) return g.rows;
  return nullptr;  // space and anything unknown: blank
}

void put_pixel(Image& img, long x, long y, const glm::vec3& c) {
  if (x < 0 || y < 0 || x >= static_cast<long>(img.width) || y >= static_cast<long>(img.height)) return;
  const std::size_t i = (static_cast<std::size_t>(y) * img.width + static_cast<std::size_t>(x)) * 3;
  for (std::size_t k = 0; k < 3; ++k)
    img.pixels[i + k] = static_cast<std::uint8_t>(std::lround(std::clamp(c[static_cast<int>(k)], 0.0f, 1.0f) * 255.0f));
}

// Text with a light box behind it so it reads on any picture.
void draw_text(Image& img, long x0, long y0, const std::string& text, int scale) {
  const long s = scale, adv = 6 * s;
  const long w = static_cast<long>(text.size()) * adv + 2 * s, h = 9 * s;
  for (long y = y0 - s; y < y0 - s + h; ++y)
    for (long x = x0 - s; x < x0 - s + w; ++x) {
      if (x < 0 || y < 0 || x >= static_cast<long>(img.width) || y >= static_cast<long>(img.height)) continue;
      const std::size_t i = (static_cast<std::size_t>(y) * img.width + static_cast<std::size_t>(x)) * 3;
      for (std::size_t k = 0; k < 3; ++k) img.pixels[i + k] = static_cast<std::uint8_t>(255 - (255 - img.pixels[i + k]) / 4);
    }
  for (std::size_t n = 0; n < text.size(); ++n) {
    const char* rows = glyph_rows(text[n]);
    if (!rows) continue;
    for (long r = 0; r < 7; ++r)
      for (long c = 0; c < 5; ++c)
        if (rows[r * 5 + c] == '#')
          for (long dy = 0; dy < s; ++dy)
            for (long dx = 0; dx < s; ++dx) put_pixel(img, x0 + static_cast<long>(n) * adv + c * s + dx, y0 + r * s + dy, {0.05f, 0.05f, 0.1f});
  }
}

void label_panel(Image& img, const std::vector<std::string>& lines) {
  const int scale = img.width >= 300 ? 2 : 1;
  long y = 4 * scale;
  for (const std::string& line : lines) {
    draw_text(img, 4L * scale, y, line, scale);
    y += 10L * scale;
  }
}

// Panels of equal size side by side, in rows of `cols`.
Image compose(const std::vector<Image>& panels, std::size_t cols) {
  const std::size_t pw = panels.front().width, ph = panels.front().height;
  const std::size_t rows = (panels.size() + cols - 1) / cols;
  Image out;
  out.width = pw * cols;
  out.height = ph * rows;
  out.channels = 3;
  out.pixels.assign(out.width * out.height * 3, 255);
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const std::size_t ox = (k % cols) * pw, oy = (k / cols) * ph;
    for (std::size_t y = 0; y < ph; ++y)
      std::copy_n(panels[k].pixels.begin() + static_cast<std::ptrdiff_t>(y * pw * 3), pw * 3,
                  out.pixels.begin() + static_cast<std::ptrdiff_t>(((oy + y) * out.width + ox) * 3));
  }
  // Thin separators between panels.
  for (std::size_t k = 1; k < cols; ++k)
    for (std::size_t y = 0; y < out.height; ++y) put_pixel(out, static_cast<long>(k * pw), static_cast<long>(y), {0.5f, 0.5f, 0.5f});
  for (std::size_t k = 1; k < rows; ++k)
    for (std::size_t x = 0; x < out.width; ++x) put_pixel(out, static_cast<long>(x), static_cast<long>(k * ph), {0.5f, 0.5f, 0.5f});
  return out;
}

// ---- colours and geometry helpers ----

glm::vec3 hash_color(Index v) {
  std::uint32_t h = v * 2654435761u;
  h ^= h >> 15;
  h *= 0x2c1b3c6dU;
  h ^= h >> 12;
  const float hue = static_cast<float>(h & 0xffffu) / 65536.0f * 6.0f;
  const float sat = 0.35f + 0.5f * static_cast<float>((h >> 16) & 0xffu) / 255.0f;
  const float val = 0.7f + 0.3f * static_cast<float>((h >> 24) & 0xffu) / 255.0f;
  const int i = static_cast<int>(hue) % 6;
  const float f = hue - std::floor(hue);
  const float p = val * (1 - sat), q = val * (1 - sat * f), t = val * (1 - sat * (1 - f));
  switch (i) {
    case 0: return {val, t, p};
    case 1: return {q, val, p};
    case 2: return {p, val, t};
    case 3: return {p, q, val};
    case 4: return {t, p, val};
    default: return {val, p, q};
  }
}

// The frustum's corners: near plane (4) then the plane at `far_dist` (4), counter-clockwise from bottom left.
std::array<glm::vec3, 8> frustum_corners(const Camera& cam, float far_dist) {
  const glm::vec3 f = cam.forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, cam.up));
  const glm::vec3 u = glm::cross(r, f);
  const float th = std::tan(glm::radians(cam.fov_y_deg) * 0.5f);
  auto corner = [&](float d, float sx, float sy) { return cam.eye + f * d + r * (sx * th * cam.aspect * d) + u * (sy * th * d); };
  std::array<glm::vec3, 8> c{};
  const float sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (std::size_t i = 0; i < 4; ++i) {
    c[i] = corner(cam.z_near, sx[i], sy[i]);
    c[i + 4] = corner(far_dist, sx[i], sy[i]);
  }
  return c;
}

// The frustum's outline from the near plane to `far_dist`, as 12 segments.
std::vector<Segment3> frustum_outline(const Camera& cam, float far_dist, const glm::vec3& color) {
  const auto c = frustum_corners(cam, far_dist);
  std::vector<Segment3> s;
  for (std::size_t i = 0; i < 4; ++i) {
    s.push_back({c[i], c[(i + 1) % 4], color});
    s.push_back({c[i + 4], c[(i + 1) % 4 + 4], color});
    s.push_back({c[i], c[i + 4], color});
  }
  return s;
}

// The frustum's footprint seen from above: the convex hull of its corners projected on the xy plane,
// clipped to the box's xy rectangle, drawn at height z without the parts that run along the rectangle.
std::vector<Segment3> frustum_footprint(const Camera& cam, const Box3& box, float z, const glm::vec3& color) {
  using P = glm::vec2;
  const auto c = frustum_corners(cam, cam.z_far);
  std::vector<P> pts;
  for (const glm::vec3& q : c) pts.push_back({q.x, q.y});
  std::sort(pts.begin(), pts.end(), [](const P& a, const P& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  auto cross = [](const P& o, const P& a, const P& b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); };
  std::vector<P> hull;  // Andrew's monotone chain, counter-clockwise
  for (int pass = 0; pass < 2; ++pass) {
    const std::size_t start = hull.size();
    for (const P& q : pts) {
      while (hull.size() >= start + 2 && cross(hull[hull.size() - 2], hull.back(), q) <= 0.0f) hull.pop_back();
      hull.push_back(q);
    }
    hull.pop_back();
    std::reverse(pts.begin(), pts.end());
  }
  // Sutherland-Hodgman against the four sides of the rectangle.
  const float lo[2] = {box.lo.x, box.lo.y}, hi[2] = {box.hi.x, box.hi.y};
  for (int axis = 0; axis < 2; ++axis)
    for (int side = 0; side < 2; ++side) {
      auto inside = [&](const P& q) { return side == 0 ? q[axis] >= lo[axis] : q[axis] <= hi[axis]; };
      const float bound = side == 0 ? lo[axis] : hi[axis];
      std::vector<P> next;
      for (std::size_t i = 0; i < hull.size(); ++i) {
        const P a = hull[i], b = hull[(i + 1) % hull.size()];
        if (inside(a)) next.push_back(a);
        if (inside(a) != inside(b)) next.push_back(a + (b - a) * ((bound - a[axis]) / (b[axis] - a[axis])));
      }
      hull = std::move(next);
    }
  std::vector<Segment3> s;
  const float eps = 1e-4f * std::max(box.extent().x, box.extent().y);
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const P a = hull[i], b = hull[(i + 1) % hull.size()];
    bool on_side = false;
    for (int axis = 0; axis < 2; ++axis)
      on_side = on_side || (std::abs(a[axis] - lo[axis]) < eps && std::abs(b[axis] - lo[axis]) < eps) ||
                (std::abs(a[axis] - hi[axis]) < eps && std::abs(b[axis] - hi[axis]) < eps);
    if (!on_side) s.push_back({{a.x, a.y, z}, {b.x, b.y, z}, color});
  }
  return s;
}

// A camera far above a box looking straight down (+y up in the picture): nearly orthographic.
Camera top_down_camera(const Box3& box) {
  const glm::vec3 c = box.center(), e = box.extent();
  const float half = 0.5f * std::max(e.x, e.y) * 1.04f;
  const float dist = 40.0f * half;
  Camera cam;
  cam.target = {c.x, c.y, c.z};
  cam.eye = {c.x, c.y, box.hi.z + dist};
  cam.up = {0.0f, 1.0f, 0.0f};
  cam.fov_y_deg = glm::degrees(2.0f * std::atan(half / dist));
  cam.aspect = 1.0f;
  cam.z_near = 0.5f * dist;
  cam.z_far = 2.0f * dist + e.z;
  return cam;
}

// Generated 3D stand-in for missing model files: a bumpy icosphere.
TriMesh make_bumpy_icosphere(int levels) {
  TriMesh m = varmesh::make_icosphere(levels);
  // A few bumps so the surface is not uniform (the analysis then has an order to follow).
  for (auto& p : m.positions) p *= 1.0f + 0.12f * std::sin(5.0f * p.x) * std::cos(4.0f * p.y) * std::sin(3.0f * p.z + 1.0f);
  return m;
}

// ---- options ----

constexpr const char* kPackagedMeshes = "/usr/share/doc/libcgal-dev/data.tar.gz";

struct Options {
  fs::path out;
  // Files are written into a staging folder inside `out` and moved into `out` when the whole run has
  // succeeded: a failed run leaves `out` as it was, earlier results included (no partial output).
  StagedFolder* stage = nullptr;
  std::vector<std::string> cases;
  fs::path data;
  bool data_present = false;
  std::string data_note;
  // Debian libcgal-demo's archive of sample data, which holds a cow and a bunny: the models' stand-ins when
  // the data folder lacks them ($VARMESH_PACKAGED_MESHES overrides the path; empty: none, the generated
  // stand-ins).
  fs::path packaged;
  std::string image;
  double feature_fraction = 0.05;
  std::size_t grid = 128;
  int panel = 400;
  CollapseCost cost = CollapseCost::kQuadric;
  bool preserve_volume = true;  // QemOptions::preserve_volume (quadric cost)
  bool quick = false, quiet = false;
};

// write_png into the staging folder (moved into the output folder when the whole run has succeeded).
void write_output_png(const Options& o, const std::string& name, const Image& image) {
  write_png(o.stage->path(name), image);
}

const char* cost_name(const Options& o) {
  if (o.cost == CollapseCost::kLindstromTurk) return "lindstrom-turk";
  return o.preserve_volume ? "quadric" : "quadric-plain";
}

long parse_integer(const std::string& text, const char* option, long lo, long hi) {
  const float v = parse_floats(text, option, 1)[0];
  if (v != std::floor(v) || v < static_cast<float>(lo) || v > static_cast<float>(hi))
    throw InvalidInput(std::string(option) + ": '" + text + "' must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
  return static_cast<long>(v);
}

// The archive of packaged meshes: $VARMESH_PACKAGED_MESHES when set and not empty, else kPackagedMeshes
// (used when it is there). "none" asks for no archive (the generated stand-ins; the tests use it). A path
// the user set must name a readable file: a wrong one fell back silently to the generated inputs. Returns
// the empty path for none.
fs::path packaged_archive() {
  const char* env = std::getenv("VARMESH_PACKAGED_MESHES");
  if (env == nullptr || *env == '\0') return kPackagedMeshes;
  const std::string path = env;
  if (path == "none") return {};
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InvalidInput("VARMESH_PACKAGED_MESHES: '" + path + "' is a folder, not an archive (.tar.gz)");
  if (!fs::is_regular_file(path, ec))
    throw InvalidInput("VARMESH_PACKAGED_MESHES: '" + path + "' is not a file (set it to an archive such as " +
                       kPackagedMeshes + ", or to none for no packaged meshes)");
  if (!std::ifstream(path, std::ios::binary))
    throw InvalidInput("VARMESH_PACKAGED_MESHES: '" + path + "' cannot be read");
  return path;
}

Options parse_options(const CompareArgs& a) {
  Options o;
  o.quick = a.quick;
  o.quiet = a.quiet;
  if (a.out_dir.empty()) throw InvalidInput("compare: --out must name a folder");
  o.out = a.out_dir;
  std::stringstream list(a.cases);
  std::string item;
  while (std::getline(list, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) continue;
    if (std::find(kKnownCases.begin(), kKnownCases.end(), item) == kKnownCases.end())
      throw InvalidInput("compare: unknown case '" + item + "' in --cases (known: image, terrain, bunny, cow, dragon)");
    if (std::find(o.cases.begin(), o.cases.end(), item) == o.cases.end()) o.cases.push_back(item);
  }
  if (o.cases.empty()) throw InvalidInput("compare: --cases lists no case (known: image, terrain, bunny, cow, dragon)");
  const float frac = parse_floats(a.feature_fraction, "--features", 1)[0];
  if (!(frac > 0.0f && frac <= 1.0f)) throw InvalidInput("--features: '" + a.feature_fraction + "' must be a fraction in (0, 1]");
  o.feature_fraction = frac;
  o.grid = a.grid_size.empty() ? (a.quick ? 64 : 128) : static_cast<std::size_t>(parse_integer(a.grid_size, "--size", 8, 1024));
  o.panel = static_cast<int>(parse_integer(a.panel, "--panel", 64, 2048));
  parse_collapse_cost(a.cost, o.cost, o.preserve_volume);
  if (!a.image.empty()) {
    if (fs::is_directory(a.image)) throw InvalidInput("--image: '" + a.image + "' is a folder, not a picture file");
    if (!fs::is_regular_file(a.image)) throw InvalidInput("--image: no such file '" + a.image + "'");
    if (std::find(o.cases.begin(), o.cases.end(), "image") == o.cases.end())
      throw InvalidInput("--image is for the image case, which --cases leaves out");
    // A picture this run writes into --out would replace the input.
    std::vector<std::string> pictures{"image_features.png"};
    for (const std::string& c : o.cases) {
      pictures.push_back(c + "_schemes.png");
      pictures.push_back(c + "_dual_pieces.png");
    }
    for (const std::string& name : pictures) refuse_same_file(a.image, "--image", (o.out / name).string(), "--out's picture");
  }
  o.image = a.image;
  if (!a.data_dir.empty()) {
    if (!fs::is_directory(a.data_dir)) throw InvalidInput("--data: '" + a.data_dir + "' is not a folder");
    o.data = a.data_dir;
    o.data_present = true;
  } else if (const char* env = std::getenv("VARMESH_DATA"); env && *env) {
    // Set by the user: a folder that is not there is an error, as with --data (it fell back silently to the
    // packaged or generated inputs).
    if (!fs::is_directory(env)) throw InvalidInput("VARMESH_DATA: '" + std::string(env) + "' is not a folder");
    o.data = env;
    o.data_present = true;
  } else {
    o.data = "../shared/data";
    o.data_present = fs::is_directory(o.data);
    if (!o.data_present)
      o.data_note = "data folder " + o.data.string() + " not found (set --data or VARMESH_DATA): packaged or generated inputs are used";
  }
  o.packaged = packaged_archive();
  return o;
}

// ---- cases ----

struct CaseInput {
  std::string name, type, criteria, source;
  std::string file;  // the model file read, named by errors about its mesh; empty for generated input
  TriMesh mesh;
  bool use_colors = false;
  // Image case: the picture, its features (pixel = input vertex ids) and the Sobel threshold fraction.
  Image picture;
  std::vector<Index> features;
  // View cases.
  bool view = false, backface = false;
  Camera view_cam;
  // Pictures.
  bool top_down = false, height_ramp = false;
  Camera panel_cam;
  std::vector<Segment3> overlay;
};

std::string data_file(const Options& o, const std::string& relative) {
  if (!o.data_present) return {};
  const fs::path p = o.data / relative;
  return fs::is_regular_file(p) ? p.string() : std::string();
}

CaseInput image_case(const Options& o) {
  CaseInput c;
  c.name = "image";
  c.type = "2D";
  c.criteria = "F.P.";
  c.use_colors = true;
  std::string file = o.image.empty() ? data_file(o, "images/peppers_256_gray.png") : o.image;
  Image img;
  if (file.empty()) {
    img = make_feature_test_image(o.grid);
    c.source = "generated discs and gradient";
  } else {
    img = lower_extension(file) == ".pgm" ? read_pgm(file) : read_png(file);
    // The long side down to about --size, but the short side kept at 2 or more (a 1000 x 2 picture became
    // 125 x 1, too thin for a grid mesh).
    const std::size_t factor = std::max<std::size_t>(
        1, std::min((std::max(img.width, img.height) + o.grid - 1) / o.grid, std::min(img.width, img.height) / 2));
    img = downsample_image(img, factor);
    c.source = fs::path(file).filename().string() + (factor > 1 ? " / " + std::to_string(factor) : std::string());
  }
  c.source += " (" + std::to_string(img.width) + " x " + std::to_string(img.height) + ")";
  try {
    c.mesh = image_grid_mesh(img);
  } catch (const InvalidInput& e) {
    if (file.empty()) throw;
    throw IoError(file, e.what());  // e.g. a 1 x 100 picture
  }
  c.features = top_fraction_features(sobel_magnitude(img), o.feature_fraction);
  c.picture = std::move(img);
  c.top_down = true;
  c.panel_cam = top_down_camera(c.mesh.bounds());
  return c;
}

CaseInput terrain_case(const Options& o) {
  CaseInput c;
  c.name = "terrain";
  c.type = "2.5D";
  c.criteria = "V.F.";
  const std::string file = data_file(o, "terrain/fuji_elevation_512_f32le.raw");
  HeightField field;
  if (file.empty()) {
    field = make_fractal_terrain(o.grid, o.grid, 2001, 0.2f * static_cast<float>(o.grid));
    c.source = "generated fractal terrain";
  } else {
    HeightFieldReadOptions ro;
    ro.raw_width = ro.raw_height = 512;
    field = read_heightfield(file, ro);
    // Metres; about 30 m per sample keeps the mountain's slopes close to the real ones.
    field.spacing_x = field.spacing_y = 30.0f;
    const std::size_t factor = std::max<std::size_t>(1, (512 + o.grid - 1) / o.grid);
    field = downsample_heightfield(field, factor);
    c.source = "fuji_elevation_512_f32le.raw / " + std::to_string(factor);
  }
  c.source += " (" + std::to_string(field.width) + " x " + std::to_string(field.height) + ")";
  c.mesh = heightfield_grid_mesh(field);
  const Box3 box = c.mesh.bounds();
  const glm::vec3 e = box.extent();
  // A camera at the terrain's south-west side, above the highest point, looking across it (Figure 8).
  c.view = true;
  c.view_cam.eye = {box.lo.x + 0.12f * e.x, box.lo.y + 0.05f * e.y, box.hi.z + 0.15f * e.z};
  c.view_cam.target = {box.lo.x + 0.55f * e.x, box.lo.y + 0.6f * e.y, box.lo.z + 0.3f * e.z};
  c.view_cam.up = {0.0f, 0.0f, 1.0f};
  c.view_cam.fov_y_deg = 40.0f;
  c.view_cam.aspect = 1.0f;
  c.view_cam.z_near = 0.01f * e.x;
  c.view_cam.z_far = 0.75f * glm::length(glm::vec2(e.x, e.y));
  c.top_down = true;
  c.height_ramp = true;
  c.panel_cam = top_down_camera(box);
  c.overlay = frustum_footprint(c.view_cam, box, box.hi.z + 0.05f * e.z, {0.9f, 0.05f, 0.05f});
  return c;
}

struct ModelSpec {
  const char* file;        // full run
  const char* quick_file;  // --quick
  glm::vec3 up;            // the model's up axis
  glm::vec3 view_dir;      // from the target towards the frustum camera
  glm::vec3 target_offset; // frustum target = centre + offset * radius
  float fov;               // frustum camera's vertical field of view, degrees
  glm::vec3 overview_dir;  // from the centre towards the camera of the pictures (need not be unit)
};

// The packaged stand-in of a model (Debian libcgal-demo: data/meshes/cow.off, the same cow as the data
// folder's; data/meshes/bunny00.off, a closed 37.7k-vertex bunny in the Stanford bunny's axes), or nothing
// when the archive is not installed or has no such model. A corrupt archive is an error, not a fallback.
std::optional<TriMesh> packaged_model(const Options& o, const std::string& name, std::string& source,
                                      std::string& file) {
  const char* member = name == "cow" ? "data/meshes/cow.off" : name == "bunny" ? "data/meshes/bunny00.off" : nullptr;
  std::error_code ec;
  if (member == nullptr || o.packaged.empty() || !fs::is_regular_file(o.packaged, ec)) return std::nullopt;
  std::optional<std::string> data = read_tar_member(o.packaged.string(), member, std::uint64_t{64} << 20);
  if (!data) return std::nullopt;
  TriMesh mesh = read_input_mesh_data(o.packaged.string() + ":" + member, *data);
  source = fs::path(member).filename().string() + " (libcgal-demo)";
  file = o.packaged.string() + ":" + member;
  return mesh;
}

CaseInput model_case(const Options& o, const std::string& name) {
  ModelSpec spec{};
  // Frusta on the head of each model (Figure 10a: a close-up of the bunny's face); the pictures look from
  // the side so that the refined region, the frustum and the coarse rest show together (Figure 10b).
  if (name == "bunny")
    spec = {"meshes/bun_zipper_35947v.obj", "meshes/bunny_libigl_3485v.off", {0, 1, 0}, {-1.0f, 0.2f, 0.5f}, {-0.4f, 0.3f, 0.05f}, 20.0f, {-0.3f, 0.35f, 1.0f}};
  else if (name == "cow")
    spec = {"meshes/cow_cgal_2904v.off", "meshes/cow_cgal_2904v.off", {0, 1, 0}, {1.0f, 0.3f, 0.6f}, {0.7f, 0.2f, 0.0f}, 20.0f, {0.2f, 0.35f, 1.0f}};
  else
    spec = {"meshes/dragon_vrip_res3_22998v.ply", "meshes/dragon_vrip_res4_5205v.ply", {0, 1, 0}, {-1.0f, 0.3f, 0.6f}, {-0.55f, 0.3f, 0.0f}, 20.0f, {-0.3f, 0.35f, 1.0f}};
  CaseInput c;
  c.name = name;
  c.type = "3D";
  c.criteria = "V.F. & B.F.C.";
  const std::string file = data_file(o, o.quick ? spec.quick_file : spec.file);
  std::optional<TriMesh> packaged;
  if (file.empty()) packaged = packaged_model(o, name, c.source, c.file);
  if (packaged) {
    c.mesh = std::move(*packaged);
  } else if (file.empty()) {
    spec.up = {0, 0, 1};
    if (name == "cow") {
      c.mesh = o.quick ? varmesh::make_torus(32, 16, 1.0f, 0.35f, 0.15f) : varmesh::make_torus(120, 60, 1.0f, 0.35f, 0.15f);
      c.source = "generated torus";
    } else {
      c.mesh = make_bumpy_icosphere(o.quick ? 3 : (name == "bunny" ? 5 : 6));
      c.source = "generated bumpy icosphere";
    }
  } else {
    c.mesh = read_input_mesh(file);  // coordinates beyond float's reach refused by name, as the other commands do
    c.source = fs::path(file).filename().string();
    c.file = file;
  }
  c.mesh.normals.clear();
  c.mesh.texcoords.clear();
  c.mesh.colors.clear();
  // Bounding sphere of the referenced vertices (files may carry unreferenced ones far away).
  Box3 box;
  for (Index i : c.mesh.indices) box.add(c.mesh.positions[i]);
  const glm::vec3 centre = box.center();
  const float radius = 0.5f * box.diagonal();
  // All faces on one point (or within 1e-19 of it, where squared lengths underflow): no picture can frame
  // the model ("frame_sphere: radius 0.000000 is not a positive number", naming no file).
  if (!(radius > 0.0f))
    throw IoError(c.file, "the model has no size: every vertex of its faces lies at one point (" +
                              count_noun(c.mesh.num_faces(), "face") + ")");
  c.view = c.backface = true;
  c.view_cam.target = centre + spec.target_offset * radius;
  c.view_cam.eye = c.view_cam.target + glm::normalize(spec.view_dir) * (1.4f * radius);
  c.view_cam.up = spec.up;
  c.view_cam.fov_y_deg = spec.fov;
  c.view_cam.aspect = 1.0f;
  c.view_cam.z_near = 0.01f * radius;
  c.view_cam.z_far = 2.0f * radius;
  c.panel_cam = frame_sphere(centre, radius, -spec.overview_dir, 36.0f, 1.0f, spec.up);
  c.overlay = frustum_outline(c.view_cam, 2.0f * radius, {0.9f, 0.05f, 0.05f});
  return c;
}

// ---- running the schemes ----

struct SchemeRun {
  RefinementScheme scheme{};
  SelectiveRefineResult result;
  double ms = 0.0;
  std::size_t vertices = 0, faces = 0, missing = 0;
  std::size_t flipped = 0;  // faces facing against the original face they stand for (Kim-Lee section 6)
  std::vector<std::uint8_t> state;  // per node: 0 below, 1 active, 2 refined
  TriMesh mesh;
  std::string invalid;  // validate() message, empty when valid
};

struct CaseResult {
  CaseInput in;
  std::size_t input_vertices = 0, input_faces = 0, original_vertices = 0, original_faces = 0;
  std::size_t base_vertices = 0, base_faces = 0, required = 0;
  std::size_t repaired_copies = 0, detached_faces = 0, dropped_faces = 0;
  double analysis_ms = 0.0;
  std::vector<SchemeRun> runs;
  bool ordering = false;
  std::string ordering_line, notes;
};

const SchemeRun& run_of(const CaseResult& r, RefinementScheme s) {
  for (const SchemeRun& run : r.runs)
    if (run.scheme == s) return run;
  return r.runs.front();
}

// Why a <= b failed in #V or #F: which nodes each refined that the other did not.
std::string diagnose(const CaseResult& r, const std::vector<std::uint8_t>& needs, RefinementScheme a, RefinementScheme b) {
  const SchemeRun& ra = run_of(r, a);
  const SchemeRun& rb = run_of(r, b);
  std::size_t a_only = 0, a_only_needed = 0, b_only = 0, b_only_needed = 0;
  for (std::size_t v = 0; v < ra.state.size(); ++v) {
    const bool ea = ra.state[v] == 2, eb = rb.state[v] == 2;
    if (ea && !eb) {
      ++a_only;
      a_only_needed += needs[v];
    }
    if (eb && !ea) {
      ++b_only;
      b_only_needed += needs[v];
    }
  }
  std::ostringstream s;
  s << "- " << r.in.name << ": expected " << scheme_name(a) << " <= " << scheme_name(b) << ", measured #V " << ra.vertices << " vs "
    << rb.vertices << ", #F " << ra.faces << " vs " << rb.faces << ".\n"
    << "  Nodes split by " << scheme_name(a) << " and not by " << scheme_name(b) << ": " << a_only << " (" << a_only_needed
    << " needed by the criterion, " << a_only - a_only_needed << " not needed: forced or degenerate-case splits); split by "
    << scheme_name(b) << " only: " << b_only << " (" << b_only_needed << " needed).\n";
  if (!rb.result.complete())
    s << "  " << scheme_name(b) << " is incomplete: " << count_noun(rb.result.unsatisfied, "active node")
      << (rb.result.unsatisfied == 1 ? " still needs" : " still need") << " refinement after "
      << count_noun(rb.result.refused_vsplits, "refused vsplit") << " (dependency cycles), so its mesh lacks required vertices.\n";
  if (ra.result.stats.degenerate_cases > 0)
    s << "  " << scheme_name(a) << " met " << count_noun(ra.result.stats.degenerate_cases, "degenerate case")
      << " (Kim-Lee 4.4 pre-splits count here).\n";
  if (rb.result.stats.forced_ecols > 0)
    s << "  " << scheme_name(b) << " collapsed " << count_noun(rb.result.stats.forced_ecols, "vertex")
      << " to satisfy its rule (forced ecols), which removes vertices another scheme keeps.\n";
  if (ra.faces > rb.faces && ra.vertices <= rb.vertices)
    s << "  Same or fewer vertices but more faces: #F - 2 #V depends on the border length of the active mesh (Euler), and "
      << scheme_name(a) << "'s finer border is longer.\n";
  return s.str();
}

CaseResult run_case(CaseInput in, const Options& o, bool& failed) {
  CaseResult r;
  r.input_vertices = in.mesh.num_vertices();
  r.input_faces = in.mesh.num_faces();
  QemOptions qo;
  qo.use_colors = in.use_colors;
  qo.cost = o.cost;  // the analysis falls back to quadrics when colours are used
  qo.preserve_volume = o.preserve_volume;
  QemStats qs;
  Stopwatch analysis;
  VertexHierarchy h;
  {
    const std::string what = "analysing " + in.name + " (" + in.source + ")";
    Step step(what.c_str(), o.quiet);
    try {
      h = build_vertex_hierarchy(in.mesh, qo, &qs);
    } catch (const InvalidInput& e) {
      if (in.file.empty()) throw;
      throw IoError(in.file, e.what());  // name the model file (e.g. "mesh has no non-degenerate face")
    }
  }
  r.analysis_ms = analysis.ms();
  r.original_vertices = h.num_leaves();
  r.original_faces = h.num_faces();
  r.base_vertices = h.num_roots();
  r.base_faces = h.base_faces().size();
  r.repaired_copies = h.repair_report().added_vertex_copies;
  r.detached_faces = h.repair_report().nonmanifold_edge_faces;
  r.dropped_faces = h.repair_report().duplicate_faces + h.repair_report().degenerate_faces;

  std::vector<std::uint8_t> needs(h.num_nodes(), 0);
  std::vector<std::uint8_t> feature_leaves;
  if (!in.features.empty()) {
    feature_leaves = leaves_of_inputs(h, in.features);
    needs = flag_ancestors(h, feature_leaves);
  } else if (in.view) {
    const Frustum fr = in.view_cam.frustum();
    const Criterion crit = in.backface ? Criterion::any_of({Criterion::outside_frustum(fr), Criterion::back_facing(in.view_cam.eye)})
                                       : Criterion::outside_frustum(fr);
    for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) needs[v] = !crit.is_fine(h.bound(static_cast<Index>(v)));
  }
  for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) r.required += needs[v];

  for (RefinementScheme scheme : kSchemes) {
    SchemeRun run;
    run.scheme = scheme;
    // Time: the best of five runs from the base mesh (the machine is shared; the counts do not vary). The
    // quick cases take well under a millisecond, where one run can catch a page fault or a context switch
    // (single runs showed 4 ms outliers against 0.03 ms).
    const int reps = 5;
    run.ms = 1e300;
    for (int rep = 1; rep < reps; ++rep) {
      SrMesh warm(h, scheme);
      Stopwatch watch;
      refine_to_predicate(warm, [&](Index v) { return needs[v] != 0; });
      run.ms = std::min(run.ms, watch.ms());
    }
    SrMesh m(h, scheme);
    Stopwatch watch;
    run.result = refine_to_predicate(m, [&](Index v) { return needs[v] != 0; });
    run.ms = std::min(run.ms, watch.ms());
    try {
      m.validate();
    } catch (const std::exception& e) {
      run.invalid = e.what();
      failed = true;
    }
    run.vertices = m.num_active_vertices();
    run.faces = m.num_faces();
    run.state.resize(h.num_nodes());
    for (std::size_t v = 0; v < h.num_nodes(); ++v) run.state[v] = static_cast<std::uint8_t>(m.state(static_cast<Index>(v)));
    if (!feature_leaves.empty()) {
      for (std::size_t l = 0; l < feature_leaves.size(); ++l) run.missing += feature_leaves[l] && !m.is_active(static_cast<Index>(l));
    } else {
      for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) run.missing += needs[v] && run.state[v] != 2;
    }
    if (run.missing > 0 && scheme != RefinementScheme::kXiaVarshney) failed = true;
    // A face of any selectively refined mesh is an original face with its corners replaced by their active
    // ancestors; it is flipped when that turns it against the original face's normal.
    m.for_each_face([&](Index f, Index a, Index b, Index c) {
      const auto leaf = h.face(f);
      const glm::vec3 n0 = glm::cross(h.position(leaf[1]) - h.position(leaf[0]), h.position(leaf[2]) - h.position(leaf[0]));
      const glm::vec3 n = glm::cross(h.position(b) - h.position(a), h.position(c) - h.position(a));
      run.flipped += glm::dot(n, n0) < 0.0f;
    });
    run.mesh = m.to_mesh();
    r.runs.push_back(std::move(run));
  }

  const SchemeRun& kl = run_of(r, RefinementScheme::kKimLee);
  const SchemeRun& hp = run_of(r, RefinementScheme::kHoppe97);
  const SchemeRun& xv = run_of(r, RefinementScheme::kXiaVarshney);
  const bool kl_hp = kl.vertices <= hp.vertices && kl.faces <= hp.faces;
  const bool hp_xv = hp.vertices <= xv.vertices && hp.faces <= xv.faces;
  r.ordering = kl_hp && hp_xv;
  r.ordering_line = in.name + ": kim-lee <= hoppe97 <= xia-varshney in #V and #F: " +
                    (r.ordering ? "holds" : std::string("DOES NOT HOLD (") + (kl_hp ? "" : "kim-lee > hoppe97") +
                                                (!kl_hp && !hp_xv ? ", " : "") + (hp_xv ? "" : "hoppe97 > xia-varshney") + ")");
  r.in = std::move(in);
  if (!kl_hp) r.notes += diagnose(r, needs, RefinementScheme::kKimLee, RefinementScheme::kHoppe97);
  if (!hp_xv) r.notes += diagnose(r, needs, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney);

  // ---- pictures ----
  const std::string what = "drawing " + r.in.name;
  Step step(what.c_str(), o.quiet);
  const int p = o.panel;
  RenderOptions ro;
  ro.width = ro.height = p;
  ro.smooth = !r.in.top_down;
  ro.height_ramp = r.in.height_ramp;
  ro.wire_color = {0.1f, 0.1f, 0.12f};
  auto stats_label = [&](const SchemeRun& run) {
    std::vector<std::string> lines{scheme_name(run.scheme),
                                   "#v " + std::to_string(run.vertices) + "  #f " + std::to_string(run.faces)};
    if (run.missing) lines.push_back("missing " + std::to_string(run.missing));
    return lines;
  };
  std::vector<Image> panels;
  if (r.in.name == "image") {
    // Top row: the meshes' vertex colours (Gouraud), bottom row: their wireframes (Figure 9).
    for (const SchemeRun& run : r.runs) {
      Image img = render_mesh(run.mesh, r.in.panel_cam, ro);
      label_panel(img, stats_label(run));
      panels.push_back(std::move(img));
    }
    RenderOptions wo = ro;
    wo.wireframe = true;
    wo.base_color = {1.0f, 1.0f, 1.0f};
    for (const SchemeRun& run : r.runs) {
      TriMesh plain = run.mesh;
      plain.colors.clear();
      panels.push_back(render_mesh(plain, r.in.panel_cam, wo));
    }
  } else {
    RenderOptions wo = ro;
    wo.wireframe = true;
    for (const SchemeRun& run : r.runs) {
      Image img = render_mesh(run.mesh, r.in.panel_cam, wo, r.in.overlay);
      label_panel(img, stats_label(run));
      panels.push_back(std::move(img));
    }
  }
  write_output_png(o, r.in.name + "_schemes.png", compose(panels, 3));

  // Dual pieces (Figures 10c, 11c): each original face split into its three corner regions (corner, edge
  // midpoints, centroid), each region coloured by the active ancestor of its corner, so every active
  // vertex shows as the patch of original surface it stands for.
  TriMesh pieces;
  std::vector<Index> region_leaf;
  {
    for (std::size_t l = 0; l < h.num_leaves(); ++l) pieces.positions.push_back(h.position(static_cast<Index>(l)));
    std::unordered_map<std::uint64_t, Index> mid;
    auto midpoint = [&](Index a, Index b) {
      const std::uint64_t key = undirected_edge_key(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      pieces.positions.push_back(0.5f * (h.position(a) + h.position(b)));
      const Index v = static_cast<Index>(pieces.positions.size() - 1);
      mid.emplace(key, v);
      return v;
    };
    for (std::size_t f = 0; f < h.num_faces(); ++f) {
      const auto c = h.face(static_cast<Index>(f));
      const Index m01 = midpoint(c[0], c[1]), m12 = midpoint(c[1], c[2]), m20 = midpoint(c[2], c[0]);
      pieces.positions.push_back((h.position(c[0]) + h.position(c[1]) + h.position(c[2])) / 3.0f);
      const Index g = static_cast<Index>(pieces.positions.size() - 1);
      const Index before[3] = {m20, m01, m12}, after[3] = {m01, m12, m20};
      for (int k = 0; k < 3; ++k) {
        pieces.indices.insert(pieces.indices.end(), {c[k], after[k], g, c[k], g, before[k]});
        region_leaf.insert(region_leaf.end(), {c[k], c[k]});
      }
    }
  }
  panels.clear();
  RenderOptions po = ro;
  po.height_ramp = false;
  for (const SchemeRun& run : r.runs) {
    std::vector<std::uint8_t> active(run.state.size());
    for (std::size_t v = 0; v < active.size(); ++v) active[v] = run.state[v] == 1;
    const std::vector<Index> anc = active_ancestors(h, active);
    std::vector<glm::vec3> colors(region_leaf.size());
    for (std::size_t f = 0; f < region_leaf.size(); ++f) colors[f] = hash_color(anc[region_leaf[f]]);
    po.face_colors = &colors;
    Image img = render_mesh(pieces, r.in.panel_cam, po, r.in.overlay);
    po.face_colors = nullptr;
    std::vector<std::string> lines = stats_label(run);
    lines[0] += " dual pieces";
    label_panel(img, lines);
    panels.push_back(std::move(img));
  }
  write_output_png(o, r.in.name + "_dual_pieces.png", compose(panels, 3));

  if (r.in.name == "image") {
    // The input picture and its Sobel features (Figure 9a), nearest-neighbour enlarged.
    const Image& pic = r.in.picture;
    std::vector<std::uint8_t> is_feature(pic.width * pic.height, 0);
    for (Index f : r.in.features) is_feature[f] = 1;
    std::vector<Image> two;
    for (int k = 0; k < 2; ++k) {
      Image img;
      img.width = img.height = static_cast<std::size_t>(p);
      img.channels = 3;
      img.pixels.assign(img.width * img.height * 3, 255);
      const float scale = static_cast<float>(std::max(pic.width, pic.height)) / static_cast<float>(p);
      for (std::size_t y = 0; y < img.height; ++y)
        for (std::size_t x = 0; x < img.width; ++x) {
          const auto sx = static_cast<std::size_t>(static_cast<float>(x) * scale), sy = static_cast<std::size_t>(static_cast<float>(y) * scale);
          if (sx >= pic.width || sy >= pic.height) continue;
          const float g = image_luma(pic, sx, sy);
          const bool feat = k == 1 && is_feature[sy * pic.width + sx];
          put_pixel(img, static_cast<long>(x), static_cast<long>(y), feat ? glm::vec3(0.9f, 0.05f, 0.05f) : glm::vec3(k == 1 ? 0.4f + 0.6f * g : g));
        }
      label_panel(img, {k == 0 ? std::string("input ") + std::to_string(pic.width) + " x " + std::to_string(pic.height)
                               : count_noun(r.in.features.size(), "sobel feature")});
      two.push_back(std::move(img));
    }
    write_output_png(o, "image_features.png", compose(two, 2));
  }
  return r;
}

// ---- the table ----

struct Row {
  const char* label;
  std::function<std::string(const SchemeRun&)> value;
};

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ms < 10.0 ? "%.2f" : "%.1f", ms);
  return buf;
}

std::vector<Row> table_rows() {
  return {
      {"#V", [](const SchemeRun& r) { return std::to_string(r.vertices); }},
      {"#F", [](const SchemeRun& r) { return std::to_string(r.faces); }},
      {"#DC", [](const SchemeRun& r) { return std::to_string(r.result.stats.degenerate_cases); }},
      {"forced vsplits", [](const SchemeRun& r) { return std::to_string(r.result.stats.forced_vsplits); }},
      {"forced ecols", [](const SchemeRun& r) { return std::to_string(r.result.stats.forced_ecols); }},
      {"time ms", [](const SchemeRun& r) { return fmt_ms(r.ms); }},
      {"missing", [](const SchemeRun& r) { return std::to_string(r.missing); }},
      {"flipped faces", [](const SchemeRun& r) { return std::to_string(r.flipped); }},
  };
}

const char* short_name(RefinementScheme s) {
  switch (s) {
    case RefinementScheme::kXiaVarshney: return "XV96";
    case RefinementScheme::kHoppe97: return "H97";
    case RefinementScheme::kKimLee: return "ours";
  }
  return "?";
}

void print_table(std::FILE* out, const std::vector<CaseResult>& results) {
  const int lw = 16, cw = 9;
  auto line = [&](const std::string& label, const std::vector<std::string>& cells) {
    std::fprintf(out, "%-*s", lw, label.c_str());
    for (std::size_t k = 0; k < cells.size(); ++k) std::fprintf(out, "%s%*s", k % 3 == 0 ? " |" : "", cw, cells[k].c_str());
    std::fprintf(out, "\n");
  };
  std::vector<std::string> cells;
  for (const CaseResult& r : results) {
    std::string name = r.in.name + " " + r.in.type;
    const int width = 3 * cw;
    cells.push_back(name.size() > static_cast<std::size_t>(width) ? name.substr(0, static_cast<std::size_t>(width)) : name);
  }
  std::fprintf(out, "%-*s", lw, "model");
  for (const std::string& c : cells) std::fprintf(out, " |%*s", 3 * cw, c.c_str());
  std::fprintf(out, "\n");
  auto per_case = [&](const char* label, const std::function<std::string(const CaseResult&)>& fn) {
    std::fprintf(out, "%-*s", lw, label);
    for (const CaseResult& r : results) std::fprintf(out, " |%*s", 3 * cw, fn(r).c_str());
    std::fprintf(out, "\n");
  };
  per_case("criteria", [](const CaseResult& r) { return r.in.criteria; });
  per_case("original #V", [](const CaseResult& r) { return std::to_string(r.original_vertices); });
  per_case("original #F", [](const CaseResult& r) { return std::to_string(r.original_faces); });
  per_case("base #V", [](const CaseResult& r) { return std::to_string(r.base_vertices); });
  per_case("nodes to split", [](const CaseResult& r) { return std::to_string(r.required); });
  cells.clear();
  for (const CaseResult& r : results)
    for (const SchemeRun& run : r.runs) cells.push_back(short_name(run.scheme));
  line("scheme", cells);
  for (const Row& row : table_rows()) {
    cells.clear();
    for (const CaseResult& r : results)
      for (const SchemeRun& run : r.runs) cells.push_back(row.value(run));
    line(row.label, cells);
  }
}

std::string markdown_table(const std::vector<CaseResult>& results) {
  std::ostringstream s;
  s << "| |";
  for (const CaseResult& r : results)
    for (const SchemeRun& run : r.runs) s << ' ' << r.in.name << ' ' << scheme_name(run.scheme) << " |";
  s << "\n|---|";
  for (const CaseResult& r : results)
    for (std::size_t k = 0; k < r.runs.size(); ++k) s << "---:|";
  s << '\n';
  for (const Row& row : table_rows()) {
    s << "| " << row.label << " |";
    for (const CaseResult& r : results)
      for (const SchemeRun& run : r.runs) s << ' ' << row.value(run) << " |";
    s << '\n';
  }
  return s.str();
}

std::string csv_table(const std::vector<CaseResult>& results) {
  std::ostringstream s;
  s << "case,type,criteria,source,original_vertices,original_faces,base_vertices,nodes_to_split,scheme,vertices,faces,"
       "degenerate_cases,forced_vsplits,forced_ecols,time_ms,missing,flipped_faces,requested_vsplits,refused_vsplits\n";
  for (const CaseResult& r : results)
    for (const SchemeRun& run : r.runs)
      s << r.in.name << ',' << r.in.type << ",\"" << r.in.criteria << "\",\"" << r.in.source << "\"," << r.original_vertices << ','
        << r.original_faces << ',' << r.base_vertices << ',' << r.required << ',' << scheme_name(run.scheme) << ',' << run.vertices
        << ',' << run.faces << ',' << run.result.stats.degenerate_cases << ',' << run.result.stats.forced_vsplits << ','
        << run.result.stats.forced_ecols << ',' << fmt_ms(run.ms) << ',' << run.missing << ',' << run.flipped << ','
        << run.result.requested_vsplits << ','
        << run.result.refused_vsplits << '\n';
  return s.str();
}

void write_text(const Options& o, const std::string& name, const std::string& text) {
  write_file_atomically(o.stage->path(name), text);
}

}  // namespace

void add_compare_options(CLI::App& sub, CompareArgs& args) {
  sub.add_option("--out", args.out_dir, "output folder (default varmesh_compare)");
  sub.add_option("--cases", args.cases, "comma-separated cases: image,terrain,bunny,cow,dragon (default all)");
  sub.add_option("--data", args.data_dir,
                 "data folder (default $VARMESH_DATA, else ../shared/data; missing files are taken from the packaged "
                 "meshes or generated)");
  sub.add_option("--image", args.image,
                 "image for the image case (PNG or PGM; default images/peppers_256_gray.png in the data folder)")
      ->check(check_file_name);
  sub.add_option("--features", args.feature_fraction, "fraction of pixels kept as Sobel feature points, in (0, 1] (default 0.05)")->type_name("FRACTION");
  sub.add_option("--size", args.grid_size, "side of the image and terrain grids in vertices, 8..1024 (default 128, 64 with --quick)")->type_name("N");
  sub.add_option("--panel", args.panel, "side of one picture panel in pixels, 64..2048 (default 400)")->type_name("PIXELS");
  sub.add_option("--cost", args.cost,
                 "collapse cost of the analysis: quadric (Garland-Heckbert order, volume-preserving placement; "
                 "default), quadric-plain (vs at the quadric's minimiser) or lindstrom-turk")
      ->type_name("KIND");
  sub.add_flag("--quick", args.quick, "small inputs (64 x 64 grids, small model files): a fast run");
  sub.add_flag("--quiet", args.quiet, "no progress on stderr");
  sub.footer(
      "Environment:\n"
      "  VARMESH_DATA             the data folder when --data is not given (default ../shared/data, used when it is "
      "there)\n"
      "  VARMESH_PACKAGED_MESHES  the archive of the packaged cow and bunny, used when the data folder lacks them "
      "(default /usr/share/doc/libcgal-dev/data.tar.gz, used when it is there); none: no packaged meshes (generated "
      "stand-ins)\n"
      "  A variable that is set (not empty) must name an existing folder (VARMESH_DATA) or a readable file: "
      "anything else is an error, as with --data.");
}

static int run_compare_in(const Options& o);

int run_compare(const CompareArgs& args) {
  Options o = parse_options(args);
  StagedFolder stage(o.out.string());
  o.stage = &stage;
  const int status = run_compare_in(o);
  stage.commit();
  return status;
}

static int run_compare_in(const Options& o) {
  if (!o.data_note.empty() && !o.quiet) std::fprintf(stderr, "[varmesh] %s\n", o.data_note.c_str());

  bool failed = false;
  std::vector<CaseResult> results;
  for (const std::string& name : o.cases) {
    CaseInput in = name == "image" ? image_case(o) : name == "terrain" ? terrain_case(o) : model_case(o, name);
    results.push_back(run_case(std::move(in), o, failed));
  }

  std::printf("Kim-Lee 2001 Table 2 on varmesh: one QEM hierarchy per case (collapse cost: %s), refined from its base mesh "
              "under each scheme\n",
              cost_name(o));
  for (const CaseResult& r : results) {
    std::printf("%-8s %s, %s: %s; original %zu V %zu F (input %zu V %zu F), base %zu V %zu F, analysis %.0f ms", r.in.name.c_str(),
                r.in.type.c_str(), r.in.criteria.c_str(), r.in.source.c_str(), r.original_vertices, r.original_faces,
                r.input_vertices, r.input_faces, r.base_vertices, r.base_faces, r.analysis_ms);
    if (!r.in.features.empty()) std::printf("; %s", count_noun(r.in.features.size(), "feature pixel").c_str());
    std::printf("\n");
  }
  std::printf("\n");
  print_table(stdout, results);
  std::printf("\n");
  for (const CaseResult& r : results) std::printf("%s\n", r.ordering_line.c_str());
  for (const CaseResult& r : results)
    for (const SchemeRun& run : r.runs)
      if (!run.invalid.empty()) std::printf("%s %s: INVALID MESH: %s\n", r.in.name.c_str(), scheme_name(run.scheme), run.invalid.c_str());

  std::ostringstream md;
  md << "# varmesh compare: Kim-Lee 2001 Table 2\n\nCollapse cost of the analysis: " << cost_name(o)
     << (o.cost == CollapseCost::kLindstromTurk ? " (the image case's colour quadrics stay Garland-Heckbert)" : "") << ".\n\n";
  for (const CaseResult& r : results)
    md << "- **" << r.in.name << "** (" << r.in.type << ", " << r.in.criteria << "): " << r.in.source << "; original "
       << r.original_vertices << " V " << r.original_faces << " F, base " << r.base_vertices << " V, "
       << count_noun(r.required, "node") << (r.required == 1 ? " needs" : " need") << " splitting"
       << (r.in.features.empty() ? "" : ", " + count_noun(r.in.features.size(), "feature pixel"))
       << "\n";
  md << '\n' << markdown_table(results) << '\n';
  for (const CaseResult& r : results) md << "- " << r.ordering_line << '\n';
  write_text(o, "table.md", md.str());
  write_text(o, "table.csv", csv_table(results));

  std::ostringstream notes;
  notes << "# varmesh compare: notes on the expected ordering\n\n"
        << "Expected (Kim-Lee 2001, Table 2): kim-lee <= hoppe97 <= xia-varshney in #V and #F in every case.\n\n";
  bool all = true;
  for (const CaseResult& r : results) {
    notes << "- " << r.ordering_line << '\n';
    all = all && r.ordering;
  }
  if (!all) {
    notes << "\n## Where it does not hold\n\n";
    for (const CaseResult& r : results) notes << r.notes;
  }
  notes << "\n## Reading the table\n\n"
        << "- #V, #F: the selectively refined mesh after refining from the base mesh until no active vertex needs "
           "refinement (image: a feature pixel's leaf lies below it; terrain: its bounding sphere meets the frustum; 3D: "
           "that and its normal cone is not entirely back-facing). The needed set is the same for every scheme; what "
           "differs is what each dependency rule adds (forced vsplits/ecols) and Kim-Lee's degenerate-case pre-splits (#DC).\n"
        << "- missing: required vertices a scheme did not reach (0 expected); flipped faces: faces whose normal points "
           "against the original face they stand for (the fold-overs Kim-Lee section 6 mentions; connectivity is always valid).\n"
        << "- time: milliseconds for the whole refinement from the base mesh (the best of 5 runs).\n";
  for (const CaseResult& r : results)
    if (r.base_vertices * 20 > r.original_vertices)
      notes << "- " << r.in.name << ": the base mesh keeps " << r.base_vertices << " of " << r.original_vertices
            << " vertices: the input needed repair (" << count_noun(r.dropped_faces, "duplicate or degenerate face")
            << " dropped, " << count_noun(r.detached_faces, "face") << " detached from non-manifold edges, "
            << count_noun(r.repaired_copies, "vertex copy")
            << "), and the analysis stops early on the result (the border vertices of the detached pieces make "
               "its link condition refuse most remaining collapses, and every piece keeps at least 4 vertices); all schemes "
               "share that base, so the comparison still holds, but every count starts higher.\n";
  write_text(o, "compare_notes.md", notes.str());
  std::printf("wrote %s/{table.md,table.csv,compare_notes.md} and <case>_schemes.png, <case>_dual_pieces.png%s\n",
              o.out.string().c_str(), std::find(o.cases.begin(), o.cases.end(), "image") != o.cases.end() ? ", image_features.png" : "");
  return failed ? 3 : 0;
}

}  // namespace varmesh::app
