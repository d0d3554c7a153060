#include "apps/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec4.hpp>

#include "multitri/errors.hpp"

// Techniques, all textbook:
// - clipping in homogeneous coordinates before the divide (Sutherland & Hodgman 1974; Blinn & Newell 1978,
//   "Clipping using homogeneous coordinates"), against the near and far planes and a guard band, so
//   vertices behind the eye never reach the divide and screen coordinates stay small enough for fixed point;
// - edge functions on 1/256-pixel fixed-point vertices with the top-left fill rule (Pineda 1988, "A parallel
//   algorithm for polygon rasterization"): exact integer arithmetic, so shared edges are watertight;
// - 1/w as depth and as the denominator of perspective-correct interpolation (Heckbert & Moreton 1991):
//   1/w is affine in screen space and keeps its relative precision at every distance;
// - Gouraud (1971) per-vertex Lambert shading with a head light.

namespace varmesh {
namespace {

constexpr int kMaxSize = 16384;
constexpr int kSubpixelBits = 8;  // with kGuard and 2 * kMaxSize samples the edge products fit in int64
constexpr std::int64_t kSubpixel = std::int64_t{1} << kSubpixelBits;
constexpr float kMaxWireWidth = 256.0f;
constexpr float kGuard = 4.0f;           // guard band: x and y are clipped at +-kGuard * w
constexpr float kAmbient = 0.25f;
constexpr glm::vec3 kBackTint{0.55f, 0.52f, 0.62f};
// A line point may be this much farther (relative, in 1/w) than the surface and still show; the
// per-pixel depth slope term below covers the depth change across the line's own width.
constexpr float kDepthRelBias = 5e-4f;

bool finite3(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

glm::vec3 safe_normalize(const glm::vec3& v) {
  const float len = glm::length(v);
  return len > 0.0f ? v / len : glm::vec3(0.0f);
}

// Planes 0..5: near, far, left, right, bottom, top (GL clip space: -w <= z <= w); x and y are scaled by
// `g` (1 = the viewport, kGuard = the guard band). Inside is >= 0.
float plane_distance(const glm::vec4& p, int plane, float g) {
  switch (plane) {
    case 0: return p.z + p.w;
    case 1: return p.w - p.z;
    case 2: return p.x + g * p.w;
    case 3: return g * p.w - p.x;
    case 4: return p.y + g * p.w;
    default: return g * p.w - p.y;
  }
}

unsigned outcode(const glm::vec4& p, float g) {
  unsigned code = 0;
  for (int i = 0; i < 6; ++i)
    if (!(plane_distance(p, i, g) >= 0.0f)) code |= 1u << i;  // NaN counts as outside
  return code;
}

struct ScreenPoint {
  double x = 0.0, y = 0.0;  // pixels, y down
  float iw = 0.0f;          // 1 / w
};

// Every vertex goes through this one function, clipped or not, so a vertex shared by a clipped and an
// unclipped triangle lands on the same fixed-point position.
ScreenPoint to_screen(const glm::vec4& p, int width, int height) {
  const double iw = 1.0 / static_cast<double>(p.w);
  return {(static_cast<double>(p.x) * iw + 1.0) * 0.5 * width, (1.0 - static_cast<double>(p.y) * iw) * 0.5 * height,
          static_cast<float>(iw)};
}

std::int64_t to_fixed(double v) { return std::llround(v * static_cast<double>(kSubpixel)); }

struct RasterVertex {
  std::int64_t x = 0, y = 0;  // fixed point
  float iw = 0.0f;
  glm::vec3 c_iw{0.0f};  // colour * iw
};

struct ClipVertex {
  glm::vec4 p{0.0f};
  glm::vec3 c{0.0f};
};

// Terrain colours from green lowlands through brown slopes to white peaks; t in [0, 1].
glm::vec3 height_ramp_color(float t) {
  struct Stop {
    float t;
    glm::vec3 c;
  };
  static constexpr Stop kStops[] = {
      {0.00f, {0.18f, 0.40f, 0.17f}}, {0.30f, {0.42f, 0.60f, 0.27f}}, {0.55f, {0.60f, 0.52f, 0.33f}},
      {0.75f, {0.50f, 0.40f, 0.30f}}, {0.90f, {0.86f, 0.85f, 0.83f}}, {1.00f, {0.98f, 0.98f, 0.98f}}};
  t = std::clamp(t, 0.0f, 1.0f);
  for (std::size_t i = 1; i < std::size(kStops); ++i)
    if (t <= kStops[i].t) {
      const float u = (t - kStops[i - 1].t) / (kStops[i].t - kStops[i - 1].t);
      return kStops[i - 1].c + u * (kStops[i].c - kStops[i - 1].c);
    }
  return kStops[std::size(kStops) - 1].c;
}

std::uint8_t to_byte(float v) {
  if (!(v > 0.0f)) return 0;  // also NaN
  if (v >= 1.0f) return 255;
  return static_cast<std::uint8_t>(v * 255.0f + 0.5f);
}

// Colour and depth samples of one render; lines are depth-tested but write no depth.
class Target {
 public:
  Target(int width, int height, const glm::vec3& background)
      : width_(width),
        height_(height),
        depth_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0.0f),
        color_(depth_.size(), background) {}

  int width() const { return width_; }
  int height() const { return height_; }
  const std::vector<glm::vec3>& color() const { return color_; }

  void fill_triangle(RasterVertex a, RasterVertex b, RasterVertex c);
  /// Depth slopes for line visibility; call once after the last triangle and before the first line.
  void compute_slopes();
  /// A line `thickness` pixels wide, spans perpendicular to its major axis (like non-antialiased GL lines).
  void draw_line(ScreenPoint a, ScreenPoint b, int thickness, const glm::vec3& color);

 private:
  bool line_visible(std::size_t idx, float iw, int thickness) const {
    const float d = depth_[idx];
    return d == 0.0f || iw >= d * (1.0f - kDepthRelBias) - slope_[idx] * (0.5f * static_cast<float>(thickness) + 1.0f);
  }

  int width_, height_;
  std::vector<float> depth_;  // 1/w of the nearest surface; 0 = nothing
  std::vector<glm::vec3> color_;
  std::vector<float> slope_;  // |d depth / d pixel| estimate, see compute_slopes
};

// Pixels whose centres lie in the triangle's bounding box, clamped to the target; empty for most
// triangles of a big mesh (smaller than a pixel), which lets the caller skip their shading.
struct PixelBox {
  std::int64_t x0, x1, y0, y1;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

PixelBox sample_box(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c, int width, int height) {
  // Pixel i has its centre at i * kSubpixel + kHalf; arithmetic shifts floor negative values.
  constexpr std::int64_t kHalf = kSubpixel / 2;
  const std::int64_t min_x = std::min({a.x, b.x, c.x}), max_x = std::max({a.x, b.x, c.x});
  const std::int64_t min_y = std::min({a.y, b.y, c.y}), max_y = std::max({a.y, b.y, c.y});
  return {std::max<std::int64_t>((min_x - kHalf + kSubpixel - 1) >> kSubpixelBits, 0),
          std::min<std::int64_t>((max_x - kHalf) >> kSubpixelBits, width - 1),
          std::max<std::int64_t>((min_y - kHalf + kSubpixel - 1) >> kSubpixelBits, 0),
          std::min<std::int64_t>((max_y - kHalf) >> kSubpixelBits, height - 1)};
}

struct Edge {
  std::int64_t value = 0, step_x = 0, step_y = 0;
};

// Edge p -> q of a triangle with positive area (y down), evaluated at the fixed-point sample (sx, sy).
// Inside is value >= 0. Samples exactly on an edge belong to the triangle only when the edge is a top edge
// (horizontal, interior below) or a left edge (interior to its right), hence the -1 on the others.
Edge make_edge(const RasterVertex& p, const RasterVertex& q, std::int64_t sx, std::int64_t sy) {
  const std::int64_t dx = q.x - p.x, dy = q.y - p.y;
  Edge e;
  e.value = dx * (sy - p.y) - dy * (sx - p.x);
  const bool top_left = dy < 0 || (dy == 0 && dx > 0);
  if (!top_left) e.value -= 1;
  e.step_x = -dy * kSubpixel;
  e.step_y = dx * kSubpixel;
  return e;
}

void Target::fill_triangle(RasterVertex a, RasterVertex b, RasterVertex c) {
  std::int64_t area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  if (area == 0) return;
  if (area < 0) {
    std::swap(b, c);
    area = -area;
  }
  const PixelBox box = sample_box(a, b, c, width_, height_);
  if (box.empty()) return;
  const std::int64_t x0 = box.x0, x1 = box.x1, y0 = box.y0, y1 = box.y1;

  const std::int64_t sx = x0 * kSubpixel + kSubpixel / 2, sy = y0 * kSubpixel + kSubpixel / 2;
  Edge e_a = make_edge(b, c, sx, sy);  // proportional to a's barycentric weight
  Edge e_b = make_edge(c, a, sx, sy);
  Edge e_c = make_edge(a, b, sx, sy);
  const float inv_area = 1.0f / static_cast<float>(area);

  for (std::int64_t y = y0; y <= y1; ++y) {
    std::int64_t wa = e_a.value, wb = e_b.value, wc = e_c.value;
    std::size_t idx = static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x0);
    bool entered = false;  // a row of a triangle is one span: stop at its end
    for (std::int64_t x = x0; x <= x1; ++x, ++idx) {
      if ((wa | wb | wc) >= 0) {
        entered = true;
        const float ba = static_cast<float>(wa) * inv_area;
        const float bb = static_cast<float>(wb) * inv_area;
        const float bc = static_cast<float>(wc) * inv_area;
        const float iw = ba * a.iw + bb * b.iw + bc * c.iw;
        if (iw > depth_[idx]) {
          depth_[idx] = iw;
          color_[idx] = (ba * a.c_iw + bb * b.c_iw + bc * c.c_iw) / iw;
        }
      } else if (entered) {
        break;
      }
      wa += e_a.step_x;
      wb += e_b.step_x;
      wc += e_c.step_x;
    }
    e_a.value += e_a.step_y;
    e_b.value += e_b.step_y;
    e_c.value += e_c.step_y;
  }
}

void Target::compute_slopes() {
  // One-sided differences, the smaller of the two per axis: across a depth discontinuity (a silhouette)
  // the smooth side wins, so an edge hidden just behind a silhouette does not get a huge tolerance.
  slope_.assign(depth_.size(), 0.0f);
  const auto w = static_cast<std::size_t>(width_), h = static_cast<std::size_t>(height_);
  auto axis_slope = [&](float d, std::size_t prev, bool has_prev, std::size_t next, bool has_next) {
    float s = -1.0f;
    if (has_prev && depth_[prev] > 0.0f) s = std::abs(d - depth_[prev]);
    if (has_next && depth_[next] > 0.0f) {
      const float t = std::abs(d - depth_[next]);
      s = s < 0.0f ? t : std::min(s, t);
    }
    return std::max(s, 0.0f);
  };
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) {
      const std::size_t i = y * w + x;
      const float d = depth_[i];
      if (d == 0.0f) continue;
      slope_[i] = axis_slope(d, i - 1, x > 0, i + 1, x + 1 < w) + axis_slope(d, i - w, y > 0, i + w, y + 1 < h);
    }
}

void Target::draw_line(ScreenPoint a, ScreenPoint b, int thickness, const glm::vec3& color) {
  const bool x_major = std::abs(b.x - a.x) >= std::abs(b.y - a.y);
  // (u, v): u along the major axis, v across it.
  double ua = x_major ? a.x : a.y, va = x_major ? a.y : a.x;
  double ub = x_major ? b.x : b.y, vb = x_major ? b.y : b.x;
  float iwa = a.iw, iwb = b.iw;
  if (ua > ub) {
    std::swap(ua, ub);
    std::swap(va, vb);
    std::swap(iwa, iwb);
  }
  const int u_size = x_major ? width_ : height_, v_size = x_major ? height_ : width_;
  // Columns containing the end points are included, so a sub-pixel segment still marks one pixel.
  const double u_first = std::max(std::floor(ua), 0.0), u_last = std::min(std::floor(ub), u_size - 1.0);
  if (u_first > u_last) return;
  const double du = ub - ua;
  for (int u = static_cast<int>(u_first); u <= static_cast<int>(u_last); ++u) {
    const double uc = std::clamp(u + 0.5, ua, ub);
    const double t = du > 0.0 ? (uc - ua) / du : 0.5;
    const double v_line = va + t * (vb - va);
    const float iw = static_cast<float>(iwa + t * (static_cast<double>(iwb) - iwa));
    const double v_first = std::floor(v_line + 0.5 - 0.5 * thickness);
    const int v0 = static_cast<int>(std::max(v_first, 0.0));
    const int v1 = static_cast<int>(std::min(v_first + thickness - 1.0, v_size - 1.0));
    for (int v = v0; v <= v1; ++v) {
      const std::size_t idx = x_major ? static_cast<std::size_t>(v) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(u)
                                      : static_cast<std::size_t>(u) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(v);
      if (line_visible(idx, iw, thickness)) color_[idx] = color;
    }
  }
}

// Whether a clipped point `p` (screen position `s`) lies where clipping puts it: in front of the eye and
// within the guard band (with a margin). Coordinates of 1e18 units with a near plane at 1 round in the
// clipping to a w <= 0 or a position far outside: such a point has no trustworthy position, and its
// fixed-point coordinates overflowed int64 (a crash of the demo on a needle-shaped height field).
bool on_guard_band(const glm::vec4& p, const ScreenPoint& s, const Target& target) {
  const double reach_x = double(kGuard) * target.width(), reach_y = double(kGuard) * target.height();
  return p.w > 0.0f && std::abs(s.x) <= reach_x && std::abs(s.y) <= reach_y;
}

// Sutherland-Hodgman against the planes named in `planes` (outcode bits), then a fan. The intersection on
// an edge is always computed from its inside end, so two triangles sharing the edge get the same point.
void clip_and_fill(Target& target, const ClipVertex (&tri)[3], unsigned planes) {
  ClipVertex buf[2][12];
  int n = 3;
  std::copy(tri, tri + 3, buf[0]);
  int cur = 0;
  for (int plane = 0; plane < 6; ++plane) {
    if (!(planes & (1u << plane))) continue;
    const ClipVertex* in = buf[cur];
    ClipVertex* out = buf[1 - cur];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const ClipVertex& p = in[i];
      const ClipVertex& q = in[(i + 1) % n];
      const float dp = plane_distance(p.p, plane, kGuard), dq = plane_distance(q.p, plane, kGuard);
      if (dp >= 0.0f) out[m++] = p;
      if ((dp >= 0.0f) != (dq >= 0.0f)) {
        const ClipVertex& inside = dp >= 0.0f ? p : q;
        const ClipVertex& outside = dp >= 0.0f ? q : p;
        const float di = dp >= 0.0f ? dp : dq, d_o = dp >= 0.0f ? dq : dp;
        const float t = di / (di - d_o);
        out[m++] = ClipVertex{inside.p + t * (outside.p - inside.p), inside.c + t * (outside.c - inside.c)};
      }
    }
    n = m;
    cur = 1 - cur;
    if (n < 3) return;
  }
  RasterVertex rv[12];
  for (int i = 0; i < n; ++i) {
    const ClipVertex& v = buf[cur][i];
    const ScreenPoint s = to_screen(v.p, target.width(), target.height());
    if (!on_guard_band(v.p, s, target)) return;
    rv[i] = RasterVertex{to_fixed(s.x), to_fixed(s.y), s.iw, v.c * s.iw};
  }
  for (int i = 1; i + 1 < n; ++i) target.fill_triangle(rv[0], rv[i], rv[i + 1]);
}

