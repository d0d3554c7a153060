#pragma once
// The correctness oracle of selective refinement under the three dependency rules, shared by
// sr_mesh_test.cpp and the soak driver pm_soak.cpp. Random vsplit/ecol walks are checked against two
// references built from the original mesh alone, never from SrMesh: pm/dual_pieces.hpp (Kim-Lee sections
// 3.2, 4.2) and DualPieceModel, the same definition kept up to date operation by operation, which predicts
// each Kim-Lee operation (the splits it does, section 4.4's pre-splits and postponed collapses) and lets every
// operation be checked face by face. The Hoppe 1997 and Xia-Varshney rules are checked at every split they do
// (seen through refine()'s sink) and every collapse. No GoogleTest here: a failed walk says what failed in
// WalkResult::failure, and the caller reports it.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pm/dual_pieces.hpp"
#include "pm/sr_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh::testing {
inline std::array<Index, 3> rotate_min_first(std::array<Index, 3> c) {
  while (c[0] > c[1] || c[0] > c[2]) c = {c[1], c[2], c[0]};
  return c;
}

inline bool has_corner(const std::array<Index, 3>& c, Index v) { return c[0] == v || c[1] == v || c[2] == v; }

inline std::string face_text(const std::array<Index, 3>& c) {
  if (c[0] == kInvalid) return "(inactive)";
  return "(" + std::to_string(c[0]) + " " + std::to_string(c[1]) + " " + std::to_string(c[2]) + ")";
}

inline std::array<Index, 3> sr_face(const SrMesh& sr, Index f) {
  return sr.face_active(f) ? sr.face(f) : std::array<Index, 3>{kInvalid, kInvalid, kInvalid};
}

// Per hierarchy: the leaves below each node and the original faces with a corner below each node (each face
// once), as offsets + items. A vsplit or ecol of v can only change the faces listed under v.
struct Subtrees {
  std::vector<Index> leaf_off, leaf_items, face_off, face_items;
  std::span<const Index> leaves(Index v) const { return {leaf_items.data() + leaf_off[v], leaf_items.data() + leaf_off[v + 1]}; }
  std::span<const Index> faces(Index v) const { return {face_items.data() + face_off[v], face_items.data() + face_off[v + 1]}; }
};

inline Subtrees subtrees_of(const VertexHierarchy& h) {
  const std::size_t n = h.num_nodes();
  Subtrees t;
  // Two passes each (count, then fill), walking up from every leaf.
  auto build = [&](std::vector<Index>& off, std::vector<Index>& items, bool faces) {
    off.assign(n + 1, 0);
    std::vector<Index> last(n, kInvalid);
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<Index> at(off.begin(), off.end() - 1);
      std::fill(last.begin(), last.end(), kInvalid);
      const std::size_t count = faces ? h.num_faces() : h.num_leaves();
      for (Index e = 0; e < count; ++e) {
        const std::array<Index, 3> starts = faces ? h.face(e) : std::array<Index, 3>{e, e, e};
        for (Index s : starts)
          for (Index a = s; a != kInvalid; a = h.parent(a)) {
            if (last[a] == e) break;  // the rest of the path is listed already (or, for a leaf, listed)
            last[a] = e;
            if (pass == 0) ++off[a + 1];
            else items[at[a]++] = e;
          }
      }
      if (pass == 0) {
        for (std::size_t v = 0; v < n; ++v) off[v + 1] += off[v];
        items.assign(off[n], kInvalid);
      }
    }
  };
  build(t.leaf_off, t.leaf_items, false);
  build(t.face_off, t.face_items, true);
  return t;
}

// The mesh an active vertex set defines (Kim-Lee sections 3.2, 4.2), kept by the test: the active ancestor of
// each leaf, and each original face's corners (its leaves' three active ancestors when they differ).
class DualPieceModel {
 public:
  DualPieceModel(const VertexHierarchy& h, const Subtrees& t) : h_(h), t_(t) {}

  // Takes the active set of `sr` (any state) and derives everything else from it.
  void sync(const SrMesh& sr) {
    active_.assign(h_.num_nodes(), 0);
    std::vector<Index> anc(h_.num_nodes(), kInvalid);
    num_active_ = 0;
    for (std::size_t v = h_.num_nodes(); v-- > 0;) {
      const Index p = h_.parent(static_cast<Index>(v));
      active_[v] = sr.is_active(static_cast<Index>(v)) ? 1 : 0;
      num_active_ += active_[v];
      anc[v] = active_[v] ? static_cast<Index>(v) : p == kInvalid ? kInvalid : anc[p];
    }
    anc_.assign(anc.begin(), anc.begin() + static_cast<std::ptrdiff_t>(h_.num_leaves()));
    faces_.assign(h_.num_faces(), {kInvalid, kInvalid, kInvalid});
    num_faces_ = 0;
    for (Index f = 0; f < h_.num_faces(); ++f) relabel(f);
  }

