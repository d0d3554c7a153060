// Derived arrays of a vertex hierarchy (parents, face creators, roots, base faces, <tree-id, node-id> keys
// of Kim-Lee 2001 section 4.3) and its self-check.
#include "pm/vertex_hierarchy.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
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

namespace {

// From this many nodes finish() runs the untrusted checks on a second thread (it costs a thread, no work).
constexpr std::size_t kThreadedUntrustedNodes = 1u << 14;
// From this many collapses validate() splits the replay. The split has costs of its own (the mesh the second
// part starts from, a second set of scratch arrays): on the bunny, 35k collapses, 10 ms of processor time
// more for a load of 50, which a busy second core turns into a loss; on the dragon, 436k, a tenth more time
// for a third less wall time.
constexpr std::size_t kSplitCollapses = 1u << 17;

// How many distinct values `values` holds, all below `bound`: one pass over a bit per possible value when
// that takes at most a 64-bit word per value, else a sort.
std::size_t count_distinct(const std::vector<Index>& values, std::size_t bound) {
  if (bound > 64 * (values.size() + 1)) {
    std::vector<Index> sorted(values);
    std::sort(sorted.begin(), sorted.end());
    return static_cast<std::size_t>(std::unique(sorted.begin(), sorted.end()) - sorted.begin());
  }
  std::vector<std::uint64_t> seen(bound / 64 + 1, 0);
  std::size_t distinct = 0;
  for (Index x : values) {
    const std::uint64_t bit = 1ull << (x % 64);
    distinct += (seen[x / 64] & bit) == 0;
    seen[x / 64] |= bit;
  }
  return distinct;
}

// The smallest value that `values` holds twice; kInvalid when none does. Counted as count_distinct does.
Index smallest_repeated(std::span<const Index> values) {
  const std::size_t bound = values.empty() ? 0 : std::size_t{*std::max_element(values.begin(), values.end())} + 1;
  if (bound > 64 * (values.size() + 1)) {
    std::vector<Index> sorted(values.begin(), values.end());
    std::sort(sorted.begin(), sorted.end());
    const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
    return dup == sorted.end() ? kInvalid : *dup;
  }
  std::vector<std::uint64_t> seen(bound / 64 + 1, 0), twice(bound / 64 + 1, 0);
  for (Index x : values) {
    const std::uint64_t bit = 1ull << (x % 64);
    twice[x / 64] |= seen[x / 64] & bit;
    seen[x / 64] |= bit;
  }
  for (std::size_t w = 0; w < twice.size(); ++w)
    if (twice[w] != 0) return static_cast<Index>(64 * w + static_cast<std::size_t>(std::countr_zero(twice[w])));
  return kInvalid;
}

}  // namespace

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
    const InputRepairReport& r = raw.repair;
    const std::size_t distinct = count_distinct(raw.leaf_to_input, r.input_vertices);
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
  // The untrusted checks only read `raw`, as the derivation below does: on a large file they run on a second
  // thread meanwhile. Their failure is reported first, as when they ran before the derivation.
  std::exception_ptr untrusted_error;
  std::thread untrusted;
  if (!trusted && nn >= kThreadedUntrustedNodes) {
    try {
      untrusted = std::thread([&] {
        try {
          check_untrusted(raw);
        } catch (...) {
          untrusted_error = std::current_exception();
        }
      });
    } catch (const std::system_error&) {
      check_untrusted(raw);
    }
  } else if (!trusted) {
    check_untrusted(raw);
  }
  auto join_untrusted = [&] {
    if (untrusted.joinable()) untrusted.join();
    if (untrusted_error) std::rethrow_exception(untrusted_error);
  };
  auto derive = [&] {
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

  };
  try {
    derive();
  } catch (...) {
    join_untrusted();
    throw;
  }
  join_untrusted();

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

[[noreturn]] void fail_validate(const std::string& what) { throw std::logic_error("VertexHierarchy::validate: " + what); }

