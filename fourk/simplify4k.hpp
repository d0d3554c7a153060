#pragma once
/// Four-face-cluster simplification of an arbitrary triangle mesh, stored as an increasing 4-k
/// Multi-Triangulation (Velho-Gomes 2000, section 8.2 and Figure 21; the 4-k nodes of section 7.1/7.2).
///
/// The method. Level by level, the mesh is covered with independent clusters around removable vertices:
/// - an interior vertex of degree 4 is a four-face cluster; it is collapsed (the vertex is removed and its 4
///   faces become 2, split by the diagonal of its ring that gives the smaller error bound, then the better
///   shape);
/// - an interior vertex of degree 5..max_swap_degree is first brought to degree 4 by swapping spokes
///   (v, w) into ring edges (w-, w+) (2 -> 2 each), then collapsed; an interior vertex of degree 3 gets one
///   outward swap of a ring edge (its degree becomes 4), then is collapsed. Every order of swaps and both
///   diagonals are tried; the legal plan with the smallest error bound (then the best worst shape) wins;
/// - a border vertex with 2 faces is collapsed 2 -> 1 (the border edge pair (w0, v), (v, w2) becomes the
///   edge (w0, w2)); a border vertex with 3..max_border_faces faces is first brought to 2 faces by swaps.
///   With lock_border every border vertex stays.
/// Levels (8.2: "cover the mesh with four-face clusters", "clusters at subsequent levels are interleaved").
/// Within a level, swaps prepare clusters and the clusters collapse; the two faces a collapse creates are
/// frozen until the next level, so a plan may not touch them, while faces made by a swap of this level may
/// be reused by another cluster. Hence the swaps of a level can all be moved before its collapses, and the
/// level's four-face clusters are then disjoint faces of one mesh: a non-overlapping cover. Candidates are
/// taken greedily and re-planned when their neighbourhood changes, ordered (prefer_cover) by how many other
/// candidates their collapse would block, then by a cheap flatness estimate (the bound already on the star
/// plus v's distance to the mean plane of its ring, plus its distance to the new border edge on a border).
/// On a regular 4-8 mesh the first level collapses every degree-4 vertex and halves the face count.
///
/// A step is legal when it creates no edge already in the mesh (no non-manifold edge), no face whose vertex
/// triple ever existed (MT non-redundancy), no face of quality (radius ratio 4*sqrt(3)*area / sum of squared
/// edges) below min(min_quality, worst quality of the faces the plan replaces), no face whose normal makes a
/// dot product < min_normal_dot with an old face of the same step it shares an edge with (no fold-over), and
/// when every edge of the plan's final faces has a dihedral normal dot >= min_dihedral_cos (or, on the ring
/// of the cluster, at least what the old faces had there). Geometric self-intersection is not checked.
///
/// The MT (canonical increasing form, 8.2). Source image = the coarsest level's mesh. Each collapse is a
/// kSplit node (2 faces -> 4, or 1 -> 2 on the border), each swap a kSwap node (2 -> 2), in reverse order
/// of the simplification; MtBuilder checks the MT definition. MT vertex i is input vertex i (same position);
/// MT faces are input faces or faces the simplification created, with their corners in the same order.
/// Refining every node gives exactly the input faces; the front of level l (simplify4k_level_front) is the
/// mesh after l rounds of simplification (level 0 = input, level num_levels() - 1 = the source's image).
///
/// The error bound (what exactly is bounded). Every MT face f carries h(f) >= 0 such that each point of the
/// input surface assigned to f lies within distance h(f) of the triangle f. Input faces are assigned to
/// themselves (h = 0). A plan replaces the anchor faces A (the star, plus one outer face at degree 3) by
/// intermediate and final faces; each point of an anchor is carried to one face of every stage:
/// - projection mode (interior vertices whose region projects one-to-one along its mean normal N, with all
///   old and new faces facing N): every stage triangulates the same projected polygon, the point goes to the
///   face above the same projected point, and h(F) = max over anchors A overlapping F in projection of
///   h(A) + the largest distance along N between A and F over their overlap (attained at a vertex of the
///   clipped overlap polygon, since the difference of two linear height functions is affine). This is the
///   "successive mapping" bound of Cohen, Manocha and Olano (1997), not accumulated within a plan;
/// - fallback (border vertices, strongly curved regions), step by step: each old face T goes to the new face
///   F whose largest distance to T's corners is smallest; h(F) = max of h(T) + that distance (distance to a
///   triangle is convex, so T's corners bound all of T; the triangle inequality accumulates it).
/// The assignments form chains through the DAG, so every front holds exactly one face of each input point's
/// chain. A node's error is max h over its pre-image (the faces left when it is not refined), rounded up to
/// float; MtBuilder then saturates (nests) errors, which only raises them. Consequence, for
/// extract(front, {Criterion::object_error(e)}) with an empty focus set: every point of the input surface is
/// within distance e of the extracted mesh. The bound is one-sided (input to front; the distance from the
/// front back to the input is not bounded), conservative, and grows across levels (triangle inequality).
///
/// Input classes (see simplify4k()): non-manifold vertices (several fans) are data: they are locked (never
/// removed) and counted; everything else the MT cannot represent is an error.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Parameters of simplify4k(); the file comment says what each criterion means.
struct Simplify4kOptions {
  int max_levels = 64;                 ///< at most this many rounds of simplification (>= 0)
  std::size_t target_faces = 0;        ///< stop as soon as the mesh has at most this many faces (0: none)
  /// Never make a step whose new faces' error bound exceeds this (object units, >= 0; default: no limit).
  double max_error = std::numeric_limits<double>::infinity();
  int max_swap_degree = 7;             ///< interior vertices of degree 3..max_swap_degree are candidates (4..10)
  int max_border_faces = 4;            ///< border vertices with 2..max_border_faces faces are candidates (2..8)
  bool lock_border = false;            ///< never remove a border vertex (the border keeps its resolution)
  /// Order of the greedy cover: true = first the clusters whose collapse blocks the fewest other candidates
  /// of the level (denser levels, closer to a 4-8 cover), then the flattest; false = the flattest first.
  bool prefer_cover = true;
  double min_normal_dot = 0.0;         ///< no fold-over: see the file comment (in [-1, 1])
  double min_dihedral_cos = -0.8;      ///< dihedral criterion: see the file comment (in [-1, 1])
  double min_quality = 0.1;            ///< shape criterion: see the file comment (in [0, 1])
  bool keep_level_meshes = false;      ///< also record each level's mesh as the simplification made it
  MtBuilder::Options build;            ///< passed to MtBuilder::build
};

