// Derived arrays of a vertex hierarchy (parents, face creators, roots, base faces, <tree-id, node-id> keys
// of Kim-Lee 2001 section 4.3) and its self-check.
#include "pm/vertex_hierarchy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "pm/read_ahead.hpp"

namespace varmesh {

namespace {

[[noreturn]] void bad(const std::string& what) { throw InvalidInput("vertex hierarchy: " + what); }

}  // namespace

int VertexHierarchy::depth(Index v) const noexcept {
  const std::uint64_t mask = (node_bits_ >= 64) ? ~0ull : ((1ull << node_bits_) - 1ull);
  return static_cast<int>(std::bit_width(keys_[v].value & mask)) - 1;
}

std::size_t VertexHierarchy::memory_bytes() const noexcept {
  return positions_.size() * sizeof(glm::vec3) + colors_.size() * sizeof(glm::vec3) + parent_.size() * sizeof(Index) +
         records_.size() * sizeof(CollapseRecord) + faces_.size() * sizeof(Index) + face_creator_.size() * sizeof(Index) +
         roots_.size() * sizeof(Index) + base_faces_.size() * sizeof(Index) + bounds_.size() * sizeof(ElementBound) +
         (ring_offsets_.size() + ring_items_.size()) * sizeof(Index) + keys_.size() * sizeof(NodeKey);
}

VertexHierarchy VertexHierarchyBuilder::finish(Raw raw, bool validate) {
  VertexHierarchy h;
  const std::size_t nl = raw.num_leaves;
  const std::size_t nn = raw.positions.size();
  const std::size_t nc = raw.records.size();
  if (nl == 0) bad("no leaf");
  if (nn != nl + nc) bad("positions: " + std::to_string(nn) + " nodes for " + std::to_string(nl) + " leaves and " + std::to_string(nc) + " collapses");
  if (nn >= kInvalid) bad("too many nodes");
  if (!raw.colors.empty() && raw.colors.size() != nn) bad("colors: wrong count");
  if (raw.bounds.size() != nn) bad("bounds: wrong count");
  if (raw.faces.size() % 3 != 0 || raw.faces.empty()) bad("faces: count not a positive multiple of 3");
  const std::size_t nf = raw.faces.size() / 3;
  if (raw.ring_offsets.size() != nc + 1 || raw.ring_offsets[0] != 0 || raw.ring_offsets.back() != raw.ring_items.size())
    bad("stored rings: offsets inconsistent");
  for (std::size_t i = 0; i < nc; ++i)
    if (raw.ring_offsets[i + 1] < raw.ring_offsets[i]) bad("stored rings: offsets decrease at collapse " + std::to_string(i));
  if (raw.leaf_to_input.size() != nl) bad("leaf_to_input: wrong count");
  if (raw.face_to_input.size() != nf) bad("face_to_input: wrong count");
  if (!raw.locked.empty() && raw.locked.size() != nl) bad("locked: wrong count");
  for (std::size_t i = 0; i < raw.faces.size(); ++i)
    if (raw.faces[i] >= nl) bad("face " + std::to_string(i / 3) + ": corner is not a leaf");
  // The maps back to the caller's mesh stay inside it (leaves_of_inputs and the commands index by them).
  for (std::size_t l = 0; l < nl; ++l)
    if (raw.leaf_to_input[l] >= raw.repair.input_vertices)
      bad("leaf " + std::to_string(l) + ": input vertex " + std::to_string(raw.leaf_to_input[l]) + " beyond the input's " +
          std::to_string(raw.repair.input_vertices));
  for (std::size_t f = 0; f < nf; ++f)
    if (raw.face_to_input[f] >= raw.repair.input_faces)
      bad("face " + std::to_string(f) + ": input face " + std::to_string(raw.face_to_input[f]) + " beyond the input's " +
          std::to_string(raw.repair.input_faces));
  for (std::size_t v = 0; v < nn; ++v) {
    const glm::vec3& p = raw.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) bad("node " + std::to_string(v) + ": position not finite");
    const ElementBound& b = raw.bounds[v];
    if (!(b.radius >= 0.0f) || !std::isfinite(b.radius) || !(b.error >= 0.0f) || !std::isfinite(b.error))
      bad("node " + std::to_string(v) + ": bound not finite or negative");
  }

