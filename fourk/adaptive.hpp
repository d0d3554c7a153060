#pragma once
/// Adaptive (irregular) 4-k refinement of parametric, implicit and sampled surfaces, exported as a
/// Multi-Triangulation (Velho-Gomes 2000, section 8.1 "irregular refinement", Figure 20; the method of Velho,
/// de Figueiredo, Gomes, "A unified approach for hierarchical adaptive tessellation of surfaces", 1999).
///
/// Method. A base mesh is refined by internal edge splits only (section 7.1 (i)): splitting an edge bisects
/// both faces that share it (2 -> 4, or 1 -> 2 on a border) and is one MT node of kind kSplit. Which edge a
/// face splits follows newest-vertex bisection (the marking convention of fourk/bisection.hpp: a face marks
/// one edge; its two children mark the edges opposite the new vertex). A face whose error exceeds the
/// tolerance is split; when the face across its marked edge marks another edge, that neighbour is split
/// first (recursively), so the mesh stays conforming at every step (no T-junction). Face errors are a
/// function of the face alone and every forced split is necessary for conformity, so the finest mesh is the
/// coarsest conforming bisection mesh meeting the tolerance: it does not depend on the order of work, and a
/// smaller tolerance never gives fewer triangles.
///
/// Base meshes and markings.
/// - Parametric and sampled surfaces: the domain rectangle cut along its diagonal (u_lo, v_lo)-(u_hi, v_hi)
///   into two faces that both mark the diagonal, as in Figure 20(c). Domain coordinates live on an integer
///   lattice (2^26 steps per side), so every new vertex is an exact lattice midpoint. A periodic direction
///   identifies the two opposite borders: their vertices are distinct MT vertices with bit-identical
///   positions (the seam), and a split of a seam edge splits the face on each side in one node (2 -> 4,
///   creating one new vertex per side). The MT is then a surface with a border along the seam whose 3D
///   geometry closes up with no crack.
/// - Implicit surfaces: the zero set of f polygonized on a Coxeter-Freudenthal (Kuhn) decomposition of a grid
///   (6 tetrahedra per cell around the main diagonal; marching tetrahedra with roots on grid edges found by
///   bisection, so base vertices lie on the surface; a grid vertex within 0.2 of an edge's length of a root is
///   snapped onto it, so that roots next to a grid vertex make no needle faces), or a caller's base mesh whose
///   vertices are projected. A new vertex is the midpoint of the split edge projected onto the surface (Newton
///   steps along the gradient) when that lands between the edge's ends: at most a quarter of the edge's length
///   from the midpoint along the edge and at most 0.9 of it from either end. Across a part of the surface
///   thinner than the edge, the projection can land next to one end or past it, and bisecting there would not
///   shorten the edge (on the genus-2 surface of the tests polygonized on 14 x 10 x 4 cells it refined to
///   max_level at tolerance 0.2 and missed 0.1); the new vertex is then the root of f on the line through the
///   midpoint along the ends' normals averaged (made perpendicular to the edge), within the reach that keeps
///   both halves at most 0.9 of the edge: on a tube, the middle of the arc between the ends.
///   A grid whose polygonization has an edge whose midpoint does not project between its ends is too coarse
///   for the surface (its chords cross a thin part); build_adaptive_implicit(surface, options) then
///   polygonizes on twice the cells per axis, while the grid stays within polygonize_freudenthal's limits, and
///   reports the grid in AdaptiveHierarchy::base_cells (the genus-2 surface: 14 x 10 x 4 -> 28 x 20 x 8). A
///   caller's base is used as given: where it does not resolve the surface, faces may stay turned over.
///   The faces are paired across shared edges by a maximum matching of the dual graph (greedy on the longest
///   edges, then Edmonds augmenting paths) and a pair marks its shared edge. A face left unpaired marks its
///   longest border edge if it has one (a 1 -> 2 split), otherwise its longest edge, whose neighbour is
///   paired (the matching is maximal): forcing it costs one extra split. (Closed surfaces always have a
///   perfect matching; if a marking ever made forced splits cycle, a guard throws std::logic_error.)
///
/// Error (the tolerance `AdaptiveOptions::tolerance`, object units). Let S_k be the barycentric sample points
/// (i, j, l) / k, i + j + l = k, of a face, corners excluded (k = sample_order; k = 2 gives the edge
/// midpoints, the edge test of Velho et al. 1999; the default k = 4 adds the 3 interior points and two more
/// points per edge).
/// - Parametric surfaces: the parametric deviation max over b in S_k of |S(sum b_i uv_i) - sum b_i P_i|,
///   the distance between the surface point and the flat-triangle point with the same barycentric
///   coordinates. It bounds the distance from those triangle points to the surface.
/// - Sampled data (height fields, cylindrical scans): the same deviation at S_k (the surface between samples
///   is the bilinear interpolant of the samples) and at every data sample whose (u, v) lies in the closed
///   domain triangle.
/// - Implicit surfaces: max over b in S_k of the distance from the triangle point sum b_i P_i to the point
///   that Newton steps along the gradient reach on the surface (an upper bound of the distance to the
///   surface; when Newton fails, a sign change along the face normal is searched; when both fail, the point
///   counts as out of tolerance). Distances cannot see a fold (a face standing across the surface, in the
///   plane of a meridian of the torus, keeps its points near it), so a face is also split, whatever its error,
///   when its normal is more than 60 degrees from the gradient of f at its centroid and its longest edge is
///   longer than the tolerance (the fold guard; AdaptiveHierarchy::num_folded_faces counts these faces). Such
///   folds come from bisecting a long chord whose sagitta exceeds the face's width and go away as faces
///   shrink (on the genus-2 surface polygonized on 16 x 12 x 5 cells, within 7 levels). Where they do not (a
///   base that does not resolve the surface, whose faces are turned over in its tangent plane and stay so in
///   their children), the guard stops: it splits a face only while fewer than 8 of its ancestors in a row had
///   their error within the tolerance, 4 if the face is turned over (normal more than 90 degrees from the
///   gradient), so it adds at most 8 levels below the faces the error needs instead of refining a fold that
///   bisection cannot remove down to max_level; AdaptiveHierarchy::num_unresolved_folds counts the finest faces
///   it left folded. 60 degrees lies between the deviation of a coarse but sound face (the
///   torus's base faces that span a third of its tube reach 43) and a face seen from behind (90). The error of
///   a face split by the guard alone stays its distance error.
/// An MT node's error is the largest error of its pre-image faces (MtBuilder then saturates it). So
/// extract() with Criterion::object_error(e), e >= tolerance, gives a mesh whose faces all have error <= e,
/// and every face of the finest front has error <= tolerance (implicit surfaces: and, when its longest edge is
/// longer than the tolerance and num_unresolved_folds is 0, a normal within 60 degrees of the gradient).
/// Between sample points nothing is guaranteed.
///
/// Figure 20 counts (tests/fourk/adaptive_test.cpp, default sample_order 4): torus_parametric() at tolerance
/// 0.0685 gives 528 finest triangles (the paper shows 516; the count jumps 464 -> 528 between 0.069 and
/// 0.068 because the torus is refined ring by ring); torus_implicit() at 0.041 gives 1322 (paper: 1324) from
/// a 144-face base (at 0.046, the tolerance chosen before grid vertices were snapped, 1088). The paper does not
/// state its tolerances, so these were chosen to match the counts.
///
/// Result invariants (AdaptiveHierarchy): mt passes Mt::validate(); every node except the source is a
/// kSplit (on a periodic seam its two pre-image faces share no vertex id: they are the two sides of the
/// seam edge); face_error / face_level have one entry per Mt face; domain has one entry per Mt vertex for
/// parametric and sampled surfaces (empty for implicit ones). Vertex ids: base vertices first, then one per
/// new vertex in creation order (MtBuilder keeps vertex numbering).
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "multitri/heightfield.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Parameters shared by every adaptive builder. Checked: tolerance finite and > 0; 2 <= sample_order <= 16;
/// 1 <= max_level <= 48; 16 <= max_faces <= 2^28. Violations throw InvalidInput naming the parameter.
struct AdaptiveOptions {
  float tolerance = 0.0f;              ///< required: the largest error a finest face may keep (object units)
  int sample_order = 4;                ///< k of the barycentric sample points S_k (see the header comment)
  int max_level = 40;                  ///< deepest bisection level (base faces are level 0)
  std::size_t max_faces = std::size_t(1) << 22;  ///< cap on MT faces (all levels together)
  MtBuilder::Options build;            ///< passed to MtBuilder::build
};

