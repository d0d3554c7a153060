#pragma once
/// The vertex hierarchy of a progressive mesh (Hoppe 1997; Kim-Lee 2001, sections 3-4): the record of a
/// sequence of full-edge collapses ecol_i(vs, vt, vu, vl, vr) from the original mesh M^ to a base mesh M^0.
///
/// Numbering. Leaves 0 .. num_leaves()-1 are the vertices of the original mesh M^ (after the repair of
/// manifold_input.hpp; leaf_to_input() maps them back). Collapse i creates node vs = num_leaves() + i, the
/// parent of its two children vt and vu. Roots (nodes without a parent) are the vertices of the base mesh.
/// Original faces are numbered 0 .. num_faces()-1 and never renumbered: a face of any selectively refined
/// mesh *is* an original face whose three corners currently have three distinct active ancestors (section
/// 4.2), so face ids are stable across every scheme and operation.
///
/// Per collapse (Kim-Lee section 4.2): vt, vu, the fundamental cut vertices vl^, vr^ (leaves: corners of the
/// original faces fl^, fr^ that became fl, fr), the original faces fl^, fr^ (kInvalid on the border side);
/// Hoppe 1997's four neighbour faces fn0..fn3 (original face ids; kInvalid where absent) and Xia-Varshney
/// 1996's stored 1-ring of vs in M^i (node ids), so that the three schemes of sr_mesh.hpp can run on one
/// hierarchy. Per node: position (and colour), a bounding sphere and normal cone of its region, an error
/// (object units), and the 64-bit <tree-id, node-id> key of section 4.3.
///
/// Invariants (validate()): finite positions and bounds (radius and error >= 0), parent/children consistent,
/// children created before parents, keys consistent with the tree shape, bounds nested (child sphere inside
/// parent sphere up to rounding, child error <= parent error, child cone inside parent cone up to 2e-3
/// radians), faces' corners are leaves, fl^/fr^ contain vl^/vr^ and one descendant of each child; and the
/// topology, by replaying the collapses on the original faces: the original mesh is an
/// oriented 2-manifold with border (no repeated corner, each directed edge once, each vertex one fan, no two
/// faces on the same corners), and each record, in node order, is a legal full-edge collapse of its current
/// mesh as the analysis makes them: vt and vu share exactly the faces fl^ (holding vt -> vu) and fr^ (vu ->
/// vt), whose third corners are the ancestors of vl^ and vr^; the link condition holds (their only common
/// neighbours are those corners, an interior edge does not join two border vertices, an apex keeps a face, no
/// tetrahedron); fn0..fn3 are the faces across (vu, vl), (vl, vt), (vt, vr), (vr, vu); the stored ring is the
/// set of vs's neighbours afterwards; and the faces left at the end are the base mesh. Then each leaf's cone
/// holds its faces' normals (up to 1e-4 in the cosine), locked leaves are never collapsed, and no two faces
/// come from one input face. Up to geometry, a hierarchy that passes is one the analysis could have built,
/// which is what SrMesh's three schemes rely on.
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/detail/assert.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// One edge collapse ecol_i(vs, vt, vu, vl, vr) with the topological details of the three schemes.
struct CollapseRecord {
  Index vt = kInvalid, vu = kInvalid;          ///< children of vs (node ids)
  Index vl_hat = kInvalid, vr_hat = kInvalid;  ///< fundamental cut vertices (leaves); kInvalid on a border side
  Index fl_hat = kInvalid, fr_hat = kInvalid;  ///< original faces (vt, vu, vl) and (vu, vt, vr) at collapse time
  std::array<Index, 4> fn{kInvalid, kInvalid, kInvalid, kInvalid};  ///< Hoppe 1997: faces across fl's edges
  ///< (vu,vl), (vl,vt) then fr's edges (vt,vr), (vr,vu), as original face ids; kInvalid across a border
};

/// <tree-id, node-id> packing of Kim-Lee section 4.3. The node part is a heap index (root 1, children 2k and
/// 2k+1) of node_bits bits; the tree part (a root's index) sits above it.
struct NodeKey {
  std::uint64_t value = 0;
};

