#pragma once
/// Variable-resolution spatial queries (Velho-Gomes 2000, section 9; De Floriani-Puppo level-of-detail
/// operations): point location, ray picking, region intersection and neighbour search, each answered on
/// the mesh that a Query (criterion + focus + budgets, query.hpp) extracts from a variable-resolution
/// structure. Figure 22(e, f) of the paper is pick() at object_error(0): the smallest triangle under the
/// cursor.
///
/// Fronts. Every function is a template over a front type F that models RefinableFront and lists its
/// current faces through `for_each_face_geometry(fn(Index key, const glm::vec3& a, b, c))` (MtFront,
/// Grid48Front, and any later front with the same two members). A face is named by the front's key:
/// MtFront gives Mt face ids (stable), Grid48Front the rank in its walk order (valid until the front moves).
/// Grid48Front lists its triangles unclipped: on grids that are not (2^k S + 1) wide, faces over the padding
/// beyond the grid rectangle are searched too.
///
/// Global vs local (section 9.1). With QueryScope::kGlobal the query is answered as given (the whole mesh
/// is adapted) and then the region is searched. With QueryScope::kLocal the region joins the focus: an
/// element is refined only when its bounding sphere meets both q.focus and the region, so outside the
/// region the mesh stays as coarse as the structure allows (refinements forced by the region excepted).
/// This is implemented by answering q with its criterion replaced by
/// any_of("the sphere misses the region", q.criterion), which keeps the region test exact for every shape
/// (box, frustum, ball, vertical line, ray: no thin boxes or sphere chains stand in for a ray) and keeps
/// the criterion monotone on nested bounds. A face meeting the region can only be removed by an element
/// whose sphere contains the face and so meets the region; hence no face a local query returns is removed
/// by an element q wants, exactly as in the global answer: results are at the resolution the query asks
/// (the two answers may still differ in faces that forced refinements split further).
///
/// Answering. FrontMode::kUpdate (default) moves the existing front with update() (incremental),
/// kExtract rebuilds it with extract() from the coarsest state, kKeep searches the front as it is and
/// ignores q. Either way the front is left in the answered state.
///
/// Cost. Answering costs what update()/extract() cost (query.hpp): in the local scope refinement is
/// confined to the elements whose spheres meet the region, but update() still scans the current faces
/// once for candidates. The search itself is one O(faces) scan of the current mesh (for the local scope,
/// a mesh that is coarse away from the region), plus O(hits log hits) for choosing a face. face_adjacency()
/// is O(faces log faces).
///
/// Robustness. Geometric predicates run in double on the float corners. Ray and point tests accept
/// barycentric coordinates down to -1e-9, so a ray or point on a shared edge or vertex hits every face
/// around it up to rounding, never none of them; locate_point() and pick() then return exactly one face
/// by a rule that depends only on geometry (not on keys or corner order): nearest (depths within a relative
/// 1e-9 count as equal), then smallest area, then lexicographically smallest sorted corners. So the same
/// mesh gives the same face whatever front or numbering holds it. Faces degenerate in the tested
/// projection (zero area, or a ray lying in the face's plane) are never hit.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/camera.hpp"
#include "multitri/query.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// A half-line origin + t * direction, t >= 0. direction need not be unit (t is in units of its length)
/// but must be non-zero and finite.
struct Ray {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};
};

/// A face found by a query, with its corners (in the front's corner order).
struct FaceHit {
  Index key = kInvalid;  ///< the front's face key
  float t = 0.0f;        ///< pick(): ray parameter; faces_within(): distance to the point; otherwise 0
  glm::vec3 point{0.0f}; ///< pick()/locate_point(): the hit point; faces_within(): the face's closest point;
                         ///< intersect_region(): the face's centroid
  glm::vec3 a{0.0f}, b{0.0f}, c{0.0f};
};

enum class QueryScope : std::uint8_t {
  kGlobal,  ///< answer the query as given, then search (globally defined query, section 9.1)
  kLocal,   ///< refine only where the region is (locally defined query)
};

enum class FrontMode : std::uint8_t {
  kUpdate,   ///< update(front, q): move the existing front (incremental)
  kExtract,  ///< extract(front, q): from the coarsest state
  kKeep,     ///< search the current front; q is ignored
};

