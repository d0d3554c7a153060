#pragma once
/// The hierarchical 4-k structure of Velho-Gomes 2000, section 7.1, in index form: the paper's Face
/// (three half-edges, a parent, two children) and half-edge (point, mate, fbase), for a hierarchy built
/// by internal edge splits (2 faces -> 4, or 1 -> 2 on the border) and internal edge swaps (2 -> 2).
///
/// Layout (no pointers; DESIGN.md "Storage habits"). Faces are numbered in creation order: the base mesh
/// K0 is faces [0, num_base_faces()), every later face is created by a modification. Face f owns the
/// half-edges 3f, 3f + 1, 3f + 2 ("edge[0..2]" of the paper): half-edge 3f + k starts at corner k
/// (point(3f + k)) and ends at corner (k + 1) % 3, so fbase(h) = h / 3 needs no storage. edge[0] is the
/// face's split edge (split_edge(f) = 3f) and corner 2 its apex. Children of a split are created with
/// their edges cyclically shifted so that edge[0] is the edge opposite the new vertex (newest-vertex
/// bisection), as the paper prescribes; a modification applied to another edge of a current face first
/// shifts that face (and its mate's face) cyclically, which only a current face allows.
///
/// Modifications (section 7.1, Figures 12 and 13), for the current faces f = (a, b, c) with edge[0] = a->b
/// and g = (b, a, d) with edge[0] = b->a (g absent when a->b is on the border):
/// - split with new vertex m on a-b: f.children = {(c, a, m), (b, c, m)}, g.children = {(d, b, m), (a, d, m)};
///   a border split has no g (1 face -> 2). children[0] holds the parent's corner 0.
/// - swap (interior edges only): f.children = {(d, c, a), kInvalid}, g.children = {(c, d, b), kInvalid}: the
///   new edge c-d is edge[0] of both; each face has one child, which is how the paper tells a swap apart
///   (modification_type()).
/// A modification is named by the half-edge edge[0] of either face of its pre-image (the paper's W(e));
/// the one passed to split()/swap() (after the cyclic shift) is logged in modifications().
///
/// Invariants (validate() checks all of them):
/// 1. array sizes agree; corners are vertices; no face has a repeated corner; positions are finite;
///    errors are finite and >= 0;
/// 2. faces [0, num_base_faces()) have no parent; every other face has a parent numbered before it;
/// 3. a face is current (in the finest mesh) iff children[0] == kInvalid, and then children[1] == kInvalid;
///    every child names its parent back;
/// 4. current faces: a mate links two current half-edges with reversed endpoints (mate(mate(h)) == h);
///    no directed edge is used twice; a half-edge without mate has no reversed twin among current faces
///    (it is on the border of the current mesh);
/// 5. removed faces: mate(edge[0]) is the partner's edge[0] (mutual, reversed endpoints) or kInvalid for a
///    border split; the partner has the same kind (both one child: swap; both two: split); mates of
///    edge[1] and edge[2] are kInvalid (they were only meaningful while the face was current);
/// 6. children have the corners listed above, up to a cyclic shift of a child that is still current (one
///    new vertex shared by all children of a split, not a corner of the pre-image); the log lists every
///    modification once.
/// Every modification is then minimally compatible (section 3.1), so to_mt() yields a valid
/// Multi-Triangulation unless a swap recreated a face that existed before (non-redundancy), which
/// MtBuilder::build reports.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/detail/assert.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Half-edge of a FourKMesh: 3 * face + k.
using HalfEdgeId = Index;

/// Up to four faces: the pre-image (1 or 2) or image (2 or 4) of a modification.
struct FourKFaceSet {
  std::array<FaceId, 4> faces{kInvalid, kInvalid, kInvalid, kInvalid};
  std::size_t size = 0;

  std::span<const FaceId> span() const noexcept { return {faces.data(), size}; }
  const FaceId* begin() const noexcept { return faces.data(); }
  const FaceId* end() const noexcept { return faces.data() + size; }
};

/// What to_mt() produced, relative to the FourKMesh (vertices keep their numbers).
struct FourKMtMap {
  std::vector<HalfEdgeId> node_edge;  ///< per Mt node: the modification's logged half-edge; kInvalid for the source
  std::vector<FaceId> face;           ///< per Mt face: the FourKMesh face
};

/// A 4-k hierarchy under construction and its current (finest) mesh; see the header comment.
class FourKMesh {
 public:
  FourKMesh() = default;
  /// Takes `base` as K0 (face i = base face i, same corner order; vertex i = base vertex i). Throws
  /// InvalidInput naming the element when base.validate() fails, the mesh has no face, or
  /// find_topology_problem(base, kFourKMeshRules) (poly_mesh.hpp) finds a problem: a face repeats a corner,
  /// an edge has three faces or two that run it in the same direction, two faces have the same three
  /// vertices (the first problem in that function's order; the element is TopologyProblem::element()).
  /// Non-manifold vertices, zero-area faces and unreferenced vertices are accepted. O(F log F).
  explicit FourKMesh(const TriMesh& base);