/// O(1) ancestor test by shifts (Kim-Lee section 4.3): is a an ancestor of b (or b itself)?
/// `node_bits` is VertexHierarchy::node_bits().
inline bool is_ancestor_or_self(NodeKey a, NodeKey b, int node_bits) noexcept {
  if ((a.value >> node_bits) != (b.value >> node_bits)) return false;
  const std::uint64_t mask = (node_bits >= 64) ? ~0ull : ((1ull << node_bits) - 1ull);
  const std::uint64_t na = a.value & mask, nb = b.value & mask;
  const int la = static_cast<int>(std::bit_width(na)), lb = static_cast<int>(std::bit_width(nb));
  return la <= lb && (nb >> (lb - la)) == na;
}

/// How the input was turned into the manifold original mesh M^ (manifold_input.hpp fills it).
struct InputRepairReport {
  std::size_t input_vertices = 0, input_faces = 0;
  std::size_t unreferenced_vertices = 0;  ///< dropped
  std::size_t degenerate_faces = 0;       ///< dropped (a repeated corner)
  std::size_t duplicate_faces = 0;        ///< dropped (same three corners as an earlier face, any order)
  std::size_t nonmanifold_edge_faces = 0; ///< faces detached from an edge used by > 2 faces or twice in one direction
  std::size_t nonmanifold_vertices = 0;   ///< vertices whose face fans were split into separate copies
  std::size_t added_vertex_copies = 0;    ///< leaves created by the two splits above
  std::size_t locked_vertices = 0;        ///< copies locked (NonManifoldPolicy::kLock): never collapsed
};

/// The immutable hierarchy. Built by build_vertex_hierarchy (qem_analysis.hpp), saved and loaded by
/// hierarchy_io.hpp; read by SrMesh (sr_mesh.hpp) and the dual-piece oracle (dual_pieces.hpp).
///
/// A default-constructed hierarchy is empty (no node, no face); so is a moved-from one. The accessors that
/// take an id are unchecked, as std::vector::operator[] is: each states the range its id must be in, and
/// VARMESH_ASSERT checks it in debug and sanitizer builds. Const members only read: threads may share a
/// hierarchy freely.
class VertexHierarchy {
 public:
  VertexHierarchy() = default;
  VertexHierarchy(const VertexHierarchy&) = default;
  VertexHierarchy& operator=(const VertexHierarchy&) = default;
  /// Leaves `other` empty, as default-constructed.
  VertexHierarchy(VertexHierarchy&& other) noexcept { swap(other); }
  VertexHierarchy& operator=(VertexHierarchy&& other) noexcept {
    if (this != &other) {
      VertexHierarchy taken(std::move(other));
      swap(taken);
    }
    return *this;
  }
  ~VertexHierarchy() = default;

  std::size_t num_leaves() const noexcept { return num_leaves_; }
  std::size_t num_nodes() const noexcept { return positions_.size(); }
  std::size_t num_collapses() const noexcept { return records_.size(); }
  std::size_t num_faces() const noexcept { return faces_.size() / 3; }
  std::size_t num_roots() const noexcept { return roots_.size(); }