  h.parent_.assign(nn, kInvalid);
  h.face_creator_.assign(nf, kInvalid);
  for (std::size_t i = 0; i < nc; ++i) {
    const CollapseRecord& r = raw.records[i];
    const Index vs = static_cast<Index>(nl + i);
    // Built only for a message: a string per collapse would cost more than all the checks.
    auto name = [&] { return "collapse " + std::to_string(i) + " (node " + std::to_string(vs) + ")"; };
    for (Index c : {r.vt, r.vu}) {
      if (c >= vs) bad(name() + ": child " + std::to_string(c) + " is not an earlier node");
      if (h.parent_[c] != kInvalid) bad(name() + ": child " + std::to_string(c) + " already has parent " + std::to_string(h.parent_[c]));
      h.parent_[c] = vs;
    }
    if (r.vt == r.vu) bad(name() + ": both children are node " + std::to_string(r.vt));
    if (r.vl_hat == kInvalid && r.vr_hat == kInvalid) bad(name() + ": no cut vertex");
    if ((r.vl_hat == kInvalid) != (r.fl_hat == kInvalid) || (r.vr_hat == kInvalid) != (r.fr_hat == kInvalid))
      bad(name() + ": cut vertex and face disagree");
    for (Index c : {r.vl_hat, r.vr_hat})
      if (c != kInvalid && c >= nl) bad(name() + ": cut vertex " + std::to_string(c) + " is not a leaf");
    if (r.vl_hat != kInvalid && r.vl_hat == r.vr_hat) bad(name() + ": both cut vertices are leaf " + std::to_string(r.vl_hat));
    for (Index f : {r.fl_hat, r.fr_hat}) {
      if (f == kInvalid) continue;
      if (f >= nf) bad(name() + ": face " + std::to_string(f) + " out of range");
      if (h.face_creator_[f] != kInvalid) bad(name() + ": face " + std::to_string(f) + " already created by node " + std::to_string(h.face_creator_[f]));
      h.face_creator_[f] = vs;
    }
    if (r.fl_hat != kInvalid && r.fl_hat == r.fr_hat) bad(name() + ": fl and fr are the same face");
    for (Index f : r.fn)
      if (f != kInvalid && f >= nf) bad(name() + ": neighbour face " + std::to_string(f) + " out of range");
  }
  for (Index item : raw.ring_items)
    if (item >= nn) bad("stored ring item " + std::to_string(item) + " out of range");
  // What the schemes rely on to terminate. Hoppe's fn faces are in the mesh just before vs is collapsed: base
  // faces or faces created by later collapses (a face created by vs itself or earlier sends the forced splits
  // round in a cycle). Xia-Varshney's stored ring of vs is the 1-ring right after its collapse: nodes before vs
  // that are collapsed after it, if at all.
  for (std::size_t i = 0; i < nc; ++i) {
    const CollapseRecord& r = raw.records[i];
    const Index vs = static_cast<Index>(nl + i);
    for (Index f : r.fn)
      if (f != kInvalid && h.face_creator_[f] != kInvalid && h.face_creator_[f] <= vs)
        bad("collapse " + std::to_string(i) + " (node " + std::to_string(vs) + "): neighbour face " + std::to_string(f) +
            " is created by node " + std::to_string(h.face_creator_[f]) + ", not after it");
    for (Index k = raw.ring_offsets[i]; k < raw.ring_offsets[i + 1]; ++k) {
      const Index n = raw.ring_items[k];
      if (n >= vs || (h.parent_[n] != kInvalid && h.parent_[n] <= vs))
        bad("collapse " + std::to_string(i) + " (node " + std::to_string(vs) + "): stored ring item " + std::to_string(n) +
            " is not a node of the mesh after that collapse");
    }
  }

  for (std::size_t v = 0; v < nn; ++v)
    if (h.parent_[v] == kInvalid) h.roots_.push_back(static_cast<Index>(v));