// Per leaf, its original faces in increasing face id (a counting sort of the corners): where every replay of
// the collapses starts from, and what the check of the original mesh walks. Built once, then only read (by
// both threads of a split validation).
struct LeafFaces {
  std::vector<std::size_t> off;  // num_leaves() + 1
  std::vector<Index> faces;      // three entries per original face
  std::span<const Index> of(Index l) const noexcept { return {faces.data() + off[l], faces.data() + off[l + 1]}; }
};

LeafFaces leaf_faces(const VertexHierarchy& h) {
  const std::span<const Index> corners = h.face_corners();
  LeafFaces lf;
  lf.off.assign(h.num_leaves() + 1, 0);
  for (Index c : corners) ++lf.off[c + 1];
  for (std::size_t l = 0; l < h.num_leaves(); ++l) lf.off[l + 1] += lf.off[l];
  lf.faces.resize(corners.size());
  std::vector<std::size_t> fill(lf.off.begin(), lf.off.end() - 1);
  for (std::size_t i = 0; i < corners.size(); ++i) lf.faces[fill[corners[i]]++] = static_cast<Index>(i / 3);
  return lf;
}

// The original mesh: an oriented 2-manifold with border. Per leaf, its faces' (next, prev) corners, placed
// by the leaf runs of `lf` in one pass over the faces.
void check_original_mesh(const VertexHierarchy& h, const LeafFaces& lf) {
  const std::span<const Index> cur = h.face_corners();
  const std::size_t nl = h.num_leaves(), nf = h.num_faces();
  for (std::size_t f = 0; f < nf; ++f)
    if (cur[3 * f] == cur[3 * f + 1] || cur[3 * f + 1] == cur[3 * f + 2] || cur[3 * f] == cur[3 * f + 2])
      fail_validate("original face " + std::to_string(f) + " repeats a corner");
  std::vector<std::array<Index, 2>> np(cur.size());
  {
    std::vector<std::size_t> fill(lf.off.begin(), lf.off.end() - 1);
    for (std::size_t f = 0; f < nf; ++f) {
      const Index c0 = cur[3 * f], c1 = cur[3 * f + 1], c2 = cur[3 * f + 2];
      np[fill[c0]++] = {c1, c2};
      np[fill[c1]++] = {c2, c0};
      np[fill[c2]++] = {c0, c1};
    }
  }
  std::vector<std::uint32_t> mark(nl, 0);
  std::uint32_t stamp = 0;
  std::vector<Index> pos_of(nl, 0), succ;
  for (Index v = 0; v < nl; ++v) {
    const std::span<const std::array<Index, 2>> fs(np.data() + lf.off[v], lf.off[v + 1] - lf.off[v]);
    const auto name = [&] { return "original vertex " + std::to_string(v); };
    // Directed edges v -> next: each once. pos_of[next] = the face's place in the run while v is tested.
    ++stamp;
    for (Index i = 0; i < fs.size(); ++i) {
      const Index w = fs[i][0];
      if (mark[w] == stamp) fail_validate(name() + ": the directed edge to " + std::to_string(w) + " is in two faces");
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
      if (fs[j][1] == next_i) fail_validate(name() + ": two faces on the same corners");
      if (succ[j] != kInvalid) fail_validate(name() + ": the directed edge from " + std::to_string(prev_i) + " is in two faces");
      succ[j] = i;
    }
    Index count = fs.empty() ? 0 : 1;
    if (starts <= 1)
      for (Index i = fs.empty() ? kInvalid : succ[start]; i != kInvalid && i != start && count <= fs.size(); i = succ[i])
        ++count;
    if (starts > 1 || count != fs.size()) fail_validate(name() + ": its faces form more than one fan");
  }
}

