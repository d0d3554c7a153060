#include "multitri/mt_front.hpp"

#include <algorithm>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

MtFront::MtFront(const Mt& mt) : mt_(&mt) {
  if (mt.num_nodes() == 0) throw InvalidInput("MtFront: the Mt is empty (default-constructed or moved-from)");
  reset();
}

void MtFront::reset() {
  applied_.assign(mt_->num_nodes(), 0);
  faces_.clear();
  slot_.assign(mt_->num_faces(), kInvalid);
  num_applied_ = 0;
  refine_set_.list.clear();
  refine_set_.pos.assign(mt_->num_nodes(), kInvalid);
  coarsen_set_.list.clear();
  coarsen_set_.pos.assign(mt_->num_nodes(), kInvalid);
  apply(0);
}

void MtFront::add_face(FaceId f) {
  slot_[f] = static_cast<Index>(faces_.size());
  faces_.push_back(f);
}

void MtFront::remove_face(FaceId f) {
  const Index s = slot_[f];
  const FaceId last = faces_.back();
  faces_[s] = last;
  slot_[last] = s;
  faces_.pop_back();
  slot_[f] = kInvalid;
}

void MtFront::check_node(NodeId n, const char* move) const {
  if (n >= mt_->num_nodes())
    throw InvalidInput(std::string("MtFront::") + move + ": node " + std::to_string(n) + " is not a node of the Mt (" +
                           std::to_string(mt_->num_nodes()) + " nodes)",
                       n);
}

void MtFront::apply(NodeId n) {
  check_node(n, "apply");
  if (!can_apply(n))
    throw InvalidInput("MtFront::apply: node " + std::to_string(n) +
                           (applied_[n] ? " is already applied" : " has a parent that is not applied"),
                       n);
  for (FaceId f : mt_->pre_image(n)) remove_face(f);
  for (FaceId f = mt_->image_begin(n); f < mt_->image_end(n); ++f) add_face(f);
  applied_[n] = 1;
  ++num_applied_;
  // Candidates: n is refined now and undoable (its whole image is current); its parents lost a face each.
  refine_set_.erase(n);
  for (NodeId p : mt_->parents(n)) coarsen_set_.erase(p);
  if (n != 0) coarsen_set_.insert(n);
  for (FaceId f = mt_->image_begin(n); f < mt_->image_end(n); ++f)
    if (const NodeId d = mt_->destroyer(f); d != kInvalid) refine_set_.insert(d);
}

void MtFront::undo(NodeId n) {
  check_node(n, "undo");
  if (!can_undo(n))
    throw InvalidInput("MtFront::undo: node " + std::to_string(n) +
                           (n == 0 ? " is the source"
                                   : !applied_[n] ? " is not applied" : " has an applied child"),
                       n);
  for (FaceId f = mt_->image_begin(n); f < mt_->image_end(n); ++f) remove_face(f);
  for (FaceId f : mt_->pre_image(n)) add_face(f);
  applied_[n] = 0;
  --num_applied_;
  // Candidates: n can be applied again; a child keeps its place only through another pre-image face; a
  // parent whose image is whole again can be undone.
  coarsen_set_.erase(n);
  refine_set_.insert(n);
  for (FaceId f = mt_->image_begin(n); f < mt_->image_end(n); ++f) {
    const NodeId d = mt_->destroyer(f);
    if (d == kInvalid || !refine_set_.contains(d)) continue;
    bool exposed = false;
    for (FaceId g : mt_->pre_image(d)) exposed = exposed || has_face(g);
    if (!exposed) refine_set_.erase(d);
  }
  for (NodeId p : mt_->parents(n))
    if (can_undo(p)) coarsen_set_.insert(p);
}