  bool active(Index v) const { return active_[v] != 0; }
  bool collapsible(Index v) const { return !h_.is_leaf(v) && active(h_.vt(v)) && active(h_.vu(v)); }
  bool face_active(Index f) const { return f != kInvalid && faces_[f][0] != kInvalid; }
  // A cut vertex: the active ancestor of a fundamental cut vertex vl^ or vr^ (kInvalid for kInvalid).
  Index cut_vertex(Index leaf) const { return leaf == kInvalid ? kInvalid : anc_[leaf]; }
  bool cut_vertices_coincide(Index vs) const {
    const CollapseRecord& r = h_.record(vs);
    return r.vl_hat != kInvalid && r.vr_hat != kInvalid && anc_[r.vl_hat] == anc_[r.vr_hat];
  }

  void split(Index vs) {
    const CollapseRecord& r = h_.record(vs);
    active_[vs] = 0;
    active_[r.vt] = active_[r.vu] = 1;
    ++num_active_;
    for (Index c : {r.vt, r.vu})
      for (Index l : t_.leaves(c)) anc_[l] = c;
    for (Index f : t_.faces(vs)) relabel(f);
  }
  void collapse(Index vs) {
    const CollapseRecord& r = h_.record(vs);
    active_[r.vt] = active_[r.vu] = 0;
    active_[vs] = 1;
    --num_active_;
    for (Index l : t_.leaves(vs)) anc_[l] = vs;
    for (Index f : t_.faces(vs)) relabel(f);
  }
  // Kim-Lee vsplit_new(vs) as section 4.4 describes it, applied to the model: while both cut vertices are one
  // active vertex, that vertex is split first (by the same rule). Appends the splits done, in order; stops
  // short (and the caller's comparison fails) at a coincident cut vertex that is a leaf.
  void kim_lee_split(Index vs, std::vector<Index>& order) {
    while (cut_vertices_coincide(vs)) {
      const Index w = cut_vertex(h_.record(vs).vl_hat);
      if (h_.is_leaf(w)) return;
      kim_lee_split(w, order);
    }
    split(vs);
    order.push_back(vs);
  }

