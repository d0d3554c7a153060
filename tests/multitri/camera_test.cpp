// Cameras and frusta: the frustum planes agree with the projection (a point is inside the planes iff its
// clip coordinates lie in [-w, w]), frame_sphere keeps the sphere in view and fills it, pixel scale.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "multitri/camera.hpp"
#include "multitri/errors.hpp"

namespace varmesh {
namespace {

float uniform(std::mt19937& rng, float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(rng); }

glm::vec3 random_unit(std::mt19937& rng) {
  for (;;) {
    const glm::vec3 v(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
    const float l = glm::length(v);
    if (l > 0.1f && l <= 1.0f) return v / l;
  }
}

Camera random_camera(std::mt19937& rng) {
  Camera c;
  c.eye = {uniform(rng, -5, 5), uniform(rng, -5, 5), uniform(rng, -5, 5)};
  do {
    c.target = c.eye + random_unit(rng) * uniform(rng, 0.5f, 5.0f);
    c.up = random_unit(rng);
  } while (glm::length(glm::cross(glm::normalize(c.target - c.eye), c.up)) < 0.2f);
  c.fov_y_deg = uniform(rng, 20.0f, 100.0f);
  c.aspect = uniform(rng, 0.4f, 2.5f);
  c.z_near = uniform(rng, 0.05f, 1.0f);
  c.z_far = c.z_near + uniform(rng, 1.0f, 20.0f);
  return c;
}

TEST(Camera, FrustumPlanesContainWhatTheProjectionShows) {
  std::mt19937 rng(1);
  int inside = 0, outside = 0;
  for (int cam_i = 0; cam_i < 60; ++cam_i) {
    const Camera cam = random_camera(rng);
    const glm::mat4 clip_from_world = cam.projection() * cam.view();
    const Frustum fr = cam.frustum();
    for (const Plane& p : fr.planes) EXPECT_NEAR(glm::length(p.n), 1.0f, 1e-5f);
    // The middle of the view volume is inside every plane.
    const glm::vec3 mid = cam.eye + cam.forward() * (0.5f * (cam.z_near + cam.z_far));
    for (const Plane& p : fr.planes) EXPECT_GT(p.signed_distance(mid), 0.0f);
    for (int k = 0; k < 500; ++k) {
      // Points around the camera, half of them near the view direction.
      glm::vec3 p = cam.eye + random_unit(rng) * uniform(rng, 0.0f, cam.z_far * 1.2f);
      if (k % 2) p = cam.eye + glm::normalize(cam.forward() + 0.6f * random_unit(rng)) * uniform(rng, 0.0f, cam.z_far * 1.2f);
      const glm::vec4 c = clip_from_world * glm::vec4(p, 1.0f);
      const float slack = std::min({c.w - std::abs(c.x), c.w - std::abs(c.y), c.w - std::abs(c.z)});
      if (std::abs(slack) < 1e-3f * std::max(1.0f, std::abs(c.w))) continue;  // on a boundary: either answer
      const bool shown = slack > 0.0f;
      EXPECT_EQ(fr.contains_point(p), shown) << "camera " << cam_i << " point " << k;
      (shown ? inside : outside)++;
    }
  }
  EXPECT_GT(inside, 3000);
  EXPECT_GT(outside, 3000);
}

TEST(Camera, FrustumCornersAreOnThePlanes) {
  std::mt19937 rng(2);
  for (int cam_i = 0; cam_i < 20; ++cam_i) {
    const Camera cam = random_camera(rng);
    const glm::mat4 world_from_clip = glm::inverse(cam.projection() * cam.view());
    const Frustum fr = cam.frustum();
    auto unproject = [&](float x, float y, float z) {
      const glm::vec4 h = world_from_clip * glm::vec4(x, y, z, 1.0f);
      return glm::vec3(h) / h.w;
    };
    for (float x : {-1.0f, 1.0f})
      for (float y : {-1.0f, 1.0f})
        for (float z : {-1.0f, 1.0f}) {
          EXPECT_TRUE(fr.contains_point(unproject(0.98f * x, 0.98f * y, 0.98f * z)));
          EXPECT_FALSE(fr.contains_point(unproject(1.02f * x, 0.98f * y, 0.98f * z)));
          EXPECT_FALSE(fr.contains_point(unproject(0.98f * x, 1.02f * y, 0.98f * z)));
          EXPECT_FALSE(fr.contains_point(unproject(0.98f * x, 0.98f * y, 1.02f * z)));
        }
    // A sphere just touching a side plane from outside intersects; moved away by more than its radius it
    // does not.
    const Plane& left = fr.planes[0];
    const glm::vec3 on = unproject(-1.0f, 0.0f, 0.0f);
    EXPECT_TRUE(fr.intersects_sphere(on - left.n * 0.5f, 0.51f));
    EXPECT_FALSE(fr.intersects_sphere(on - left.n * 0.5f, 0.49f));
  }
}

void expect_sphere_framed(const Camera& cam, const glm::vec3& center, float radius, std::mt19937& rng) {
  ASSERT_TRUE(std::isfinite(cam.eye.x) && std::isfinite(cam.eye.y) && std::isfinite(cam.eye.z));
  const glm::mat4 clip_from_world = cam.projection() * cam.view();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) ASSERT_TRUE(std::isfinite(clip_from_world[i][j])) << "camera matrix is not finite";
  const Frustum fr = cam.frustum();
  EXPECT_TRUE(fr.intersects_sphere(center, radius));
  for (const Plane& p : fr.planes) EXPECT_GE(p.signed_distance(center), radius * (1.0f - 1e-3f));
  float extent_x = 0.0f, extent_y = 0.0f;
  for (int k = 0; k < 300; ++k) {
    const glm::vec3 p = center + random_unit(rng) * radius;
    const glm::vec4 c = clip_from_world * glm::vec4(p, 1.0f);
    ASSERT_GT(c.w, 0.0f);
    EXPECT_LE(std::abs(c.x), c.w * 1.0001f);
    EXPECT_LE(std::abs(c.y), c.w * 1.0001f);
    EXPECT_LE(std::abs(c.z), c.w * 1.0001f);
    extent_x = std::max(extent_x, std::abs(c.x / c.w));
    extent_y = std::max(extent_y, std::abs(c.y / c.w));
  }
  // The sphere fills the view in its tighter direction.
  EXPECT_GT(std::max(extent_x, extent_y), 0.75f);
}

// A camera looking straight down with the default +z up: lookAt degenerated and every frustum plane was
// NaN, so culling silently stopped (a top view of a terrain kept 20x the triangles). And z_far / z_near
// of 1e8 cancelled the far plane's rows in float.
TEST(Camera, TopViewAndDeepFrustaHaveFinitePlanes) {
  Camera c;
  c.eye = {200, 170, 300};
  c.target = {200, 170, 0};
  c.fov_y_deg = 60;
  c.z_near = 0.1f;
  c.z_far = 1e7f;
  const Frustum f = c.frustum();
  for (const Plane& p : f.planes) {
    EXPECT_TRUE(std::isfinite(p.n.x) && std::isfinite(p.n.y) && std::isfinite(p.n.z) && std::isfinite(p.d));
    EXPECT_NEAR(glm::length(p.n), 1.0f, 1e-5f);
  }
  EXPECT_TRUE(f.contains_point({200, 170, 0}));
  EXPECT_FALSE(f.contains_point({1e6f, 0, 1e6f}));
  EXPECT_FALSE(f.contains_point({200, 170, 400}));  // behind the eye
}

TEST(Camera, FrameSphereKeepsTheSphereInView) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 100; ++trial) {
    const glm::vec3 center(uniform(rng, -100, 100), uniform(rng, -100, 100), uniform(rng, -100, 100));
    // Radii from 1/1000 of the centre's magnitude up: below that float rounding of the eye position alone
    // moves the sphere by a visible fraction of itself.
    const float radius = std::pow(10.0f, uniform(rng, -1.0f, 2.0f));
    glm::vec3 dir = random_unit(rng) * uniform(rng, 0.1f, 10.0f);
    if (glm::length(glm::cross(glm::normalize(dir), glm::vec3(0, 0, 1))) < 0.05f) dir.x += 1.0f;
    const float fov = uniform(rng, 20.0f, 90.0f), aspect = uniform(rng, 0.3f, 3.0f);
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Camera cam = frame_sphere(center, radius, dir, fov, aspect);
    EXPECT_NEAR(glm::dot(cam.forward(), glm::normalize(dir)), 1.0f, 1e-4f);
    expect_sphere_framed(cam, center, radius, rng);
  }
}