// A replay of the collapses on the original faces: the current mesh as corners (node ids) and, per node, a
// run of its faces in one pool (a collapse appends the new node's run; the children's runs are dropped).
// A run holds `cnt` entries from `off`, `live` of them alive: an apex's run keeps the faces a collapse removed
// from it, skipped when the run is read, which is cheaper than compacting it.
//
// A replay can start at any node `first`, from the mesh that the collapses before it leave when they are all
// legal, derived from the tree alone: a face is alive unless one of those collapses creates it (face_creator),
// a corner is its leaf's highest ancestor below `first`, and a node's run lists its alive faces in the order
// the serial replay would: its first child's run, then its second child's (a leaf's faces in increasing id).
// So when the collapses before `first` pass, the replay from `first` checks exactly what one replay from the
// original mesh would, failures and messages included; that is what lets validate() split the replay in two.
class Replay {
 public:
  Replay(const VertexHierarchy& h, const LeafFaces& lf, std::size_t first);
  // Replays the collapses creating nodes first .. last - 1, in node order; stops early (leaving the mesh
  // unfinished) once `stop` is set.
  void run(std::size_t last, const std::atomic<bool>* stop);
  // What is left once every collapse is replayed is the base mesh.
  void check_base() const;

 private:
  struct Run {
    std::size_t off = 0;
    Index cnt = 0, live = 0;
  };
  // Per face of a child: the face, the child's corner index in it, the corners after and before the child.
  struct Around {
    Index face, next, prev;
    int k;
  };
  std::span<const Index> faces_of(Index v) const noexcept { return {pool_.data() + run_[v].off, run_[v].cnt}; }
  void read_around(Index v, std::vector<Around>& out) const;
  bool is_border(const std::vector<Around>& ar);

  const VertexHierarchy& h_;
  std::size_t next_;  // the node the next collapse creates
  std::vector<Index> cur_;
  std::vector<std::uint8_t> alive_;
  std::vector<Run> run_;
  std::vector<Index> pool_;
  // Stamped scratch marks, one array per purpose.
  std::vector<std::uint32_t> mark_, seen_;
  std::uint32_t stamp_ = 0;
  std::vector<Around> around_a_, around_b_;
};

Replay::Replay(const VertexHierarchy& h, const LeafFaces& lf, std::size_t first) : h_(h), next_(first) {
  const std::size_t nl = h.num_leaves(), nn = h.num_nodes(), nf = h.num_faces();
  const std::span<const Index> corners = h.face_corners();
  if (first == nl) {  // the original mesh: every face alive on its leaves, a leaf's run its faces
    cur_.assign(corners.begin(), corners.end());
    alive_.assign(nf, 1);
    run_.assign(nn, Run{});
    for (std::size_t l = 0; l < nl; ++l) {
      run_[l].off = lf.off[l];
      run_[l].cnt = run_[l].live = static_cast<Index>(lf.off[l + 1] - lf.off[l]);
    }
    pool_.reserve(3 * corners.size());
    pool_.assign(lf.faces.begin(), lf.faces.end());
    mark_.assign(nn, 0);
    seen_.assign(nn, 0);
    return;
  }
  // act[v], for v < first: the node standing for v in the mesh before `first`. Parents come after their
  // children, so walking down from first - 1 meets each parent before its children.
  std::vector<Index> act(first);
  for (std::size_t v = first; v-- > 0;) {
    const Index p = h.parent(static_cast<Index>(v));
    act[v] = (p == kInvalid || p >= first) ? static_cast<Index>(v) : act[p];
  }
  alive_.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const Index c = h.face_creator(static_cast<Index>(f));
    alive_[f] = c == kInvalid || c >= first;
  }
  cur_.resize(corners.size());
  for (std::size_t i = 0; i < corners.size(); ++i) cur_[i] = act[corners[i]];
  // The runs, laid out as a walk of each active node's subtree (first child first) would list them, but in
  // passes over the arrays in order instead of the walk's scattered reads: per node the number of alive
  // faces under it, bottom-up; per node the place of its run, top-down; then each leaf's alive faces there.
  std::vector<std::size_t> weight(first, 0), place(first, 0);
  for (std::size_t l = 0; l < nl; ++l)
    for (Index f : lf.of(static_cast<Index>(l))) weight[l] += alive_[f];
  for (std::size_t v = nl; v < first; ++v) {
    const CollapseRecord& r = h.record(static_cast<Index>(v));
    weight[v] = weight[r.vt] + weight[r.vu];
  }
  run_.assign(nn, Run{});
  std::size_t total = 0;
  for (std::size_t v = 0; v < first; ++v)
    if (act[v] == v) {
      place[v] = total;
      run_[v].off = total;
      run_[v].cnt = run_[v].live = static_cast<Index>(weight[v]);
      total += weight[v];
    }
  for (std::size_t v = first; v-- > nl;) {
    const CollapseRecord& r = h.record(static_cast<Index>(v));
    place[r.vt] = place[v];
    place[r.vu] = place[v] + weight[r.vt];
  }
  pool_.reserve(std::max(total, 3 * corners.size()));
  pool_.resize(total);
  for (std::size_t l = 0; l < nl; ++l) {
    std::size_t at = place[l];
    for (Index f : lf.of(static_cast<Index>(l)))
      if (alive_[f]) pool_[at++] = f;
  }
  mark_.assign(nn, 0);
  seen_.assign(nn, 0);
}

