#pragma once
/// A small deterministic software rasterizer: what `varmesh render` and the demo use to write pictures.
///
/// Flat or smooth (Gouraud) Lambert shading with a head light, z-buffered, optional wireframe overlay,
/// per-vertex colours when the mesh has them, optional per-face colours, optional extra line segments
/// (e.g. a frustum outline). Output depends only on the inputs (no threads, no time, no randomness).
///
/// Conventions: row 0 of the image is the top; the camera's `up` points up in the picture and +x of the
/// view is to the right (not mirrored). Triangles are clipped in homogeneous space against the near and
/// far planes (and a guard band around the viewport), so a camera inside or under a mesh is fine. Pixels
/// are sampled at their centres with the top-left fill rule on 1/256-pixel fixed-point vertices, so
/// triangles sharing an edge leave no cracks and cover no pixel twice. Depth is 1/w (perspective-correct
/// colours). Front faces are counter-clockwise as seen from the eye.
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/camera.hpp"
#include "multitri/image.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh {

/// Colour priority per face: face_colors, then height_ramp, then mesh.colors, then base_color. The colour
/// is multiplied by ambient + diffuse * |n . l| with l pointing to the eye (smooth: from each vertex; flat:
/// the view direction, one for the picture, so coplanar faces get one shade); back faces are darker.
struct RenderOptions {
  int width = 800;   ///< pixels, 1..16384
  int height = 600;  ///< pixels, 1..16384
  bool wireframe = false;  ///< draw the edges of the drawn faces where they are visible
  glm::vec3 wire_color{0.05f, 0.05f, 0.05f};
  float wire_width = 1.0f;  ///< in pixels, rounded, clamped to 1..256; also the width of overlay segments
  bool smooth = true;                  ///< Gouraud shading with vertex normals; flat otherwise
  glm::vec3 base_color{0.80f, 0.78f, 0.72f};
  glm::vec3 background{1.0f, 1.0f, 1.0f};
  bool two_sided = true;               ///< shade back faces (with a darker tint) instead of culling them
  const std::vector<glm::vec3>* face_colors = nullptr;  ///< optional, one per face, overrides vertex colours
  /// Optional colour by height: when true, base colour follows a terrain ramp of z between bounds
  /// (green lowlands, brown slopes, white peaks); overrides mesh.colors.
  bool height_ramp = false;
  /// Samples per pixel along each axis: 1, or 2 for 2x2 supersampling (the average of four samples; slower,
  /// smoother edges). Other values throw InvalidInput.
  int supersample = 1;
};

/// A line segment drawn on top of the shaded image (depth-tested against the surface with a small bias).
struct Segment3 {
  glm::vec3 a, b;
  glm::vec3 color{0.9f, 0.1f, 0.1f};
};

/// Renders `mesh` seen by `camera` (camera.aspect is overridden by width/height) into an RGB 8-bit image
/// (channels 3, bit_depth 8). Overlay segments are drawn last, also over the background, hidden where
/// the surface is in front of them. Time O(faces + pixels covered); memory about 20 bytes per sample.
/// Throws InvalidInput on non-positive or absurd (> 16384) sizes, a bad `supersample`, face_colors whose
/// size is not mesh.num_faces(), a degenerate camera (fov outside (0, 180), z_near <= 0, z_far <= z_near,
/// eye == target, up parallel to the view direction, non-finite values) or if mesh.validate() fails.
Image render_mesh(const TriMesh& mesh, const Camera& camera, const RenderOptions& options,
                  const std::vector<Segment3>& overlay = {});

/// The number of pixels of an 8-bit RGB picture of render_mesh() that differ from `background` (as
/// render_mesh() writes it): 0 when the camera saw nothing of the mesh.
std::size_t pixels_unlike(const Image& picture, const glm::vec3& background);

/// A camera that frames the mesh's bounding sphere from a pleasant 3/4 view above (z up): the eye is in
/// front (-y) and to the right (+x) of the centre, 25 degrees above the horizon, or 40 degrees when the
/// mesh is nearly flat in z (a terrain). An empty mesh gives a camera framing the unit sphere.
/// Throws InvalidInput when `aspect` is not a positive finite number.
Camera default_camera_for(const TriMesh& mesh, float aspect);

/// A camera for pictures of the referenced vertices of `reference`: it looks from the direction `view`
/// (towards the eye; zero: the 3/4 view from above, 25 degrees up and 60 degrees round, about `up`), keeps
/// `up` up, centres what it sees and stands as close as it can with every referenced vertex inside 92 % of
/// the frame. Falls back to default_camera_for when no vertex is referenced. Throws InvalidInput naming
/// `--up` when `up` is zero, and as frame_sphere.
Camera picture_camera_for(const TriMesh& reference, const glm::vec3& up, const glm::vec3& view, float aspect);

}  // namespace varmesh
