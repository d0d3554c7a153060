#include "apps/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>
#include <gtest/gtest.h>

#include <set>

#include "multitri/errors.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

constexpr int kW = 160;
constexpr int kH = 120;

struct Rgb {
  int r = 0, g = 0, b = 0;
  int sum() const { return r + g + b; }
  bool operator==(const Rgb&) const = default;
};

Rgb pixel(const Image& im, int x, int y) {
  const std::uint8_t* p = &im.pixels[(static_cast<std::size_t>(y) * im.width + static_cast<std::size_t>(x)) * 3];
  return {p[0], p[1], p[2]};
}

// A camera on -y looking at the origin, z up: +x is to the right of the picture and +z up.
Camera front_camera(float distance = 5.0f) {
  Camera c;
  c.eye = {0.0f, -distance, 0.0f};
  c.target = {0.0f, 0.0f, 0.0f};
  c.up = {0.0f, 0.0f, 1.0f};
  c.fov_y_deg = 45.0f;
  c.aspect = static_cast<float>(kW) / static_cast<float>(kH);
  c.z_near = 0.1f;
  c.z_far = 100.0f;
  return c;
}

RenderOptions black_background() {
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  o.background = {0.0f, 0.0f, 0.0f};
  o.base_color = {1.0f, 1.0f, 1.0f};
  return o;
}

void add_triangle(TriMesh& m, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  const auto base = static_cast<Index>(m.positions.size());
  m.positions.insert(m.positions.end(), {a, b, c});
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
}

// A square in the plane y = `y`, x and z in [-h, h], counter-clockwise seen from -y (facing the camera).
void add_square(TriMesh& m, float y, float h) {
  const auto base = static_cast<Index>(m.positions.size());
  m.positions.insert(m.positions.end(), {{-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}});
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// An n x n grid in the plane y = 0 over x, z in [-h, h], interior vertices jiggled within the plane so the
// edges are not axis-aligned; counter-clockwise seen from -y.
TriMesh jiggled_grid(int n, float h) {
  TriMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      float x = -h + 2.0f * h * static_cast<float>(i) / static_cast<float>(n);
      float z = -h + 2.0f * h * static_cast<float>(j) / static_cast<float>(n);
      if (i > 0 && i < n && j > 0 && j < n) {
        const float cell = 2.0f * h / static_cast<float>(n);
        x += 0.3f * cell * std::sin(static_cast<float>(7 * i + 3 * j));
        z += 0.3f * cell * std::cos(static_cast<float>(5 * i - 11 * j));
      }
      m.positions.push_back({x, 0.0f, z});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const auto a = static_cast<Index>(j * (n + 1) + i), b = a + 1, c = a + static_cast<Index>(n + 1), d = c + 1;
      if ((i + j) % 2 == 0)
        m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      else
        m.indices.insert(m.indices.end(), {a, b, c, b, d, c});
    }
  return m;
}

// A UV sphere with outward counter-clockwise faces.
TriMesh uv_sphere(glm::vec3 center, float r, int rings, int segments) {
  TriMesh m;
  const float pi = std::numbers::pi_v<float>;
  for (int i = 0; i <= rings; ++i) {
    const float theta = pi * static_cast<float>(i) / static_cast<float>(rings);
    for (int j = 0; j < segments; ++j) {
      const float phi = 2.0f * pi * static_cast<float>(j) / static_cast<float>(segments);
      m.positions.push_back(center + r * glm::vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                                   std::cos(theta)));
    }
  }
  auto at = [&](int i, int j) { return static_cast<Index>(i * segments + (j % segments)); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const Index a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (i > 0) m.indices.insert(m.indices.end(), {a, b, d});
      if (i + 1 < rings) m.indices.insert(m.indices.end(), {b, c, d});
    }
  return m;
}

std::size_t count_non_black(const Image& im) {
  std::size_t n = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) n += pixel(im, x, y).sum() > 0 ? 1 : 0;
  return n;
}

// Pixel position of a world point, the convention render.hpp documents (row 0 at the top).
glm::dvec2 project(const Camera& cam, glm::vec3 p) {
  const glm::vec4 c = cam.projection() * cam.view() * glm::vec4(p, 1.0f);
  return {(c.x / c.w + 1.0) * 0.5 * kW, (1.0 - c.y / c.w) * 0.5 * kH};
}

