// Derived arrays of a vertex hierarchy (parents, face creators, roots, base faces, <tree-id, node-id> keys
// of Kim-Lee 2001 section 4.3) and its self-check.
#include "pm/vertex_hierarchy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "pm/read_ahead.hpp"

namespace varmesh {

namespace {

[[noreturn]] void bad(const std::string& what) { throw InvalidInput("vertex hierarchy: " + what); }

}  // namespace

int VertexHierarchy::depth(Index v) const noexcept {
  const std::uint64_t mask = (node_bits_ >= 64) ? ~0ull : ((1ull << node_bits_) - 1ull);
  return static_cast<int>(std::bit_width(key(v).value & mask)) - 1;
}

void VertexHierarchy::swap(VertexHierarchy& o) noexcept {
  using std::swap;
  swap(num_leaves_, o.num_leaves_);
  swap(positions_, o.positions_);
  swap(colors_, o.colors_);
  swap(parent_, o.parent_);
  swap(records_, o.records_);
  swap(faces_, o.faces_);
  swap(face_creator_, o.face_creator_);
  swap(roots_, o.roots_);
  swap(base_faces_, o.base_faces_);
  swap(bounds_, o.bounds_);
  swap(ring_offsets_, o.ring_offsets_);
  swap(ring_items_, o.ring_items_);
  swap(keys_, o.keys_);
  swap(node_bits_, o.node_bits_);
  swap(leaf_to_input_, o.leaf_to_input_);
  swap(face_to_input_, o.face_to_input_);
  swap(locked_, o.locked_);
  swap(repair_, o.repair_);
}

std::size_t VertexHierarchy::memory_bytes() const noexcept {
  return positions_.size() * sizeof(glm::vec3) + colors_.size() * sizeof(glm::vec3) + parent_.size() * sizeof(Index) +
         records_.size() * sizeof(CollapseRecord) + faces_.size() * sizeof(Index) + face_creator_.size() * sizeof(Index) +
         roots_.size() * sizeof(Index) + base_faces_.size() * sizeof(Index) + bounds_.size() * sizeof(ElementBound) +
         (ring_offsets_.size() + ring_items_.size()) * sizeof(Index) + keys_.size() * sizeof(NodeKey);
}

// The checks of finish() that only an untrusted Raw needs (a file's): the maps back to the input, the repair
// report's counts, finite positions inside their own spheres, and the leaves' spheres holding their faces.
namespace {

void check_untrusted(const VertexHierarchyBuilder::Raw& raw) {
  const std::size_t nl = raw.num_leaves, nn = raw.positions.size(), nf = raw.faces.size() / 3;
  // The maps back to the caller's mesh stay inside it (leaves_of_inputs and the commands index by them).
  for (std::size_t l = 0; l < nl; ++l)
    if (raw.leaf_to_input[l] >= raw.repair.input_vertices)
      bad("leaf " + std::to_string(l) + ": input vertex " + std::to_string(raw.leaf_to_input[l]) + " beyond the input's " +
          std::to_string(raw.repair.input_vertices));
  for (std::size_t f = 0; f < nf; ++f)
    if (raw.face_to_input[f] >= raw.repair.input_faces)
      bad("face " + std::to_string(f) + ": input face " + std::to_string(raw.face_to_input[f]) + " beyond the input's " +
          std::to_string(raw.repair.input_faces));
  // The repair report adds up: every input vertex is some leaf's source or unreferenced, every input face
  // kept or dropped as degenerate or duplicate, and every leaf beyond one per source is a copy; and the input
  // had 32-bit indices, so every count is below 2^32 (counts raised by 2^63 on both sides of a sum, or two
  // terms of one sum raised by 2^63 each, would otherwise pass). Nothing is sized by these counts
  // (input_mesh_of and leaves_of_inputs number densely); they are printed and compared.
  {
    const InputRepairReport& r = raw.repair;
    for (std::size_t count : {r.input_vertices, r.input_faces, r.unreferenced_vertices, r.degenerate_faces, r.duplicate_faces,
                              r.nonmanifold_edge_faces, r.nonmanifold_vertices, r.added_vertex_copies, r.locked_vertices})
      if (count >= kInvalid)
        bad("repair report: a count of " + std::to_string(count) + " for an input of " + std::to_string(r.input_vertices) +
            " vertices and " + std::to_string(r.input_faces) + " faces is beyond 32-bit indices");
  }
  {
    std::vector<Index> sources(raw.leaf_to_input);
    std::sort(sources.begin(), sources.end());
    const auto distinct = static_cast<std::size_t>(std::unique(sources.begin(), sources.end()) - sources.begin());
    const InputRepairReport& r = raw.repair;
    if (r.input_vertices != distinct + r.unreferenced_vertices)
      bad("repair report: " + std::to_string(r.input_vertices) + " input vertices, but " + std::to_string(distinct) +
          " used and " + std::to_string(r.unreferenced_vertices) + " unreferenced");
    if (r.input_faces != nf + r.degenerate_faces + r.duplicate_faces)
      bad("repair report: " + std::to_string(r.input_faces) + " input faces, but " + std::to_string(nf) + " kept, " +
          std::to_string(r.degenerate_faces) + " degenerate and " + std::to_string(r.duplicate_faces) + " duplicate");
    if (r.added_vertex_copies != nl - distinct)
      bad("repair report: " + std::to_string(r.added_vertex_copies) + " vertex copies, but " + std::to_string(nl - distinct) +
          " leaves share a source");
    // The counts outside those sums: each face detached from a non-manifold edge and each non-manifold
    // vertex split made at least one copy (manifold_input.cpp), and the locked vertices are the leaves locked.
    if (r.nonmanifold_edge_faces + r.nonmanifold_vertices > r.added_vertex_copies)
      bad("repair report: " + std::to_string(r.nonmanifold_edge_faces) + " faces detached and " +
          std::to_string(r.nonmanifold_vertices) + " vertices split, but " + std::to_string(r.added_vertex_copies) +
          " vertex copies");
    const auto locked = static_cast<std::size_t>(std::count_if(raw.locked.begin(), raw.locked.end(), [](std::uint8_t x) { return x != 0; }));
    if (r.locked_vertices != locked)
      bad("repair report: " + std::to_string(r.locked_vertices) + " locked vertices, but " + std::to_string(locked) +
          " leaves locked");
  }
  // Slack for the float rounding of the enclosing spheres: relative to the sphere's size and place, plus a few
  // of the smallest subnormal floats (coordinates near 1e-40 are rounded in absolute steps of that size).
  // In double: the float squared distance overflows past ~1.8e19.
  auto outside = [](const glm::vec3& p, const ElementBound& b) {
    const double scale = std::max({std::abs(b.center.x), std::abs(b.center.y), std::abs(b.center.z), b.radius});
    const double ulp = double(std::numeric_limits<float>::denorm_min());
    return glm::length(glm::dvec3(p) - glm::dvec3(b.center)) > double(b.radius) + 1e-5 * scale + 4.0 * ulp;
  };
  for (std::size_t v = 0; v < nn; ++v) {
    const glm::vec3& p = raw.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) bad("node " + std::to_string(v) + ": position not finite");
    const ElementBound& b = raw.bounds[v];
    if (!(b.radius >= 0.0f) || !std::isfinite(b.radius) || !(b.error >= 0.0f) || !std::isfinite(b.error) ||
        !std::isfinite(b.center.x) || !std::isfinite(b.center.y) || !std::isfinite(b.center.z) ||
        !std::isfinite(b.cone.axis.x) || !std::isfinite(b.cone.axis.y) || !std::isfinite(b.cone.axis.z) ||
        !std::isfinite(b.cone.cos_half_angle))
      bad("node " + std::to_string(v) + ": bound not finite or negative");
    if (outside(p, b)) bad("node " + std::to_string(v) + ": position outside its bounding sphere");
  }
  // A leaf's sphere holds its faces (the view criteria test spheres, and the faces must not escape them).
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      for (int j = 1; j < 3; ++j)
        if (outside(raw.positions[raw.faces[3 * f + (k + j) % 3]], raw.bounds[raw.faces[3 * f + k]]))
          bad("leaf " + std::to_string(raw.faces[3 * f + k]) + ": face " + std::to_string(f) + " leaves its bounding sphere");
}

}  // namespace

