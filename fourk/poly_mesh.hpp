#pragma once
/// Polygon meshes: the input of the subdivision schemes (subdiv.hpp, subdiv_dual.hpp).
///
/// A PolyMesh is an oriented 2-manifold polygon mesh, possibly with borders: every face has at least three
/// distinct corners, every directed edge belongs to one face at most, every undirected edge to one or two
/// faces (opposite orientations), and the faces around a vertex form one fan (a closed fan for an
/// interior vertex, one open fan for a border vertex). validate() checks all of it.
///
/// Quads made by pair_triangles() list their corners so that corners 0 and 2 are the ends of the shared
/// edge of the two triangles: the quad's *diagonal* in the 4-8 sense (the edge a binary 4-8 step splits
/// first). Native quads use the same convention, so a quad mesh is a 4-8 mesh whose triangles are
/// (c0, c1, c2) and (c0, c2, c3).
///
/// find_topology_problem() holds the manifold rules: validate() and the FourKMesh constructor phrase its
/// answer in the library's numbering, the command line in a mesh file's (apps/file_faces.hpp).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/detail/assert.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

struct PolyMesh {
  std::vector<glm::dvec3> positions;
  std::vector<Index> face_offsets{0};  ///< num_faces + 1 entries; face f = corners[offsets[f] .. offsets[f+1])
  std::vector<Index> corners;

  std::size_t num_vertices() const noexcept { return positions.size(); }
  std::size_t num_faces() const noexcept { return face_offsets.empty() ? 0 : face_offsets.size() - 1; }
  /// Corners of face f. Unchecked: f < num_faces() (and well-formed offsets, which validate() checks).
  std::size_t face_size(std::size_t f) const noexcept {
    VARMESH_ASSERT(f + 1 < face_offsets.size());
    return face_offsets[f + 1] - face_offsets[f];
  }
  std::span<const Index> face(std::size_t f) const noexcept {
    VARMESH_ASSERT(f + 1 < face_offsets.size());
    return {corners.data() + face_offsets[f], face_size(f)};
  }
  /// Appends a face; no check (validate() checks).
  void add_face(std::span<const Index> face_corners);
  bool all_quads() const noexcept;

  /// Throws InvalidInput naming the first offending element, in this order: offsets malformed, no face, a
  /// non-finite position or one beyond 1e300 in size (the schemes' sums would overflow), a face with fewer
  /// than 3 corners or a corner out of range (the first such face), then the first problem
  /// find_topology_problem(*this, kPolyMeshRules) finds (a repeated corner, a non-manifold edge, an
  /// inconsistent orientation, a non-manifold vertex; its element is TopologyProblem::element()).
  /// Unreferenced vertices are allowed. O(C log d) for C corners and largest vertex degree d.
  void validate() const;
};

/// The manifold rules, in the order find_topology_problem() checks them.
enum class TopologyRule : std::uint8_t {
  kNone,
  kRepeatedCorner,           ///< a face lists one vertex twice
  kNonManifoldEdge,          ///< three or more faces have one edge
  kInconsistentOrientation,  ///< two faces run their shared edge in the same direction
  kDoubledFace,              ///< two faces have the same set of corners (TopologyRules::distinct_faces)
  kNonManifoldVertex,        ///< the faces around a vertex form several fans (TopologyRules::one_fan_per_vertex)
};

/// Which rules find_topology_problem() checks besides the first three, which it always checks.
struct TopologyRules {
  /// No two faces on the same vertices. The other rules allow (a, b, c) with (a, c, b), a closed surface of
  /// two faces; a FourKMesh refuses it, as its hierarchy would hold one triangle twice (a redundant Mt).
  bool distinct_faces = false;
  /// One fan of faces around each vertex. A FourKMesh takes non-manifold vertices (its splits and swaps
  /// only need the edges), the subdivision schemes do not.
  bool one_fan_per_vertex = true;
};
/// The rules of PolyMesh::validate().
inline constexpr TopologyRules kPolyMeshRules{};
/// The rules of the FourKMesh constructor, and of the bases of simplify4k(), build_bisection_mt() and
/// build_adaptive_implicit().
inline constexpr TopologyRules kFourKMeshRules{.distinct_faces = true, .one_fan_per_vertex = false};

/// The first manifold rule a polygon mesh breaks, as data: which rule, the faces and the vertices involved.
/// Faces and vertices are numbered as in the mesh given to find_topology_problem().
struct TopologyProblem {
  TopologyRule rule = TopologyRule::kNone;
  /// The faces involved, in increasing order. kRepeatedCorner: the face. kNonManifoldEdge: every face
  /// that has the edge (3 or more). kInconsistentOrientation: the two faces. kDoubledFace: the earlier
  /// face and the face that repeats its corners. kNonManifoldVertex: the first face of each fan around
  /// the vertex, so faces.size() is the number of fans (2 or more).
  std::vector<Index> faces;
  /// kRepeatedCorner, kNonManifoldVertex: vertices[0] is the vertex. kNonManifoldEdge: the edge
  /// vertices[0] -> vertices[1] as faces[0] runs it; kInconsistentOrientation: as both faces run it.
  /// kInvalid where unused (kDoubledFace names no vertex).
  std::array<Index, 2> vertices{kInvalid, kInvalid};