TriMesh MtFront::to_mesh(std::vector<FaceId>* face_ids, std::vector<VertexId>* vertex_ids) const {
  TriMesh out;
  std::vector<FaceId> order(faces_.begin(), faces_.end());
  std::sort(order.begin(), order.end());  // deterministic output whatever the move history
  std::vector<Index> remap(mt_->num_vertices(), kInvalid);
  std::vector<VertexId> used;
  out.indices.reserve(order.size() * 3);
  for (FaceId f : order)
    for (VertexId v : mt_->face(f)) {
      if (remap[v] == kInvalid) {
        remap[v] = static_cast<Index>(used.size());
        used.push_back(v);
      }
      out.indices.push_back(remap[v]);
    }
  out.positions.reserve(used.size());
  for (VertexId v : used) out.positions.push_back(mt_->position(v));
  if (face_ids) *face_ids = std::move(order);
  if (vertex_ids) *vertex_ids = std::move(used);
  return out;
}

void MtFront::validate() const {
  const Mt& mt = *mt_;
  auto fail = [](const std::string& why, std::uint64_t e) { throw InvalidInput("MtFront::validate: " + why, e); };
  if (!applied_[0]) fail("the source is not applied", 0);
  std::size_t count = 0;
  for (NodeId n = 0; n < mt.num_nodes(); ++n) {
    if (!applied_[n]) continue;
    ++count;
    for (NodeId p : mt.parents(n))
      if (!applied_[p]) fail("node " + std::to_string(n) + " is applied but its parent " + std::to_string(p) + " is not", n);
  }
  if (count != num_applied_) fail("applied count is stale", count);
  // The face-table legality tests agree with the definitions on the applied flags.
  for (NodeId n = 0; n < mt.num_nodes(); ++n) {
    bool parents_applied = true, children_unapplied = true;
    for (NodeId p : mt.parents(n)) parents_applied = parents_applied && applied_[p];
    for (NodeId c : mt.children(n)) children_unapplied = children_unapplied && !applied_[c];
    if (can_apply(n) != (!applied_[n] && parents_applied) || can_undo(n) != (n != 0 && applied_[n] && children_unapplied))
      fail("node " + std::to_string(n) + ": legality from the face table disagrees with the applied flags", n);
  }
  std::size_t expected = 0;
  for (FaceId f = 0; f < mt.num_faces(); ++f) {
    const bool in = applied_[mt.creator(f)] && (mt.destroyer(f) == kInvalid || !applied_[mt.destroyer(f)]);
    if (in != has_face(f)) fail("face " + std::to_string(f) + (in ? " is missing from" : " should not be in") + " the front", f);
    if (in) {
      ++expected;
      if (faces_[slot_[f]] != f) fail("face slot table is corrupt", f);
    }
  }
  if (expected != faces_.size()) fail("face list has extra entries", faces_.size());
  // The candidate sets are exactly their definitions.
  for (NodeId n = 0; n < mt.num_nodes(); ++n) {
    bool exposed = false;
    for (FaceId g : mt.pre_image(n)) exposed = exposed || has_face(g);
    if (refine_set_.contains(n) != (!applied_[n] && exposed))
      fail("node " + std::to_string(n) + ": refine candidate set is stale", n);
    if (coarsen_set_.contains(n) != can_undo(n)) fail("node " + std::to_string(n) + ": coarsen candidate set is stale", n);
    for (const NodeSet* set : {&refine_set_, &coarsen_set_})
      if (set->contains(n) && (set->pos[n] >= set->list.size() || set->list[set->pos[n]] != n))
        fail("node " + std::to_string(n) + ": candidate list is corrupt", n);
  }
  // Conformity: every directed edge appears once, and its reverse at most once.
  std::vector<std::uint64_t> edges;
  edges.reserve(faces_.size() * 3);
  for (FaceId f : faces_) {
    const auto v = mt.face(f);
    for (int k = 0; k < 3; ++k) edges.push_back((std::uint64_t(v[k]) << 32) | v[(k + 1) % 3]);
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 1; i < edges.size(); ++i)
    if (edges[i] == edges[i - 1]) fail("directed edge used twice: the front is not a conforming mesh", i);
}

}  // namespace varmesh