TEST(RenderInput, InvalidSizesThrow) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  for (const auto& [w, h] : {std::pair{0, 10}, {10, 0}, {-4, 10}, {10, -1}, {16385, 10}, {10, 20000}}) {
    RenderOptions o;
    o.width = w;
    o.height = h;
    EXPECT_THROW(render_mesh(m, front_camera(), o), InvalidInput) << w << "x" << h;
  }
  RenderOptions ok;
  ok.width = 1;
  ok.height = 1;
  EXPECT_NO_THROW(render_mesh(m, front_camera(), ok));
}

TEST(RenderInput, BadMeshOptionsOrCameraThrow) {
  TriMesh bad;
  add_square(bad, 0.0f, 1.0f);
  bad.indices[4] = 99;
  EXPECT_THROW(render_mesh(bad, front_camera(), black_background()), InvalidInput);

  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  RenderOptions o = black_background();
  const std::vector<glm::vec3> one_colour{{1.0f, 0.0f, 0.0f}};
  o.face_colors = &one_colour;  // two faces
  EXPECT_THROW(render_mesh(m, front_camera(), o), InvalidInput);
  o = black_background();
  o.supersample = 3;
  EXPECT_THROW(render_mesh(m, front_camera(), o), InvalidInput);

  Camera cam = front_camera();
  cam.target = cam.eye;
  EXPECT_THROW(render_mesh(m, cam, black_background()), InvalidInput);
  cam = front_camera();
  cam.z_near = 0.0f;
  EXPECT_THROW(render_mesh(m, cam, black_background()), InvalidInput);
  cam = front_camera();
  cam.up = {0.0f, 1.0f, 0.0f};  // parallel to the view direction
  EXPECT_THROW(render_mesh(m, cam, black_background()), InvalidInput);
}

TEST(RenderOutput, ImageIsRgb8OfTheRequestedSize) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  RenderOptions o = black_background();
  o.width = 37;
  o.height = 23;
  const Image im = render_mesh(m, front_camera(), o);
  EXPECT_EQ(im.width, 37u);
  EXPECT_EQ(im.height, 23u);
  EXPECT_EQ(im.channels, 3);
  EXPECT_EQ(im.bit_depth, 8);
  EXPECT_EQ(im.pixels.size(), 37u * 23u * 3u);
}

TEST(RenderDeterminism, SameInputGivesIdenticalPixels) {
  TriMesh m = uv_sphere({0.0f, 0.0f, 0.0f}, 1.0f, 24, 48);
  const TriMesh grid = jiggled_grid(10, 1.5f);
  const auto base = static_cast<Index>(m.positions.size());
  for (const auto& p : grid.positions) m.positions.push_back(p + glm::vec3(0.0f, 0.5f, 0.0f));
  for (const Index i : grid.indices) m.indices.push_back(base + i);
  const std::vector<Segment3> overlay{{{-2.0f, -1.0f, -1.0f}, {2.0f, 1.0f, 1.0f}}};
  for (const int ss : {1, 2}) {
    RenderOptions o;
    o.width = kW;
    o.height = kH;
    o.wireframe = true;
    o.supersample = ss;
    const Camera cam = default_camera_for(m, 4.0f / 3.0f);
    const Image a = render_mesh(m, cam, o, overlay);
    const Image b = render_mesh(m, cam, o, overlay);
    EXPECT_EQ(a.pixels, b.pixels) << "supersample " << ss;
  }
}

TEST(RenderCoverage, TriangleCoversExactlyThePixelCentresInsideIt) {
  const Camera cam = front_camera();
  const glm::vec3 a{-1.0f, 0.0f, -0.8f}, b{1.2f, 0.0f, -0.5f}, c{0.1f, 0.0f, 1.0f};
  TriMesh m;
  add_triangle(m, a, b, c);
  const Image im = render_mesh(m, cam, black_background());

  const glm::dvec2 pa = project(cam, a), pb = project(cam, b), pc = project(cam, c);
  const double area2 = (pb.x - pa.x) * (pc.y - pa.y) - (pb.y - pa.y) * (pc.x - pa.x);
  // Signed distance to an edge in pixels, positive inside.
  auto dist = [&](glm::dvec2 p, glm::dvec2 q, glm::dvec2 s) {
    const double cross = (q.x - p.x) * (s.y - p.y) - (q.y - p.y) * (s.x - p.x);
    return (area2 > 0 ? cross : -cross) / glm::length(q - p);
  };
  std::size_t covered = 0, checked_inside = 0, checked_outside = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const glm::dvec2 s{x + 0.5, y + 0.5};
      const double d = std::min({dist(pa, pb, s), dist(pb, pc, s), dist(pc, pa, s)});
      const bool lit = pixel(im, x, y).sum() > 0;
      covered += lit ? 1 : 0;
      if (d > 0.02) {
        ++checked_inside;
        EXPECT_TRUE(lit) << "hole at " << x << "," << y;
      } else if (d < -0.02) {
        ++checked_outside;
        EXPECT_FALSE(lit) << "spill at " << x << "," << y;
      }
    }
  EXPECT_GT(checked_inside, 1000u);
  EXPECT_GT(checked_outside, 1000u);
  EXPECT_NEAR(static_cast<double>(covered), std::abs(area2) / 2.0, 0.02 * std::abs(area2) / 2.0);
}