struct SpatialOptions {
  QueryScope scope = QueryScope::kGlobal;
  FrontMode mode = FrontMode::kUpdate;
  QueryStats* stats = nullptr;  ///< optional: receives the counters of the update()/extract() run
};

/// A front whose current faces can be listed with their corner positions.
template <class F>
concept FaceGeometrySource =
    requires(const F& f, void (*fn)(Index, const glm::vec3&, const glm::vec3&, const glm::vec3&)) {
      f.for_each_face_geometry(fn);
    };

/// A front usable by the spatial queries: refinable (query.hpp) and listing its face geometry.
template <class F>
concept SpatialFront = RefinableFront<F> && FaceGeometrySource<F>;

// ---- geometric predicates (double precision; spatial_query.cpp) ------------------------------------

/// Möller-Trumbore ray/triangle test with the barycentric tolerance described in the file comment.
/// Returns the ray parameter t >= 0 of the hit, or nothing (miss, degenerate face, ray in the face's plane).
std::optional<double> intersect_ray_triangle(const Ray& ray, const glm::vec3& a, const glm::vec3& b,
                                             const glm::vec3& c) noexcept;
/// The height at `xy` of the triangle's plane when the triangle's xy-projection contains xy (same
/// tolerance); nothing when it does not or the projection is degenerate (a vertical face).
std::optional<double> locate_in_xy(const glm::vec2& xy, const glm::vec3& a, const glm::vec3& b,
                                   const glm::vec3& c) noexcept;
/// Exact separating-axis triangle/box overlap (Akenine-Moller 2001: 3 box axes, the face normal and the 9
/// edge-axis cross products). Touching counts as overlapping. False for an empty box.
bool triangle_overlaps_box(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const Box3& box) noexcept;
/// Conservative triangle/frustum test: false only when all three corners are strictly outside one plane.
/// It may answer true for a triangle that passes outside a frustum corner or edge (the usual culling test).
bool triangle_may_meet_frustum(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                               const Frustum& frustum) noexcept;
/// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection 5.1.5).
glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                     const glm::dvec3& c) noexcept;

// ---- neighbour search --------------------------------------------------------------------------------

/// Edge adjacency of the current faces of a front, at the moment it was built.
///
/// Vertices are identified by exact position equality (fronts of one structure share corner positions
/// bit for bit). Face i's edge k joins corners k and k+1 (mod 3); across[3i+k] is the face sharing that
/// edge, or kInvalid when the edge is on the border, is non-manifold (3 or more faces: counted, not
/// linked) or the face is degenerate there. Invariant (validate()): the relation is symmetric and two linked
/// faces share exactly the two corners of the edge.
struct FaceAdjacency {
  std::vector<Index> keys;         ///< front key of face i
  std::vector<glm::vec3> corners;  ///< 3 per face, in the front's corner order
  std::vector<Index> vertices;     ///< 3 per face: welded vertex ids
  std::vector<Index> across;       ///< 3 per face: neighbour face index or kInvalid
  std::vector<Index> by_key;       ///< face indices sorted by key (lookup)
  std::size_t num_vertices = 0;
  std::size_t num_border_edges = 0;
  std::size_t num_nonmanifold_edges = 0;

  /// Builds the adjacency from faces given as keys and 3 corners each. Throws InvalidInput when
  /// corners.size() != 3 * keys.size() or a key repeats (naming it). O(n log n).
  static FaceAdjacency build(std::vector<Index> keys, std::vector<glm::vec3> corners);

  std::size_t num_faces() const noexcept { return keys.size(); }
  /// Face index of `key`, kInvalid when no current face has it. O(log n).
  Index find(Index key) const noexcept;
  /// Keys of the up to 3 faces sharing an edge with face `key`, in edge order. Throws InvalidInput naming
  /// the key when no current face has it.
  std::vector<Index> neighbors(Index key) const;
  /// Throws InvalidInput naming the first face that breaks the invariant above. O(n).
  void validate() const;
};

/// Builds the edge adjacency of the front's current faces. O(faces log faces).
template <FaceGeometrySource F>
FaceAdjacency face_adjacency(const F& front) {
  std::vector<Index> keys;
  std::vector<glm::vec3> corners;
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    keys.push_back(key);
    corners.insert(corners.end(), {a, b, c});
  });
  return FaceAdjacency::build(std::move(keys), std::move(corners));
}

