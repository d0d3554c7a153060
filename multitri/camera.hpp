#pragma once
/// Perspective cameras and view frusta, shared by the query criteria and the renderer.
#include <array>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace varmesh {

/// A plane n.x + d = 0 with unit normal n pointing to the inside (kept) half-space.
struct Plane {
  glm::vec3 n{0.0f, 0.0f, 1.0f};
  float d = 0.0f;
  float signed_distance(const glm::vec3& p) const noexcept { return n.x * p.x + n.y * p.y + n.z * p.z + d; }
};

/// Six inward planes: left, right, bottom, top, near, far.
struct Frustum {
  std::array<Plane, 6> planes{};
  /// True when the sphere is not entirely outside any plane (conservative: may say true for a sphere just
  /// outside a frustum corner). Branch-free over the six planes: the query criteria call it for every
  /// candidate of every frame, and an early exit mispredicts about as often as it saves.
  bool intersects_sphere(const glm::vec3& c, float r) const noexcept {
    bool in = true;
    for (const auto& p : planes) in &= !(p.signed_distance(c) < -r);
    return in;
  }
  bool contains_point(const glm::vec3& p) const noexcept { return intersects_sphere(p, 0.0f); }
  /// Throws InvalidInput naming the plane (0..5) when a plane's normal or offset is not finite or its normal
  /// is zero. Such a plane never excludes anything (every comparison with NaN is false), so a frustum from
  /// a broken camera would silently mean "everywhere". Criterion::outside_frustum, the frusta of a focus set
  /// (FocusSet::validate) and intersect_region call it.
  void validate() const;
};

/// A perspective camera. Angles in degrees; `aspect` = width / height.
struct Camera {
  glm::vec3 eye{0.0f, -3.0f, 2.0f};
  glm::vec3 target{0.0f, 0.0f, 0.0f};
  glm::vec3 up{0.0f, 0.0f, 1.0f};
  float fov_y_deg = 45.0f;
  float aspect = 4.0f / 3.0f;
  float z_near = 0.01f;
  float z_far = 1000.0f;

  /// Throws InvalidInput (naming the field) unless every field is finite, eye != target, up != 0,
  /// fov_y_deg is in (0, 180), aspect > 0 and 0 < z_near < z_far. A camera that fails it makes NaN or
  /// inverted planes, which cull nothing or everything without a word. An `up` parallel to the view
  /// direction is not an error: view_up() replaces it.
  void validate() const;
  /// lookAt(eye, target, view_up()): world to eye coordinates, looking down -z. Calls validate() first
  /// (it is called once per frame or picture, where that costs nothing). Throws InvalidInput when the camera
  /// fails validate(), or when the matrix is not finite in float: eye and target more than about 1e19 apart
  /// or closer than about 1e-19, or the eye near float's limit (frustum(), computed in double, still works
  /// for those).
  glm::mat4 view() const;
  /// The up vector view() and frustum() use: `up`, except that an `up` parallel to the view direction (a top
  /// view with the default +z up) is replaced by the world axis least aligned with the view (+y first), as
  /// frame_sphere does, and an `up` too long or too short for float arithmetic (largest component beyond
  /// 1e12 or below 1e-12) is scaled to a largest component of 1. Does not check the camera; on eye == target
  /// it returns `up`.
  glm::vec3 view_up() const;
  /// glm::perspective(fov_y_deg, aspect, z_near, z_far): eye to clip coordinates (OpenGL conventions, depth
  /// in [-1, 1]). Calls validate() first; throws InvalidInput when the camera fails it, or when the matrix
  /// is not finite in float (an aspect or a z range at the edge of float's range).
  glm::mat4 projection() const;
  /// The view frustum of projection() * view(), computed in double. Calls validate() first (throws
  /// InvalidInput). view_up(), forward() and pixels_per_unit_at_distance_one() do not check: on a camera
  /// that fails validate() they return NaN or meaningless values.
  Frustum frustum() const;
  /// Pixels per unit of world length seen at distance 1 on a viewport `viewport_height` pixels high.
  float pixels_per_unit_at_distance_one(float viewport_height) const;
  /// Unit vector from eye to target.
  glm::vec3 forward() const;
};

/// Frames a bounding sphere: camera looking at `center` from direction `dir` (need not be unit) so that
/// the sphere fills the view; z_near/z_far set around it. When `up` is parallel to `dir` (a top view with
/// the default +z up) the world axis least aligned with `dir` is used instead (+y first). Throws
/// InvalidInput when radius <= 0, dir is zero, fov_y_deg is not in (0, 180) or aspect <= 0 (or any is not
/// finite).
Camera frame_sphere(const glm::vec3& center, float radius, const glm::vec3& dir, float fov_y_deg, float aspect,
                    const glm::vec3& up = {0.0f, 0.0f, 1.0f});

}  // namespace varmesh