TEST(RenderCoverage, FinelyTriangulatedSquareHasNoCracks) {
  const Camera cam = front_camera();
  const TriMesh m = jiggled_grid(24, 1.0f);
  const Image im = render_mesh(m, cam, black_background());
  // The square projects to an axis-aligned rectangle; every pixel centre inside it must be covered.
  const glm::dvec2 lo = project(cam, {-1.0f, 0.0f, 1.0f}), hi = project(cam, {1.0f, 0.0f, -1.0f});
  int inside = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double cx = x + 0.5, cy = y + 0.5;
      if (cx > lo.x + 0.02 && cx < hi.x - 0.02 && cy > lo.y + 0.02 && cy < hi.y - 0.02) {
        ++inside;
        EXPECT_GT(pixel(im, x, y).sum(), 0) << "crack at " << x << "," << y;
      }
    }
  EXPECT_GT(inside, 2000);
}

TEST(RenderCoverage, SharedEdgesThroughPixelCentresHaveOneOwner) {
  // A fan of four triangles around the view axis: its spokes are a vertical and a horizontal line through
  // pixel centres (odd image size). The top-left rule gives each centre on a spoke to exactly one
  // triangle, so the picture does not depend on the draw order.
  TriMesh fan;
  const glm::vec3 c{0.0f, 0.0f, 0.0f}, r{1.0f, 0.0f, 0.0f}, t{0.0f, 0.0f, 1.0f}, l{-1.0f, 0.0f, 0.0f},
      b{0.0f, 0.0f, -1.0f};
  add_triangle(fan, c, r, t);
  add_triangle(fan, c, t, l);
  add_triangle(fan, c, l, b);
  add_triangle(fan, c, b, r);
  TriMesh reversed;
  for (int f = 3; f >= 0; --f)
    add_triangle(reversed, fan.positions[fan.corner(static_cast<std::size_t>(f), 0)],
                 fan.positions[fan.corner(static_cast<std::size_t>(f), 1)],
                 fan.positions[fan.corner(static_cast<std::size_t>(f), 2)]);
  const std::vector<glm::vec3> colours{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}};
  const std::vector<glm::vec3> reversed_colours(colours.rbegin(), colours.rend());
  RenderOptions o = black_background();
  o.width = kW + 1;
  o.height = kH + 1;
  o.smooth = false;
  o.face_colors = &colours;
  const Image a = render_mesh(fan, front_camera(), o);
  o.face_colors = &reversed_colours;
  const Image z = render_mesh(reversed, front_camera(), o);
  EXPECT_EQ(a.pixels, z.pixels);
}

TEST(RenderOrientation, ZIsUpAndXIsRightNotMirrored) {
  // Red face at +x, blue at -x, green at +z: centroids of their pixels must sit right, left and on top.
  TriMesh m;
  add_triangle(m, {0.6f, 0.0f, -0.3f}, {1.2f, 0.0f, -0.3f}, {0.9f, 0.0f, 0.2f});
  add_triangle(m, {-1.2f, 0.0f, -0.3f}, {-0.6f, 0.0f, -0.3f}, {-0.9f, 0.0f, 0.2f});
  add_triangle(m, {-0.3f, 0.0f, 0.8f}, {0.3f, 0.0f, 0.8f}, {0.0f, 0.0f, 1.3f});
  const std::vector<glm::vec3> colours{{1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f}};
  RenderOptions o = black_background();
  o.face_colors = &colours;
  const Image im = render_mesh(m, front_camera(), o);
  glm::dvec2 sum[3]{};
  int count[3]{};
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const Rgb p = pixel(im, x, y);
      const int k = p.r > 0 ? 0 : p.b > 0 ? 1 : p.g > 0 ? 2 : -1;
      if (k < 0) continue;
      sum[k] += glm::dvec2(x, y);
      ++count[k];
    }
  for (int k = 0; k < 3; ++k) ASSERT_GT(count[k], 20) << k;
  EXPECT_GT(sum[0].x / count[0], kW * 0.6);  // red on the right
  EXPECT_LT(sum[1].x / count[1], kW * 0.4);  // blue on the left
  EXPECT_LT(sum[2].y / count[2], kH * 0.4);  // green at the top
}