/// The up to 3 faces sharing an edge with face `key` of the current front (keys). Builds the adjacency:
/// O(faces log faces); build face_adjacency() once for many look-ups. Throws InvalidInput for an unknown key.
template <FaceGeometrySource F>
std::vector<Index> neighbors(const F& front, Index key) {
  return face_adjacency(front).neighbors(key);
}

// ---- internals shared by the templates ---------------------------------------------------------------

namespace detail {

using SphereTest = std::function<bool(const ElementBound&)>;

/// q restricted to the elements whose sphere passes `meets` (the local scope, see the file comment).
Query localize(const Query& q, SphereTest meets);

bool sphere_meets_ray(const glm::vec3& c, float r, const Ray& ray) noexcept;
bool sphere_meets_vertical_line(const glm::vec3& c, float r, const glm::vec2& xy) noexcept;

/// Throws InvalidInput when the ray's origin or direction is not finite or the direction is zero.
void check_ray(const Ray& ray);
void check_finite(const glm::vec3& v, const char* what);
/// Throws InvalidInput when r is negative or not finite.
void check_radius(float r, const char* what);

/// A face containing the query point / hit by the ray, at `depth` along the search direction.
struct HitCandidate {
  FaceHit hit;
  double depth = 0.0;
};
/// The single face chosen by the rule in the file comment; `scale` is the magnitude of the depths'
/// inputs (for the relative tolerance). Nothing when there is no candidate.
std::optional<FaceHit> choose_hit(std::span<const HitCandidate> candidates, double scale);

template <SpatialFront F>
void answer(F& front, const Query& q, const SpatialOptions& o, SphereTest meets) {
  QueryStats stats;
  if (o.mode != FrontMode::kKeep) {
    if (o.scope == QueryScope::kLocal) {
      const Query local = localize(q, std::move(meets));
      stats = o.mode == FrontMode::kExtract ? extract(front, local) : update(front, local);
    } else {
      stats = o.mode == FrontMode::kExtract ? extract(front, q) : update(front, q);
    }
  }
  if (o.stats != nullptr) *o.stats = stats;
}

inline glm::vec3 centroid(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) noexcept {
  return (a + b + c) * (1.0f / 3.0f);
}

}  // namespace detail

// ---- point location and picking ----------------------------------------------------------------------

/// Point location in a height-field-like (z-up) structure: answers q, then returns the current face whose
/// xy-projection contains `xy` (the topmost one if several overlap, then the rule of the file comment),
/// with point = (x, y, height of the face there). The local focus is the vertical line through xy.
/// Nothing when no face covers xy. Throws InvalidInput for a non-finite xy.
template <SpatialFront F>
std::optional<FaceHit> locate_point(F& front, const Query& q, glm::vec2 xy, const SpatialOptions& options = {}) {
  detail::check_finite(glm::vec3(xy, 0.0f), "locate_point: the point");
  detail::answer(front, q, options,
                 [xy](const ElementBound& b) { return detail::sphere_meets_vertical_line(b.center, b.radius, xy); });
  std::vector<detail::HitCandidate> found;
  double scale = 0.0;
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    const std::optional<double> z = locate_in_xy(xy, a, b, c);
    if (!z) return;
    FaceHit h{key, 0.0f, glm::vec3(xy, static_cast<float>(*z)), a, b, c};
    found.push_back({h, -*z});  // the topmost face first: depth seen from +z
    scale = std::max({scale, std::abs(*z), double(std::abs(a.z)), double(std::abs(b.z)), double(std::abs(c.z))});
  });
  return detail::choose_hit(found, scale);
}