/// A parametric surface S: [u_lo, u_hi] x [v_lo, v_hi] -> R^3. `eval` must return finite points; a periodic
/// direction requires S to agree on the two opposite borders (it is evaluated only on one of them).
struct ParametricSurface {
  std::function<glm::vec3(glm::vec2)> eval;
  glm::vec2 domain_lo{0.0f, 0.0f};
  glm::vec2 domain_hi{1.0f, 1.0f};
  bool periodic_u = false;
  bool periodic_v = false;
};

/// The torus of Figure 20(c, d): x = cos u (r + cos v), y = sin u (r + cos v), z = sin v on [0, 2pi]^2,
/// periodic in u and v (tube radius 1, centre-line radius r).
ParametricSurface torus_parametric(float r = 1.6f);
/// The saddle z = (uv)^3, x = u, y = v on [0, 1]^2.
ParametricSurface saddle_parametric();

/// An implicit surface f = 0 with the inside f < 0, and the grid of its base polygonization: `cells` cells
/// per axis over the box [box_lo, box_hi]. `gradient` is optional (central differences with step 1e-6 times
/// the box diagonal otherwise). The box diagonal is also the length scale of the projection's convergence
/// test, also when a caller's base mesh is used. f must be finite where it is evaluated; a grid vertex with
/// f == 0 counts as outside and its roots are welded into one vertex.
struct ImplicitSurface {
  std::function<double(const glm::dvec3&)> value;
  std::function<glm::dvec3(const glm::dvec3&)> gradient;
  glm::dvec3 box_lo{-1.0, -1.0, -1.0};
  glm::dvec3 box_hi{1.0, 1.0, 1.0};
  std::array<int, 3> cells{4, 4, 4};
};

