#pragma once
/// Semi-regular 4-8 refinement of an arbitrary triangle mesh (Velho-Gomes 2000, sections 6.2 and 8.1;
/// the two-face clusters of 7.2): the base faces are paired into two-face blocks by a maximum matching of
/// the dual graph, then every level bisects all faces across their marked edge (interleaved binary edge
/// splits: level j + 1 splits exactly the edges level j left alone). The hierarchy is built as a
/// FourKMesh (fourk_mesh.hpp) of split nodes and exported as a Multi-Triangulation.
///
/// Pairing. The dual graph has one vertex per face and one edge per interior (two-face) mesh edge; a
/// maximum matching of it (Edmonds' blossom algorithm after a Karp-Sipser greedy start) pairs as many
/// faces as possible. Each pair is marked on its shared edge and splits as one node (2 -> 4).
///
/// Leftovers. A face left unmatched is split alone across one of its *border* edges (a border split,
/// 1 -> 2). Every leftover can be placed on a border face: after the matching is maximum, an unmatched
/// face with no border edge is exchanged, along an even alternating path (same matching size), for an
/// unmatched border face. Such a path always exists for an edge-manifold mesh (Gallai-Edmonds): the
/// leftover's alternating search reaches a set S of odd components and the set T of Tutte-set faces next
/// to them, with |S| >= |T| + 1 (each face of T is matched into its own component of S; the leftover's
/// component is matched to none), and every face of S is the end of an even alternating path. A component
/// made only of interior faces has at least 3 dual edges to T (its boundary is a closed mod-2 cycle of
/// distinct mesh edges, of odd length), and a face of T has at most 3 dual edges, so if no face of S had a
/// border edge then 3|S| <= 3|T|, a contradiction. In particular a closed mesh has a perfect matching (its
/// dual is cubic and bridgeless: Petersen's theorem), and leftovers occur only on meshes with a border.
///
/// Why everything stays conforming. The marking is compatible (bisection.hpp): an interior edge is marked
/// by both of its faces or by neither, and an edge marked by one face only is a border edge, where a lone
/// split creates no T-junction because no face lies across. Newest-vertex bisection keeps the marking
/// compatible at every level (a child marks an unmarked edge of its parent, which the neighbour's child
/// across it marks too), so every level is a set of independent split nodes, each minimally compatible,
/// and every front of the resulting Mt is conforming. The base mesh is used unchanged: |K_j| = |K0| 2^j
/// exactly, leftovers included, and the same marking (DualMatching::refinement_edge) fed to
/// build_bisection_mt gives the same Mt up to a cyclic shift of face corners.
///
/// Valences (section 6.2). A vertex created by an interior split has valence 4 in the level that creates
/// it and 8 at every later level; a vertex created on a border edge (a lone split, or a split of a border
/// edge at a later level) has valence 3, then 5. Original vertices get no such rule; from level 2 on no
/// two of them are adjacent (every base edge has been split), so extraordinary vertices are isolated
/// among regular ones.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "fourk/bisection.hpp"
#include "fourk/fourk_mesh.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Options of maximum_matching().
struct MatchingOptions {
  /// Empty, or one flag per vertex: after the matching is maximum, each unmatched unflagged vertex is
  /// exchanged for a flagged one when an even alternating path joins them (the size does not change).
  std::span<const std::uint8_t> prefer_unmatched;
  /// Also compute tutte_set (one more search per unmatched vertex).
  bool certificate = false;
  /// Start from the Karp-Sipser greedy matching (false: from the empty matching, so that every pair comes
  /// from a blossom search; for tests and comparisons).
  bool greedy_start = true;
};

/// A matching of a general graph and how it was found.
struct GraphMatching {
  std::vector<Index> mate;        ///< per vertex: its partner, kInvalid when unmatched
  std::size_t num_pairs = 0;
  std::size_t num_unmatched = 0;
  std::size_t greedy_pairs = 0;   ///< pairs of the Karp-Sipser start
  std::size_t augmentations = 0;  ///< augmenting paths found by the blossom searches
  std::size_t moved = 0;          ///< unmatched vertices exchanged for preferred ones
  /// With MatchingOptions::certificate: the Gallai-Edmonds set A (vertices reachable from an unmatched
  /// vertex by an odd but no even alternating path), sorted. By the Tutte-Berge formula the matching is
  /// maximum iff num_unmatched == (odd components of G - A) - |A|; tests check this independently.
  std::vector<Index> tutte_set;
};