void Replay::read_around(Index v, std::vector<Around>& out) const {
  out.clear();
  for (Index f : faces_of(v)) {
    if (!alive_[f]) continue;
    const Index* c = &cur_[3 * std::size_t{f}];
    const int k = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
    out.push_back({f, c[(k + 1) % 3], c[(k + 2) % 3], k});
  }
}

// An open fan has a corner after v that is before v in no face.
bool Replay::is_border(const std::vector<Around>& ar) {
  ++stamp_;
  for (const Around& x : ar) seen_[x.prev] = stamp_;
  for (const Around& x : ar)
    if (seen_[x.next] != stamp_) return true;
  return false;
}

void Replay::run(std::size_t last, const std::atomic<bool>* stop) {
  const VertexHierarchy& h = h_;
  const std::size_t nl = h.num_leaves(), nn = h.num_nodes(), nc = h.num_collapses();
  std::vector<Index>& cur = cur_;
  std::vector<std::uint8_t>& alive = alive_;
  std::vector<Run>& run = run_;
  std::vector<Index>& pool = pool_;
  std::vector<std::uint32_t>&mark = mark_, &seen = seen_;
  std::uint32_t& stamp = stamp_;
  std::vector<Around>&around_a = around_a_, &around_b = around_b_;
  auto fail = fail_validate;
  auto is_border = [&](const std::vector<Around>& ar) { return this->is_border(ar); };
  // The faces around successive collapses are scattered: read the children's runs two steps ahead and their
  // faces' corners one step ahead so that the misses overlap (a run not created yet has no entries).
  constexpr std::size_t kAhead = 8;
  using detail::touch;
  auto touch_runs = [&](std::size_t i) {
    const CollapseRecord& q = h.record(static_cast<Index>(nl + i));
    for (Index c : {q.vt, q.vu})
      if (c < nn) touch(run[c].cnt);
  };
  auto touch_corners = [&](std::size_t i) {
    const CollapseRecord& q = h.record(static_cast<Index>(nl + i));
    for (Index c : {q.vt, q.vu})
      if (c < nn)
        for (Index k = 0; k < run[c].cnt; ++k) touch(cur[3 * std::size_t{pool[run[c].off + k]}]);
  };
  for (; next_ < last; ++next_) {
    const std::size_t v = next_, i = v - nl;
    if (stop != nullptr && i % 1024 == 0 && stop->load(std::memory_order_relaxed)) return;
    if (i + 2 * kAhead < nc) touch_runs(i + 2 * kAhead);
    if (i + kAhead < nc) touch_corners(i + kAhead);
    const CollapseRecord& r = h.record(static_cast<Index>(v));
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
        (vl != kInvalid && !h.is_ancestor_or_self(vl, r.vl_hat)) || (vr != kInvalid && !h.is_ancestor_or_self(vr, r.vr_hat)))
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
    const std::span<const Index> ring = h.stored_ring(static_cast<Index>(v));
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
}

void Replay::check_base() const {
  std::size_t left = 0;
  for (std::uint8_t a : alive_) left += a;
  if (left != h_.base_faces().size())
    fail_validate("the collapses leave " + std::to_string(left) + " faces, the base mesh has " + std::to_string(h_.base_faces().size()));
  for (Index f : h_.base_faces())
    if (!alive_[f]) fail_validate("base face " + std::to_string(f) + " was removed by a collapse");
}