TEST(Camera, FrameSphereLookingAlongUp) {
  // Looking straight down on a terrain with the default up (+z): the view must still be well defined.
  std::mt19937 rng(4);
  for (const glm::vec3 dir : {glm::vec3(0, 0, -1), glm::vec3(0, 0, 2), glm::vec3(1e-7f, 0, -1)}) {
    const Camera cam = frame_sphere({1, 2, 3}, 2.0f, dir, 45.0f, 1.5f);
    EXPECT_GT(glm::length(glm::cross(cam.forward(), cam.up)), 0.5f) << "up is parallel to the view direction";
    expect_sphere_framed(cam, {1, 2, 3}, 2.0f, rng);
  }
}

// Any finite non-zero direction frames the sphere, whatever its length: in float, the length of
// (3e19, 0, 0) overflowed and that of (1e-30, 0, 0) underflowed, and both were refused as zero.
TEST(Camera, FrameSphereTakesDirectionsOfAnyLength) {
  std::mt19937 rng(6);
  for (const glm::vec3 dir : {glm::vec3(3e19f, 0, 0), glm::vec3(1e30f, 1e30f, 1e30f), glm::vec3(1e-30f, 0, 0),
                              glm::vec3(0, -1e-40f, 0), glm::vec3(3e38f, -3e38f, 1)}) {
    const Camera cam = frame_sphere({1, 2, 3}, 2.0f, dir, 45.0f, 1.5f);
    EXPECT_NEAR(glm::length(glm::dvec3(cam.forward()) - glm::normalize(glm::dvec3(dir))), 0.0, 1e-5);
    expect_sphere_framed(cam, {1, 2, 3}, 2.0f, rng);
  }
}