/// Maximum-cardinality matching of the undirected graph given by `offsets` (n + 1 entries, starting at 0,
/// non-decreasing) and `neighbours` (vertex v's neighbours are neighbours[offsets[v] .. offsets[v + 1])).
/// Parallel edges are allowed, self-loops ignored. Edmonds' blossom algorithm with union-find blossom
/// bases and per-search lazy resets, started from a Karp-Sipser greedy matching; a vertex whose search
/// fails is never searched again (no augmenting path can appear from it later). Throws InvalidInput naming
/// the vertex when the arrays are malformed, a neighbour is out of range, or the adjacency is not
/// symmetric (w listed by v as often as v by w), or when prefer_unmatched has the wrong size.
/// Cost: one search per vertex left unmatched by the greedy start, each O(E alpha) plus the blossom-base
/// walks (O(V) per blossom): O(V^3) in the worst case, close to linear on mesh dual graphs, where the
/// greedy start leaves few vertices (the bunny's 69,451 faces: 208 augmenting searches).
GraphMatching maximum_matching(std::span<const Index> offsets, std::span<const Index> neighbours,
                               const MatchingOptions& options = {});

/// The pairing of a mesh's faces (see the header comment).
struct DualMatching {
  std::vector<FaceId> mate;  ///< per face: the face it is paired with, kInvalid for a leftover
  /// Per face: the edge k in {0, 1, 2} (corners k and k+1) it splits at level 1: the edge shared with its
  /// mate, or a border edge for a leftover. A compatible marking for build_bisection_mt.
  std::vector<std::uint8_t> refinement_edge;
  std::size_t num_pairs = 0;
  std::size_t num_leftovers = 0;     ///< = faces - 2 * num_pairs; all of them are border faces
  std::size_t num_border_faces = 0;  ///< faces with at least one border edge
  GraphMatching graph;               ///< the matching of the dual graph (mate, counters, certificate)
};

/// Maximum matching of the dual graph of `mesh` with leftovers moved onto border faces. Throws
/// InvalidInput as the FourKMesh constructor (empty mesh, degenerate face, non-manifold edge, inconsistent
/// orientation, two faces on one vertex triple). `certificate`: fill graph.tutte_set. O(F log F) for the
/// adjacency plus the matching.
DualMatching match_dual_faces(const TriMesh& mesh, bool certificate = false);

/// Options of the semi-regular builders. The callbacks see the split as bisection.hpp describes it (level,
/// split edge e0 -> e1 in the first face, apexes, new vertex, positions so far).
struct SemiRegularOptions {
  /// Position of the new vertex; default: the midpoint of the split edge. Must be finite.
  std::function<glm::vec3(const BisectionSplit&)> place_vertex;
  /// Node error (object units, >= 0); default: the length of the split edge, so that
  /// Criterion::object_error(e) refines until every split edge in focus is at most e long (uniform
  /// refinement of a flat-faced mesh has no geometric error, so a resolution measure is the useful default).
  std::function<float(const BisectionSplit&)> node_error;
  MtBuilder::Options build;  ///< passed to MtBuilder::build by build_semiregular_mt
};

/// What the semi-regular builders did.
struct SemiRegularInfo {
  DualMatching matching;
  std::vector<std::uint16_t> modification_level;  ///< per FourKMesh modification (log order), 1-based
  std::vector<std::uint16_t> node_level;          ///< per Mt node, 0 for the source (build_semiregular_mt only)
  std::vector<std::uint16_t> vertex_level;        ///< per vertex, 0 for base vertices
  std::vector<std::size_t> faces_per_level;       ///< |K_j|, j = 0..levels
  std::vector<std::size_t> splits_per_level;      ///< nodes of level j, j = 0..levels ([0] = 1, the source)
  std::vector<std::size_t> border_splits_per_level;  ///< lone (1 -> 2) splits of level j ([0] = 0)
};

/// Largest `levels` accepted for a base of `faces` faces: |K0| 2^levels < 2^31. -1 when faces >= 2^31.
int max_semiregular_levels(std::size_t faces) noexcept;

/// Pairs the faces of `base` (match_dual_faces) and bisects them `levels` times, as a 4-k hierarchy.
/// Face i of the hierarchy is base face i up to a cyclic shift of its corners (marked edge first);
/// vertex i = base vertex i, new vertices follow level by level. Throws InvalidInput naming the
/// parameter when levels < 0, |base| 2^levels >= 2^31 or the build would need more than the machine's
/// physical memory (about 90 bytes per finest face; 260 for build_semiregular_mt), all checked before
/// anything is allocated, and as match_dual_faces otherwise. Cost: O(|base| 2^levels) time and ~2 |base| 2^levels faces of storage
/// (FourKMesh::memory_bytes), plus the matching.
FourKMesh build_semiregular_fourk(const TriMesh& base, int levels, const SemiRegularOptions& options = {},
                                  SemiRegularInfo* info = nullptr);

/// The same hierarchy as a Multi-Triangulation (FourKMesh::to_mt): source image = the base mesh, one
/// kSplit node per two-face block (or border face) and level; node level (longest path from the source,
/// mt_metrics.hpp) = bisection level. Throws as build_semiregular_fourk.
Mt build_semiregular_mt(const TriMesh& base, int levels, const SemiRegularOptions& options = {},
                        SemiRegularInfo* info = nullptr);

}  // namespace varmesh
