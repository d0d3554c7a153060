#pragma once
/// Dual subdivision of polygon meshes (poly_mesh.hpp): Zwart-Powell (mid-edge) steps and Doo-Sabin steps.
///
/// A dual step puts its new vertices inside the faces or on the edges of the input and drops the old
/// vertices; the new faces are one per old face, one per old vertex (and, for Doo-Sabin, one per old edge).
///
/// Zwart-Powell (ZP) step: the mid-edge topology of Peters and Reif ("The simplest subdivision scheme for
/// smoothing polyhedra", ACM TOG 16(4), 1997). New vertex = one per edge, at its midpoint. New faces: per
/// face a k-gon through the midpoints of its k edges, per interior vertex an n-gon through the midpoints of
/// its n edges. On a regular quad grid the step is the quincunx refinement with symbol (1 + z)(1 + w)/2: the
/// new grid is turned by 45 degrees and scaled by 1/sqrt(2), and two steps are one dyadic step with mask
/// 1/4 [0 1 1 0; 1 2 2 1; 1 2 2 1; 0 1 1 0], the quadratic four-direction (Zwart-Powell) box spline, C1.
/// After two steps the new vertex of the corner (face f, vertex v) of the grid sits at (v + centroid(f)) / 2
/// with value v/2 + (the two neighbours of v in f)/4: the same lattice as a Doo-Sabin step. Peters and
/// Reif analyse this plain rule at extraordinary vertices and faces (C1, piecewise quadratic away from
/// isolated points) and propose modified weights there; this file implements the plain rule only.
///
/// Doo-Sabin (DS) step (Doo and Sabin, "Behaviour of recursive division surfaces near extraordinary
/// points", CAD 10(6), 1978): new vertex = one per corner (face f, vertex v_i of f), at
///   c(f, v_i) = sum_j w_ij v_j,  w_ii = (k + 5) / (4k),  w_ij = (3 + 2 cos(2 pi (i - j) / k)) / (4k),
/// for quads 9/16, 3/16 (the two neighbours of v_i in f), 1/16 (the opposite corner). New faces: per face
/// its corner points, per interior vertex the n-gon of its corner points, per interior edge the quad of
/// the four corner points at its ends. On a regular quad grid the step is the biquadratic B-spline
/// (Chaikin in each direction): dyadic mask (1/16) [1 3 3 1] (x) [1 3 3 1]. All weights are positive, so
/// every new point is a convex combination of old ones (in the convex hull of its face).
///
/// Doo-Sabin and 4-8 steps (subdiv.hpp). For a quad, c(f, v) = (v + F + m1 + m2) / 4 with F the face
/// centroid and m1, m2 the midpoints of the two edges of v in f: 9/3/3/1 over 16. That is three binary 4-8
/// steps: a linear diagonal step (F = mean of the corners), a linear edge step (m = edge midpoints), then a
/// binary step on the v-F diagonals whose new vertex is the average of its block's four corners (v, F, m1,
/// m2); the old vertices are then dropped. At a k-gon with k != 4 that 4-8 average weighs v by
/// 1/2 + 1/(4k), its neighbours by 1/8 + 1/(4k), the others by 1/(4k) (triangle: 7/12, 5/24, 5/24), not the
/// classic Doo-Sabin weights (triangle: 2/3, 1/6, 1/6); this file uses the classic weights for every k.
///
/// Borders (both steps keep the output an oriented 2-manifold with border, PolyMesh::validate()):
/// - ZP: a border vertex v with n edges gets an (n+1)-gon: v itself (new vertex, at its old position)
///   followed by the midpoints of its n edges. The output border is the input border polyline with its
///   edge midpoints inserted, so the border never moves (interpolating, C0 along the border). Border
///   edges halve at every step while interior edges shrink by 1/sqrt(2): near the border, faces get
///   thinner with the steps.
/// - DS: the border follows the quadratic B-spline (Chaikin) of the border polygon. Each border edge
///   a -> b gets two border points 3/4 a + 1/4 b and 1/4 a + 3/4 b and a quad (c(f, b), c(f, a), its point
///   near a, its point near b); a border vertex v with n edges gets an (n+1)-gon: its n - 1 corner points,
///   then the border points near v of its incoming and of its outgoing border edge. The output border is
///   the Chaikin polygon of the input border; repeated steps converge to the quadratic B-spline curve.
/// - Both: an interior vertex with 2 edges (allowed by PolyMesh) gets no face (its face would be a
///   2-gon); the two faces that would meet it then share an edge directly. Unreferenced vertices give
///   nothing.
///
/// Output numbering (depends only on the connectivity of the input, never on positions). Edges are
/// numbered in order of first appearance, scanning faces in order and each face's edges c_i -> c_{i+1}
/// in order (E edges, E_b on the border).
/// - ZP vertices: edge e's midpoint is vertex e; then the border vertices, in increasing input index.
///   Faces: input face f is output face f, with corner i = the midpoint of the edge c_i -> c_{i+1}; then
///   one face per input vertex (increasing index; unreferenced and 2-edge interior vertices skipped).
/// - DS vertices: the corner point of corner slot s (corners[s], s in [face_offsets[f], face_offsets[f+1]))
///   is vertex s; then two points per border edge (in edge order: near its first vertex, near its second,
///   in the orientation of its face). Faces: input face f is output face f with the same offsets (corner i
///   = the corner point of corner i); then one face per input vertex as for ZP; then one quad per edge.
/// - Vertex faces start at the corner (face, v) of the lowest corner slot of v for an interior vertex; at
///   v itself (ZP) or at the corner of the face whose outgoing edge at v is on the border (DS) for a border
///   vertex.
///
/// Sizes (C corners, F faces, V_b border vertices = E_b, V_f vertices that get a face): ZP gives E + V_b
/// vertices, F + V_f faces, C + 2E + V_b - 2 (interior 2-edge vertices) corners; DS gives C + 2 E_b vertices,
/// F + V_f + E faces, 2C + 4E + 2 V_b - 2 (interior 2-edge vertices) corners. On a closed mesh: ZP doubles
/// the corners and DS multiplies them by 4 at every step.
#include <cstdint>

