#pragma once
/// A small deterministic software rasterizer: what `varmesh render` and the demo use to write pictures.
///
/// Flat or smooth (Gouraud) Lambert shading with a head light, z-buffered, optional wireframe overlay,
/// per-vertex colours when the mesh has them, optional per-face colours, optional extra line segments
/// (e.g. a frustum outline). Output depends only on the inputs (no threads, no time, no randomness).
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/camera.hpp"
#include "multitri/image.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh {

struct RenderOptions {
  int width = 800;
  int height = 600;
  bool wireframe = false;
  glm::vec3 wire_color{0.05f, 0.05f, 0.05f};
  float wire_width = 1.0f;             ///< in pixels
  bool smooth = true;                  ///< Gouraud shading with vertex normals; flat otherwise
  glm::vec3 base_color{0.80f, 0.78f, 0.72f};
  glm::vec3 background{1.0f, 1.0f, 1.0f};
  bool two_sided = true;               ///< shade back faces (with a darker tint) instead of culling them
  const std::vector<glm::vec3>* face_colors = nullptr;  ///< optional, one per face, overrides vertex colours
  /// Optional colour by height: when true, base colour follows a terrain ramp of z between bounds.
  bool height_ramp = false;
};

/// A line segment drawn on top of the shaded image (depth-tested against the surface with a small bias).
struct Segment3 {
  glm::vec3 a, b;
  glm::vec3 color{0.9f, 0.1f, 0.1f};
};

/// Renders `mesh` seen by `camera` (camera.aspect is overridden by width/height). Throws InvalidInput
/// on non-positive or absurd (> 16384) sizes or if mesh.validate() fails.
Image render_mesh(const TriMesh& mesh, const Camera& camera, const RenderOptions& options,
                  const std::vector<Segment3>& overlay = {});

/// A camera that frames the mesh's bounding sphere from a pleasant 3/4 view above (z up).
Camera default_camera_for(const TriMesh& mesh, float aspect);

}  // namespace varmesh
