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
#include <cstddef>
#include <span>
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

  /// Throws InvalidInput naming the first offending element: no face, offsets malformed, a face with
  /// fewer than 3 corners or a repeated corner, a corner out of range, a non-finite position or one beyond
  /// 1e300 in size (the schemes' sums would overflow), a directed
  /// edge used twice (non-manifold edge or inconsistent orientation), a vertex whose faces form several
  /// fans (non-manifold vertex). Unreferenced vertices are allowed.
  void validate() const;
};

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