#include "fourk/poly_mesh.hpp"

namespace varmesh {

enum class DualScheme : std::uint8_t { kZwartPowell = 0, kDooSabin = 1 };

const char* to_string(DualScheme scheme) noexcept;

/// Largest number of corners a dual step or subdivide_dual() may produce (2^31).
inline constexpr std::uint64_t kMaxDualCorners = std::uint64_t{1} << 31;

/// One Zwart-Powell (mid-edge) step (rules, borders and numbering above). `in` must satisfy
/// PolyMesh::validate(): the step checks the same conditions while it finds the edges and throws the
/// InvalidInput validate() would throw, with the same element and the same words after "zwart_powell_step: "
/// (validate's "polygon mesh: "; for a mesh of no face, "the polygon mesh has no face"), a manifold rule as
/// find_topology_problem(in, kPolyMeshRules) reports it.
/// Throws InvalidInput when the output would have more than kMaxDualCorners corners. Cost: linear in the
/// number of corners, but for find_topology_problem's sort of the sides around each vertex.
PolyMesh zwart_powell_step(const PolyMesh& in);

/// One Doo-Sabin step (classic weights; rules, borders and numbering above). Throws as zwart_powell_step.
/// Cost: as zwart_powell_step (a k-gon costs O(k)).
PolyMesh doo_sabin_step(const PolyMesh& in);

/// One step of `scheme`.
PolyMesh dual_step(const PolyMesh& in, DualScheme scheme);

/// Sizes of the mesh after `steps` steps of `scheme` on `base` (formulas above; exact). Counts that do
/// not fit 64 bits saturate at UINT64_MAX. Throws InvalidInput when `base` is invalid (as
/// zwart_powell_step) or steps < 0.
struct DualMeshSize {
  std::uint64_t vertices = 0;
  std::uint64_t faces = 0;
  std::uint64_t corners = 0;
};
DualMeshSize dual_mesh_size(const PolyMesh& base, DualScheme scheme, int steps);

/// `steps` steps of `scheme` on `base` (steps = 0: a copy of `base` after validation). Throws InvalidInput
/// when `base` is invalid (PolyMesh::validate conditions), or naming `steps` when steps < 0 or the result
/// would have more than kMaxDualCorners corners; both checked before any step runs. Peak memory: two
/// consecutive levels plus the edge table of the larger input.
PolyMesh subdivide_dual(const PolyMesh& base, DualScheme scheme, int steps);

/// One Doo-Sabin step made of binary 4-8 steps (subdiv.hpp): a linear diagonal step, a linear edge step and
/// a linear diagonal step on the resulting quads (whose new vertex is the average of its block's corners
/// v, m1, F, m2), then the dual of that quad mesh: its vertices are those last face points, its faces one
/// per vertex of the quad mesh (an old vertex, an old face's point, an old edge's point), ordered around it.
/// On a closed quad mesh this is doo_sabin_step() up to the numbering (tests compare the two face for face);
/// at other faces the corner weights are the 4-8 average of the header, not the classic ones. Closed meshes
/// only: throws InvalidInput naming the border vertex otherwise, and as PolyMesh::validate(). Output
/// numbering: vertex q = the point of level-1 quad q (subdiv.hpp numbering); faces in level-1 vertex order,
/// skipping vertices with fewer than 3 faces.
PolyMesh doo_sabin_by_four_eight_steps(const PolyMesh& base);

}  // namespace varmesh