/// Ray picking: answers q, then returns the current face hit nearest to the ray origin (Möller-Trumbore;
/// on shared edges see the file comment), with t and the hit point. The local focus is the ray itself
/// (every element whose sphere the half-line meets, tested exactly). Nothing when the ray misses the mesh.
/// Throws InvalidInput for a non-finite ray or a zero direction.
template <SpatialFront F>
std::optional<FaceHit> pick(F& front, const Query& q, const Ray& ray, const SpatialOptions& options = {}) {
  detail::check_ray(ray);
  detail::answer(front, q, options,
                 [ray](const ElementBound& b) { return detail::sphere_meets_ray(b.center, b.radius, ray); });
  std::vector<detail::HitCandidate> found;
  double scale = 0.0;
  const glm::dvec3 o(ray.origin), d(ray.direction);
  const double inv_len = 1.0 / glm::length(d);
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    const std::optional<double> t = intersect_ray_triangle(ray, a, b, c);
    if (!t) return;
    const glm::dvec3 p = o + *t * d;
    FaceHit h{key, static_cast<float>(*t), glm::vec3(p), a, b, c};
    found.push_back({h, *t});
    scale = std::max({scale, *t, glm::length(glm::dvec3(a) - o) * inv_len});
  });
  return detail::choose_hit(found, scale);
}

// ---- region intersection -----------------------------------------------------------------------------

/// Answers q, then returns every current face that overlaps the box (exact SAT test, touching included),
/// in the front's face order; point = centroid, t = 0. Local focus: the box. An empty box returns nothing.
/// Throws InvalidInput for a non-finite box.
template <SpatialFront F>
std::vector<FaceHit> intersect_region(F& front, const Query& q, const Box3& box, const SpatialOptions& options = {}) {
  detail::check_finite(box.lo, "intersect_region: box.lo");
  detail::check_finite(box.hi, "intersect_region: box.hi");
  detail::answer(front, q, options, [box](const ElementBound& b) {
    return !box.empty() && sphere_intersects_box(b.center, b.radius, box);
  });
  std::vector<FaceHit> out;
  if (box.empty()) return out;
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    if (triangle_overlaps_box(a, b, c, box)) out.push_back({key, 0.0f, detail::centroid(a, b, c), a, b, c});
  });
  return out;
}

/// Answers q, then returns every current face that may meet the frustum (conservative plane test, see
/// triangle_may_meet_frustum: no face that meets it is missed, a few near its corners may be extra), in
/// the front's face order; point = centroid, t = 0. Local focus: spheres the frustum's planes do not
/// exclude (Frustum::intersects_sphere, conservative the same way). Throws InvalidInput when the frustum
/// fails Frustum::validate() (a NaN plane would exclude nothing).
template <SpatialFront F>
std::vector<FaceHit> intersect_region(F& front, const Query& q, const Frustum& frustum,
                                      const SpatialOptions& options = {}) {
  frustum.validate();
  detail::answer(front, q, options,
                 [frustum](const ElementBound& b) { return frustum.intersects_sphere(b.center, b.radius); });
  std::vector<FaceHit> out;
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    if (triangle_may_meet_frustum(a, b, c, frustum)) out.push_back({key, 0.0f, detail::centroid(a, b, c), a, b, c});
  });
  return out;
}

/// Answers q, then returns every current face within `radius` of `point` (exact point-triangle distance,
/// computed in double), in the front's face order; t = the distance, point = the face's closest point.
/// Local focus: the ball. Throws InvalidInput for a non-finite point or a radius that is negative or not
/// finite.
template <SpatialFront F>
std::vector<FaceHit> faces_within(F& front, const Query& q, const glm::vec3& point, float radius,
                                  const SpatialOptions& options = {}) {
  detail::check_finite(point, "faces_within: the point");
  detail::check_radius(radius, "faces_within: the radius");
  detail::answer(front, q, options, [point, radius](const ElementBound& b) {
    const glm::vec3 d = b.center - point;
    const float rr = b.radius + radius;
    return glm::dot(d, d) <= rr * rr;
  });
  std::vector<FaceHit> out;
  const glm::dvec3 p(point);
  const double r2 = double(radius) * double(radius);
  front.for_each_face_geometry([&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    const glm::dvec3 cp = closest_point_on_triangle(p, glm::dvec3(a), glm::dvec3(b), glm::dvec3(c));
    const glm::dvec3 d = cp - p;
    const double dd = glm::dot(d, d);
    if (dd <= r2) out.push_back({key, static_cast<float>(std::sqrt(dd)), glm::vec3(cp), a, b, c});
  });
  return out;
}

}  // namespace varmesh