// Clips a segment to the near/far planes and the guard band; false when nothing is left.
bool clip_segment(glm::vec4& a, glm::vec4& b) {
  float t0 = 0.0f, t1 = 1.0f;
  for (int plane = 0; plane < 6; ++plane) {
    const float da = plane_distance(a, plane, kGuard), db = plane_distance(b, plane, kGuard);
    if (da < 0.0f && db < 0.0f) return false;
    if (da < 0.0f)
      t0 = std::max(t0, da / (da - db));
    else if (db < 0.0f)
      t1 = std::min(t1, da / (da - db));
  }
  if (t0 > t1) return false;
  const glm::vec4 d = b - a;
  b = a + t1 * d;
  a = a + t0 * d;
  return true;
}

bool finite4(const glm::vec4& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

void draw_clip_segment(Target& target, glm::vec4 a, glm::vec4 b, int thickness, const glm::vec3& color) {
  if (!finite4(a) || !finite4(b)) return;  // huge coordinates overflowed the transform
  if (outcode(a, 1.0f) & outcode(b, 1.0f)) return;
  if (!clip_segment(a, b)) return;
  const ScreenPoint sa = to_screen(a, target.width(), target.height()), sb = to_screen(b, target.width(), target.height());
  if (!on_guard_band(a, sa, target) || !on_guard_band(b, sb, target)) return;
  target.draw_line(sa, sb, thickness, color);
}

void check_camera(const Camera& cam) {
  if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f))
    throw InvalidInput("render: camera fov_y_deg " + std::to_string(cam.fov_y_deg) + " is not in (0, 180)");
  if (!(cam.z_near > 0.0f) || !(cam.z_far > cam.z_near) || !std::isfinite(cam.z_far))
    throw InvalidInput("render: camera needs 0 < z_near < z_far < inf, got z_near " + std::to_string(cam.z_near) +
                       ", z_far " + std::to_string(cam.z_far));
  if (!finite3(cam.eye) || !finite3(cam.target) || !finite3(cam.up))
    throw InvalidInput("render: camera eye, target or up is not finite");
  // In double: the squared lengths of a camera framing a model of 1e-20 units underflow float.
  const glm::dvec3 fwd = glm::dvec3(cam.target) - glm::dvec3(cam.eye), up(cam.up);
  const double lf = glm::length(fwd), lu = glm::length(up);
  if (!(lf > 0.0)) throw InvalidInput("render: camera eye equals target");
  if (!(glm::length(glm::cross(fwd, up)) > 1e-6 * lf * lu))
    throw InvalidInput("render: camera up is zero or parallel to the view direction");
}

}  // namespace