// The share of the replay the caller's thread takes when split: the other thread has besides the checks of
// the nodes and records, of the original mesh and of the leaves' geometry, and the derivation of the mesh it
// starts from (balanced on the dragon, 436k collapses).
constexpr std::size_t kFirstPartPercent = 70;

}  // namespace

// The checks of validate() before the replay: finite values, the tree, the keys, the nested bounds and the
// faces fl^/fr^ of every record.
void VertexHierarchy::check_nodes() const {
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
      // In double, as enclose() computes the spheres: a float |d|^2 overflows past ~1.8e19, and a model with
      // a coordinate near 2e38 failed its own validation (found by fuzz_pipeline).
      const glm::dvec3 pc(pb.center), cc(cb.center);
      const double slack = 1e-4 * (double(pb.radius) + glm::length(pc)) + 1e-6;
      if (glm::length(cc - pc) + double(cb.radius) > double(pb.radius) + slack)
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

// The checks of validate() after the replay: the geometry and the maps, on a hierarchy whose topology is sound.
void VertexHierarchy::check_leaf_geometry() const {
  auto fail = fail_validate;
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
  if (const Index dup = smallest_repeated(face_to_input_); dup != kInvalid)
    fail("input face " + std::to_string(dup) + " is the source of two faces");
}


void VertexHierarchy::validate(unsigned threads) const {
  const std::size_t nl = num_leaves_, nn = num_nodes(), nc = records_.size();
  if (threads == 0) threads = nc >= kSplitCollapses && std::thread::hardware_concurrency() >= 2 ? 2 : 1;
  if (threads == 1 || nc < 2) {
    check_nodes();
    const LeafFaces lf = leaf_faces(*this);
    check_original_mesh(*this, lf);
    Replay whole(*this, lf, nl);
    whole.run(nn, nullptr);
    whole.check_base();
    check_leaf_geometry();
    return;
  }
  // Split in two: this thread replays the first collapses from the original mesh while the other checks the
  // nodes and the original mesh, then replays the rest from the mesh they leave (see Replay) and checks the
  // leaves. The parts run without waiting for each other's verdict (each is safe on any hierarchy that
  // finish() accepted, only its conclusions need the earlier checks to pass); the error reported is the first
  // one a serial run meets: the other thread's before the replay (nodes, original mesh), then this thread's,
  // then the other's later ones. A part whose outcome can no longer matter stops early.
  const std::size_t split = std::clamp<std::size_t>(nl + nc * kFirstPartPercent / 100, nl + 1, nn - 1);
  const LeafFaces lf = leaf_faces(*this);
  std::exception_ptr first_error, second_error;
  bool second_failed_early = false;
  std::atomic<bool> stop{false};          // the first part's outcome no longer matters
  std::atomic<bool> first_failed{false};  // nor then does the second part's
  auto second = [&] {
    try {
      check_nodes();
      check_original_mesh(*this, lf);
    } catch (...) {
      second_error = std::current_exception();
      second_failed_early = true;
      stop.store(true, std::memory_order_relaxed);
      return;
    }
    try {
      Replay rest(*this, lf, split);
      rest.run(nn, &first_failed);
      if (first_failed.load(std::memory_order_relaxed)) return;
      rest.check_base();
      check_leaf_geometry();
    } catch (...) {
      second_error = std::current_exception();
    }
  };
  std::thread helper;
  try {
    helper = std::thread(second);
  } catch (const std::system_error&) {  // no thread to be had: the same checks, serially
    validate(1);
    return;
  }
  try {
    Replay first(*this, lf, nl);
    first.run(split, &stop);
  } catch (...) {
    first_error = std::current_exception();
    first_failed.store(true, std::memory_order_relaxed);
  }
  helper.join();
  if (second_failed_early) std::rethrow_exception(second_error);
  if (first_error) std::rethrow_exception(first_error);
  if (second_error) std::rethrow_exception(second_error);
}

}  // namespace varmesh