/// One level of the simplification.
struct Simplify4kLevel {
  std::size_t faces = 0;       ///< faces of the level's mesh
  std::size_t vertices = 0;    ///< vertices used by its faces
  std::size_t collapses = 0;   ///< interior 4 -> 2 collapses that produced this level from the previous one
  std::size_t border_collapses = 0;  ///< border 2 -> 1 collapses
  std::size_t swaps = 0;       ///< 2 -> 2 swaps
  double max_error = 0.0;      ///< largest h over the level's faces (its one-sided distance bound)
};

/// What simplify4k() builds: the MT (the hierarchy) and a description of its levels.
struct Simplify4kResult {
  Mt mt;
  /// levels[0] is the input mesh (no modification), levels.back() the coarsest mesh (the MT source).
  std::vector<Simplify4kLevel> levels;
  /// Per MT node: the level whose construction made its modification (1..levels.size() - 1); 0 for the source.
  std::vector<std::uint16_t> node_level;
  std::size_t num_split_nodes = 0;    ///< kSplit nodes (collapses), border ones included
  std::size_t num_swap_nodes = 0;     ///< kSwap nodes
  std::size_t locked_vertices = 0;    ///< non-manifold input vertices, kept at every level
  /// With Simplify4kOptions::keep_level_meshes: levels.size() meshes made by the simplification itself
  /// (positions = the input's, faces in no particular order), an oracle for the MT fronts. Else empty.
  std::vector<TriMesh> level_meshes;

  std::size_t num_levels() const noexcept { return levels.size(); }
};

/// Simplifies `mesh` by four-face clusters (see the file comment) and returns the hierarchy.
///
/// Preconditions, checked (throws InvalidInput naming the element): mesh.validate() passes (indices in
/// range, finite positions); at least one face ("empty mesh"); fewer than 2^31 faces and vertices; the
/// manifold rules of a FourKMesh, find_topology_problem(mesh, kFourKMeshRules) (poly_mesh.hpp; the first
/// problem it finds, named by its TopologyProblem::element() in its words): no degenerate face (a repeated
/// corner), no directed edge used by two faces (a non-manifold edge or inconsistent orientation), no two
/// faces on one vertex triple; options in range. Non-manifold vertices are locked, unreferenced vertices ignored;
/// faces of zero area are accepted (steps never create one).
/// Cost: about O(F log F + L * V * p) time for F faces, V vertices and L levels, with p the cost of one plan
/// search (every ear order: up to a few hundred steps at degree 7); O(F) memory. The cow (5,804 faces) takes
/// about 0.3 s of CPU in a Release build, a 39k-face mesh a few seconds.
Simplify4kResult simplify4k(const TriMesh& mesh, const Simplify4kOptions& options = {});

/// The front of `level` (0 = the input mesh, result.num_levels() - 1 = the base): the nodes made at levels
/// above `level` are applied. The front refers to result.mt, which must outlive it and stay in place.
/// Throws InvalidInput when level >= result.num_levels(). O(MT size).
MtFront simplify4k_level_front(const Simplify4kResult& result, std::size_t level);
/// The front would refer to the temporary's Mt: refused at compile time.
MtFront simplify4k_level_front(const Simplify4kResult&& result, std::size_t level) = delete;

/// The mesh of `level` (see simplify4k_level_front) with compact vertex numbering, faces in no particular
/// order and corners as in the input's orientation; `vertex_ids` (optional) receives the input vertex of
/// each output vertex (to render the levels with the input's attributes). Throws InvalidInput when level is
/// out of range. O(MT size).
TriMesh simplify4k_level_mesh(const Simplify4kResult& result, std::size_t level,
                              std::vector<VertexId>* vertex_ids = nullptr);

/// The level whose face count is closest to `faces` (ties: the finer level), e.g. to pick the levels of
/// Figure 21 (about 1200, 700, 400, 300 and 200 faces on the cow). Throws InvalidInput on an empty result.
std::size_t simplify4k_closest_level(const Simplify4kResult& result, std::size_t faces);

}  // namespace varmesh