TEST(RenderDepth, NearTriangleHidesFarOneWhateverTheDrawOrder) {
  TriMesh near_first, far_first;
  const glm::vec3 na{-1.0f, 0.0f, -1.0f}, nb{1.0f, 0.0f, -1.0f}, nc{0.0f, 0.0f, 1.0f};
  const glm::vec3 fa{-1.0f, 1.0f, 1.0f}, fb{0.0f, 1.0f, -1.5f}, fc{1.0f, 1.0f, 1.0f};
  add_triangle(near_first, na, nb, nc);
  add_triangle(near_first, fa, fb, fc);
  add_triangle(far_first, fa, fb, fc);
  add_triangle(far_first, na, nb, nc);
  const std::vector<glm::vec3> red_blue{{1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}};
  const std::vector<glm::vec3> blue_red{{0.0f, 0.0f, 1.0f}, {1.0f, 0.0f, 0.0f}};
  RenderOptions o = black_background();
  o.face_colors = &red_blue;
  const Image a = render_mesh(near_first, front_camera(), o);
  o.face_colors = &blue_red;
  const Image b = render_mesh(far_first, front_camera(), o);
  EXPECT_EQ(a.pixels, b.pixels);
  const Rgb centre = pixel(a, kW / 2, kH / 2);  // inside both triangles
  EXPECT_GT(centre.r, 0);
  EXPECT_EQ(centre.b, 0);
  int blue = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) blue += pixel(a, x, y).b > 0 ? 1 : 0;
  EXPECT_GT(blue, 50);  // the far triangle shows where the near one does not cover it
}

// Flat shading lights every face from one direction (the view's): the faces of a plane seen up close and
// at an angle get one shade. Lit from the eye towards each centroid, they got many, and the diagonals of
// a quad mesh showed.
TEST(RenderFaces, FlatShadingGivesCoplanarFacesOneShade) {
  const TriMesh grid = jiggled_grid(8, 1.0f);
  Camera cam = front_camera(1.5f);
  cam.eye = {0.9f, -1.2f, 0.7f};
  RenderOptions o = black_background();
  o.smooth = false;
  const Image im = render_mesh(grid, cam, o);
  std::set<std::array<std::uint8_t, 3>> shades;
  for (std::size_t i = 0; i + 2 < im.pixels.size(); i += 3)
    if (im.pixels[i] + im.pixels[i + 1] + im.pixels[i + 2] > 0) shades.insert({im.pixels[i], im.pixels[i + 1], im.pixels[i + 2]});
  EXPECT_GT(count_non_black(im), std::size_t{kW * kH / 10});
  EXPECT_EQ(shades.size(), 1u);
  EXPECT_EQ(pixels_unlike(im, o.background), count_non_black(im));
}

TEST(RenderFaces, BackFacesCulledWhenOneSidedAndDarkerWhenTwoSided) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);  // faces -y
  const Camera front = front_camera();
  Camera behind = front;
  behind.eye = {0.0f, 5.0f, 0.0f};
  RenderOptions o = black_background();
  o.two_sided = false;
  EXPECT_EQ(count_non_black(render_mesh(m, behind, o)), 0u);
  EXPECT_GT(count_non_black(render_mesh(m, front, o)), 1000u);

  o.two_sided = true;
  auto mean_brightness = [](const Image& im) {
    double s = 0.0;
    std::size_t n = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        if (const int v = pixel(im, x, y).sum(); v > 0) {
          s += v;
          ++n;
        }
    return n ? s / static_cast<double>(n) : 0.0;
  };
  const Image back_image = render_mesh(m, behind, o);
  const Image front_image = render_mesh(m, front, o);
  EXPECT_EQ(count_non_black(back_image), count_non_black(front_image));
  EXPECT_LT(mean_brightness(back_image), 0.8 * mean_brightness(front_image));
}