/// The torus of Figure 20(a, b): f = (x^2 + y^2 + z^2 - r^2 - 1)^2 - 4 r^2 (1 - z^2) on [-3, 3]^2 x [-1, 1]
/// with a 4 x 4 x 2 grid and the analytic gradient. Same surface as torus_parametric(r).
ImplicitSurface torus_implicit(double r = 1.6);

/// A cylindrical range scan (the Cyberware layout of Figure 20(e, f)): a radius per (angle, height) sample.
/// Sample (i, j) sits at angle 2 pi i / num_angles (periodic) and height height_min + j * height_step, at
/// (r cos a, r sin a, h). Between samples the radius is bilinear in (angle, height).
struct CylindricalScan {
  std::size_t num_angles = 0;   ///< >= 3
  std::size_t num_heights = 0;  ///< >= 2
  std::vector<float> radius;    ///< num_angles * num_heights, radius[j * num_angles + i], finite, >= 0
  float height_min = 0.0f;
  float height_step = 1.0f;     ///< > 0

  float at(std::size_t i, std::size_t j) const noexcept { return radius[j * num_angles + i]; }
  /// Throws InvalidInput naming the first violation above (the sample index for a bad radius; more than 2^28
  /// samples is rejected). O(samples).
  void validate() const;
};

/// An adaptive 4-k hierarchy and what the builder measured.
struct AdaptiveHierarchy {
  Mt mt;
  std::vector<float> face_error;          ///< per Mt face: its error as defined above (object units)
  std::vector<std::uint8_t> face_level;   ///< per Mt face: bisection level, 0 for base faces
  std::vector<glm::vec2> domain;          ///< per Mt vertex: (u, v); empty for implicit surfaces
  std::size_t num_base_faces = 0;
  std::size_t num_finest_faces = 0;       ///< faces of the drain (the finest front)
  std::size_t num_unpaired_base_faces = 0;  ///< implicit: base faces the matching left unpaired
  std::size_t num_folded_faces = 0;       ///< implicit: faces split by the fold guard alone (error in tolerance)
  /// implicit: finest faces the fold guard still holds for (normal more than 60 degrees from the gradient, longest
  /// edge longer than the tolerance) but stopped splitting (its level limit or max_level; see the header). 0
  /// when every fold was resolved.
  std::size_t num_unresolved_folds = 0;
  /// build_adaptive_implicit from a grid: the cells of the grid the base was polygonized on (ImplicitSurface::cells,
  /// doubled per axis while the polygonization did not resolve the surface; see the header). {0, 0, 0} otherwise.
  std::array<int, 3> base_cells{0, 0, 0};
  int max_level = 0;                      ///< deepest face level reached
};

/// Adaptive refinement of a parametric surface from the two-face base of its domain.
/// Throws InvalidInput: bad options (see AdaptiveOptions); missing eval; a domain bound not finite or
/// domain_lo >= domain_hi; eval returning a non-finite point (the message gives (u, v), the element is the
/// vertex or face being evaluated); the tolerance not met at max_level or more than max_faces faces needed.
/// Cost: O(F k^2) evaluations of eval for F MT faces, plus O(F log F) to build the MT.
AdaptiveHierarchy build_adaptive_parametric(const ParametricSurface& surface, const AdaptiveOptions& options);