  // Depth of every node: parents come after children, so walk the nodes from the last one down.
  std::vector<std::uint16_t> depth(nn, 0);
  int max_depth = 0;
  for (std::size_t v = nn; v-- > 0;) {
    const Index p = h.parent_[v];
    if (p != kInvalid) {
      depth[v] = static_cast<std::uint16_t>(std::min<int>(depth[p] + 1, 65535));
      max_depth = std::max<int>(max_depth, depth[v]);
    }
  }
  const int node_bits = max_depth + 1;
  const int tree_bits = h.roots_.size() <= 1 ? 0 : static_cast<int>(std::bit_width(h.roots_.size() - 1));
  if (max_depth > 62) bad("tree depth " + std::to_string(max_depth) + ": more than 62 levels");
  if (node_bits + tree_bits > 64)
    bad("tree depth " + std::to_string(max_depth) + " with " + std::to_string(h.roots_.size()) + " trees needs " +
        std::to_string(node_bits + tree_bits) + " bits, more than the 64 of a node key");
  h.node_bits_ = node_bits;
  h.keys_.assign(nn, NodeKey{});
  for (std::size_t t = 0; t < h.roots_.size(); ++t)
    h.keys_[h.roots_[t]].value = (node_bits >= 64 ? 0ull : (static_cast<std::uint64_t>(t) << node_bits)) | 1ull;
  for (std::size_t v = nn; v-- > nl;) {
    const CollapseRecord& r = raw.records[v - nl];
    const std::uint64_t k = h.keys_[v].value;
    const std::uint64_t tree = node_bits >= 64 ? 0ull : (k >> node_bits) << node_bits;
    const std::uint64_t node = k ^ tree;
    h.keys_[r.vt].value = tree | (node << 1);
    h.keys_[r.vu].value = tree | ((node << 1) | 1ull);
  }

  // Base faces: corners with three distinct roots.
  std::vector<Index> root_of(nl);
  {
    std::vector<Index> top(nn);
    for (std::size_t v = nn; v-- > 0;) top[v] = h.parent_[v] == kInvalid ? static_cast<Index>(v) : top[h.parent_[v]];
    for (std::size_t l = 0; l < nl; ++l) root_of[l] = top[l];
  }
  for (std::size_t f = 0; f < nf; ++f) {
    const Index a = root_of[raw.faces[3 * f]], b = root_of[raw.faces[3 * f + 1]], c = root_of[raw.faces[3 * f + 2]];
    const bool alive = a != b && b != c && a != c;
    if (alive != (h.face_creator_[f] == kInvalid))
      bad("face " + std::to_string(f) + (alive ? " survives in the base mesh but is created by a collapse"
                                               : " is not in the base mesh and no collapse creates it"));
    if (alive) h.base_faces_.push_back(static_cast<Index>(f));
  }
  // Every root is a vertex of the base mesh (a root without a face has no place in any selectively refined
  // mesh: SrMesh could not even start).
  {
    std::vector<std::uint8_t> has_face(nn, 0);
    for (Index f : h.base_faces_)
      for (int k = 0; k < 3; ++k) has_face[root_of[raw.faces[3 * f + k]]] = 1;
    for (Index r : h.roots_)
      if (!has_face[r]) bad("root node " + std::to_string(r) + " is a corner of no base face");
  }

  h.num_leaves_ = nl;
  h.positions_ = std::move(raw.positions);
  h.colors_ = std::move(raw.colors);
  h.records_ = std::move(raw.records);
  h.faces_ = std::move(raw.faces);
  h.bounds_ = std::move(raw.bounds);
  h.ring_offsets_ = std::move(raw.ring_offsets);
  h.ring_items_ = std::move(raw.ring_items);
  h.leaf_to_input_ = std::move(raw.leaf_to_input);
  h.face_to_input_ = std::move(raw.face_to_input);
  h.locked_ = std::move(raw.locked);
  h.repair_ = raw.repair;
  if (validate) h.validate();
  return h;
}

namespace {

// Whether cone c lies inside cone p up to rounding, without trigonometry: with phi the angle between the
// axes, c is inside when phi + t <= T + delta (t, T the half-angles), i.e. cos(phi + t) >= cos(T + delta),
// each side expanded as cos x cos y - sin x sin y with the sines from the cosines (all angles in [0, pi]).
// delta = 2e-3 radians: a float cosine near 1 resolves an angle only to about 3.5e-4 radians (acos has an
// infinite slope at 1), and enclose() of multitri/bounds.cpp decides containment from three float acos
// values (the measured excesses reach 6e-4).
bool cone_inside(const NormalCone& c, const NormalCone& p) noexcept {
  if (p.is_full()) return true;
  if (c.is_full()) return false;
  const double cos_phi = std::clamp(static_cast<double>(glm::dot(c.axis, p.axis)), -1.0, 1.0);
  const double cos_t = std::clamp(static_cast<double>(c.cos_half_angle), -1.0, 1.0);
  const double cos_p = std::clamp(static_cast<double>(p.cos_half_angle), -1.0, 1.0);
  constexpr double kCosDelta = 0.9999980000006666, kSinDelta = 0.0019999986666669333;  // delta = 2e-3
  if (cos_p <= -kCosDelta) return true;  // T + delta >= pi: p holds every direction up to delta
  // phi + t > pi (cos t < cos(pi - phi) = -cos phi): c reaches past the antipode of p's axis, which p
  // (T + delta < pi) does not hold.
  if (cos_t + cos_phi < 0.0) return false;
  auto sine = [](double cosine) { return std::sqrt(std::max(0.0, 1.0 - cosine * cosine)); };
  return cos_phi * cos_t - sine(cos_phi) * sine(cos_t) >= cos_p * kCosDelta - sine(cos_p) * kSinDelta;
}

}  // namespace