TEST(RenderClipping, GroundThroughTheNearPlaneShowsBelowTheHorizonOnly) {
  // A huge ground square z = -1 around a camera at the origin looking along +y: its corners are behind
  // the eye, so the triangles must be clipped, not projected through w <= 0.
  TriMesh m;
  const auto q = [](float x, float y) { return glm::vec3(x, y, -1.0f); };
  add_triangle(m, q(-50, -50), q(50, -50), q(50, 50));
  add_triangle(m, q(-50, -50), q(50, 50), q(-50, 50));
  Camera cam = front_camera();
  cam.eye = {0.0f, 0.0f, 0.0f};
  cam.target = {0.0f, 1.0f, 0.0f};
  const Image im = render_mesh(m, cam, black_background());
  // The far edge (y = 50) is 1/50 rad below the view axis: about 3 pixels below the middle row.
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (y < kH / 2) {
        EXPECT_EQ(pixel(im, x, y).sum(), 0) << x << "," << y;
      } else if (y >= kH / 2 + 5) {
        EXPECT_GT(pixel(im, x, y).sum(), 0) << x << "," << y;
      }
    }
}

TEST(RenderClipping, NearAndFarPlanesCutTheGround) {
  // Same ground, but z_near = 3 and z_far = 20: ground closer than 3 (rows below ~108) and farther than 20
  // (rows above ~67) is cut away.
  TriMesh m;
  const auto q = [](float x, float y) { return glm::vec3(x, y, -1.0f); };
  add_triangle(m, q(-50, -50), q(50, -50), q(50, 50));
  add_triangle(m, q(-50, -50), q(50, 50), q(-50, 50));
  Camera cam = front_camera();
  cam.eye = {0.0f, 0.0f, 0.0f};
  cam.target = {0.0f, 1.0f, 0.0f};
  cam.z_near = 3.0f;
  cam.z_far = 20.0f;
  const Image im = render_mesh(m, cam, black_background());
  const double rows_per_tan = (kH / 2.0) / std::tan(glm::radians(22.5));
  const int near_row = static_cast<int>(kH / 2.0 + rows_per_tan / 3.0);  // tan = 1/3 below the axis
  const int far_row = static_cast<int>(kH / 2.0 + rows_per_tan / 20.0);
  for (int y = 0; y < kH; ++y) {
    const int lit = [&] {
      int n = 0;
      for (int x = 0; x < kW; ++x) n += pixel(im, x, y).sum() > 0 ? 1 : 0;
      return n;
    }();
    if (y < far_row - 1 || y > near_row + 1) {
      EXPECT_EQ(lit, 0) << "row " << y;
    } else if (y > far_row + 1 && y < near_row - 1) {
      EXPECT_EQ(lit, kW) << "row " << y;
    }
  }
}

TEST(RenderClipping, CameraInsideAClosedMeshSeesItEverywhere) {
  const TriMesh sphere = uv_sphere({0.0f, 0.0f, 0.0f}, 2.0f, 16, 32);
  Camera cam = front_camera();
  cam.eye = {0.1f, 0.2f, 0.3f};
  cam.target = {1.0f, 1.0f, 0.5f};
  RenderOptions o = black_background();
  const Image im = render_mesh(sphere, cam, o);  // back faces, two-sided
  EXPECT_EQ(count_non_black(im), static_cast<std::size_t>(kW * kH));
  o.two_sided = false;  // all back faces seen from inside
  EXPECT_EQ(count_non_black(render_mesh(sphere, cam, o)), 0u);
}