  std::size_t num_vertices() const noexcept { return positions_.size(); }
  std::size_t num_faces() const noexcept { return parent_.size(); }  ///< all faces ever created
  std::size_t num_half_edges() const noexcept { return point_.size(); }
  std::size_t num_base_faces() const noexcept { return num_base_faces_; }
  std::size_t num_current_faces() const noexcept { return num_current_; }
  std::size_t num_modifications() const noexcept { return log_.size(); }
  /// The modifications in the order they were applied (each named by its logged half-edge).
  std::span<const HalfEdgeId> modifications() const noexcept { return log_; }

  static constexpr HalfEdgeId edge(FaceId f, int k) noexcept { return 3 * f + static_cast<Index>(k); }
  static constexpr FaceId fbase(HalfEdgeId h) noexcept { return h / 3; }
  static constexpr HalfEdgeId next(HalfEdgeId h) noexcept { return h % 3 == 2 ? h - 2 : h + 1; }
  static constexpr HalfEdgeId prev(HalfEdgeId h) noexcept { return h % 3 == 0 ? h + 2 : h - 1; }
  // The accessors below that take an id are unchecked, as std::vector::operator[] (VARMESH_ASSERT in debug
  // and sanitizer builds): h < num_half_edges(), f < num_faces(), v < num_vertices().

  /// Origin vertex of h (the paper's Hedge::point). Unchecked: h < num_half_edges().
  VertexId point(HalfEdgeId h) const noexcept {
    VARMESH_ASSERT(h < point_.size());
    return point_[h];
  }
  /// End vertex of h. Unchecked: h < num_half_edges().
  VertexId target(HalfEdgeId h) const noexcept {
    VARMESH_ASSERT(h < point_.size());
    return point_[next(h)];
  }
  /// The opposite half-edge (see invariants 4 and 5); kInvalid on the border. Unchecked: h < num_half_edges().
  HalfEdgeId mate(HalfEdgeId h) const noexcept {
    VARMESH_ASSERT(h < mate_.size());
    return mate_[h];
  }

  /// Corners of face f. Unchecked: f < num_faces().
  std::array<VertexId, 3> face(FaceId f) const noexcept {
    VARMESH_ASSERT(f < parent_.size());
    return {point_[3 * f], point_[3 * f + 1], point_[3 * f + 2]};
  }
  /// kInvalid for a base face. Unchecked: f < num_faces().
  FaceId parent(FaceId f) const noexcept {
    VARMESH_ASSERT(f < parent_.size());
    return parent_[f];
  }
  /// children[i] of the paper, i in {0, 1}; kInvalid when absent. Unchecked: f < num_faces(), i in {0, 1}.
  FaceId child(FaceId f, int i) const noexcept {
    VARMESH_ASSERT(f < parent_.size() && (i == 0 || i == 1));
    return children_[2 * f + static_cast<Index>(i)];
  }
  /// Unchecked: f < num_faces().
  bool is_current(FaceId f) const noexcept {
    VARMESH_ASSERT(f < parent_.size());
    return children_[2 * f] == kInvalid;
  }
  /// split_edge(f) := f.edge[0].
  static constexpr HalfEdgeId split_edge(FaceId f) noexcept { return 3 * f; }
  /// Unchecked: v < num_vertices().
  const glm::vec3& position(VertexId v) const noexcept {
    VARMESH_ASSERT(v < positions_.size());
    return positions_[v];
  }
  std::span<const glm::vec3> positions() const noexcept { return positions_; }
  /// Error of the modification that removes f (0 while f is current). Unchecked: f < num_faces().
  float error(FaceId f) const noexcept {
    VARMESH_ASSERT(f < error_.size());
    return error_[f];
  }

  /// True when e is edge[0] of a removed face, i.e. names a modification. O(1).
  bool is_modification(HalfEdgeId e) const noexcept { return e < point_.size() && e % 3 == 0 && !is_current(fbase(e)); }
  /// pre_image_w(e) = {e.fbase, e.mate.fbase} (one face for a border split). Precondition:
  /// is_modification(e) (throws InvalidInput otherwise). O(1).
  FourKFaceSet pre_image(HalfEdgeId e) const;
  /// image_w(e): {e.fbase.children[0..1], e.mate.fbase.children[0..1]} for a split, {e.fbase.children[0],
  /// e.mate.fbase.children[0]} for a swap (the paper prints children[1] for the mate, which is NULL for a
  /// swap face; children[0] is meant). Precondition as pre_image. O(1).
  FourKFaceSet image(HalfEdgeId e) const;
  /// successor_f(f) = split_edge(f): the modification that removes f, or kInvalid when f is current
  /// (it belongs to the drain). O(1). Unchecked: f < num_faces().
  HalfEdgeId successor(FaceId f) const noexcept { return is_current(f) ? kInvalid : split_edge(f); }
  /// predecessor_f(f) = split_edge(f.parent): the modification that created f, kInvalid for a base face
  /// (created by the source). O(1). Unchecked: f < num_faces().
  HalfEdgeId predecessor(FaceId f) const noexcept { return parent(f) == kInvalid ? kInvalid : split_edge(parent_[f]); }
  /// modification_type(e): NodeKind::kSwap when e.fbase and e.mate.fbase both have no second child, else
  /// NodeKind::kSplit. Precondition as pre_image. O(1).
  NodeKind modification_type(HalfEdgeId e) const;