TEST(Camera, FrameSphereRejectsBadInput) {
  EXPECT_THROW(frame_sphere({0, 0, 0}, 0.0f, {1, 0, 0}, 45.0f, 1.0f), InvalidInput);
  EXPECT_THROW(frame_sphere({0, 0, 0}, -1.0f, {1, 0, 0}, 45.0f, 1.0f), InvalidInput);
  EXPECT_THROW(frame_sphere({0, 0, 0}, 1.0f, {0, 0, 0}, 45.0f, 1.0f), InvalidInput);
  EXPECT_THROW(frame_sphere({0, 0, 0}, 1.0f, {1, 0, 0}, 0.0f, 1.0f), InvalidInput);
  EXPECT_THROW(frame_sphere({0, 0, 0}, 1.0f, {1, 0, 0}, 45.0f, 0.0f), InvalidInput);
  EXPECT_THROW(frame_sphere({std::nanf(""), 0, 0}, 1.0f, {1, 0, 0}, 45.0f, 1.0f), InvalidInput);
}

TEST(Camera, PixelsPerUnitMatchTheProjection) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    Camera cam;
    cam.eye = {0, 0, 0};
    cam.target = {0, 5, 0};
    cam.up = {0, 0, 1};
    cam.fov_y_deg = uniform(rng, 20.0f, 100.0f);
    cam.aspect = uniform(rng, 0.5f, 2.0f);
    const float height = 480.0f, d = uniform(rng, 1.0f, 50.0f), len = uniform(rng, 0.01f, 0.1f) * d;
    // A vertical segment of length len at distance d, centred on the view axis.
    const glm::mat4 m = cam.projection() * cam.view();
    const glm::vec4 a = m * glm::vec4(0.0f, d, -0.5f * len, 1.0f), b = m * glm::vec4(0.0f, d, 0.5f * len, 1.0f);
    const float pixels = (b.y / b.w - a.y / a.w) * 0.5f * height;
    EXPECT_NEAR(pixels, len / d * cam.pixels_per_unit_at_distance_one(height), 1e-3f * pixels);
  }
}


