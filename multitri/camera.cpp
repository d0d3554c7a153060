#include "multitri/camera.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "multitri/errors.hpp"

namespace varmesh {

namespace {
// lookAt needs an up vector that is not parallel to the view direction (else every plane of the frustum is
// NaN and culling silently stops); a top view of a terrain with the default +z up is the common case. Fall
// back to the world axis least aligned with the view (y first). The test runs on `up` scaled so that its
// largest component is 1: glm::length of an up near 1e20 overflows float (and near 1e-20 underflows), which
// made the test fail and replaced a perfectly usable up by an axis. Such an up is returned scaled (lookAt
// would overflow on it too); any other is returned as it is. `forward` is a unit vector.
glm::vec3 usable_up(const glm::vec3& forward, const glm::vec3& up) {
  const float m = std::max({std::abs(up.x), std::abs(up.y), std::abs(up.z)});
  if (m > 0.0f && std::isfinite(m)) {
    const glm::vec3 u = up / m;
    if (glm::length(glm::cross(forward, u)) > 1e-3f * glm::length(u)) return m > 1e-12f && m < 1e12f ? up : u;
  }
  const glm::vec3 a = glm::abs(forward);
  return a.y <= a.x && a.y <= a.z ? glm::vec3(0.0f, 1.0f, 0.0f)
         : a.x <= a.z             ? glm::vec3(1.0f, 0.0f, 0.0f)
                                  : glm::vec3(0.0f, 0.0f, 1.0f);
}

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// The unit view direction, computed in double: in float, target - eye beyond about 1e19 overflows the
// squared length and below about 1e-19 underflows it, and the direction comes out NaN.
glm::vec3 unit_direction(const glm::vec3& eye, const glm::vec3& target) {
  const glm::dvec3 d = glm::dvec3(target) - glm::dvec3(eye);
  const double len = glm::length(d);
  return len > 0.0 ? glm::vec3(d / len) : glm::vec3(0.0f);
}
}  // namespace

void Camera::validate() const {
  auto finite3 = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!finite3(eye) || !finite3(target) || !finite3(up)) throw InvalidInput("camera: eye, target and up must be finite");
  if (eye == target) throw InvalidInput("camera: eye and target are the same point (no view direction)");
  if (up == glm::vec3(0.0f)) throw InvalidInput("camera: up is zero");
  if (!(fov_y_deg > 0.0f && fov_y_deg < 180.0f))
    throw InvalidInput("camera: fov_y_deg " + std::to_string(fov_y_deg) + " is not in (0, 180)");
  if (!(aspect > 0.0f) || !std::isfinite(aspect)) throw InvalidInput("camera: aspect " + std::to_string(aspect) + " is not positive");
  if (!(z_near > 0.0f) || !(z_near < z_far) || !std::isfinite(z_far))
    throw InvalidInput("camera: z_near " + std::to_string(z_near) + " and z_far " + std::to_string(z_far) +
                       " must satisfy 0 < z_near < z_far (finite)");
}

void Frustum::validate() const {
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const Plane& p = planes[i];
    if (!std::isfinite(p.n.x) || !std::isfinite(p.n.y) || !std::isfinite(p.n.z) || !std::isfinite(p.d))
      throw InvalidInput("frustum: plane " + std::to_string(i) + " is not finite", i);
    if (p.n == glm::vec3(0.0f)) throw InvalidInput("frustum: plane " + std::to_string(i) + " has a zero normal", i);
  }
}

glm::vec3 Camera::view_up() const {
  const glm::vec3 f = unit_direction(eye, target);
  return f == glm::vec3(0.0f) ? up : usable_up(f, up);
}

// Both check the camera: they are called once per frame or per picture (Grid48Front::update_view, the
// renderer), where validate() costs nothing next to the work that follows.
glm::mat4 Camera::view() const {
  validate();
  const glm::mat4 m = glm::lookAt(eye, target, view_up());
  if (!finite(m))
    throw InvalidInput("camera: the view matrix overflows float (eye at distance " +
                       std::to_string(glm::length(glm::dvec3(eye))) + " from the origin, " +
                       std::to_string(glm::length(glm::dvec3(target) - glm::dvec3(eye))) +
                       " from the target); move the scene nearer to the origin or use frustum(), which works in double");
  return m;
}