TEST(RenderClipping, PointsThatClippingCannotPlaceAreSkipped) {
  // The demo's top view of a needle-shaped height field (heights 0, 1e18 and 2e18 on a 17 x 17 grid): the
  // eye stands at the height of the tallest samples (2e18 + 24 rounds to 2e18) with a near plane of 0.8.
  // Clipping at that scale rounded points to w <= 0; their screen positions overflowed the fixed-point
  // coordinates (signed overflow, then a write outside the picture in the wireframe).
  TriMesh m;
  constexpr int kN = 17;
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) m.positions.push_back({float(x), float(y), 1e18f * float((y * kN + x) % 3)});
  for (int y = 0; y + 1 < kN; ++y)
    for (int x = 0; x + 1 < kN; ++x) {
      const auto v = [](int i, int j) { return static_cast<Index>(j * kN + i); };
      m.indices.insert(m.indices.end(), {v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y), v(x + 1, y + 1), v(x, y + 1)});
    }
  Camera top;
  top.target = {8.0f, 8.0f, 0.0f};
  top.eye = {8.0f, 8.0f, 2e18f + 24.0f};
  top.up = {0.0f, 1.0f, 0.0f};
  top.fov_y_deg = 45.0f;
  top.aspect = 1.0f;
  top.z_near = 0.8f;
  top.z_far = 40.0f + 2e18f;
  RenderOptions o = black_background();
  o.width = o.height = 256;
  o.wireframe = true;
  o.wire_color = {0.0f, 1.0f, 0.0f};
  const std::vector<Segment3> overlay = {{{0.0f, 0.0f, 2e18f}, {16.0f, 16.0f, 0.0f}, {1.0f, 0.0f, 0.0f}}};
  const Image im = render_mesh(m, top, o, overlay);
  ASSERT_EQ(im.width, 256u);
  ASSERT_EQ(im.height, 256u);
  // The samples at height 0 lie 2e18 below the eye, well inside the frustum: the ground shows.
  EXPECT_GT(count_non_black(im), 0u);
}

TEST(RenderWireframe, AddsDarkPixelsOnTheEdgesOnly) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  const Camera cam = front_camera();
  const Image plain = render_mesh(m, cam, o);
  o.wireframe = true;
  const Image wired = render_mesh(m, cam, o);
  // Square side in pixels; its outline and one diagonal are drawn one pixel wide.
  const double side = project(cam, {1.0f, 0.0f, 0.0f}).x - project(cam, {-1.0f, 0.0f, 0.0f}).x;
  int changed = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const Rgb p = pixel(wired, x, y);
      if (p == pixel(plain, x, y)) continue;
      ++changed;
      EXPECT_LT(p.sum(), 3 * 30) << x << "," << y;
    }
  EXPECT_GT(changed, static_cast<int>(5.0 * side * 0.9));
  EXPECT_LT(changed, static_cast<int>(5.0 * side * 1.2) + 10);
  EXPECT_EQ(pixel(wired, kW / 2 + 10, kH / 2 - 20), pixel(plain, kW / 2 + 10, kH / 2 - 20));  // off the edges
}

TEST(RenderWireframe, EdgesBehindTheSurfaceStayHidden) {
  // A small square 1% of the distance behind a big one: its edges must not show through.
  TriMesh front_only, both;
  add_square(front_only, 0.0f, 1.0f);
  add_square(both, 0.0f, 1.0f);
  add_square(both, 0.05f, 0.5f);
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  o.wireframe = true;
  o.wire_width = 2.0f;
  EXPECT_EQ(render_mesh(both, front_camera(), o).pixels, render_mesh(front_only, front_camera(), o).pixels);
}

TEST(RenderWireframe, EdgesOnASurfaceSeenAtAGrazingAngleShow) {
  // Ground seen from 0.3 above it: the depth across a 3-pixel line changes by several percent per pixel,
  // so the slope term of the line depth test must keep these visible edges whole.
  TriMesh ground = jiggled_grid(8, 1.0f);
  for (auto& p : ground.positions) p = {p.x, 2.5f + 2.0f * p.z, -0.3f};
  Camera cam = front_camera();
  cam.eye = {0.0f, 0.0f, 0.0f};
  cam.target = {0.0f, 1.0f, -0.15f};
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  o.wireframe = true;
  o.wire_width = 3.0f;
  const Image im = render_mesh(ground, cam, o);
  int checked = 0, dark = 0;
  for (std::size_t f = 0; f < ground.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const glm::dvec2 a = project(cam, ground.positions[ground.corner(f, k)]);
      const glm::dvec2 b = project(cam, ground.positions[ground.corner(f, (k + 1) % 3)]);
      const glm::dvec2 mid = 0.5 * (a + b);
      const int x = static_cast<int>(std::floor(mid.x)), y = static_cast<int>(std::floor(mid.y));
      if (x < 2 || y < 2 || x >= kW - 2 || y >= kH - 2) continue;
      const bool x_major = std::abs(b.x - a.x) >= std::abs(b.y - a.y);
      for (int d = -1; d <= 1; ++d) {  // the span across the line
        ++checked;
        dark += pixel(im, x_major ? x : x + d, x_major ? y + d : y).sum() < 3 * 30 ? 1 : 0;
      }
    }
  EXPECT_GT(checked, 300);
  EXPECT_GE(dark, checked * 95 / 100);
}