  explicit operator bool() const noexcept { return rule != TopologyRule::kNone; }
  /// The element an exception names: the face that shows the problem (the face of a repeated corner, the
  /// third face of a non-manifold edge, the later of two faces) or the non-manifold vertex; kInvalid for
  /// kNone.
  Index element() const noexcept;
};

/// The first manifold rule broken by the polygon mesh of `face_offsets` and `corners` (PolyMesh's layout)
/// over `num_vertices` vertices, kNone when there is none. The rules are checked one after the other, each
/// over the whole mesh, so that the answer depends on the faces and their order only:
/// 1. kRepeatedCorner: the first face that lists a vertex twice, with the vertex it repeats first;
/// 2. the edges: at the first face that gives an edge a third face or runs it in the direction of an earlier
///    face (at its first such side, in corner order), that edge, reported as kNonManifoldEdge when three or
///    more faces of the whole mesh have it, else as kInconsistentOrientation;
/// 3. kDoubledFace, if rules.distinct_faces: the first face whose set of corners an earlier face has, with
///    the first such earlier face;
/// 4. kNonManifoldVertex, if rules.one_fan_per_vertex: the vertex of the lowest number whose faces form
///    more than one fan.
/// Once 1 and 2 pass, every edge has one face, or two that run it in opposite directions. Unreferenced
/// vertices are fine. Throws InvalidInput (naming the face when there is one) when the offsets do not start
/// at 0, decrease or do not end at corners.size(), a face has fewer than 3 corners or a corner is
/// num_vertices or more. `opposite` (optional) receives, once the edge rules pass (the answer is kNone,
/// kDoubledFace or kNonManifoldVertex), the slot of the opposite side for each corner slot s (the side from
/// corners[s] to the next corner of its face), kInvalid on the border; it is left alone otherwise. O(C log d)
/// time for C corners and largest vertex degree d, O(C + V) memory for V vertices.
TopologyProblem find_topology_problem(std::span<const Index> face_offsets, std::span<const Index> corners,
                                      std::size_t num_vertices, const TopologyRules& rules = kPolyMeshRules,
                                      std::vector<Index>* opposite = nullptr);
/// The same for a PolyMesh (its positions are not looked at).
TopologyProblem find_topology_problem(const PolyMesh& mesh, const TopologyRules& rules = kPolyMeshRules);
/// The same for the triangles of a TriMesh (slot 3f + k is corner k of face f); throws also when it has
/// 2^32 corners or more.
TopologyProblem find_topology_problem(const TriMesh& mesh, const TopologyRules& rules,
                                      std::vector<Index>* opposite = nullptr);

/// The problem in the library's numbering (faces and vertices from 0), without a prefix: e.g. "face 2 uses
/// the edge (0, 1) in the same direction as face 0 (inconsistent orientation)". Empty for kNone. `problem`
/// is one find_topology_problem() returned (its faces are read unchecked).
std::string describe_topology_problem(const TopologyProblem& problem);

/// Number of edges and border edges of a (valid) PolyMesh.
struct PolyEdgeCount {
  std::size_t edges = 0;
  std::size_t border_edges = 0;
};
PolyEdgeCount count_edges(const PolyMesh& mesh);

/// Pairs the triangles of `mesh` into quads by a maximum matching of the dual graph (match_dual_faces,
/// semiregular.hpp); unmatched triangles (only on meshes with a border; none on closed meshes) stay
/// triangles. Quad corners are ordered (a, x, b, y) with a-b the shared edge. Positions are converted to
/// double. Throws as match_dual_faces. `num_leftovers` (optional) receives the number of triangles left.
PolyMesh pair_triangles(const TriMesh& mesh, std::size_t* num_leftovers = nullptr);

/// Polygon mesh of a triangle mesh, face for face.
PolyMesh poly_from_triangles(const TriMesh& mesh);

/// Triangulation: a quad (c0..c3) becomes (c0, c1, c2), (c0, c2, c3) (its 4-8 diagonal); any other
/// polygon becomes a fan from corner 0 (a face of fewer than 3 corners gives none). Positions converted to
/// float. The result passes TriMesh::validate(): throws InvalidInput naming the face or vertex for
/// malformed face_offsets, a corner out of range, or a position that is not finite once in float
/// (manifoldness is not required; PolyMesh::validate() checks it). O(corners).
TriMesh triangulate(const PolyMesh& mesh);

/// Generators for tests and demos. A cube of 6 quads (side 2, centred at the origin), and a torus of
/// `nu` x `nv` quads (major radius R, minor r), both closed.
PolyMesh make_quad_cube();
PolyMesh make_quad_torus(int nu, int nv, double major_radius = 1.0, double minor_radius = 0.4);

}  // namespace varmesh
