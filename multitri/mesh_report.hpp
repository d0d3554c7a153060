#pragma once
/// Topology report of a triangle mesh: what `varmesh info` prints.
///
/// Definitions (chosen to agree with ../shared/data/tools/meshstat.py, which produced MANIFEST.md):
/// - faces counts every face; a degenerate face (repeated index) is counted and then ignored by every other
///   count below (its vertices may be unreferenced, its edges do not exist);
/// - unreferenced vertex: not a corner of any non-degenerate face;
/// - an edge is an unordered vertex pair used by at least one non-degenerate face; its face count counts
///   every such face, duplicates included; boundary edge: used by exactly 1 face; non-manifold edge: used by
///   more than 2 faces;
/// - boundary loops: connected components of the graph of boundary edges (so two holes touching at a
///   vertex count as one loop);
/// - non-manifold vertex: a vertex whose incident faces form more than one fan, where two faces are in one
///   fan when they are linked by a chain of faces sharing an edge at the vertex. All faces on an edge are
///   linked, non-manifold edges included, so a vertex is not flagged because of a non-manifold edge alone
///   (a "book" of three faces on one edge has no non-manifold vertex; a bow-tie has one);
/// - components: connected components of the faces (sharing a vertex); unreferenced vertices do not count;
/// - zero-area faces: non-degenerate faces whose corners are exactly collinear (coincident corners
///   included), decided in exact arithmetic on the float positions. meshstat.py prints no such count; the
///   MANIFEST figure (108 for the full dragon) agrees with this exact test;
/// - duplicate faces: non-degenerate faces with the same vertex set as an earlier face (orientation
///   ignored), counted once per extra copy;
/// - euler characteristic chi = V - E + F over referenced vertices, edges and non-degenerate faces;
/// - closed: at least one non-degenerate face, no boundary edge and no non-manifold edge (meshstat.py calls
///   a mesh without faces closed; here it is not);
/// - genus = floor((2 - chi) / 2) when the mesh is closed, has one component and no non-manifold vertex,
///   else -1.
#include <cstddef>
#include <string>

#include "multitri/tri_mesh.hpp"

namespace varmesh {

struct MeshReport {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  std::size_t unreferenced_vertices = 0;
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;
  std::size_t boundary_loops = 0;
  std::size_t non_manifold_edges = 0;
  std::size_t non_manifold_vertices = 0;
  std::size_t components = 0;
  std::size_t degenerate_faces = 0;
  std::size_t zero_area_faces = 0;
  std::size_t duplicate_faces = 0;
  /// Manifold edges (two faces) whose faces both run along them in the same direction: the two sides of the
  /// edge disagree about which way is out.
  std::size_t orientation_inconsistent_edges = 0;
  /// Vertices at exactly the position of a lower-numbered vertex (referenced or not): seams of a scan or of a
  /// file written per face that look closed but are not connected. Positions are compared as float values, so
  /// -0 and +0 are one place; they are finite (NaN and infinity make analyze_mesh throw, see below).
  std::size_t coincident_vertices = 0;
  long long euler_characteristic = 0;
  int genus = -1;
  bool closed = false;  ///< no boundary edge and no non-manifold edge
  Box3 bounds;
};

/// Computes the report. O(V + F) expected (coincident positions are found with a hash table) plus sorting
/// the half-edges around each vertex (O(F log F) worst case, for a hub vertex). Scratch memory about
/// 37 F + 9 V bytes (a 64-bit key per half-edge, a union-find slot per corner and per vertex), and before
/// those are allocated 8 to 16 V bytes for the position hash table; the 871k-face dragon takes about 70 ms.
/// Never throws on odd topology (non-manifold, degenerate, duplicate, unreferenced, no faces); throws
/// InvalidInput if mesh.validate() fails (among others, for a NaN or infinite coordinate, naming the vertex)
/// or the mesh has 2^32 - 1 or more corners or vertices.
MeshReport analyze_mesh(const TriMesh& mesh);

/// Multi-line human-readable form of the report (what `varmesh info` prints).
std::string format_report(const MeshReport& report);

}  // namespace varmesh