Image render_mesh(const TriMesh& input, const Camera& camera, const RenderOptions& options,
                  const std::vector<Segment3>& input_overlay) {
  if (options.width <= 0 || options.width > kMaxSize || options.height <= 0 || options.height > kMaxSize)
    throw InvalidInput("render: image size " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                       " is not within 1.." + std::to_string(kMaxSize));
  if (options.supersample != 1 && options.supersample != 2)
    throw InvalidInput("render: supersample must be 1 or 2, got " + std::to_string(options.supersample));
  if (options.face_colors && options.face_colors->size() != input.num_faces())
    throw InvalidInput("render: " + std::to_string(options.face_colors->size()) + " face colours for " +
                       std::to_string(input.num_faces()) + " faces");
  input.validate();
  Camera checked = camera;
  checked.aspect = static_cast<float>(options.width) / static_cast<float>(options.height);
  check_camera(checked);

  // A picture does not change when the whole scene is moved and scaled alike, so it is drawn in the frame
  // where the camera's target is the origin and its eye is at distance 1 (mapped in double). Squared
  // lengths in the view, clipping and shading maths then stay in float's range for models of any size
  // (a model of 1e-20 units underflowed them and drew nothing), and models far from the origin lose no
  // precision to their offset.
  const glm::dvec3 origin(camera.target);
  const double scale = 1.0 / glm::length(glm::dvec3(camera.eye) - origin);
  auto to_frame = [&](const glm::vec3& p) { return glm::vec3((glm::dvec3(p) - origin) * scale); };
  TriMesh mesh = input;
  for (glm::vec3& p : mesh.positions) p = to_frame(p);
  std::vector<Segment3> overlay = input_overlay;
  for (Segment3& seg : overlay) {
    seg.a = to_frame(seg.a);
    seg.b = to_frame(seg.b);
  }
  Camera cam = checked;
  cam.eye = to_frame(camera.eye);
  cam.target = glm::vec3(0.0f);
  cam.z_near = static_cast<float>(camera.z_near * scale);
  cam.z_far = static_cast<float>(camera.z_far * scale);
  if (!(cam.z_near > 0.0f) || !(cam.z_far > cam.z_near) || !std::isfinite(cam.z_far))
    throw InvalidInput("render: camera z_near " + std::to_string(camera.z_near) + ", z_far " +
                       std::to_string(camera.z_far) + " are out of proportion to the eye's distance " +
                       std::to_string(1.0 / scale));
  const glm::mat4 clip_from_world = cam.projection() * cam.view();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (!std::isfinite(clip_from_world[i][j])) throw InvalidInput("render: camera matrices are not finite");

  const int ss = options.supersample;
  Target target(options.width * ss, options.height * ss, options.background);
  const float wire_samples = options.wire_width * static_cast<float>(ss);
  const int thickness =
      wire_samples >= 1.0f ? static_cast<int>(std::lround(std::min(wire_samples, kMaxWireWidth))) : 1;  // NaN -> 1

  const std::size_t nv = mesh.num_vertices();
  std::vector<glm::vec4> clip(nv);
  std::vector<std::uint8_t> view_code(nv), guard_code(nv);
  std::vector<RasterVertex> raster(nv);  // valid where guard_code == 0
  for (std::size_t v = 0; v < nv; ++v) {
    clip[v] = clip_from_world * glm::vec4(mesh.positions[v], 1.0f);
    view_code[v] = static_cast<std::uint8_t>(outcode(clip[v], 1.0f));
    guard_code[v] = static_cast<std::uint8_t>(outcode(clip[v], kGuard));
    if (guard_code[v] == 0) {
      const ScreenPoint s = to_screen(clip[v], target.width(), target.height());
      raster[v] = RasterVertex{to_fixed(s.x), to_fixed(s.y), s.iw, glm::vec3(0.0f)};
    }
  }

  const glm::vec3 eye = cam.eye;
  // Per-vertex albedo when colours come from vertices; the head light makes |n . l| the diffuse term.
  const bool vertex_albedo = !options.face_colors && (options.height_ramp || mesh.has_colors());
  std::vector<glm::vec3> albedo;
  if (vertex_albedo) {
    albedo.resize(nv);
    const Box3 box = mesh.bounds();
    const float z_range = box.hi.z - box.lo.z;
    for (std::size_t v = 0; v < nv; ++v)
      albedo[v] = options.height_ramp
                      ? height_ramp_color(z_range > 0.0f ? (mesh.positions[v].z - box.lo.z) / z_range : 0.0f)
                      : mesh.colors[v];
  }
  std::vector<float> shade;
  if (options.smooth) {
    std::vector<glm::vec3> computed;
    if (!mesh.has_normals()) computed = compute_vertex_normals(mesh);
    const std::vector<glm::vec3>& normals = mesh.has_normals() ? mesh.normals : computed;
    shade.resize(nv);
    // |n . l| rather than max(0, n . l): shading does not depend on the normals' orientation, which scans
    // often get wrong, and back faces see their own side lit.
    for (std::size_t v = 0; v < nv; ++v)
      shade[v] = kAmbient + (1.0f - kAmbient) * std::abs(glm::dot(safe_normalize(normals[v]),
                                                                   safe_normalize(eye - mesh.positions[v])));
  }

  const glm::vec3 flat_light = safe_normalize(eye - cam.target);  // flat shading: a directional head light
  std::vector<FaceId> drawn;  // faces whose edges the wireframe draws
  const std::size_t nf = mesh.num_faces();
  for (std::size_t f = 0; f < nf; ++f) {
    const Index i[3] = {mesh.corner(f, 0), mesh.corner(f, 1), mesh.corner(f, 2)};
    if (view_code[i[0]] & view_code[i[1]] & view_code[i[2]]) continue;
    const glm::vec3& p0 = mesh.positions[i[0]];
    // In double: the side test is cubic in the model's size and would underflow float for models of 1e-13
    // and less (every face skipped, a blank picture).
    const glm::dvec3 d0(p0);
    const glm::dvec3 fn = glm::cross(glm::dvec3(mesh.positions[i[1]]) - d0, glm::dvec3(mesh.positions[i[2]]) - d0);
    // Counter-clockwise seen from the eye = the eye on the side the face normal points to.
    const double side = glm::dot(fn, glm::dvec3(eye) - d0);
    if (!(side != 0.0)) continue;  // edge-on or degenerate: no area on screen
    const bool front = side > 0.0;
    if (!front && !options.two_sided) continue;
    if (options.wireframe) drawn.push_back(static_cast<FaceId>(f));
    const unsigned planes = guard_code[i[0]] | guard_code[i[1]] | guard_code[i[2]];
    if (planes == 0 && sample_box(raster[i[0]], raster[i[1]], raster[i[2]], target.width(), target.height()).empty())
      continue;

    glm::vec3 c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = options.face_colors ? (*options.face_colors)[f] : vertex_albedo ? albedo[i[k]] : options.base_color;
    if (options.smooth) {
      for (int k = 0; k < 3; ++k) c[k] *= shade[i[k]];
    } else {
      // One light direction for the whole picture (the view direction): lit from the eye towards each
      // face's centroid, two coplanar faces got two shades and showed the diagonal between them.
      const glm::vec3 unit_fn(glm::normalize(fn));  // fn != 0 (side != 0)
      const float s = kAmbient + (1.0f - kAmbient) * std::abs(glm::dot(unit_fn, flat_light));
      for (auto& ck : c) ck *= s;
    }
    if (!front)
      for (auto& ck : c) ck *= kBackTint;

    if (planes == 0) {
      RasterVertex rv[3];
      for (int k = 0; k < 3; ++k) {
        rv[k] = raster[i[k]];
        rv[k].c_iw = c[k] * rv[k].iw;
      }
      target.fill_triangle(rv[0], rv[1], rv[2]);
    } else if (finite4(clip[i[0]]) && finite4(clip[i[1]]) && finite4(clip[i[2]])) {
      const ClipVertex tri[3] = {{clip[i[0]], c[0]}, {clip[i[1]], c[1]}, {clip[i[2]], c[2]}};
      clip_and_fill(target, tri, planes);
    }
  }

  if (options.wireframe || !overlay.empty()) target.compute_slopes();
  for (const FaceId f : drawn)
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.corner(f, k), b = mesh.corner(f, (k + 1) % 3);
      if (guard_code[a] == 0 && guard_code[b] == 0) {
        // Same fixed-point positions as the triangles, so the line sits exactly on the drawn edge.
        auto screen = [](const RasterVertex& r) {
          return ScreenPoint{static_cast<double>(r.x) / kSubpixel, static_cast<double>(r.y) / kSubpixel, r.iw};
        };
        target.draw_line(screen(raster[a]), screen(raster[b]), thickness, options.wire_color);
      } else {
        draw_clip_segment(target, clip[a], clip[b], thickness, options.wire_color);
      }
    }
  for (const Segment3& s : overlay) {
    if (!finite3(s.a) || !finite3(s.b)) continue;
    draw_clip_segment(target, clip_from_world * glm::vec4(s.a, 1.0f), clip_from_world * glm::vec4(s.b, 1.0f),
                      thickness, s.color);
  }

  Image image;
  image.width = static_cast<std::size_t>(options.width);
  image.height = static_cast<std::size_t>(options.height);
  image.channels = 3;
  image.bit_depth = 8;
  image.pixels.resize(image.width * image.height * 3);
  const std::vector<glm::vec3>& samples = target.color();
  const auto tw = static_cast<std::size_t>(target.width());
  for (std::size_t y = 0; y < image.height; ++y)
    for (std::size_t x = 0; x < image.width; ++x) {
      glm::vec3 sum(0.0f);
      for (std::size_t sy = 0; sy < static_cast<std::size_t>(ss); ++sy)
        for (std::size_t sx = 0; sx < static_cast<std::size_t>(ss); ++sx)
          sum += samples[(y * static_cast<std::size_t>(ss) + sy) * tw + x * static_cast<std::size_t>(ss) + sx];
      sum /= static_cast<float>(ss * ss);
      std::uint8_t* px = &image.pixels[(y * image.width + x) * 3];
      px[0] = to_byte(sum.r);
      px[1] = to_byte(sum.g);
      px[2] = to_byte(sum.b);
    }
  return image;
}