void VertexHierarchy::validate() const {
  auto fail = [](const std::string& what) { throw std::logic_error("VertexHierarchy::validate: " + what); };
  const std::size_t nn = num_nodes();
  // The children and faces of successive records are scattered over the arrays: read them a few records
  // ahead (the faces' corners one step later than the faces) so that the misses overlap. Plain loads, not
  // __builtin_prefetch: a prefetch that misses the TLB may be dropped (on the machine measured, a VM, the
  // prefetches gained nothing; these loads take 40 % off the dragon's validation).
  constexpr std::size_t kAhead = 8;
  using detail::touch;
  auto touch_record = [&](std::size_t i) {
    const CollapseRecord& r = records_[i];
    for (Index c : {r.vt, r.vu}) {
      touch(parent_[c]);
      touch(keys_[c].value);
      touch(bounds_[c].error);
    }
    for (Index f : {r.fl_hat, r.fr_hat})
      if (f != kInvalid) touch(faces_[3 * f]);
  };
  auto touch_corners = [&](std::size_t i) {
    const CollapseRecord& r = records_[i];
    for (Index f : {r.fl_hat, r.fr_hat})
      if (f != kInvalid)
        for (int k = 0; k < 3; ++k) touch(keys_[faces_[3 * f + k]].value);
  };
  for (std::size_t v = num_leaves_; v < nn; ++v) {
    const std::size_t i = v - num_leaves_;
    if (i + 2 * kAhead < records_.size()) touch_record(i + 2 * kAhead);
    if (i + kAhead < records_.size()) touch_corners(i + kAhead);
    const CollapseRecord& r = records_[i];
    auto name = [&] { return "node " + std::to_string(v); };
    if (parent_[r.vt] != v || parent_[r.vu] != v) fail(name() + ": children's parent is not the node");
    if (!is_ancestor_or_self(static_cast<Index>(v), r.vt) || !is_ancestor_or_self(static_cast<Index>(v), r.vu) ||
        is_ancestor_or_self(r.vt, r.vu) || is_ancestor_or_self(r.vt, static_cast<Index>(v)))
      fail(name() + ": keys disagree with the tree");
    for (Index c : {r.vt, r.vu}) {
      const ElementBound &pb = bounds_[v], &cb = bounds_[c];
      if (cb.error > pb.error) fail(name() + ": child " + std::to_string(c) + " has a larger error");
      const float slack = 1e-4f * (pb.radius + glm::length(pb.center)) + 1e-6f;
      if (glm::length(cb.center - pb.center) + cb.radius > pb.radius + slack)
        fail(name() + ": sphere of child " + std::to_string(c) + " is not inside");
      if (!cone_inside(cb.cone, pb.cone)) fail(name() + ": normal cone of child " + std::to_string(c) + " is not inside");
    }
    // fl^ = (vt-part, vu-part, vl^) and fr^ = (vu-part, vt-part, vr^) up to rotation: one corner under each
    // child, the third the cut vertex, in that cyclic order (the orientation vsplit gives the new faces).
    auto check_face = [&](Index f, Index cut, Index first, Index second) {
      if (f == kInvalid) return;
      const auto c = face(f);
      int k = 0;
      while (k < 3 && c[k] != cut) ++k;
      if (k == 3 || !is_ancestor_or_self(first, c[(k + 1) % 3]) || !is_ancestor_or_self(second, c[(k + 2) % 3]))
        fail(name() + ": face " + std::to_string(f) + " is not (" + (first == r.vt ? "vt, vu" : "vu, vt") + ", cut)");
    };
    check_face(r.fl_hat, r.vl_hat, r.vt, r.vu);
    check_face(r.fr_hat, r.vr_hat, r.vu, r.vt);
  }
}

}  // namespace varmesh
