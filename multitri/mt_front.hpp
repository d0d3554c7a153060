#pragma once
/// A front on an immutable Mt: the state of one extraction (which nodes are applied).
///
/// Invariants (validate()): the applied nodes form an order ideal of the DAG containing the source (every
/// parent of an applied node is applied); the current faces are exactly the faces created by an applied node
/// and not removed by an applied node; the current mesh is conforming. Many fronts may share one Mt.
///
/// Moves: apply/undo are single legal steps (they throw InvalidInput when illegal); refine/coarsen force
/// what they need (refining applies missing ancestors first, coarsening undoes applied descendants first).
/// All four throw InvalidInput naming the node when it is not a node of the Mt.
/// Cost: O(faces changed) per node; legality tests O(faces of the node) from the face table, so a front
/// holds no per-node counters. The front keeps its refine candidates (unapplied nodes with a pre-image face
/// in the front) and coarsen candidates (undoable nodes) in two lists maintained by apply/undo, so that a
/// query lists them in O(their number) instead of walking every face of the front.
///
/// Lifetime: a front keeps a pointer to its Mt, which must outlive it (and not move). Constructing a front
/// from a temporary Mt does not compile.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "multitri/detail/assert.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh {

class MtFront {
 public:
  /// The coarsest front: only the source applied (the base mesh). The front refers to `mt` (see the file
  /// comment). Throws InvalidInput when mt has no node (default-constructed or moved-from).
  explicit MtFront(const Mt& mt);
  /// A front would dangle on a temporary Mt.
  explicit MtFront(const Mt&& mt) = delete;

  const Mt& mt() const noexcept { return *mt_; }

  // is_applied, can_apply, can_undo, is_refined, is_coarsenable and element_bound are unchecked:
  // n < mt().num_nodes(); has_face: f < mt().num_faces() (as vector::operator[]; VARMESH_ASSERT in debug and
  // sanitizer builds). The moves (apply, undo, refine, coarsen) check and throw.

  bool is_applied(NodeId n) const noexcept {
    VARMESH_ASSERT(n < applied_.size());
    return applied_[n] != 0;
  }
  /// Legal when not applied and every pre-image face is current (a pre-image face is absent exactly when
  /// its creator is not applied, since its only remover is n). O(pre-image size), no per-node counters.
  bool can_apply(NodeId n) const noexcept {
    VARMESH_ASSERT(n < applied_.size());
    if (applied_[n]) return false;
    for (FaceId g : mt_->pre_image(n))
      if (!has_face(g)) return false;
    return true;
  }
  /// Legal when applied and every image face is current (none removed by an applied child).
  bool can_undo(NodeId n) const noexcept {
    VARMESH_ASSERT(n < applied_.size());
    if (n == 0 || !applied_[n]) return false;
    for (FaceId f = mt_->image_begin(n); f < mt_->image_end(n); ++f)
      if (!has_face(f)) return false;
    return true;
  }

  void apply(NodeId n);
  void undo(NodeId n);
  /// Applies n after its missing ancestors; calls sink(m) for each node applied, in order. No-op if applied.
  template <class Sink>
  void refine(NodeId n, Sink&& sink);
  void refine(NodeId n) { refine(n, [](NodeId) {}); }
  /// Undoes n after its applied descendants; calls sink(m) for each node undone. No-op if not applied.
  template <class Sink>
  void coarsen(NodeId n, Sink&& sink);
  void coarsen(NodeId n) { coarsen(n, [](NodeId) {}); }
  /// Back to the base mesh.
  void reset();

  std::size_t num_faces() const noexcept { return faces_.size(); }
  std::size_t num_applied() const noexcept { return num_applied_; }
  std::span<const FaceId> faces() const noexcept { return faces_; }
  bool has_face(FaceId f) const noexcept {
    VARMESH_ASSERT(f < slot_.size());
    return slot_[f] != kInvalid;
  }

  /// The current mesh with compact vertex numbering; `face_ids` (optional) receives the Mt face of each
  /// output face, `vertex_ids` the Mt vertex of each output vertex.
  TriMesh to_mesh(std::vector<FaceId>* face_ids = nullptr, std::vector<VertexId>* vertex_ids = nullptr) const;

  /// Throws InvalidInput naming the first violated invariant. O(nodes + faces).
  void validate() const;

