#pragma once
/// Uniform newest-vertex bisection of a triangle mesh as a Multi-Triangulation: the semi-regular 4-8
/// refinement of Velho-Gomes 2000 (sections 5.1 and 6.2, "interleaved binary subdivision"; analysed in
/// 7.2) generalised to any compatibly marked base mesh.
///
/// Marking convention. refinement_edge[f] = k in {0, 1, 2} marks edge k of face f, which joins corners k
/// and (k + 1) % 3 (indices[3f + k], indices[3f + (k + 1) % 3]). The corner opposite it, (k + 2) % 3, is the
/// face's apex. A marking is *compatible* when each marked edge shared by two faces is marked by both; a
/// face whose marked edge is on the mesh border is also fine (it splits alone, 1 face -> 2).
///
/// One level: every current face is bisected at the midpoint m of its marked edge (e0, e1) with apex a,
/// into (m, a, e0) and (m, e1, a) (orientation kept); each child's marked edge is the one opposite m, i.e.
/// corners 1-2 of the child. The faces sharing a marked edge form one split node (2 -> 4, or 1 -> 2 on the
/// border). The children's marked edges are edges of the previous mesh, shared by the two children that
/// face each other across them, so the marking stays compatible at every level and level j + 1 splits
/// exactly the edges that were not split at level j (the interleaving of 4-8 refinement).
///
/// Result: an Mt whose source image is the base mesh (face i of the Mt's base = face i of `base`, same
/// corner order; vertex i = base vertex i, new vertices follow level by level), |K_j| = |K0| * 2^j, and
/// node level (longest path from the source, mt_metrics.hpp) = bisection level. Node kind: kSplit.
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// One split, as handed to the callbacks of BisectionOptions.
struct BisectionSplit {
  int level = 0;                       ///< 1 for the first bisection of the base mesh
  VertexId e0 = kInvalid, e1 = kInvalid;  ///< the split edge, as oriented in the first face of the node
  std::array<VertexId, 2> apex{kInvalid, kInvalid};  ///< apexes of the one or two faces; [1] = kInvalid on a border
  VertexId mid = kInvalid;             ///< the new vertex (kInvalid while it is being placed)
  std::span<const glm::vec3> positions;  ///< all vertices so far (base first)
};

struct BisectionOptions {
  /// Position of the new vertex of a split; default: the edge midpoint. Must be finite.
  std::function<glm::vec3(const BisectionSplit&)> place_vertex;
  /// Node error (>= 0, object units) of a split; default 0. Called after place_vertex (mid is set).
  std::function<float(const BisectionSplit&)> node_error;
  /// Passed to MtBuilder::build.
  MtBuilder::Options build;
};

/// Levels of what build_bisection_mt created (optional output).
struct BisectionInfo {
  std::vector<std::uint16_t> node_level;    ///< per Mt node (after renumbering); 0 for the source
  std::vector<std::uint16_t> vertex_level;  ///< per Mt vertex; 0 for base vertices
};

/// Bisects `base` uniformly `levels` times (see the header comment) and returns the Mt.
///
/// Preconditions, checked (throws InvalidInput naming the face or vertex): base.validate() passes;
/// 0 <= levels and |base| * 2^levels < 2^31; refinement_edge has one entry per face, each < 3; the manifold
/// rules of a FourKMesh base, find_topology_problem(base, kFourKMeshRules) (poly_mesh.hpp; names its
/// TopologyProblem::element()): no degenerate face (a repeated corner), every edge used at most once in each
/// direction (so edges are manifold and orientations consistent; non-manifold vertices are accepted), no two
/// faces on one vertex triple; the marking is compatible (the error names the face whose marked edge is
/// shared with a face marking another edge). MtBuilder::build then re-checks the MT definition.
/// Cost: O(|base| 2^levels) time and memory.
Mt build_bisection_mt(const TriMesh& base, std::span<const std::uint8_t> refinement_edge, int levels,
                      const BisectionOptions& options = {}, BisectionInfo* info = nullptr);

/// Marks the longest edge of every face (ties: the edge whose sorted endpoint pair is smallest). Compatible
/// only when shared longest edges are longest on both sides (e.g. right-isosceles 4-8 triangulations);
/// build_bisection_mt reports the first face where it is not. O(faces).
std::vector<std::uint8_t> mark_longest_edges(const TriMesh& mesh);

/// Marks, in every face, the one edge of `edges` (unordered vertex pairs) it contains: e.g. the two
/// opposite edges {0,1} and {2,3} of a tetrahedron pair its faces. Throws InvalidInput naming a face that
/// contains none or several of them. O(faces + edges log edges).
std::vector<std::uint8_t> mark_edges(const TriMesh& mesh, std::span<const std::array<VertexId, 2>> edges);

}  // namespace varmesh