Camera default_camera_for(const TriMesh& mesh, float aspect) {
  if (!(aspect > 0.0f) || !std::isfinite(aspect))
    throw InvalidInput("default_camera_for: aspect " + std::to_string(aspect) + " is not a positive number");
  // The referenced vertices only: an unreferenced one far away framed an empty picture (or, near float's
  // limit, an infinite sphere).
  Box3 box;
  for (Index i : mesh.indices) box.add(mesh.positions[i]);
  glm::vec3 center(0.0f);
  float radius = 1.0f;
  bool flat = false;
  if (!box.empty()) {
    center = box.center();
    double r2 = 0.0;  // double: squared distances of a model of 1e-20 units underflow float
    for (Index i : mesh.indices) {
      const glm::dvec3 d = glm::dvec3(mesh.positions[i]) - glm::dvec3(center);
      r2 = std::max(r2, glm::dot(d, d));
    }
    radius = static_cast<float>(std::sqrt(r2));
    if (!(radius > 0.0f)) radius = 1.0f;
    const glm::vec3 ext = box.extent();
    flat = ext.z < 0.25f * std::max(ext.x, ext.y);
  }
  // Eye in front (-y) and to the right (+x), above the horizon.
  const float elevation = glm::radians(flat ? 40.0f : 25.0f);
  const float azimuth = glm::radians(-60.0f);
  const glm::vec3 to_eye(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                         std::sin(elevation));
  return frame_sphere(center, radius, -to_eye, 40.0f, aspect);
}