/// Adaptive refinement of a height field: domain (u, v) = (column, row) in sample units over
/// [0, width - 1] x [0, height - 1], points (u spacing_x, v spacing_y, bilinear z). Error at S_k and at the
/// samples inside each face (the vertical deviation). Throws InvalidInput: field.validate() fails, width or
/// height < 2, or as build_adaptive_parametric. Cost: as parametric plus O(samples per face) per face.
AdaptiveHierarchy build_adaptive_heightfield(const HeightField& field, const AdaptiveOptions& options);

/// Adaptive refinement of a cylindrical range scan: domain (u, v) = (angle in [0, 2 pi], height), periodic
/// in u. Error at S_k and at the samples inside each face. Throws InvalidInput: scan.validate() fails, or as
/// build_adaptive_parametric. Cost: as build_adaptive_heightfield.
AdaptiveHierarchy build_adaptive_cylindrical(const CylindricalScan& scan, const AdaptiveOptions& options);

/// The base mesh of an implicit surface: marching tetrahedra on the Coxeter-Freudenthal decomposition of the
/// grid (see the header comment), faces oriented with normals towards f > 0, vertices on the surface to
/// double precision (stored as float). A grid vertex with a root on one of its tetrahedron edges closer than
/// 0.2 of that edge's length is moved onto the nearest such root and the roots of its crossing edges welded
/// into it (isosurface stuffing's snapping); a snap that would turn a face over, make the mesh non-manifold
/// or weld roots with opposite normals is not made, and if the topology would change no vertex is snapped.
/// Degenerate faces (from welded grid vertices) are dropped.
/// Throws InvalidInput: missing value; box not finite or box_lo >= box_hi; cells outside [1, 256] or more
/// than 2^21 cells in all; f not finite at a grid vertex (named by (i, j, k) and its point); the result
/// breaking a FourKMesh's manifold rules (find_topology_problem(result, kFourKMeshRules), poly_mesh.hpp;
/// named by its face). Cost: O(cells) evaluations of f plus 64 per root and a gradient per root around each
/// grid vertex near a root; the tetrahedra are marched 1 to 9 times (once without snaps, then until no snap
/// is undone).
TriMesh polygonize_freudenthal(const ImplicitSurface& surface);

/// Adaptive refinement of an implicit surface from polygonize_freudenthal(surface), or from the polygonization
/// on twice (four, eight times...) the cells per axis when that grid does not resolve the surface (reported in
/// base_cells; see the header comment). New vertices are edge midpoints projected onto the surface (Newton
/// steps along the gradient; across thin parts, the root along the ends' normals). Faces are split while their
/// error exceeds the tolerance or the fold guard holds (see the header comment). Throws InvalidInput: as
/// polygonize_freudenthal; an empty polygonization; bad options; f or its gradient not finite at a point
/// the builder visits (named); a midpoint that cannot be projected; tolerance not met at max_level or more
/// than max_faces faces. Cost: one projection per base edge and, per doubling, a polygonization with 8 times
/// the cells; then O(F k^2) projections (each a few evaluations of f and its gradient).
AdaptiveHierarchy build_adaptive_implicit(const ImplicitSurface& surface, const AdaptiveOptions& options);

/// As above from a caller's base mesh (e.g. a coarse sphere), used as given (no grid to refine): its vertices
/// are projected onto the surface first, and its marking comes from the matching. The base may face either
/// way: the fold guard compares normals with the side most of its area faces. Throws InvalidInput also when
/// base.validate() fails, the base is empty, breaks a FourKMesh's manifold rules (a degenerate face, an edge
/// used twice in one direction, two faces on one vertex triple: find_topology_problem(base, kFourKMeshRules),
/// poly_mesh.hpp, named by its TopologyProblem::element()), or has a vertex that cannot be projected.
AdaptiveHierarchy build_adaptive_implicit(const ImplicitSurface& surface, const TriMesh& base,
                                          const AdaptiveOptions& options);

/// The Mt faces of the finest front (the drain: faces no node removes), in increasing order. O(faces).
std::vector<FaceId> adaptive_finest_faces(const AdaptiveHierarchy& hierarchy);

/// The domain (u, v) triangulation of `faces` (Mt faces, e.g. MtFront::faces(); empty span: the finest
/// front) as a mesh with positions (u, v, 0), vertices compacted in first-use order, face i = faces[i] with
/// the same corner order. This is the "domain decomposition" picture of Figure 20(c, e). Throws
/// InvalidInput for an implicit hierarchy (no domain) or a face id out of range (named). O(faces).
TriMesh adaptive_domain_mesh(const AdaptiveHierarchy& hierarchy, std::span<const FaceId> faces = {});

}  // namespace varmesh