glm::mat4 Camera::projection() const {
  validate();
  const glm::mat4 m = glm::perspective(glm::radians(fov_y_deg), aspect, z_near, z_far);
  if (!finite(m))
    throw InvalidInput("camera: the projection matrix overflows float (aspect " + std::to_string(aspect) + ", z_near " +
                       std::to_string(z_near) + ", z_far " + std::to_string(z_far) + ")");
  return m;
}

glm::vec3 Camera::forward() const { return glm::normalize(target - eye); }

float Camera::pixels_per_unit_at_distance_one(float viewport_height) const {
  return viewport_height / (2.0f * std::tan(glm::radians(fov_y_deg) * 0.5f));
}

Frustum Camera::frustum() const {
  validate();
  // Gribb-Hartmann extraction from the clip matrix: each plane is a sum or difference of matrix rows. In
  // double: with z_far / z_near near 1e8 the far plane's rows cancel in float (a NaN plane culls nothing).
  const glm::dmat4 m = glm::perspective(glm::radians(double(fov_y_deg)), double(aspect), double(z_near), double(z_far)) *
                       glm::lookAt(glm::dvec3(eye), glm::dvec3(target), glm::dvec3(view_up()));
  auto row = [&](int i) { return glm::dvec4(m[0][i], m[1][i], m[2][i], m[3][i]); };
  const glm::dvec4 r0 = row(0), r1 = row(1), r2 = row(2), r3 = row(3);
  const glm::dvec4 raw[6] = {r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 + r2, r3 - r2};
  Frustum f;
  for (int i = 0; i < 6; ++i) {
    const glm::dvec3 n(raw[i]);
    const double len = glm::length(n);
    f.planes[static_cast<std::size_t>(i)] = Plane{glm::vec3(n / len), static_cast<float>(raw[i].w / len)};
  }
  f.validate();  // a valid camera far beyond float range can still overflow an offset
  return f;
}

Camera frame_sphere(const glm::vec3& center, float radius, const glm::vec3& dir, float fov_y_deg, float aspect,
                    const glm::vec3& up) {
  // The direction's length in double: in float, |dir|^2 overflows past ~1.8e19 and underflows below
  // ~1e-19, and a finite non-zero direction such as (3e19, 0, 0) was refused as zero.
  const glm::dvec3 ddir(dir);
  const double dir_len = glm::length(ddir);
  if (!(radius > 0.0f) || !std::isfinite(radius))
    throw InvalidInput("frame_sphere: radius " + std::to_string(radius) + " is not a positive number");
  if (!(dir_len > 0.0) || !std::isfinite(dir_len) || !std::isfinite(center.x) || !std::isfinite(center.y) ||
      !std::isfinite(center.z))
    throw InvalidInput("frame_sphere: the centre is not finite or the view direction is zero");
  if (!(fov_y_deg > 0.0f && fov_y_deg < 180.0f) || !(aspect > 0.0f) || !std::isfinite(aspect))
    throw InvalidInput("frame_sphere: fov_y_deg must be in (0, 180) and aspect > 0");
  Camera cam;
  cam.fov_y_deg = fov_y_deg;
  cam.aspect = aspect;
  const float half = glm::radians(fov_y_deg) * 0.5f * std::min(1.0f, aspect);
  const float dist = radius / std::sin(half);
  const glm::vec3 forward(ddir / dir_len);
  cam.target = center;
  cam.eye = center - forward * dist;
  cam.up = usable_up(forward, up);
  cam.z_near = std::max(dist - radius * 1.5f, dist * 1e-3f);
  cam.z_far = dist + radius * 1.5f;
  return cam;
}

}  // namespace varmesh
