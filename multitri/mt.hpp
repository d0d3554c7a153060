#pragma once
/// The Multi-Triangulation (Puppo 1998; De Floriani, Magillo, Puppo 1998; Velho-Gomes 2000, section 3):
/// an immutable DAG whose nodes are modifications of a triangle mesh and whose arcs are faces.
///
/// - Node 0 is the source: its image is the base mesh K0 and its pre-image is empty. The drain is implicit:
///   a face no node removes (destroyer() == kInvalid) belongs to the drain.
/// - Every other node removes its pre-image (faces created by earlier nodes) and creates its image. Kinds:
///   split (2 faces -> 4, or 1 -> 2 on a border), swap (2 -> 2), generic (k -> m).
/// - Nodes are numbered so that every parent precedes its children; faces are numbered by their creator,
///   so the image of node n is the face range [image_begin(n), image_end(n)).
///
/// Invariants (checked by MtBuilder::build and by validate()): every face is created by exactly one node
/// and removed by at most one; the DAG is acyclic (parents precede children); no two faces have the same three vertices (non-redundancy); every node's image has the same oriented
/// boundary as its pre-image and no interior edge of the pre-image survives in the image (minimally
/// compatible modification, section 3.1). Consequently every front (order ideal of nodes) is a conforming
/// mesh when the base mesh is.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/types.hpp"

namespace varmesh {

enum class NodeKind : std::uint8_t { kSource = 0, kSplit = 1, kSwap = 2, kGeneric = 3 };

const char* to_string(NodeKind kind) noexcept;

class Mt {
 public:
  Mt() = default;

  std::size_t num_nodes() const noexcept { return kind_.size(); }  ///< including the source
  std::size_t num_faces() const noexcept { return creator_.size(); }
  std::size_t num_vertices() const noexcept { return positions_.size(); }
  static constexpr NodeId source() noexcept { return 0; }

  NodeKind kind(NodeId n) const noexcept { return kind_[n]; }
  std::span<const FaceId> pre_image(NodeId n) const noexcept {
    return {pre_items_.data() + pre_offsets_[n], pre_offsets_[n + 1] - pre_offsets_[n]};
  }
  FaceId image_begin(NodeId n) const noexcept { return image_begin_[n]; }
  FaceId image_end(NodeId n) const noexcept { return image_begin_[n + 1]; }
  std::size_t image_size(NodeId n) const noexcept { return image_begin_[n + 1] - image_begin_[n]; }
  /// Distinct nodes that create a face of n's pre-image.
  std::span<const NodeId> parents(NodeId n) const noexcept {
    return {parent_items_.data() + parent_offsets_[n], parent_offsets_[n + 1] - parent_offsets_[n]};
  }
  /// Distinct nodes that remove a face of n's image.
  std::span<const NodeId> children(NodeId n) const noexcept {
    return {child_items_.data() + child_offsets_[n], child_offsets_[n + 1] - child_offsets_[n]};
  }

  std::array<VertexId, 3> face(FaceId f) const noexcept {
    return {corners_[3 * f], corners_[3 * f + 1], corners_[3 * f + 2]};
  }
  NodeId creator(FaceId f) const noexcept { return creator_[f]; }
  NodeId destroyer(FaceId f) const noexcept { return destroyer_[f]; }  ///< kInvalid: the drain

  const glm::vec3& position(VertexId v) const noexcept { return positions_[v]; }
  const std::vector<glm::vec3>& positions() const noexcept { return positions_; }
  const std::vector<Index>& corners() const noexcept { return corners_; }
  const ElementBound& bound(NodeId n) const noexcept { return bounds_[n]; }

  /// Re-checks every invariant listed above; throws InvalidInput naming the node or face. O(size log size).
  void validate() const;
  /// Bytes held by this structure's arrays.
  std::size_t memory_bytes() const noexcept;

 private:
  friend class MtBuilder;
  std::vector<glm::vec3> positions_;
  std::vector<Index> corners_;       // 3 per face
  std::vector<NodeId> creator_;      // per face
  std::vector<NodeId> destroyer_;    // per face
  std::vector<NodeKind> kind_;       // per node
  std::vector<Index> pre_offsets_, pre_items_;
  std::vector<FaceId> image_begin_;  // num_nodes + 1
  std::vector<Index> parent_offsets_, parent_items_;
  std::vector<Index> child_offsets_, child_items_;
  std::vector<ElementBound> bounds_;
};

/// Builds an Mt from modifications given in any order, checks the definition and renumbers.
///
/// Faces and nodes get builder-local ids from add_face / add_node. build() checks (throwing InvalidInput
/// that names the offending builder node or face): base set and every node non-empty; kind arity; every
/// face created exactly once and removed at most once; no face removed by its own creator; no degenerate
/// face; non-redundancy (two faces with one vertex triple); minimal compatibility (same oriented boundary,
/// interior edges replaced); acyclicity. Then it numbers nodes parents-first and faces by creator, computes
/// bounds (sphere and normal cone of each node's pre-image and image, the caller's error) and, unless told
/// not to, saturates them so that bounds are nested (see bounds.hpp).
class MtBuilder {
 public:
  VertexId add_vertex(const glm::vec3& p);
  FaceId add_face(VertexId a, VertexId b, VertexId c);
  /// The source's image: the base mesh. Call once.
  void set_base(std::span<const FaceId> faces);
  /// `error`: approximation error of the pre-image w.r.t. the finest data (>= 0), in object units.
  NodeId add_node(NodeKind kind, std::span<const FaceId> removed, std::span<const FaceId> created, float error);

  std::size_t num_vertices() const noexcept { return positions_.size(); }
  std::size_t num_faces() const noexcept { return corners_.size() / 3; }

  struct Options {
    bool saturate = true;        ///< nest spheres, errors and cones (required for exact update == extract)
    bool check_geometry = true;  ///< minimal-compatibility check of every node
  };
  /// Consumes the builder. `node_new_to_old` / `face_new_to_old` (optional) receive the renumbering maps.
  Mt build(const Options& options, std::vector<NodeId>* node_new_to_old = nullptr,
           std::vector<FaceId>* face_new_to_old = nullptr) &&;
  Mt build() && { return std::move(*this).build(Options{}); }

 private:
  std::vector<glm::vec3> positions_;
  std::vector<Index> corners_;
  std::vector<FaceId> base_;
  bool has_base_ = false;
  std::vector<NodeKind> kinds_;
  std::vector<float> errors_;
  std::vector<Index> removed_offsets_{0}, removed_items_;
  std::vector<Index> created_offsets_{0}, created_items_;
};

}  // namespace varmesh