  // Neighbours of active v, sorted.
  std::vector<Index> ring(Index v) const {
    std::vector<Index> out;
    for (Index f : t_.faces(v)) {
      const auto& c = faces_[f];
      if (c[0] != kInvalid && has_corner(c, v))
        for (Index x : c)
          if (x != v) out.push_back(x);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  // Section 4.4: common neighbours of the children of vs other than its two cut vertices.
  bool extra_common_neighbors(Index vs) const {
    const CollapseRecord& r = h_.record(vs);
    const std::vector<Index> a = ring(r.vt), b = ring(r.vu);
    std::vector<Index> common;
    std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(common));
    for (Index c : common)
      if (c != cut_vertex(r.vl_hat) && c != cut_vertex(r.vr_hat)) return true;
    return false;
  }
  // The active face across the edge a -> b of another face (the one holding b -> a), kInvalid if none.
  Index across(Index a, Index b) const {
    const auto list = t_.faces(a).size() <= t_.faces(b).size() ? t_.faces(a) : t_.faces(b);
    for (Index f : list) {
      const auto& c = faces_[f];
      for (std::size_t k = 0; k < 3; ++k)
        if (c[k] == b && c[(k + 1) % 3] == a) return f;
    }
    return kInvalid;
  }
  // Hoppe 1997's neighbour faces around fl = (vt, vu, vl) and fr = (vu, vt, vr) of vs in the current mesh,
  // in the order of CollapseRecord::fn: across (vu, vl), (vl, vt), (vt, vr), (vr, vu).
  std::array<Index, 4> faces_around_fl_fr(Index vs) const {
    const CollapseRecord& r = h_.record(vs);
    const Index vl = cut_vertex(r.vl_hat), vr = cut_vertex(r.vr_hat);
    std::array<Index, 4> fn{kInvalid, kInvalid, kInvalid, kInvalid};
    if (vl != kInvalid) fn[0] = across(r.vu, vl), fn[1] = across(vl, r.vt);
    if (vr != kInvalid) fn[2] = across(r.vt, vr), fn[3] = across(vr, r.vu);
    return fn;
  }

  bool same_face(const SrMesh& sr, Index f) const {
    const std::array<Index, 3>& b = faces_[f];
    if (!sr.face_active(f)) return b[0] == kInvalid;
    const std::array<Index, 3> a = sr.face(f);
    // Equal up to rotation.
    return b[0] != kInvalid && ((a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) || (a[0] == b[1] && a[1] == b[2] && a[2] == b[0]) ||
                                (a[0] == b[2] && a[1] == b[0] && a[2] == b[1]));
  }
  // "" when `sr` has the model's faces on `faces` (original face ids).
  std::string differs(const SrMesh& sr, std::span<const Index> faces) const {
    for (Index f : faces)
      if (!same_face(sr, f))
        return "face " + std::to_string(f) + " is " + face_text(sr_face(sr, f)) + ", the active set defines " + face_text(faces_[f]);
    return {};
  }
  // "" when `sr` has the model's active set and faces, everywhere.
  std::string differs_everywhere(const SrMesh& sr) const {
    if (sr.num_active_vertices() != num_active_ || sr.num_faces() != num_faces_)
      return std::to_string(sr.num_active_vertices()) + " vertices and " + std::to_string(sr.num_faces()) + " faces, expected " +
             std::to_string(num_active_) + " and " + std::to_string(num_faces_);
    for (Index v = 0; v < h_.num_nodes(); ++v)
      if (sr.is_active(v) != active(v)) return "node " + std::to_string(v) + (active(v) ? " should be active" : " should not be active");
    for (Index f = 0; f < h_.num_faces(); ++f)
      if (!same_face(sr, f)) return differs(sr, std::span<const Index>(&f, 1));
    return {};
  }

 private:
  void relabel(Index f) {
    const auto c = h_.face(f);
    const std::array<Index, 3> a{anc_[c[0]], anc_[c[1]], anc_[c[2]]};
    const bool was = faces_[f][0] != kInvalid, is = a[0] != a[1] && a[1] != a[2] && a[0] != a[2];
    faces_[f] = is ? a : std::array<Index, 3>{kInvalid, kInvalid, kInvalid};
    num_faces_ = num_faces_ + (is ? 1 : 0) - (was ? 1 : 0);
  }

  const VertexHierarchy& h_;
  const Subtrees& t_;
  std::vector<std::uint8_t> active_;
  std::vector<Index> anc_;
  std::vector<std::array<Index, 3>> faces_;
  std::size_t num_active_ = 0, num_faces_ = 0;
};

// Neighbours of active v in `sr` itself, sorted (faces below v are the only ones that can hold v).
inline std::vector<Index> sr_ring(const SrMesh& sr, const Subtrees& t, Index v) {
  std::vector<Index> out;
  for (Index f : t.faces(v)) {
    if (!sr.face_active(f)) continue;
    const auto c = sr.face(f);
    if (has_corner(c, v))
      for (Index x : c)
        if (x != v) out.push_back(x);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

inline std::vector<Index> sorted(std::span<const Index> s) {
  std::vector<Index> out(s.begin(), s.end());
  std::sort(out.begin(), out.end());
  return out;
}

// Compares the SrMesh with pm/dual_pieces.hpp's mesh of its active set, and checks that mesh is an oriented
// 2-manifold: every directed edge once, every vertex's faces one fan. "" when all holds.
inline std::string compare_with_oracle(const SrMesh& sr) {
  const VertexHierarchy& h = sr.hierarchy();
  std::vector<std::uint8_t> active(h.num_nodes(), 0);
  for (Index v : sr.active_vertices()) active[v] = 1;
  const std::vector<Index> anc = active_ancestors(h, active);
  const auto ref = dual_piece_mesh(h, anc);
  if (ref.size() != sr.num_faces()) return "face count " + std::to_string(sr.num_faces()) + " vs oracle " + std::to_string(ref.size());
  for (const DualPieceFace& f : ref) {
    if (!sr.face_active(f.original)) return "oracle face " + std::to_string(f.original) + " inactive";
    if (rotate_min_first(sr.face(f.original)) != rotate_min_first(f.corners)) return "face " + std::to_string(f.original) + " corners differ";
  }
  // The faces around each vertex as the edges a -> b of its link (counting sort by vertex).
  const std::size_t n = h.num_nodes();
  std::vector<Index> off(n + 1, 0);
  for (const DualPieceFace& f : ref)
    for (Index c : f.corners) ++off[c + 1];
  for (std::size_t v = 0; v < n; ++v) off[v + 1] += off[v];
  std::vector<std::pair<Index, Index>> link(off[n]);
  std::vector<Index> at(off.begin(), off.end() - 1);
  for (const DualPieceFace& f : ref)
    for (std::size_t k = 0; k < 3; ++k) link[at[f.corners[k]]++] = {f.corners[(k + 1) % 3], f.corners[(k + 2) % 3]};
  // Per vertex: each directed edge v -> a and b -> v at most once (no a twice as a start, no b twice as an
  // end); then one fan: following a -> b from a start that is no end (an open fan) or from anywhere (a closed
  // one) passes every face. Marks per vertex keep it linear in the link's size.
  std::vector<Index> start_of(n, kInvalid), end_of(n, kInvalid), next(n, kInvalid);
  for (Index v : sr.active_vertices()) {
    const auto l = link.begin() + off[v];
    const auto k = static_cast<std::ptrdiff_t>(off[v + 1] - off[v]);
    if (k == 0) return "active vertex " + std::to_string(v) + " has no face";
    for (std::ptrdiff_t i = 0; i < k; ++i) {
      const auto [a, b] = l[i];
      if (start_of[a] == v || end_of[b] == v)
        return "vertex " + std::to_string(v) + ": a directed edge used twice (not manifold or not oriented)";
      start_of[a] = end_of[b] = v;
      next[a] = b;
    }
    Index first = l[0].first;
    for (std::ptrdiff_t i = 0; i < k; ++i)
      if (end_of[l[i].first] != v) first = l[i].first;
    std::ptrdiff_t steps = 1;
    for (Index w = next[first]; steps < k && start_of[w] == v && w != first; ++steps) w = next[w];
    if (steps != k) return "vertex " + std::to_string(v) + ": its faces form more than one fan";
  }
  return "";
}

inline bool same_as_original(const SrMesh& sr) {
  const VertexHierarchy& h = sr.hierarchy();
  if (sr.num_faces() != h.num_faces()) return false;
  for (Index f = 0; f < h.num_faces(); ++f)
    if (!sr.face_active(f) || rotate_min_first(sr.face(f)) != rotate_min_first(h.face(f))) return false;
  return true;
}

// The mesh after refine_all against the user's input: through leaf_to_input and face_to_input, each face is
// the input face it comes from (same corners, same orientation), and the faces are the input's minus those
// manifold_input.hpp drops (a repeated corner; the same corners as an earlier face, in any order), each once.
inline std::string differs_from_input(const SrMesh& sr, const TriMesh& input) {
  const VertexHierarchy& h = sr.hierarchy();
  std::vector<std::uint8_t> kept(input.num_faces(), 0);
  std::vector<std::array<Index, 3>> seen;
  for (std::size_t f = 0; f < input.num_faces(); ++f) {
    std::array<Index, 3> c{input.corner(f, 0), input.corner(f, 1), input.corner(f, 2)};
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
    std::sort(c.begin(), c.end());
    seen.push_back(c);
  }
  std::sort(seen.begin(), seen.end());
  std::vector<std::uint8_t> taken(seen.size(), 0);
  for (std::size_t f = 0; f < input.num_faces(); ++f) {
    std::array<Index, 3> c{input.corner(f, 0), input.corner(f, 1), input.corner(f, 2)};
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
    std::sort(c.begin(), c.end());
    const std::size_t i = static_cast<std::size_t>(std::lower_bound(seen.begin(), seen.end(), c) - seen.begin());
    if (!taken[i]) taken[i] = kept[f] = 1;
  }
  std::vector<std::uint8_t> hit(input.num_faces(), 0);
  const auto l2i = h.leaf_to_input();
  const auto f2i = h.face_to_input();
  std::string problem;
  sr.for_each_face([&](Index f, Index a, Index b, Index c) {
    if (!problem.empty()) return;
    const Index in = f2i[f];
    if (in >= input.num_faces() || !kept[in] || hit[in]) {
      problem = "face " + std::to_string(f) + " maps to input face " + std::to_string(in) + ", dropped or taken";
      return;
    }
    hit[in] = 1;
    if (!h.is_leaf(a) || !h.is_leaf(b) || !h.is_leaf(c)) {
      problem = "face " + std::to_string(f) + " has a corner that is not a leaf";
      return;
    }
    const std::array<Index, 3> got{l2i[a], l2i[b], l2i[c]}, want{input.corner(in, 0), input.corner(in, 1), input.corner(in, 2)};
    if (rotate_min_first(got) != rotate_min_first(want))
      problem = "face " + std::to_string(f) + " is " + face_text(got) + " in input vertices, input face " + std::to_string(in) + " is " + face_text(want);
  });
  if (!problem.empty()) return problem;
  for (std::size_t f = 0; f < input.num_faces(); ++f)
    if (kept[f] && !hit[f]) return "input face " + std::to_string(f) + " is missing";
  const InputRepairReport& rep = h.repair_report();
  const std::size_t dropped = input.num_faces() - static_cast<std::size_t>(std::count(kept.begin(), kept.end(), 1));
  if (rep.degenerate_faces + rep.duplicate_faces != dropped)
    return "the repair report drops " + std::to_string(rep.degenerate_faces + rep.duplicate_faces) + " faces, not " + std::to_string(dropped);
  return "";
}

inline bool at_base(const SrMesh& sr) {
  auto act = sr.active_vertices();
  std::vector<Index> roots(sr.hierarchy().roots().begin(), sr.hierarchy().roots().end());
  std::sort(act.begin(), act.end());
  std::sort(roots.begin(), roots.end());
  return act == roots;
}

struct WalkOptions {
  std::size_t ops = 1000;           ///< stop once this many requested vsplits and ecols have been done
  std::size_t max_steps = 0;        ///< and after this many requests at the latest (0: 4 ops + 100)
  std::uint32_t seed = 1;
  double split_bias = 0.55;         ///< probability that a request is a vsplit
  std::size_t full_every = 1;       ///< every face and every node's state against the model, every this many requests
  std::size_t oracle_every = 50;    ///< compare_with_oracle(), every this many requests
  std::size_t validate_every = 50;  ///< SrMesh::validate(), every this many requests
  /// Probability that a request takes its vertex from the mesh's own lists (its active non-leaf vertices, its
  /// coarsen candidates) instead of trying random nodes: deep in a big hierarchy few random nodes are active.
  /// The model must agree that what the lists give is active or collapsible. 0 keeps the random sequence
  /// of a walk without it.
  double list_pick = 0.0;
};


struct WalkResult {
  std::size_t steps = 0, splits = 0, collapses = 0;
  std::size_t refused = 0, failed_splits = 0;  ///< ecols that returned false, vsplits that did not split
  std::size_t presplit_requests = 0;           ///< Kim-Lee vsplits the model saw needing section 4.4 pre-splits
  std::size_t selective_splits = 0, selective_collapses = 0;  ///< operations checked to touch one vertex's star
  std::size_t full_checks = 0, oracle_checks = 0;
  bool ok = true;
  std::string failure;  ///< what failed first (scheme, request, operation), when !ok
  std::size_t ops() const { return splits + collapses; }
};

inline std::string list_text(const std::vector<Index>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + std::to_string(v[i]);
  return s + "]";
}

// Random vsplit/ecol requests on an SrMesh of any scheme, each checked as it is done:
// - the counters of SrStats agree with what happened (every split counted as requested, forced or pre-split;
//   every ecol of a vsplit request counted as forced; active vertices = splits - collapses);
// - Kim-Lee: the splits done (seen through refine()'s sink) are the model's section 4.4 prediction, no more;
//   an ecol is postponed exactly when the model finds common neighbours besides the cut vertices; outside
//   those degenerate cases a vsplit turns one vertex into two and changes only faces that held it (and adds
//   fl, fr), an ecol the reverse;
// - Hoppe 1997: every split (forced ones too) happens with its four stored faces fn0..fn3 active, which are
//   then around fl and fr where Hoppe's vsplit puts them; an ecol succeeds exactly when fl and fr have those
//   neighbours (and no extra common neighbour, as in Kim-Lee);
// - Xia-Varshney: every split happens with the current 1-ring of vs equal to its stored ring, and a successful
//   ecol leaves vs with its stored ring;
// - after each operation the faces it may change equal the model's; every `full_every` requests every face and
//   node state; every `oracle_every`, compare_with_oracle(); every `validate_every`, SrMesh::validate().
class CheckedWalk {
 public:
  CheckedWalk(SrMesh& sr, const Subtrees& t) : sr_(sr), h_(sr.hierarchy()), t_(t), model_(h_, t) { model_.sync(sr); }

  WalkResult run(const WalkOptions& o) {
    std::mt19937 rng(o.seed);
    std::uniform_int_distribution<Index> pick(static_cast<Index>(h_.num_leaves()), static_cast<Index>(h_.num_nodes() - 1));
    std::bernoulli_distribution want_split(o.split_bias);
    const std::size_t max_steps = o.max_steps ? o.max_steps : 4 * o.ops + 100;
    res_ = {};
    model_.sync(sr_);
    while (res_.ops() < o.ops && res_.steps < max_steps) {
      ++res_.steps;
      const bool split = want_split(rng);
      Index v = kInvalid;
      std::string problem;
      if (o.list_pick > 0.0 && std::bernoulli_distribution(o.list_pick)(rng)) {
        listed_.clear();
        if (split) {
          for (Index c : sr_.active_vertices())
            if (!h_.is_leaf(c)) listed_.push_back(c);
        } else {
          sr_.for_each_coarsen_candidate([&](Index c) { listed_.push_back(c); });
        }
        if (!listed_.empty()) {
          v = listed_[std::uniform_int_distribution<std::size_t>(0, listed_.size() - 1)(rng)];
          if (split ? !model_.active(v) : !model_.collapsible(v))
            problem = split ? "listed as active, the model disagrees" : "listed as a coarsen candidate, the model disagrees";
        }
      } else {
        for (int attempt = 0; attempt < 64 && v == kInvalid; ++attempt) {
          const Index c = pick(rng);
          if (split ? model_.active(c) : model_.collapsible(c)) v = c;
        }
      }
      if (v != kInvalid && problem.empty()) problem = split ? this->split(v, res_.steps % 2 == 0) : collapse(v);
      if (problem.empty() && o.full_every && res_.steps % o.full_every == 0) {
        problem = model_.differs_everywhere(sr_);
        ++res_.full_checks;
      }
      if (problem.empty() && o.validate_every && res_.steps % o.validate_every == 0) problem = validate();
      if (problem.empty() && o.oracle_every && res_.steps % o.oracle_every == 0) {
        problem = compare_with_oracle(sr_);
        ++res_.oracle_checks;
      }
      if (!problem.empty()) return fail(std::string(split ? "vsplit(" : "ecol(") + std::to_string(v) + "): " + problem);
    }
    std::string problem = model_.differs_everywhere(sr_);
    if (problem.empty()) problem = validate();
    if (problem.empty()) problem = compare_with_oracle(sr_);
    if (!problem.empty()) return fail("at the end: " + problem);
    return res_;
  }

 private:
  WalkResult fail(const std::string& what) {
    res_.failure = std::string(scheme_name(sr_.scheme())) + ", request " + std::to_string(res_.steps) + ": " + what;
    res_.ok = false;
    return res_;
  }
  std::string validate() const {
    try {
      sr_.validate();
    } catch (const std::logic_error& e) {
      return e.what();
    }
    return {};
  }
  void snapshot(Index v) {
    before_.clear();
    for (Index f : t_.faces(v)) before_.push_back(sr_face(sr_, f));
  }
  // After a Kim-Lee-like split of vs (grow = true) or collapse back into vs: one vertex became two or two one,
  // and among the faces that could change (those below vs) only those holding the vertices that went away did,
  // by taking the new vertex in their place; fl and fr appeared or went away.
  std::string star_only(Index vs, bool grow, std::size_t active_before, std::size_t faces_before) const {
    const CollapseRecord& r = h_.record(vs);
    const std::size_t flfr = (r.fl_hat != kInvalid ? 1 : 0) + (r.fr_hat != kInvalid ? 1 : 0);
    if (sr_.num_active_vertices() != (grow ? active_before + 1 : active_before - 1) || sr_.is_active(vs) == grow ||
        sr_.is_active(r.vt) != grow || sr_.is_active(r.vu) != grow)
      return "more than one vertex changed";
    if (sr_.num_faces() != (grow ? faces_before + flfr : faces_before - flfr)) return "faces other than fl and fr appeared or went away";
    const auto below = t_.faces(vs);
    for (std::size_t i = 0; i < below.size(); ++i) {
      const Index f = below[i];
      const std::array<Index, 3> was = before_[i], now = sr_face(sr_, f);
      if (f == r.fl_hat || f == r.fr_hat) {
        if ((was[0] == kInvalid) != grow || (now[0] == kInvalid) == grow) return "fl or fr not " + std::string(grow ? "created" : "removed");
        continue;
      }
      if (was == now) continue;
      if (was[0] == kInvalid || now[0] == kInvalid) return "face " + std::to_string(f) + " went from " + face_text(was) + " to " + face_text(now);
      const std::array<Index, 2> gone = grow ? std::array<Index, 2>{vs, vs} : std::array<Index, 2>{r.vt, r.vu};
      const std::array<Index, 2> came = grow ? std::array<Index, 2>{r.vt, r.vu} : std::array<Index, 2>{vs, vs};
      bool explained = false;
      for (Index old_v : gone)
        for (Index new_v : came) {
          std::array<Index, 3> expect = was;
          for (Index& c : expect)
            if (c == old_v) c = new_v;
          explained = explained || (has_corner(was, old_v) && rotate_min_first(expect) == rotate_min_first(now));
        }
      if (!explained) return "face " + std::to_string(f) + " not incident to the changed vertex went from " + face_text(was) + " to " + face_text(now);
    }
    return "";
  }
  std::string local_compare(const std::vector<Index>& nodes) const {
    for (Index x : nodes) {
      std::string d = model_.differs(sr_, t_.faces(x));
      if (!d.empty()) return d;
    }
    return "";
  }

  std::string split(Index v, bool through_refine) {
    const RefinementScheme scheme = sr_.scheme();
    const SrStats s0 = sr_.stats();
    const std::size_t n0 = sr_.num_active_vertices(), f0 = sr_.num_faces();
    snapshot(v);
    order_.clear();
    std::string rule;
    if (scheme == RefinementScheme::kKimLee && !through_refine) {
      if (!sr_.vsplit(v)) return "returned false";
    } else {
      sr_.refine(v, [&](Index x) {
        order_.push_back(x);
        // Xia-Varshney: the 1-ring of x just before its split is the union of its children's rings now.
        if (scheme == RefinementScheme::kXiaVarshney && rule.empty()) {
          const CollapseRecord& r = h_.record(x);
          std::vector<Index> ring = sr_ring(sr_, t_, r.vt), b = sr_ring(sr_, t_, r.vu);
          ring.insert(ring.end(), b.begin(), b.end());
          std::sort(ring.begin(), ring.end());
          ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
          ring.erase(std::remove_if(ring.begin(), ring.end(), [&](Index y) { return y == r.vt || y == r.vu; }), ring.end());
          if (ring != sorted(h_.stored_ring(x)))
            rule = "Xia-Varshney split of " + std::to_string(x) + " with ring " + list_text(ring) + ", stored " + list_text(sorted(h_.stored_ring(x)));
        }
      });
    }
    const SrStats& s1 = sr_.stats();
    const std::size_t dv = s1.vsplits - s0.vsplits, de = s1.ecols - s0.ecols, dfv = s1.forced_vsplits - s0.forced_vsplits,
                      dfe = s1.forced_ecols - s0.forced_ecols, dpre = s1.presplits - s0.presplits;
    const bool done = sr_.state(v) == SrMesh::State::kRefined;
    if (through_refine && order_.size() != dv) return "the sink saw " + std::to_string(order_.size()) + " splits, SrStats " + std::to_string(dv);
    if (sr_.num_active_vertices() != n0 + dv - de) return "active vertices do not follow the counted splits and collapses";
    if (dfv + dpre + (done ? 1 : 0) != dv) return "splits not counted as requested, forced or pre-split exactly once";
    if (dfe != de) return "a collapse during a vsplit request not counted as forced";
    if (s1.postponed_ecols != s0.postponed_ecols || s1.degenerate_cases - s0.degenerate_cases != dpre) return "#DC counters";
    if (!rule.empty()) return rule;
    if (done) ++res_.splits;
    else ++res_.failed_splits;
    switch (scheme) {
      case RefinementScheme::kKimLee: {
        expected_.clear();
        model_.kim_lee_split(v, expected_);
        if (!done) return "not split";
        if (through_refine && order_ != expected_) return "splits " + list_text(order_) + ", section 4.4 gives " + list_text(expected_);
        if (dv != expected_.size() || dpre != expected_.size() - 1 || dfv != 0 || de != 0)
          return "counted " + std::to_string(dv) + " splits, " + std::to_string(dpre) + " pre-splits, " + std::to_string(dfv) +
                 " forced; section 4.4 gives splits " + list_text(expected_);
        std::string d = local_compare(expected_);
        if (!d.empty()) return d;
        if (expected_.size() > 1) {
          ++res_.presplit_requests;
          return "";
        }
        ++res_.selective_splits;
        return star_only(v, true, n0, f0);
      }
      case RefinementScheme::kHoppe97: {
        if (!done) return "not split";
        for (Index x : order_) {
          if (!model_.active(x)) return "split of " + std::to_string(x) + ", which is not active";
          const CollapseRecord& r = h_.record(x);
          for (Index fn : r.fn)
            if (fn != kInvalid && !model_.face_active(fn))
              return "Hoppe split of " + std::to_string(x) + " while its stored face " + std::to_string(fn) + " is inactive";
          if (model_.cut_vertices_coincide(x)) return "split of " + std::to_string(x) + " with its cut vertices one vertex";
          model_.split(x);
          if (model_.faces_around_fl_fr(x) != r.fn) return "after the split of " + std::to_string(x) + " fl and fr are not between fn0..fn3";
        }
        return local_compare(order_);
      }
      case RefinementScheme::kXiaVarshney: {
        if (de > 0) {
          model_.sync(sr_);
          ++res_.full_checks;
          return model_.differs_everywhere(sr_);
        }
        for (Index x : order_) {
          if (!model_.active(x)) return "split of " + std::to_string(x) + ", which is not active";
          if (model_.ring(x) != sorted(h_.stored_ring(x))) return "Xia-Varshney split of " + std::to_string(x) + " with a ring other than its stored one";
          if (model_.cut_vertices_coincide(x)) return "split of " + std::to_string(x) + " with its cut vertices one vertex";
          model_.split(x);
        }
        return local_compare(order_);
      }
    }
    return "";
  }

  std::string collapse(Index v) {
    const RefinementScheme scheme = sr_.scheme();
    const CollapseRecord& r = h_.record(v);
    const SrStats s0 = sr_.stats();
    const std::size_t n0 = sr_.num_active_vertices(), f0 = sr_.num_faces();
    snapshot(v);
    const bool extra = model_.extra_common_neighbors(v);
    const bool hoppe_faces = model_.faces_around_fl_fr(v) == r.fn;
    const bool ok = sr_.ecol(v);
    const SrStats& s1 = sr_.stats();
    const std::size_t dv = s1.vsplits - s0.vsplits, de = s1.ecols - s0.ecols, dfv = s1.forced_vsplits - s0.forced_vsplits,
                      dfe = s1.forced_ecols - s0.forced_ecols, dpre = s1.presplits - s0.presplits,
                      dpost = s1.postponed_ecols - s0.postponed_ecols, dref = s1.refused_ecols - s0.refused_ecols;
    if (ok != (sr_.is_active(v) && sr_.state(r.vt) == SrMesh::State::kBelow)) return "the return value does not tell what happened";
    if (sr_.num_active_vertices() != n0 + dv - de) return "active vertices do not follow the counted splits and collapses";
    if (de != dfe + (ok ? 1 : 0) || dv != dfv + dpre) return "operations not counted as requested, forced or pre-split exactly once";
    if (dref != (ok ? 0u : 1u)) return "refused_ecols";
    if (s1.degenerate_cases - s0.degenerate_cases != dpre + dpost) return "degenerate_cases is not presplits + postponed_ecols";
    if (ok) ++res_.collapses;
    else ++res_.refused;
    switch (scheme) {
      case RefinementScheme::kKimLee:
      case RefinementScheme::kHoppe97: {
        const bool kim_lee = scheme == RefinementScheme::kKimLee;
        // Kim-Lee: postponed exactly when extra common neighbours exist (section 4.4). Hoppe 1997: legal exactly
        // when fl and fr have fn0..fn3 around them, and not done with extra common neighbours either.
        const bool legal = kim_lee ? !extra : hoppe_faces && !extra;
        if (ok != legal)
          return std::string(ok ? "done" : "refused") + " with " + (extra ? "" : "no ") + "extra common neighbours" +
                 (kim_lee ? "" : hoppe_faces ? " and fn0..fn3 around fl, fr" : " and other faces than fn0..fn3 around fl, fr");
        if (dv != 0 || de != (ok ? 1u : 0u) || dpost != (kim_lee && !ok ? 1u : 0u)) return "counters";
        if (ok) model_.collapse(v);
        std::string d = model_.differs(sr_, t_.faces(v));
        if (!d.empty()) return d;
        if (!ok) {
          for (std::size_t i = 0; i < before_.size(); ++i)
            if (sr_face(sr_, t_.faces(v)[i]) != before_[i]) return "a refused ecol changed face " + std::to_string(t_.faces(v)[i]);
          return sr_.num_active_vertices() == n0 && sr_.num_faces() == f0 ? "" : "a refused ecol changed the mesh";
        }
        ++res_.selective_collapses;
        return star_only(v, false, n0, f0);
      }
      case RefinementScheme::kXiaVarshney: {
        if (dpost != 0) return "postponed_ecols outside Kim-Lee";
        if (ok && sr_ring(sr_, t_, v) != sorted(h_.stored_ring(v))) return "Xia-Varshney ecol leaves vs with a ring other than its stored one";
        if (dv == 0 && de == (ok ? 1u : 0u)) {
          if (ok) model_.collapse(v);
          return model_.differs(sr_, t_.faces(v));
        }
        model_.sync(sr_);
        ++res_.full_checks;
        return model_.differs_everywhere(sr_);
      }
    }
    return "";
  }

  SrMesh& sr_;
  const VertexHierarchy& h_;
  const Subtrees& t_;
  DualPieceModel model_;
  WalkResult res_;
  std::vector<std::array<Index, 3>> before_;
  std::vector<Index> order_, expected_, listed_;
};

/// The walk of CheckedWalk on `sr` (t: the hierarchy's Subtrees, made here when null).
inline WalkResult run_checked_walk(SrMesh& sr, const WalkOptions& o, const Subtrees* t = nullptr) {
  Subtrees own;
  if (!t) {
    own = subtrees_of(sr.hierarchy());
    t = &own;
  }
  CheckedWalk walk(sr, *t);
  return walk.run(o);
}

}  // namespace varmesh::testing
