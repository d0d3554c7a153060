#pragma once
/// Topology report of a triangle mesh: what `varmesh info` prints.
///
/// Definitions (chosen to agree with ../shared/data/tools/meshstat.py, which produced MANIFEST.md):
/// - an edge is an unordered vertex pair used by at least one non-degenerate face; boundary edge: used by
///   exactly 1 face; non-manifold edge: used by more than 2 faces;
/// - boundary loops: connected cycles of boundary edges (counted as components of the boundary-edge graph,
///   a non-manifold boundary vertex joining two loops counts once);
/// - non-manifold vertex: a vertex whose incident faces form more than one fan (edge-connected group
///   around it), ignoring vertices on non-manifold edges;
/// - components: connected components of the faces (sharing a vertex); unreferenced vertices do not count;
/// - degenerate faces: faces with a repeated index; zero-area faces: faces with distinct indices but zero
///   area (exactly collinear corners); duplicate faces: faces with the same vertex set as an earlier face
///   (orientation ignored), counted once per extra copy;
/// - euler characteristic chi = V - E + F over referenced vertices, edges and non-degenerate faces;
///   genus = (2 - chi) / 2 when the mesh is closed, connected and manifold, else -1.
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
  long long euler_characteristic = 0;
  int genus = -1;
  bool closed = false;  ///< no boundary edge and no non-manifold edge
  Box3 bounds;
};

/// O(F log F). Never throws on odd topology; throws InvalidInput only if mesh.validate() fails.
MeshReport analyze_mesh(const TriMesh& mesh);

/// Multi-line human-readable form of the report (what `varmesh info` prints).
std::string format_report(const MeshReport& report);

}  // namespace varmesh