  // The RefinableFront interface used by extract()/update() (query.hpp).
  ElementBound element_bound(NodeId n) const noexcept { return mt_->bound(n); }
  bool is_refined(NodeId n) const noexcept { return is_applied(n); }
  std::uint64_t tie_key(NodeId n) const noexcept { return n; }
  /// Each node that is not applied and has a pre-image face in the front, once (fn must not move the front).
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const {
    for (NodeId d : refine_set_.list) fn(d);
  }
  template <class Fn> void for_each_child_candidate(NodeId n, Fn&& fn) const {
    for (NodeId c : mt_->children(n)) fn(c);
  }
  bool is_coarsenable(NodeId n) const noexcept { return can_undo(n); }
  /// Each node that can be undone (applied, whole image in the front; never the source), once (fn must not
  /// move the front).
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const {
    for (NodeId c : coarsen_set_.list) fn(c);
  }
  template <class Fn> void for_each_parent_candidate(NodeId n, Fn&& fn) const {
    for (NodeId p : mt_->parents(n)) fn(p);
  }
  void coarsen_one(NodeId n) { undo(n); }

  /// Calls fn(face, a, b, c) for every current face with its corner positions (spatial queries).
  template <class Fn> void for_each_face_geometry(Fn&& fn) const {
    for (FaceId f : faces_) {
      const auto v = mt_->face(f);
      fn(f, mt_->position(v[0]), mt_->position(v[1]), mt_->position(v[2]));
    }
  }

 private:
  void check_node(NodeId n, const char* move) const;
  void add_face(FaceId f);
  void remove_face(FaceId f);
  // An unordered set of nodes: a list and each node's position in it (kInvalid when absent).
  struct NodeSet {
    std::vector<NodeId> list;
    std::vector<Index> pos;
    bool contains(NodeId n) const noexcept { return pos[n] != kInvalid; }
    void insert(NodeId n) {
      if (pos[n] != kInvalid) return;
      pos[n] = static_cast<Index>(list.size());
      list.push_back(n);
    }
    void erase(NodeId n) noexcept {
      const Index p = pos[n];
      if (p == kInvalid) return;
      const NodeId last = list.back();
      list[p] = last;
      pos[last] = p;
      list.pop_back();
      pos[n] = kInvalid;
    }
  };

  const Mt* mt_;
  std::vector<std::uint8_t> applied_;
  std::vector<FaceId> faces_;            // current faces, unordered
  std::vector<Index> slot_;              // position of a face in faces_, kInvalid if absent
  std::size_t num_applied_ = 0;
  std::vector<NodeId> stack_;
  NodeSet refine_set_;   // unapplied nodes with a pre-image face in the front
  NodeSet coarsen_set_;  // nodes other than the source with can_undo()
};

template <class Sink>
void MtFront::refine(NodeId n, Sink&& sink) {
  check_node(n, "refine");
  if (applied_[n]) return;
  stack_.clear();
  stack_.push_back(n);
  while (!stack_.empty()) {
    const NodeId t = stack_.back();
    if (applied_[t]) {
      stack_.pop_back();
      continue;
    }
    bool pushed = false;
    for (FaceId g : mt_->pre_image(t))
      if (!has_face(g)) {  // its creator is not applied (it may be pushed twice: popped as applied)
        stack_.push_back(mt_->creator(g));
        pushed = true;
      }
    if (!pushed) {
      stack_.pop_back();
      apply(t);
      sink(t);
    }
  }
}

template <class Sink>
void MtFront::coarsen(NodeId n, Sink&& sink) {
  check_node(n, "coarsen");
  if (!applied_[n] || n == 0) return;
  stack_.clear();
  stack_.push_back(n);
  while (!stack_.empty()) {
    const NodeId t = stack_.back();
    if (!applied_[t]) {
      stack_.pop_back();
      continue;
    }
    bool pushed = false;
    for (FaceId f = mt_->image_begin(t); f < mt_->image_end(t); ++f)
      if (!has_face(f)) {  // removed by an applied child
        stack_.push_back(mt_->destroyer(f));
        pushed = true;
      }
    if (!pushed) {
      stack_.pop_back();
      undo(t);
      sink(t);
    }
  }
}

}  // namespace varmesh