// Cameras that Camera::validate() refuses, each with what is wrong.
std::vector<std::pair<const char*, Camera>> broken_cameras() {
  std::vector<std::pair<const char*, Camera>> out;
  Camera c;
  c.target = c.eye;
  out.emplace_back("eye == target", c);
  c = Camera{};
  c.eye.x = std::numeric_limits<float>::quiet_NaN();
  out.emplace_back("NaN eye", c);
  c = Camera{};
  c.fov_y_deg = 180.0f;
  out.emplace_back("fov 180", c);
  c.fov_y_deg = 270.0f;
  out.emplace_back("fov 270", c);
  c = Camera{};
  c.aspect = 0.0f;
  out.emplace_back("aspect 0", c);
  c = Camera{};
  c.z_near = 10.0f;
  c.z_far = 1.0f;
  out.emplace_back("z_near > z_far", c);
  c = Camera{};
  c.z_near = 0.0f;
  out.emplace_back("z_near 0", c);
  return out;
}

TEST(Camera, FrustumRefusesAnInvalidCamera) {
  for (const auto& [what, cam] : broken_cameras()) EXPECT_THROW(cam.frustum(), InvalidInput) << what;
  EXPECT_NO_THROW(Camera{}.frustum().validate());
}

// view() and projection() check the camera too: they used to return NaN (eye == target), infinities (fov
// 180, aspect 0) or an inverted depth range (z_near > z_far) without a word.
TEST(Camera, ViewAndProjectionRefuseAnInvalidCamera) {
  for (const auto& [what, cam] : broken_cameras()) {
    EXPECT_THROW(cam.view(), InvalidInput) << what;
    EXPECT_THROW(cam.projection(), InvalidInput) << what;
  }
}

bool all_finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// The rotation part of a view matrix is orthonormal and the target lies on the -z axis at its distance.
void expect_proper_view(const Camera& cam, const char* what) {
  const glm::mat4 v = cam.view();
  ASSERT_TRUE(all_finite(v)) << what;
  const glm::mat3 r(v);
  const glm::mat3 rtr = glm::transpose(r) * r;
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(rtr[c][k], c == k ? 1.0f : 0.0f, 1e-5f) << what;
  const glm::vec4 t = v * glm::vec4(cam.target, 1.0f);
  const float dist = glm::length(cam.target - cam.eye);
  EXPECT_NEAR(t.x, 0.0f, 1e-5f * dist) << what;
  EXPECT_NEAR(t.y, 0.0f, 1e-5f * dist) << what;
  EXPECT_NEAR(t.z, -dist, 1e-5f * dist) << what;
}

// An up parallel to the view direction (either way) is not an error: another axis is used, and the view and
// the frustum agree.
TEST(Camera, UpParallelToTheViewGivesAProperView) {
  for (float sign : {1.0f, -1.0f}) {
    Camera cam;
    cam.eye = {1.0f, 2.0f, 7.0f};
    cam.target = {1.0f, 2.0f, 0.0f};
    cam.up = {0.0f, 0.0f, 3.0f * sign};
    EXPECT_NO_THROW(cam.validate());
    expect_proper_view(cam, sign > 0 ? "up along the view" : "up against the view");
    EXPECT_GT(glm::length(glm::cross(glm::normalize(cam.target - cam.eye), cam.view_up())), 0.5f);
    const Frustum f = cam.frustum();
    const glm::mat4 m = cam.projection() * cam.view();
    // A point in view is inside the frustum, one behind the camera is not: by geometry (the first is 0.22
    // off the axis at depth 6.5, where the default 45-degree view is 2.7 high each way), and the projection
    // agrees.
    for (const auto& [p, in_view] : {std::pair{glm::vec3(1.2f, 2.1f, 0.5f), true}, std::pair{glm::vec3(1.0f, 2.0f, 9.0f), false}}) {
      const glm::vec4 c = m * glm::vec4(p, 1.0f);
      const bool in_clip = std::abs(c.x) <= c.w && std::abs(c.y) <= c.w && std::abs(c.z) <= c.w;
      EXPECT_EQ(f.contains_point(p), in_view);
      EXPECT_EQ(in_clip, in_view);
    }
  }
}