TEST(RenderOverlay, SegmentsShowOverBackgroundAndHideBehindTheSurface) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  RenderOptions o = black_background();
  const Camera cam = front_camera();
  const Image plain = render_mesh(m, cam, o);
  auto red_pixels = [](const Image& im) {
    int n = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const Rgb p = pixel(im, x, y);
        n += (p.r > 150 && p.g < 60 && p.b < 60) ? 1 : 0;
      }
    return n;
  };
  const Segment3 above{{-1.0f, 0.0f, 1.5f}, {1.0f, 0.0f, 1.5f}};   // over the background
  const Segment3 behind{{-0.5f, 1.0f, 0.0f}, {0.5f, 1.0f, 0.2f}};  // hidden by the square
  const Segment3 in_front{{-0.5f, -1.0f, 0.0f}, {0.5f, -1.0f, -0.2f}};
  const double side = project(cam, {1.0f, 0.0f, 0.0f}).x - project(cam, {-1.0f, 0.0f, 0.0f}).x;
  EXPECT_NEAR(red_pixels(render_mesh(m, cam, o, {above})), side, 3.0);
  EXPECT_EQ(render_mesh(m, cam, o, {behind}).pixels, plain.pixels);
  EXPECT_GT(red_pixels(render_mesh(m, cam, o, {in_front})), 30);
}

TEST(RenderColors, HeightRampVertexAndFaceColours) {
  TriMesh m;
  add_square(m, 0.0f, 1.0f);
  RenderOptions o = black_background();
  o.height_ramp = true;
  const Camera cam = front_camera();
  const Image ramp = render_mesh(m, cam, o);
  const glm::dvec2 top = project(cam, {0.0f, 0.0f, 0.97f}), bottom = project(cam, {0.0f, 0.0f, -0.97f});
  const Rgb low = pixel(ramp, static_cast<int>(bottom.x), static_cast<int>(bottom.y));
  const Rgb high = pixel(ramp, static_cast<int>(top.x), static_cast<int>(top.y));
  EXPECT_GT(low.g, low.r);  // green lowlands
  EXPECT_GT(low.g, low.b);
  EXPECT_GT(std::min({high.r, high.g, high.b}), 200);  // white peaks

  o.height_ramp = false;
  m.colors.assign(m.positions.size(), glm::vec3(1.0f, 0.1f, 0.1f));
  const Rgb vc = pixel(render_mesh(m, cam, o), kW / 2, kH / 2);
  EXPECT_GT(vc.r, 3 * vc.g);
  EXPECT_GT(vc.r, 3 * vc.b);

  const std::vector<glm::vec3> blue(2, glm::vec3(0.1f, 0.1f, 1.0f));
  o.face_colors = &blue;  // overrides vertex colours
  const Rgb fc = pixel(render_mesh(m, cam, o), kW / 2, kH / 2);
  EXPECT_GT(fc.b, 3 * fc.r);
  EXPECT_GT(fc.b, 3 * fc.g);
}

TEST(RenderSupersample, TwoByTwoBlendsEdgePixelsOnly) {
  TriMesh m;
  add_triangle(m, {-1.0f, 0.0f, -0.8f}, {1.2f, 0.0f, -0.5f}, {0.1f, 0.0f, 1.0f});
  RenderOptions o = black_background();
  o.smooth = false;  // one colour inside the triangle
  auto count_levels = [](const Image& im, int fill) {
    int between = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const int v = pixel(im, x, y).r;
        between += (v > 0 && v < fill) ? 1 : 0;
      }
    return between;
  };
  const Image one = render_mesh(m, front_camera(), o);
  const int fill = pixel(one, kW / 2, kH / 2).r;
  ASSERT_GT(fill, 100);
  EXPECT_EQ(count_levels(one, fill), 0);
  o.supersample = 2;
  const Image two = render_mesh(m, front_camera(), o);
  EXPECT_GT(count_levels(two, fill), 50);
  EXPECT_EQ(pixel(two, kW / 2, kH / 2).r, fill);
}