  /// Any v (no access): v < num_leaves().
  bool is_leaf(Index v) const noexcept { return v < num_leaves_; }
  /// Collapse record of non-leaf node vs. Unchecked: num_leaves() <= vs < num_nodes().
  const CollapseRecord& record(Index vs) const noexcept {
    VARMESH_ASSERT(vs >= num_leaves_ && vs < positions_.size());
    return records_[vs - num_leaves_];
  }
  /// kInvalid for a root. Unchecked: v < num_nodes().
  Index parent(Index v) const noexcept {
    VARMESH_ASSERT(v < parent_.size());
    return parent_[v];
  }
  /// Children of non-leaf node vs. Unchecked: num_leaves() <= vs < num_nodes().
  Index vt(Index vs) const noexcept { return record(vs).vt; }
  Index vu(Index vs) const noexcept { return record(vs).vu; }
  /// The other child of v's parent; kInvalid for a root. Unchecked: v < num_nodes().
  Index sibling(Index v) const noexcept {
    const Index p = parent(v);
    return p == kInvalid ? kInvalid : (vt(p) == v ? vu(p) : vt(p));
  }
  /// Original face f: three leaves, counter-clockwise. Unchecked: f < num_faces().
  std::array<Index, 3> face(Index f) const noexcept {
    VARMESH_ASSERT(f < num_faces());
    return {faces_[3 * f], faces_[3 * f + 1], faces_[3 * f + 2]};
  }
  std::span<const Index> face_corners() const noexcept { return faces_; }
  /// The node whose vsplit creates original face f (the vs whose fl^ or fr^ is f); kInvalid for base faces.
  /// Unchecked: f < num_faces().
  Index face_creator(Index f) const noexcept {
    VARMESH_ASSERT(f < face_creator_.size());
    return face_creator_[f];
  }
  std::span<const Index> roots() const noexcept { return roots_; }
  /// Base mesh M^0: original faces whose corners have three distinct roots, relabelled by the roots.
  std::span<const Index> base_faces() const noexcept { return base_faces_; }

  /// Unchecked: v < num_nodes().
  const glm::vec3& position(Index v) const noexcept {
    VARMESH_ASSERT(v < positions_.size());
    return positions_[v];
  }
  std::span<const glm::vec3> positions() const noexcept { return positions_; }
  bool has_colors() const noexcept { return !colors_.empty(); }
  /// Unchecked: has_colors() and v < num_nodes().
  const glm::vec3& color(Index v) const noexcept {
    VARMESH_ASSERT(v < colors_.size());
    return colors_[v];
  }
  std::span<const glm::vec3> colors() const noexcept { return colors_; }
  /// Sphere, cone and error of node v (nested: a parent's bound contains its children's). Unchecked:
  /// v < num_nodes().
  const ElementBound& bound(Index v) const noexcept {
    VARMESH_ASSERT(v < bounds_.size());
    return bounds_[v];
  }
  /// Xia-Varshney 1996 topological detail: the 1-ring of vs in M^i right after collapse i. Unchecked:
  /// num_leaves() <= vs < num_nodes().
  std::span<const Index> stored_ring(Index vs) const noexcept {
    VARMESH_ASSERT(vs >= num_leaves_ && vs < positions_.size());
    const std::size_t i = vs - num_leaves_;
    return {ring_items_.data() + ring_offsets_[i], ring_items_.data() + ring_offsets_[i + 1]};
  }

  /// Unchecked: v < num_nodes().
  NodeKey key(Index v) const noexcept {
    VARMESH_ASSERT(v < keys_.size());
    return keys_[v];
  }
  int node_bits() const noexcept { return node_bits_; }
  /// O(1): is a an ancestor of b, or b itself (Kim-Lee section 4.3)? Unchecked: a, b < num_nodes().
  bool is_ancestor_or_self(Index a, Index b) const noexcept {
    return varmesh::is_ancestor_or_self(key(a), key(b), node_bits_);
  }
  /// Depth of v below its root (0 for a root). O(1). Unchecked: v < num_nodes().
  int depth(Index v) const noexcept;
  /// Largest depth of any node.
  int max_depth() const noexcept { return node_bits_ - 1; }

  /// Leaf -> vertex of the mesh given to the analysis (several leaves may share one when a non-manifold
  /// vertex was split); original face -> input face.
  std::span<const Index> leaf_to_input() const noexcept { return leaf_to_input_; }
  std::span<const Index> face_to_input() const noexcept { return face_to_input_; }
  /// Leaves that the analysis was told never to collapse (non-manifold copies under NonManifoldPolicy::kLock).
  /// Unchecked: leaf < num_leaves().
  bool is_locked(Index leaf) const noexcept {
    VARMESH_ASSERT(leaf < num_leaves_);
    return !locked_.empty() && locked_[leaf] != 0;
  }
  const InputRepairReport& repair_report() const noexcept { return repair_; }