// An up of any length gives the same view as the unit up: glm::length of a 1e30 up overflowed float, and
// one of 1e-30 underflowed, so the parallel test failed and the up was silently replaced by the y axis.
TEST(Camera, UpOfAnyLengthGivesTheSameView) {
  Camera unit;
  unit.eye = {3.0f, -1.0f, 2.5f};  // view direction (-3, 1.5, -2.5): the fallback axis is y, not the up's z
  unit.target = {0.0f, 0.5f, 0.0f};
  unit.up = {0.0f, 0.0f, 1.0f};
  const glm::mat4 expected = unit.view();
  const Frustum expected_f = unit.frustum();
  for (float scale : {1e30f, 1e-30f, 1e-40f}) {
    Camera cam = unit;
    cam.up *= scale;
    const glm::mat4 v = cam.view();
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) EXPECT_NEAR(v[c][r], expected[c][r], 1e-5f) << "up scaled by " << scale;
    const Frustum f = cam.frustum();
    for (std::size_t i = 0; i < 6; ++i) {
      EXPECT_NEAR(glm::length(f.planes[i].n - expected_f.planes[i].n), 0.0f, 1e-5f) << "plane " << i;
      EXPECT_NEAR(f.planes[i].d, expected_f.planes[i].d, 1e-5f) << "plane " << i;
    }
  }
}

// Valid cameras whose float matrices are not finite: view() and projection() throw instead of returning
// NaN or infinity; frustum(), computed in double, still works for the far and near ones.
TEST(Camera, MatricesThatOverflowFloatAreRefused) {
  Camera far;
  far.eye = {0.0f, -1e20f, 0.0f};
  far.z_near = 1e19f;
  far.z_far = 1e21f;
  ASSERT_NO_THROW(far.validate());
  EXPECT_THROW(far.view(), InvalidInput);
  EXPECT_NO_THROW(far.frustum());
  Camera near;
  near.eye = {1e-30f, 0.0f, 0.0f};
  near.target = {0.0f, 0.0f, 0.0f};
  ASSERT_NO_THROW(near.validate());
  EXPECT_THROW(near.view(), InvalidInput);
  EXPECT_NO_THROW(near.frustum());
  Camera thin;
  thin.aspect = 1e-39f;  // positive, but 1 / aspect overflows
  ASSERT_NO_THROW(thin.validate());
  EXPECT_THROW(thin.projection(), InvalidInput);
  // A camera at float's limit.
  Camera edge;
  edge.eye = {3e38f, 3e38f, 3e38f};
  edge.target = edge.eye * 0.5f;
  ASSERT_NO_THROW(edge.validate());
  EXPECT_THROW(edge.view(), InvalidInput);
}

TEST(Frustum, ValidateNamesANonFiniteOrZeroPlane) {
  const Frustum good = Camera{}.frustum();
  for (std::size_t i = 0; i < 6; ++i) {
    Frustum f = good;
    f.planes[i].d = std::numeric_limits<float>::quiet_NaN();
    try {
      f.validate();
      ADD_FAILURE() << "a NaN offset of plane " << i << " was accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.element(), i);
    }
    f = good;
    f.planes[i].n = glm::vec3(0.0f);
    EXPECT_THROW(f.validate(), InvalidInput) << "zero normal, plane " << i;
    f = good;
    f.planes[i].n.y = std::numeric_limits<float>::infinity();
    EXPECT_THROW(f.validate(), InvalidInput) << "infinite normal, plane " << i;
  }
}

}  // namespace
}  // namespace varmesh