VertexHierarchy VertexHierarchyBuilder::finish(Raw raw, bool validate, bool trusted) {
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
  if (!trusted) check_untrusted(raw);
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
  for (std::size_t i = 0; i < nc && !trusted; ++i) {
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
  // Finite values first: every comparison below is false on a NaN, so a NaN error or sphere would pass them.
  auto finite3 = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  for (std::size_t v = 0; v < nn; ++v) {
    const ElementBound& b = bounds_[v];
    const char* what = !finite3(positions_[v])                                                ? "position not finite"
                       : !finite3(b.center) || !(b.radius >= 0.0f) || !std::isfinite(b.radius) ? "bounding sphere not finite or negative"
                       : !(b.error >= 0.0f) || !std::isfinite(b.error)                         ? "error not finite or negative"
                       : !finite3(b.cone.axis) || !std::isfinite(b.cone.cos_half_angle)        ? "normal cone not finite"
                                                                                              : nullptr;
    if (what != nullptr) fail("node " + std::to_string(v) + ": " + what);
  }
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
  check_collapses();
  // Then the geometry and the maps, on a hierarchy whose topology is sound.
  // A leaf's cone holds its faces' normals (the back-face and silhouette criteria trust the cones; the
  // analysis builds them from these normals, with 1e-6 of slack in the cosine).
  const std::size_t nf = faces_.size() / 3;
  for (std::size_t f = 0; f < nf; ++f) {
    const glm::dvec3 p0(positions_[faces_[3 * f]]), p1(positions_[faces_[3 * f + 1]]), p2(positions_[faces_[3 * f + 2]]);
    const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
    const double len = glm::length(n);
    if (!(len > 0.0) || !std::isfinite(len)) continue;
    for (int k = 0; k < 3; ++k) {
      const NormalCone& c = bounds_[faces_[3 * f + k]].cone;
      if (!c.is_full() && glm::dot(n / len, glm::dvec3(c.axis)) < double(c.cos_half_angle) - 1e-4)
        fail("leaf " + std::to_string(faces_[3 * f + k]) + ": the normal of face " + std::to_string(f) + " is outside its normal cone");
    }
  }
  // Locked leaves are never collapsed, and each input face has at most one face here.
  for (std::size_t l = 0; l < locked_.size(); ++l)
    if (locked_[l] && parent_[l] != kInvalid) fail("leaf " + std::to_string(l) + " is locked but collapsed by node " + std::to_string(parent_[l]));
  std::vector<Index> sources(face_to_input_.begin(), face_to_input_.end());
  std::sort(sources.begin(), sources.end());
  if (const auto dup = std::adjacent_find(sources.begin(), sources.end()); dup != sources.end())
    fail("input face " + std::to_string(*dup) + " is the source of two faces");
}

void VertexHierarchy::check_collapses() const {
  auto fail = [](const std::string& what) { throw std::logic_error("VertexHierarchy::validate: " + what); };
  const std::size_t nl = num_leaves_, nn = num_nodes(), nf = faces_.size() / 3;
  // The current mesh: corners as node ids, and per node a run of its live faces in one pool (a collapse
  // appends the new node's run; the children's runs are dropped).
  // `cnt` entries from `off`; `live` of them are faces still alive (an apex's run keeps the faces a
  // collapse removed from it: they are skipped when the run is read, which is cheaper than compacting it).
  struct Run {
    std::size_t off = 0;
    Index cnt = 0, live = 0;
  };
  std::vector<Index> cur(faces_);
  std::vector<std::uint8_t> alive(nf, 1);
  std::vector<Run> run(nn);
  std::vector<Index> pool(cur.size());
  {
    for (Index c : cur) ++run[c].cnt;
    std::size_t off = 0;
    for (std::size_t v = 0; v < nl; ++v) {
      run[v].off = off;
      off += run[v].cnt;
      run[v].live = run[v].cnt;
      run[v].cnt = 0;
    }
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        Run& r = run[cur[3 * f + k]];
        pool[r.off + r.cnt++] = static_cast<Index>(f);
      }
  }
  auto faces_of = [&](Index v) { return std::span<const Index>(pool.data() + run[v].off, run[v].cnt); };
  // Stamped scratch marks, one array per purpose.
  std::vector<std::uint32_t> mark(nn, 0), seen(nn, 0);
  std::uint32_t stamp = 0;

  // 1. The original mesh: an oriented 2-manifold with border. Per leaf, its faces' (next, prev) corners by a
  // counting sort in one pass over the faces (the leaf runs above give the places).
  for (std::size_t f = 0; f < nf; ++f)
    if (cur[3 * f] == cur[3 * f + 1] || cur[3 * f + 1] == cur[3 * f + 2] || cur[3 * f] == cur[3 * f + 2])
      fail("original face " + std::to_string(f) + " repeats a corner");
  std::vector<std::array<Index, 2>> np(cur.size());
  {
    std::vector<Index> fill(nl, 0);
    for (std::size_t f = 0; f < nf; ++f) {
      const Index c0 = cur[3 * f], c1 = cur[3 * f + 1], c2 = cur[3 * f + 2];
      np[run[c0].off + fill[c0]++] = {c1, c2};
      np[run[c1].off + fill[c1]++] = {c2, c0};
      np[run[c2].off + fill[c2]++] = {c0, c1};
    }
  }
  std::vector<Index> pos_of(nl, 0), succ;
  for (Index v = 0; v < nl; ++v) {
    const std::span<const std::array<Index, 2>> fs(np.data() + run[v].off, run[v].cnt);
    const auto name = [&] { return "original vertex " + std::to_string(v); };
    // Directed edges v -> next: each once. pos_of[next] = the face's place in the run while v is tested.
    ++stamp;
    for (Index i = 0; i < fs.size(); ++i) {
      const Index w = fs[i][0];
      if (mark[w] == stamp) fail(name() + ": the directed edge to " + std::to_string(w) + " is in two faces");
      mark[w] = stamp;
      pos_of[w] = i;
    }
    // Face j precedes face i around v when next_j == prev_i. Each face has at most one successor; one fan
    // is one path (from the only face without a predecessor) or one cycle through all the faces.
    succ.assign(fs.size(), kInvalid);
    Index start = 0, starts = 0;
    for (Index i = 0; i < fs.size(); ++i) {
      const auto [next_i, prev_i] = fs[i];
      if (mark[prev_i] != stamp) {
        if (starts++ == 0) start = i;
        continue;
      }
      const Index j = pos_of[prev_i];
      if (fs[j][1] == next_i) fail(name() + ": two faces on the same corners");
      if (succ[j] != kInvalid) fail(name() + ": the directed edge from " + std::to_string(prev_i) + " is in two faces");
      succ[j] = i;
    }
    Index count = fs.empty() ? 0 : 1;
    if (starts <= 1)
      for (Index i = fs.empty() ? kInvalid : succ[start]; i != kInvalid && i != start && count <= fs.size(); i = succ[i])
        ++count;
    if (starts > 1 || count != fs.size()) fail(name() + ": its faces form more than one fan");
  }
  std::vector<std::array<Index, 2>>().swap(np);

  // 2. The collapses, in node order. One pass per child reads its faces' corners into `ring_of` (per face:
  // the face, v's corner index, the corners after and before v); every test then runs on those arrays.
  struct Around {
    Index face, next, prev;
    int k;
  };
  std::vector<Around> around_a, around_b;
  auto read_around = [&](Index v, std::vector<Around>& out) {
    out.clear();
    for (Index f : faces_of(v)) {
      if (!alive[f]) continue;
      const Index* c = &cur[3 * f];
      const int k = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
      out.push_back({f, c[(k + 1) % 3], c[(k + 2) % 3], k});
    }
  };
  // An open fan has a corner after v that is before v in no face.
  auto is_border = [&](const std::vector<Around>& ar) {
    ++stamp;
    for (const Around& x : ar) seen[x.prev] = stamp;
    for (const Around& x : ar)
      if (seen[x.next] != stamp) return true;
    return false;
  };
  pool.reserve(3 * pool.size());
  // The faces around successive collapses are scattered: read the children's runs two steps ahead and their
  // faces' corners one step ahead so that the misses overlap (a run not created yet has no entries).
  constexpr std::size_t kAhead = 8;
  using detail::touch;
  auto touch_runs = [&](std::size_t i) {
    const CollapseRecord& q = records_[i];
    for (Index c : {q.vt, q.vu})
      if (c < nn) touch(run[c].cnt);
  };
  auto touch_corners = [&](std::size_t i) {
    const CollapseRecord& q = records_[i];
    for (Index c : {q.vt, q.vu})
      if (c < nn)
        for (Index k = 0; k < run[c].cnt; ++k) touch(cur[3 * std::size_t{pool[run[c].off + k]}]);
  };
  for (std::size_t v = nl; v < nn; ++v) {
    const std::size_t i = v - nl;
    if (i + 2 * kAhead < records_.size()) touch_runs(i + 2 * kAhead);
    if (i + kAhead < records_.size()) touch_corners(i + kAhead);
    const CollapseRecord& r = records_[v - nl];
    const auto name = [&] { return "node " + std::to_string(v) + " (replaying the collapses)"; };
    const Index a = r.vt, b = r.vu;
    if (a >= v || b >= v || a == b) fail(name() + ": its children are not earlier nodes");
    if (run[a].live == 0 || run[b].live == 0) fail(name() + ": a child has no face left");
    read_around(a, around_a);
    read_around(b, around_b);
    // The faces on the edge: fl holds a -> b, fr holds b -> a.
    Index fl = kInvalid, fr = kInvalid, vl = kInvalid, vr = kInvalid;
    int shared = 0;
    for (const Around& x : around_a) {
      if (x.next == b) fl = x.face, vl = x.prev, ++shared;
      if (x.prev == b) fr = x.face, vr = x.next, ++shared;
    }
    if (shared == 0) fail(name() + ": its children are not joined by an edge");
    if (fl != r.fl_hat || fr != r.fr_hat)
      fail(name() + ": fl^/fr^ are not the faces on the edge of its children (faces " +
           std::to_string(fl == kInvalid ? -1L : static_cast<long>(fl)) + ", " +
           std::to_string(fr == kInvalid ? -1L : static_cast<long>(fr)) + ")");
    if ((vl == kInvalid) != (r.vl_hat == kInvalid) || (vr == kInvalid) != (r.vr_hat == kInvalid) ||
        (vl != kInvalid && !is_ancestor_or_self(vl, r.vl_hat)) || (vr != kInvalid && !is_ancestor_or_self(vr, r.vr_hat)))
      fail(name() + ": vl^/vr^ are not under the third corners of fl^/fr^");
    // Link condition: the common neighbours of a and b are the apexes; an interior edge does not join two
    // border vertices; an apex keeps a face; no face of a and one of b both hold vl and vr (a tetrahedron).
    if (shared == 2 && is_border(around_a) && is_border(around_b))
      fail(name() + ": an interior edge between two border vertices");
    ++stamp;
    for (const Around& x : around_a) mark[x.next] = mark[x.prev] = stamp;
    for (const Around& x : around_b)
      for (Index w : {x.next, x.prev}) {
        if (w == a || w == vl || w == vr) continue;
        if (mark[w] == stamp) fail(name() + ": its children share the neighbour " + std::to_string(w) + " (link condition)");
      }
    for (Index x : {vl, vr})
      if (x != kInvalid && run[x].live <= 1) fail(name() + ": the collapse leaves vertex " + std::to_string(x) + " no face");
    // Hoppe's fn0..fn3: the faces across (b, vl), (vl, a), (a, vr), (vr, b), i.e. holding vl -> b, a -> vl,
    // vr -> a, b -> vr.
    std::array<Index, 4> fn{kInvalid, kInvalid, kInvalid, kInvalid};
    bool apexes[2] = {false, false};
    for (const Around& x : around_a) {
      if (x.next == vl && vl != kInvalid) fn[1] = x.face;
      if (x.prev == vr && vr != kInvalid) fn[2] = x.face;
      if (vl != kInvalid && vr != kInvalid && ((x.next == vl && x.prev == vr) || (x.next == vr && x.prev == vl)))
        apexes[0] = true;
    }
    for (const Around& x : around_b) {
      if (x.prev == vl && vl != kInvalid) fn[0] = x.face;
      if (x.next == vr && vr != kInvalid) fn[3] = x.face;
      if (vl != kInvalid && vr != kInvalid && ((x.next == vl && x.prev == vr) || (x.next == vr && x.prev == vl)))
        apexes[1] = true;
    }
    if (apexes[0] && apexes[1]) fail(name() + ": the collapse would make two faces on the same corners");
    if (fn != r.fn) fail(name() + ": fn0..fn3 are not the faces around fl^ and fr^");
    // The stored ring (Xia-Varshney): the neighbours of the new node (the corners of the faces it keeps), each
    // once.
    ++stamp;
    std::size_t neighbours = 0;
    for (const std::vector<Around>* ar : {&around_a, &around_b})
      for (const Around& x : *ar) {
        if (x.face == fl || x.face == fr) continue;
        for (Index w : {x.next, x.prev})
          if (w != a && w != b && seen[w] != stamp) seen[w] = stamp, ++neighbours;
      }
    const std::span<const Index> ring = stored_ring(static_cast<Index>(v));
    if (ring.size() != neighbours) fail(name() + ": the stored ring is not the set of its neighbours");
    for (Index w : ring) {
      if (w >= nn || seen[w] != stamp) fail(name() + ": the stored ring is not the set of its neighbours");
      seen[w] = stamp - 1;  // each once
    }
    // The collapse: fl and fr die, the other faces of a and b move to v (a's then b's), the apexes lose them.
    for (Index f : {fl, fr})
      if (f != kInvalid) alive[f] = 0;
    run[v].off = pool.size();
    for (const std::vector<Around>* ar : {&around_a, &around_b})
      for (const Around& x : *ar) {
        if (x.face == fl || x.face == fr) continue;
        cur[3 * x.face + static_cast<std::size_t>(x.k)] = static_cast<Index>(v);
        pool.push_back(x.face);
      }
    run[v].cnt = run[v].live = static_cast<Index>(pool.size() - run[v].off);
    run[a].cnt = run[b].cnt = run[a].live = run[b].live = 0;
    for (Index x : {vl, vr})
      if (x != kInvalid) --run[x].live;  // fl holds vl once, fr holds vr once
  }
  // 3. What is left is the base mesh.
  std::size_t left = 0;
  for (std::size_t f = 0; f < nf; ++f) left += alive[f];
  if (left != base_faces_.size()) fail("the collapses leave " + std::to_string(left) + " faces, the base mesh has " + std::to_string(base_faces_.size()));
  for (Index f : base_faces_)
    if (!alive[f]) fail("base face " + std::to_string(f) + " was removed by a collapse");
}

}  // namespace varmesh