  /// Checks the invariants of the header comment. Throws std::logic_error (not InvalidInput: a failure is
  /// a broken invariant, a bug of the analysis or an edited file that the reader would have refused)
  /// naming the first broken one. An empty hierarchy passes. O(nodes + faces) for the records, plus the
  /// replay of the collapses: O(sum over collapses of the faces around both ends).
  ///
  /// `threads`: 1 runs every check on the caller's thread, in the order of the header comment; 2 splits the
  /// work with a second thread (the replay in two parts, the second starting from the mesh the first must
  /// leave); 0 (the default) takes 2 for hierarchies of 2^17 collapses or more on a machine with two cores or
  /// more, else 1. Any value gives the same outcome: the same error, the first a serial run meets.
  void validate(unsigned threads = 0) const;
  /// Bytes held by the arrays the synthesis phase reads.
  std::size_t memory_bytes() const noexcept;

 private:
  friend class VertexHierarchyBuilder;
  friend struct HierarchyFileAccess;

  // The parts of validate() around the replay of the collapses (which vertex_hierarchy.cpp's Replay does):
  // before it, the nodes and records; after it, the leaves' cones and the maps.
  void check_nodes() const;
  void check_leaf_geometry() const;
  // Exchanges every member below: a member added there must be added here.
  void swap(VertexHierarchy& other) noexcept;

  std::size_t num_leaves_ = 0;
  std::vector<glm::vec3> positions_;
  std::vector<glm::vec3> colors_;
  std::vector<Index> parent_;
  std::vector<CollapseRecord> records_;
  std::vector<Index> faces_;
  std::vector<Index> face_creator_;
  std::vector<Index> roots_;
  std::vector<Index> base_faces_;
  std::vector<ElementBound> bounds_;
  std::vector<Index> ring_offsets_, ring_items_;  // offsets: empty or num_collapses() + 1
  std::vector<NodeKey> keys_;
  int node_bits_ = 1;
  std::vector<Index> leaf_to_input_, face_to_input_;
  std::vector<std::uint8_t> locked_;
  InputRepairReport repair_;
};

/// Assembles a VertexHierarchy from its raw arrays and derives the rest (parents, face creators, roots,
/// base faces, keys). Used by the analysis and by the file reader.
class VertexHierarchyBuilder {
 public:
  struct Raw {
    std::size_t num_leaves = 0;
    std::vector<glm::vec3> positions;  ///< per node
    std::vector<glm::vec3> colors;     ///< per node or empty
    std::vector<CollapseRecord> records;
    std::vector<Index> faces;          ///< 3 leaves per original face
    std::vector<ElementBound> bounds;  ///< per node
    std::vector<Index> ring_offsets{0}, ring_items;
    std::vector<Index> leaf_to_input, face_to_input;
    std::vector<std::uint8_t> locked;  ///< per leaf or empty
    InputRepairReport repair;
  };
  /// Throws InvalidInput naming the element when the arrays do not describe a hierarchy (wrong sizes,
  /// indices out of range, a node with two parents, children after parents, a tree deeper than 62 levels
  /// together with the tree ids in 64 bits, fl^/fr^ inconsistent with the tree). With `validate`, then
  /// checks the result with VertexHierarchy::validate() (std::logic_error): the file reader does; the
  /// analysis, whose records hold these invariants by construction, does so in debug builds only (its tests
  /// validate every hierarchy they build). `trusted` skips the checks that only the reader of an untrusted
  /// file needs (the maps back to the input, the repair report's counts, finite positions inside their
  /// spheres, leaves' spheres holding their faces, Hoppe's and Xia-Varshney's references): the analysis sets
  /// it, having built those by construction; sizes, the tree and the keys are checked in any case.
  static VertexHierarchy finish(Raw raw, bool validate = true, bool trusted = false);
};

}  // namespace varmesh