TEST(RenderCamera, DefaultCameraFramesTheMeshFromAbove) {
  // A terrain-like flat grid and a tall box.
  TriMesh terrain;
  for (int j = 0; j <= 20; ++j)
    for (int i = 0; i <= 20; ++i)
      terrain.positions.push_back({static_cast<float>(i), static_cast<float>(j),
                                   0.5f * std::sin(0.7f * static_cast<float>(i)) * std::cos(0.5f * static_cast<float>(j))});
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 20; ++i) {
      const auto a = static_cast<Index>(j * 21 + i);
      terrain.indices.insert(terrain.indices.end(), {a, a + 1, a + 22, a, a + 22, a + 21});
    }
  const TriMesh tall = uv_sphere({1.0f, 2.0f, 3.0f}, 1.0f, 8, 16);

  for (const TriMesh* mesh : {static_cast<const TriMesh*>(&terrain), &tall}) {
    const float aspect = 16.0f / 9.0f;
    const Camera cam = default_camera_for(*mesh, aspect);
    const glm::vec3 to_eye = cam.eye - cam.target;
    const float elevation = glm::degrees(std::asin(to_eye.z / glm::length(to_eye)));
    if (mesh == &terrain) {
      EXPECT_GE(elevation, 35.0f);
      EXPECT_LE(elevation, 45.0f);
    } else {
      EXPECT_GE(elevation, 15.0f);
      EXPECT_LE(elevation, 35.0f);
    }
    EXPECT_EQ(cam.up, glm::vec3(0.0f, 0.0f, 1.0f));
    Camera c = cam;
    c.aspect = aspect;
    const glm::mat4 mvp = c.projection() * c.view();
    for (const auto& p : mesh->positions) {
      const glm::vec4 q = mvp * glm::vec4(p, 1.0f);
      ASSERT_GT(q.w, 0.0f);
      EXPECT_LE(std::abs(q.x / q.w), 1.0f);
      EXPECT_LE(std::abs(q.y / q.w), 1.0f);
      EXPECT_LE(std::abs(q.z / q.w), 1.0f);
    }
  }
  EXPECT_NO_THROW(default_camera_for(TriMesh{}, 1.0f));
  EXPECT_THROW(default_camera_for(terrain, 0.0f), InvalidInput);
}

// The picture of a model does not depend on its units: the same sphere scaled by 1e-30 ... 1e15 and moved
// far from the origin, framed by default_camera_for and by picture_camera_for, covers the same pixels (to
// a few along the silhouette, from float rounding). At 1e-20 the face side test used to underflow and the
// picture came out blank.
TEST(RenderCamera, PicturesDoNotDependOnTheModelsScale) {
  const TriMesh unit = uv_sphere({0.0f, 0.0f, 0.0f}, 1.0f, 12, 24);
  for (const bool picture_camera : {false, true}) {
    std::size_t reference = 0;
    for (const double scale : {1.0, 1e-30, 1e-20, 1e-12, 1e-5, 1e5, 1e15}) {
      SCOPED_TRACE(std::to_string(scale) + (picture_camera ? " picture camera" : " default camera"));
      TriMesh m = unit;
      for (glm::vec3& p : m.positions) p = glm::vec3((glm::dvec3(p) + glm::dvec3(3.0, -2.0, 1.0)) * scale);
      const Camera cam = picture_camera ? picture_camera_for(m, {0, 0, 1}, {1, -2, 1}, float(kW) / float(kH))
                                        : default_camera_for(m, float(kW) / float(kH));
      const std::size_t covered = count_non_black(render_mesh(m, cam, black_background()));
      if (scale == 1.0) {
        reference = covered;
        EXPECT_GT(covered, std::size_t{kW * kH / 20});
      } else {
        EXPECT_NEAR(static_cast<double>(covered), static_cast<double>(reference), 0.01 * static_cast<double>(reference));
      }
    }
  }
}

TEST(RenderRealMesh, BunnyRendersAndWritesAPng) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bunny_npm_1839v.obj");
  const TriMesh bunny = read_mesh(path);
  RenderOptions o;
  o.width = 320;
  o.height = 240;
  o.wireframe = true;
  const Image im = render_mesh(bunny, default_camera_for(bunny, 320.0f / 240.0f), o);
  std::size_t covered = 0;
  for (std::size_t i = 0; i < im.pixels.size(); i += 3)
    covered += (im.pixels[i] != 255 || im.pixels[i + 1] != 255 || im.pixels[i + 2] != 255) ? 1 : 0;
  EXPECT_GT(covered, im.width * im.height / 20);
  EXPECT_LT(covered, im.width * im.height * 9 / 10);
  const auto file = testing::scratch_dir("RenderRealMesh") / "bunny.png";
  write_png(file.string(), im);
  EXPECT_GT(std::filesystem::file_size(file), 1000u);
}

}  // namespace
}  // namespace varmesh