std::size_t pixels_unlike(const Image& picture, const glm::vec3& background) {
  if (picture.bit_depth != 8 || picture.channels != 3) throw InvalidInput("pixels_unlike: not an 8-bit RGB picture");
  const std::uint8_t bg[3] = {to_byte(background.x), to_byte(background.y), to_byte(background.z)};
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < picture.pixels.size(); i += 3)
    n += picture.pixels[i] != bg[0] || picture.pixels[i + 1] != bg[1] || picture.pixels[i + 2] != bg[2];
  return n;
}

Camera picture_camera_for(const TriMesh& reference, const glm::vec3& up, const glm::vec3& view, float aspect) {
  Box3 box;
  for (Index i : reference.indices) box.add(reference.positions[i]);
  if (box.empty()) return default_camera_for(reference, aspect);
  if (!(glm::length(up) > 0.0f)) throw InvalidInput("--up: the direction is zero");
  glm::vec3 to_eye = view;
  if (!(glm::length(to_eye) > 0.0f)) {
    const glm::vec3 u = glm::normalize(up);
    const glm::vec3 side = std::abs(u.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 x = glm::normalize(side - glm::dot(side, u) * u), y = glm::cross(u, x);
    to_eye = 0.453f * x - 0.785f * y + 0.423f * u;  // elevation 25 degrees, azimuth -60 degrees
  }
  const float radius = std::max(0.5f * box.diagonal(), 1e-6f);
  Camera cam = frame_sphere(box.center(), radius, -to_eye, 30.0f, aspect, up);  // checks, up fallback
  const glm::vec3 f = glm::normalize(cam.target - cam.eye), r = glm::normalize(glm::cross(f, cam.up)),
                  u = glm::cross(r, f);
  // Centre the extent seen across the view, then move back until every vertex is inside (92% of the frame).
  glm::vec2 lo(1e30f), hi(-1e30f);
  for (Index i : reference.indices) {
    const glm::vec3 q = reference.positions[i] - cam.target;
    const glm::vec2 xy(glm::dot(q, r), glm::dot(q, u));
    lo = glm::min(lo, xy);
    hi = glm::max(hi, xy);
  }
  const glm::vec3 centre = cam.target + 0.5f * (lo.x + hi.x) * r + 0.5f * (lo.y + hi.y) * u;
  const float ty = 0.92f * std::tan(glm::radians(0.5f * cam.fov_y_deg)), tx = ty * aspect;
  float dist = 0.0f, zmin = 1e30f, zmax = -1e30f;
  for (Index i : reference.indices) {
    const glm::vec3 q = reference.positions[i] - centre;
    const float z = -glm::dot(q, f);  // towards the eye
    dist = std::max({dist, z + std::abs(glm::dot(q, r)) / tx, z + std::abs(glm::dot(q, u)) / ty});
    zmin = std::min(zmin, z);
    zmax = std::max(zmax, z);
  }
  // Every vertex at one point (a mesh of degenerate faces): no extent to fit, so frame a small sphere around
  // it, large enough for float to keep the eye apart from the target.
  if (!(dist > 0.0f)) {
    const glm::vec3 c = box.center();
    const float around = 1e-3f * std::max({1.0f, std::abs(c.x), std::abs(c.y), std::abs(c.z)});
    return frame_sphere(c, around, -to_eye, 30.0f, aspect, up);
  }
  cam.target = centre;
  cam.eye = centre - f * dist;
  cam.z_near = std::max(1e-3f * dist, 0.5f * (dist - zmax));
  cam.z_far = 2.0f * (dist - zmin) + 1e-3f * dist;
  return cam;
}

}  // namespace varmesh