  /// Internal edge split (Figure 12) of the current half-edge h at a new vertex placed at `position`, with
  /// node error `error` (object units, >= 0: the approximation error of the pre-image). Splits the face of
  /// h and, unless h is on the border, the face of mate(h); both are first shifted cyclically so h is
  /// their edge[0]. Returns the new vertex. Throws InvalidInput naming h when h is out of range or its face
  /// is not current, when `position` is not finite or `error` is negative or not finite, or when the
  /// structure would exceed 2^32 half-edges. O(1) amortised.
  VertexId split(HalfEdgeId h, const glm::vec3& position, float error = 0.0f);
  /// Internal edge swap (Figure 13) of the interior current half-edge h: a->b becomes c-d. Throws
  /// InvalidInput naming h unless can_swap(h) (or for a bad error value, as split). Geometry (the paper's
  /// convexity remark) is the caller's business. A swap that recreates a face that existed before
  /// (swapping back) is recorded, but to_mt() then rejects the hierarchy as redundant (section 3.1).
  /// O(valence of c and d).
  void swap(HalfEdgeId h, float error = 0.0f);
  /// h is a current interior half-edge whose opposite corners c, d differ and are not joined by an edge
  /// (checked in the umbrellas of c and d reached through mates; at a non-manifold vertex an edge in
  /// another umbrella is missed, and validate() reports the duplicate edge). O(valence).
  bool can_swap(HalfEdgeId h) const noexcept;
  /// Sets the error of the modification named by e (on every face of its pre-image), e.g. once the new
  /// vertex is known. Throws InvalidInput unless is_modification(e) and error is finite and >= 0. O(1).
  void set_error(HalfEdgeId e, float error);

  /// Faces with no children, in increasing order. O(F).
  std::vector<FaceId> current_faces() const;
  /// The current mesh with the FourKMesh's vertex numbering (unreferenced vertices included);
  /// `face_ids` (optional) receives the FourKMesh face of each output face. O(F).
  TriMesh current_mesh(std::vector<FaceId>* face_ids = nullptr) const;

  /// The hierarchy as a Multi-Triangulation: source image = the base faces, one node per modification
  /// (kSplit or kSwap) with the node error given to split()/swap() (the larger of the two faces' values).
  /// Mt vertex v = vertex v here. `map` (optional) receives node and face provenance. Throws what
  /// MtBuilder::build throws (e.g. a redundant face after a swap back). O(F log F).
  Mt to_mt(const MtBuilder::Options& options = {}, FourKMtMap* map = nullptr) const;

  /// Checks every invariant of the header comment; throws InvalidInput naming the first offending face
  /// or half-edge. O(F log F).
  void validate() const;
  /// Bytes held by the arrays.
  std::size_t memory_bytes() const noexcept;
  /// Reserves room for `faces` faces and `vertices` vertices in total.
  void reserve(std::size_t faces, std::size_t vertices);

 private:
  void check_current_half_edge(HalfEdgeId h, const char* op) const;
  void check_error(HalfEdgeId h, float error, const char* op) const;
  void check_capacity(std::size_t new_faces, HalfEdgeId h, const char* op) const;
  void rotate(FaceId f, int k);  // cyclic shift: new edge[i] = old edge[(i + k) % 3]
  FaceId new_face(VertexId a, VertexId b, VertexId c, FaceId parent);
  void adopt_outer(HalfEdgeId from, HalfEdgeId to);  // `to` takes the place of `from` opposite its mate
  void link(HalfEdgeId x, HalfEdgeId y) noexcept {
    mate_[x] = y;
    mate_[y] = x;
  }
  void retire(FaceId f, FaceId c0, FaceId c1, float error);
  bool has_edge_near(HalfEdgeId out_of_c, VertexId d) const noexcept;  // d joined to out_of_c's origin?

  std::vector<glm::vec3> positions_;
  std::vector<VertexId> point_;    // 3 per face
  std::vector<HalfEdgeId> mate_;   // 3 per face
  std::vector<FaceId> parent_;     // 1 per face
  std::vector<FaceId> children_;   // 2 per face
  std::vector<float> error_;       // 1 per face
  std::vector<HalfEdgeId> log_;    // 1 per modification
  std::size_t num_base_faces_ = 0;
  std::size_t num_current_ = 0;
};

}  // namespace varmesh
