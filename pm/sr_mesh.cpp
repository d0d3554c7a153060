// Selectively refined mesh: one physical vsplit/ecol and three dependency rules (see sr_mesh.hpp).
// Papers: J. Kim, S. Lee, "Truly selective refinement of progressive meshes", GI 2001 (sections 4.1-4.4);
// H. Hoppe, "View-dependent refinement of progressive meshes", SIGGRAPH 1997 (section 4, the fn0..fn3
// conditions and force_vsplit); J. Xia, A. Varshney, "Dynamic view-dependent simplification for polygonal
// models", IEEE Visualization 1996.
//
// Orientation convention (Kim-Lee section 4.2): fl = (vt, vu, vl) and fr = (vu, vt, vr). Walking around vs
// counter-clockwise, the faces from vl to vr go to vt and those from vr to vl go to vu.
#include "pm/sr_mesh.hpp"

#include <algorithm>
#include <bit>
#include <new>
#include <stdexcept>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

const char* scheme_name(RefinementScheme s) noexcept {
  switch (s) {
    case RefinementScheme::kKimLee: return "kim-lee";
    case RefinementScheme::kHoppe97: return "hoppe97";
    case RefinementScheme::kXiaVarshney: return "xia-varshney";
  }
  return "?";
}

namespace {
constexpr int kXvMaxDepth = 200;
// Rings longer than this look for cut vertices by walking up from the leaf and for common neighbours in a
// sorted copy; shorter ones (nearly all: valence ~6) compare in registers and test the section 4.3 keys.
constexpr std::size_t kLongRing = 32;
// Look-ahead of refine_all/coarsen_all: stages and operations between stages. The last stage walks
// kLookStages - 1 faces each way around a vertex, so 5 stages cover a whole fan of valence up to 8 or 9;
// on the dragon (AMD EPYC guest) 5 x 3 did vsplit/ecol in 143-175 / 172-203 ns against 195-231 /
// 271-305 for 4 x 4 (alternating runs; 5 x 2 was as good, 6 or 7 stages and gaps of 4-8 were slower).
constexpr int kLookStages = 5;
constexpr int kLookGap = 3;

// What a moved-from SrMesh refers to. Building it allocates nothing (all its arrays are empty), so the
// noexcept moves may reach it.
const VertexHierarchy& empty_hierarchy() noexcept {
  static const VertexHierarchy empty;
  return empty;
}

}  // namespace

SrMesh::SrMesh(SrMesh&& other) noexcept : h_(&empty_hierarchy()) { swap(other); }

SrMesh& SrMesh::operator=(SrMesh&& other) noexcept {
  if (this != &other) {
    SrMesh taken(std::move(other));
    swap(taken);
  }
  return *this;
}

void SrMesh::swap(SrMesh& o) noexcept {
  // The rings are scratch, filled again by every operation: not exchanged, and what they held forgotten.
  ecn_.vs = o.ecn_.vs = kInvalid;
  using std::swap;
  swap(h_, o.h_);
  swap(scheme_, o.scheme_);
  swap(num_slots_, o.num_slots_);
  swap(faces_, o.faces_);
  swap(slot_of_, o.slot_of_);
  swap(face_of_, o.face_of_);
  swap(splits_, o.splits_);
  swap(nodes_, o.nodes_);
  swap(base_slots_, o.base_slots_);
  swap(base_corners_, o.base_corners_);
  swap(active_list_, o.active_list_);
  swap(collapsible_, o.collapsible_);
  swap(track_collapsible_, o.track_collapsible_);
  swap(num_active_, o.num_active_);
  swap(num_faces_, o.num_faces_);
  swap(stats_, o.stats_);
  swap(in_progress_, o.in_progress_);
  swap(sink_, o.sink_);
  swap(sink_ctx_, o.sink_ctx_);
}

SrMesh::SrMesh(const VertexHierarchy& h, RefinementScheme scheme) : h_(&h), scheme_(scheme) {
  if (scheme != RefinementScheme::kKimLee && scheme != RefinementScheme::kHoppe97 &&
      scheme != RefinementScheme::kXiaVarshney)
    throw InvalidInput("SrMesh: refinement scheme " + std::to_string(static_cast<int>(scheme)) +
                       " is not one of kKimLee, kHoppe97, kXiaVarshney");
  // Half-edge ids are 4 * face + corner in 32 bits.
  if (h.num_faces() >= (std::size_t{1} << 30))
    throw InvalidInput("SrMesh: " + std::to_string(h.num_faces()) + " faces exceed the 2^30 - 1 supported");
  num_slots_ = static_cast<Index>(h.num_faces());
  faces_.assign(num_slots_, {});
  nodes_.assign(h.num_nodes(), {});
  // in_progress_ serves the Xia-Varshney rule only.
  if (scheme == RefinementScheme::kXiaVarshney) in_progress_.assign(h.num_nodes(), 0);
  // Slots in vsplit order (see faces_); every face is a base face or created by exactly one collapse.
  slot_of_.assign(num_slots_, kInvalid);
  face_of_.assign(num_slots_, kInvalid);
  Index next = 0;
  auto place = [&](Index f) {
    if (f == kInvalid) return;
    slot_of_[f] = next;
    face_of_[next++] = f;
  };
  for (Index f : h.base_faces()) place(f);
  for (std::size_t v = h.num_nodes(); v-- > h.num_leaves();) {
    const CollapseRecord& r = h.record(static_cast<Index>(v));
    place(r.fl_hat);
    place(r.fr_hat);
  }
  if (next != num_slots_) throw std::logic_error("SrMesh: faces neither in the base mesh nor created by a collapse");
  splits_.assign(h.num_collapses(), {});
  // Split::nl/nr: replaying the collapses in order with a union-find (path halving), the set of a leaf is
  // its ancestor that is active between the collapse creating node v - 1 and the one creating v, which
  // is the mesh just before the split of v in decreasing node order.
  std::vector<Index> uf(h.num_nodes());
  for (std::size_t v = 0; v < uf.size(); ++v) uf[v] = static_cast<Index>(v);
  const auto find = [&](Index x) {
    while (uf[x] != x) x = uf[x] = uf[uf[x]];
    return x;
  };
  for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) {
    const CollapseRecord& r = h.record(static_cast<Index>(v));
    const auto slot = [&](Index f) { return f == kInvalid ? kInvalid : slot_of_[f]; };
    const auto key = [&](Index leaf) { return leaf == kInvalid ? std::uint64_t{0} : h.key(leaf).value; };
    const auto cut = [&](Index leaf) { return leaf == kInvalid ? kInvalid : find(leaf); };
    splits_[v - h.num_leaves()] =
        Split{r.vt, r.vu, slot(r.fl_hat), slot(r.fr_hat), cut(r.vl_hat), cut(r.vr_hat), key(r.vl_hat), key(r.vr_hat)};
    uf[r.vt] = uf[r.vu] = static_cast<Index>(v);
  }
  active_list_.reserve(h.num_leaves());
  // Collapsible nodes have two active children each and no child is shared, so at most half the leaves
  // are collapsible at once: reserved, the list never reallocates (nor throws) inside vsplit, ecol or the
  // rebuild at the end of refine_all/coarsen_all.
  collapsible_.reserve(h.num_leaves() / 2 + 1);
  build_base();
  reset();
}

void SrMesh::build_base() {
  // Root of each leaf: nodes are numbered children first, so propagate from the top down.
  std::vector<Index> top(h_->num_nodes());
  for (std::size_t v = h_->num_nodes(); v-- > 0;) {
    const Index p = h_->parent(static_cast<Index>(v));
    top[v] = p == kInvalid ? static_cast<Index>(v) : top[p];
  }
  std::vector<std::pair<std::uint64_t, Index>> edges;
  for (Index face : h_->base_faces()) {
    const auto c = h_->face(face);
    const Index f = slot_of_[face];
    FaceSlot fs{{kInvalid, kInvalid, kInvalid}, {kInvalid, kInvalid, kInvalid}};
    for (int k = 0; k < 3; ++k) fs.v[static_cast<std::size_t>(k)] = top[c[static_cast<std::size_t>(k)]];
    faces_[f] = fs;
    for (Index k = 0; k < 3; ++k)
      edges.push_back({(static_cast<std::uint64_t>(fs.v[k]) << 32) | fs.v[next_corner(k)], he(f, static_cast<int>(k))});
  }
  std::sort(edges.begin(), edges.end());
  for (const auto& [key, h] : edges) {
    const std::uint64_t twin = (key << 32) | (key >> 32);
    const auto it = std::lower_bound(edges.begin(), edges.end(), std::pair<std::uint64_t, Index>{twin, 0});
    if (it != edges.end() && it->first == twin) faces_[h >> 2].twin[h & 3] = it->second;
  }
  base_slots_.clear();
  for (Index f : h_->base_faces()) base_slots_.push_back({slot_of_[f], faces_[slot_of_[f]]});
  std::vector<Index> corner(h_->num_nodes(), kInvalid);
  for (const auto& [f, fs] : base_slots_)
    for (int k = 0; k < 3; ++k) corner[fs.v[static_cast<std::size_t>(k)]] = he(f, k);
  base_corners_.clear();
  for (Index r : h_->roots()) base_corners_.push_back(corner[r]);
}

void SrMesh::reset() {
  // Back to the base mesh saved by build_base().
  ecn_.vs = kInvalid;
  std::fill(nodes_.begin(), nodes_.end(), NodeSlot{});
  active_list_.clear();
  collapsible_.clear();
  std::fill(faces_.begin(), faces_.end(), FaceSlot{{kInvalid, kInvalid, kInvalid}, {kInvalid, kInvalid, kInvalid}});
  const auto roots = h_->roots();
  for (std::size_t i = 0; i < roots.size(); ++i) {
    activate(roots[i]);
    nodes_[roots[i]].corner = base_corners_[i];
  }
  for (const auto& [f, fs] : base_slots_) faces_[f] = fs;
  num_active_ = h_->num_roots();
  num_faces_ = base_slots_.size();
}

void SrMesh::check_node(Index v, const char* what) const {
  if (v >= h_->num_nodes()) throw InvalidInput(std::string(what) + ": node " + std::to_string(v) + " out of range");
  if (h_->is_leaf(v)) throw InvalidInput(std::string(what) + ": node " + std::to_string(v) + " is a leaf");
}

// A ring is walked from its start half-edge both ways, counter-clockwise (growing at hi) and clockwise (at
// lo), one step of each per call: the ring is a chain of dependent loads, and two chains halve its latency
// (four when two rings are walked together). An open fan ends with both walks on the border, which leaves
// it in order from its clockwise end.
void SrMesh::ring_begin(Index start, Ring& ring) const {
  static_assert(next_corner(0) == 1 && next_corner(1) == 2 && next_corner(2) == 0);
  static_assert(prev_corner(0) == 2 && prev_corner(1) == 0 && prev_corner(2) == 1);
  ring.lo = ring.cap / 2;
  ring.hi = ring.lo + 1;
  ring.buf[ring.lo] = ring.fwd = ring.back = start;
  ring.fwd_open = ring.back_open = true;
  ring.closed = false;
}

inline bool SrMesh::ring_step(Ring& ring) const {
  Index* buf = ring.buf;
  if (ring.fwd_open) {
    // Across the edge entering the centre: the twin half-edge leaves the centre.
    const Index n = faces_[ring.fwd >> 2].twin[prev_corner(ring.fwd & 3)];
    if (n == buf[ring.lo]) return ring.closed = true;
    if (n == kInvalid) {
      ring.fwd_open = false;
    } else {
      buf[ring.hi++] = ring.fwd = n;
    }
  }
  if (ring.back_open) {
    // Across the edge leaving the centre: the twin enters it, its next half-edge leaves it.
    const Index t = faces_[ring.back >> 2].twin[ring.back & 3];
    const Index p = t == kInvalid ? kInvalid : (t & ~Index{3}) | next_corner(t & 3);
    if (p == buf[ring.hi - 1]) return ring.closed = true;
    if (p == kInvalid) {
      ring.back_open = false;
    } else {
      buf[--ring.lo] = ring.back = p;
    }
  }
  if (!ring.fwd_open && !ring.back_open) return true;
  if (ring.lo == 0 || ring.hi == ring.cap) {
    if (ring.size() > 3 * static_cast<std::size_t>(num_slots_))
      throw std::logic_error("SrMesh: the fan of node " + std::to_string(corner_node(ring.fwd)) + " does not end");
    std::vector<Index> grown(2 * ring.cap);
    const std::size_t lo = ring.cap - ring.size() / 2;
    std::copy(buf + ring.lo, buf + ring.hi, grown.data() + lo);
    ring.hi = lo + ring.size();
    ring.lo = lo;
    ring.big.swap(grown);
    ring.buf = ring.big.data();
    ring.cap = ring.big.size();
  }
  return false;
}

void SrMesh::gather_ring(Index start, Ring& ring) const {
  ring_begin(start, ring);
  while (!ring_step(ring)) {
  }
}

void SrMesh::gather_rings(Index start_a, Ring& a, Index start_b, Ring& b) const {
  ring_begin(start_a, a);
  ring_begin(start_b, b);
  bool done_a = false, done_b = false;
  while (!done_a || !done_b) {
    if (!done_a) done_a = ring_step(a);
    if (!done_b) done_b = ring_step(b);
  }
}

Index SrMesh::active_ancestor(Index leaf) const noexcept {
  Index a = leaf;
  while (a != kInvalid && !node_active(a)) a = h_->parent(a);
  return a;
}

void SrMesh::do_vsplit(Index vs, Index vl, Index vr, int pl, int pr, Why why) {
  // ring_ holds the 1-ring of vs, pl/pr the places of vl/vr among its neighbours (-1 when absent).
  ecn_.vs = kInvalid;
  const Split& r = split_of(vs);
  const Ring& ring = ring_;
  const int m = static_cast<int>(ring.size());
  const Index* hs = ring.buf + ring.lo;
  auto assign = [&](int from, int to, Index v) {
    for (int j = from; j < to; ++j) faces_[hs[j] >> 2].v[hs[j] & 3] = v;
  };
  // Faces from vl to vr (counter-clockwise) go to vt, the others to vu. On an open fan with both cut
  // vertices, pl > pr means vt takes both ends of the fan (vt stays on the border, vu becomes interior).
  if (pl >= 0 && pr >= 0) {
    if (pl <= pr) {
      assign(0, pl, r.vu), assign(pl, pr, r.vt), assign(pr, m, r.vu);
    } else {
      assign(0, pr, r.vt), assign(pr, pl, r.vu), assign(pl, m, r.vt);
    }
  } else if (pr >= 0) {
    assign(0, std::min(pr, m), r.vt), assign(std::min(pr, m), m, r.vu);
  } else {
    const int from = std::clamp(pl, 0, m);
    assign(0, from, r.vu), assign(from, m, r.vt);
  }
  auto at = [&](int j) -> Index {
    if (ring.closed) {
      // j is within a turn of [0, m): wrap without a division.
      while (j < 0) j += m;
      while (j >= m) j -= m;
      return hs[j];
    }
    return (j >= 0 && j < m) ? hs[j] : kInvalid;
  };
  // The half-edge of ring face `h` that enters the centre: its previous corner's.
  auto entering = [](Index h) { return (h & ~Index{3}) | prev_corner(h & 3); };
  const Index fl = r.fl, fr = r.fr;
  if (fl != kInvalid) {
    FaceSlot& f = faces_[fl];
    f.v = {r.vt, r.vu, vl};
    f.twin[0] = fr != kInvalid ? he(fr, 0) : kInvalid;
    const Index a = at(pl - 1);  // (vu, x, vl): its edge vl -> vu faces fl's edge vu -> vl
    const Index b = at(pl);      // (vt, vl, y): its edge vt -> vl faces fl's edge vl -> vt
    f.twin[1] = a != kInvalid ? entering(a) : kInvalid;
    f.twin[2] = b;
    if (a != kInvalid) faces_[a >> 2].twin[prev_corner(a & 3)] = he(fl, 1);
    if (b != kInvalid) faces_[b >> 2].twin[b & 3] = he(fl, 2);
    ++num_faces_;
  }
  if (fr != kInvalid) {
    FaceSlot& f = faces_[fr];
    f.v = {r.vu, r.vt, vr};
    f.twin[0] = fl != kInvalid ? he(fl, 0) : kInvalid;
    const Index c = at(pr - 1);  // (vt, x, vr): its edge vr -> vt
    const Index d = at(pr);      // (vu, vr, y): its edge vu -> vr
    f.twin[1] = c != kInvalid ? entering(c) : kInvalid;
    f.twin[2] = d;
    if (c != kInvalid) faces_[c >> 2].twin[prev_corner(c & 3)] = he(fr, 1);
    if (d != kInvalid) faces_[d >> 2].twin[d & 3] = he(fr, 2);
    ++num_faces_;
  }
  if (fl != kInvalid) {
    nodes_[r.vt].corner = he(fl, 0);
    nodes_[r.vu].corner = he(fl, 1);
  } else {
    nodes_[r.vu].corner = he(fr, 0);
    nodes_[r.vt].corner = he(fr, 1);
  }
  if (track_collapsible_) {
    // vs leaves the front, so its parent (if collapsible) no longer is; vs, with both children active, is.
    const Index parent = h_->parent(vs);
    if (parent != kInvalid && nodes_[parent].corner != kInvalid) remove_collapsible(parent);
    add_collapsible(vs);
  } else {
    nodes_[vs].corner = kInvalid;
  }
  deactivate(vs);
  nodes_[vs].active_pos = kRefinedPos;
  activate(r.vt);
  activate(r.vu);
  ++num_active_;
  ++stats_.vsplits;
  stats_.forced_vsplits += why == Why::kForced ? 1 : 0;
  if (why == Why::kPresplit) {
    ++stats_.presplits;
    ++stats_.degenerate_cases;
  }
  report(vs);
}

void SrMesh::do_ecol(Index vs, Why why) {
  // ring_ and ring2_ hold the 1-rings of vt and vu (left there by extra_common_neighbors_kept).
  ecn_.vs = kInvalid;
  const Split& r = split_of(vs);
  for (Index v : {vs, r.vt, r.vu}) prefetch_line(&nodes_[v]);
  prefetch_line(&nodes_[active_list_.back()]);
  if (active_list_.size() > 1) prefetch_line(&nodes_[active_list_[active_list_.size() - 2]]);
  for (const Ring* ring : {&ring_, &ring2_})
    for (std::size_t i = ring->lo; i < ring->hi; ++i) {
      const Index h = ring->buf[i];
      faces_[h >> 2].v[h & 3] = vs;
    }
  Index keep = kInvalid;  // a half-edge leaving vs
  auto kill = [&](Index f, Index apex) {
    // The half-edges x and y across f's edges 1 and 2 become twins. x leaves the apex (its next corner is
    // vs); y leaves vs (its next corner is the apex).
    if (f == kInvalid) return;
    FaceSlot& fs = faces_[f];
    const Index x = fs.twin[1], y = fs.twin[2];
    if (x != kInvalid) faces_[x >> 2].twin[x & 3] = y;
    if (y != kInvalid) faces_[y >> 2].twin[y & 3] = x;
    const Index x_next = x != kInvalid ? (x & ~Index{3}) | next_corner(x & 3) : kInvalid;
    const Index y_next = y != kInvalid ? (y & ~Index{3}) | next_corner(y & 3) : kInvalid;
    if (keep == kInvalid) keep = x != kInvalid ? x_next : y;
    // The apex may have its corner in f: give it x (or y's next), which leave it. Written without testing
    // the old corner: a store that misses the cache does not stall the collapse, a load would.
    nodes_[apex].corner = x != kInvalid ? x : y_next;
    fs = FaceSlot{{kInvalid, kInvalid, kInvalid}, {kInvalid, kInvalid, kInvalid}};
    --num_faces_;
  };
  const Index vl = r.fl != kInvalid ? faces_[r.fl].v[2] : kInvalid;
  const Index vr = r.fr != kInvalid ? faces_[r.fr].v[2] : kInvalid;
  kill(r.fl, vl);
  kill(r.fr, vr);
  if (keep == kInvalid) throw std::logic_error("SrMesh: ecol of node " + std::to_string(vs) + " leaves it without a face");
  if (track_collapsible_) remove_collapsible(vs);
  nodes_[vs].corner = keep;
  nodes_[r.vt].corner = nodes_[r.vu].corner = kInvalid;
  deactivate(r.vt);
  deactivate(r.vu);
  activate(vs);
  // vs is back on the front: its parent becomes collapsible if vs's sibling is active too.
  const Index parent = track_collapsible_ ? h_->parent(vs) : kInvalid;
  if (parent != kInvalid) {
    const Split& rp = split_of(parent);
    if (node_active(rp.vt == vs ? rp.vu : rp.vt)) add_collapsible(parent);
  }
  --num_active_;
  ++stats_.ecols;
  stats_.forced_ecols += why == Why::kForced ? 1 : 0;
}

bool SrMesh::extra_common_neighbors(Index vs, Ring& rt, Ring& ru) const {
  // The rings start at fl (or fr), whose corners 0 and 1 are vt and vu (fr's the other way round), which
  // spares two vertex lookups.
  const Split& r = split_of(vs);
  if (r.fl != kInvalid) prefetch_line(&faces_[r.fl]);
  if (r.fr != kInvalid) prefetch_line(&faces_[r.fr]);
  const Index vl = r.fl != kInvalid ? faces_[r.fl].v[2] : kInvalid;
  const Index vr = r.fr != kInvalid ? faces_[r.fr].v[2] : kInvalid;
  const Index f = r.fl != kInvalid ? r.fl : r.fr;
  const bool fl_side = r.fl != kInvalid;
  gather_rings(he(f, fl_side ? 0 : 1), rt, he(f, fl_side ? 1 : 0), ru);
  const std::size_t nt = rt.size() + (rt.closed ? 0 : 1), nu = ru.size() + (ru.closed ? 0 : 1);
  auto candidate = [&](Index n) { return n != vl && n != vr && n != r.vt; };
  if (nt <= kLongRing && nu <= kLongRing) {
    std::array<Index, kLongRing> nbrs;  // written before read
    for (std::size_t i = 0; i < nt; ++i) nbrs[i] = ring_neighbor(rt, i);
    const auto end = nbrs.begin() + static_cast<std::ptrdiff_t>(nt);
    for (std::size_t i = 0; i < nu; ++i) {
      const Index n = ring_neighbor(ru, i);
      if (candidate(n) && std::find(nbrs.begin(), end, n) != end) return true;
    }
    return false;
  }
  return long_rings_share(rt, nt, ru, nu, {vl, vr, r.vt});
}

bool SrMesh::long_rings_share(const Ring& rt, std::size_t nt, const Ring& ru, std::size_t nu,
                              const std::array<Index, 3>& except) const {
  // A long ring (the coarse side of an adaptive mesh, rare): vt's neighbours sorted, vu's looked up. Apart
  // from the short rings' loop, which it would otherwise crowd.
  std::vector<Index> nbrs(nt);
  for (std::size_t i = 0; i < nt; ++i) nbrs[i] = ring_neighbor(rt, i);
  std::sort(nbrs.begin(), nbrs.end());
  for (std::size_t i = 0; i < nu; ++i) {
    const Index n = ring_neighbor(ru, i);
    if (n != except[0] && n != except[1] && n != except[2] && std::binary_search(nbrs.begin(), nbrs.end(), n))
      return true;
  }
  return false;
}

bool SrMesh::hoppe_ecol_legal(Index vs) const {
  const CollapseRecord& r = h_->record(vs);
  if (r.fl_hat != kInvalid && (neighbor(r.fl_hat, 1) != r.fn[0] || neighbor(r.fl_hat, 2) != r.fn[1])) return false;
  if (r.fr_hat != kInvalid && (neighbor(r.fr_hat, 1) != r.fn[2] || neighbor(r.fr_hat, 2) != r.fn[3])) return false;
  return true;
}

bool SrMesh::xv_ring_matches(Index vs) const {
  for (Index n : h_->stored_ring(vs))
    if (!node_active(n)) return false;
  return true;
}

// update() asks is_coarsenable(e) and then coarsen_one(e), which need the same walk: the non-const members
// keep its rings and answer in ring_/ring2_ and ecn_ until the mesh or ring_ changes. The const ones (which
// several threads may call at once) keep nothing and walk rings of their own.
bool SrMesh::extra_common_neighbors_kept(Index vs) {
  if (ecn_.vs == vs) return ecn_.result;
  ecn_.result = extra_common_neighbors(vs, ring_, ring2_);
  ecn_.vs = vs;
  return ecn_.result;
}

inline bool SrMesh::ecol_rule_allows(Index vs) const {
  if (vs >= h_->num_nodes() || h_->is_leaf(vs) || !collapsible(vs)) return false;
  if (scheme_ == RefinementScheme::kHoppe97 && !hoppe_ecol_legal(vs)) return false;
  if (scheme_ == RefinementScheme::kXiaVarshney && !xv_ring_matches(vs)) return false;
  return true;
}

bool SrMesh::can_ecol(Index vs) const {
  if (!ecol_rule_allows(vs)) return false;
  Ring rt, ru;  // this call's own
  return !extra_common_neighbors(vs, rt, ru);
}

bool SrMesh::is_coarsenable(Index e) { return ecol_rule_allows(e) && !extra_common_neighbors_kept(e); }

bool SrMesh::vsplit_kim_lee(Index vs, Why why) {
  const Split& r = split_of(vs);
  const int bits = h_->node_bits();
  const std::uint64_t mask = bits >= 64 ? ~0ull : (1ull << bits) - 1ull;
  // Section 4.3's ancestor test against a fixed leaf, with the leaf's parts computed once.
  struct Leaf {
    std::uint64_t tree = 0, node = 0;
    int len = 0;
  };
  auto leaf_of = [&](std::uint64_t k) {
    return Leaf{k >> bits, k & mask, static_cast<int>(std::bit_width(k & mask))};
  };
  auto is_ancestor = [&](std::uint64_t k, const Leaf& l) {
    const std::uint64_t n = k & mask;
    const int len = static_cast<int>(std::bit_width(n));
    return (k >> bits) == l.tree && len <= l.len && (l.node >> (l.len - len)) == n;
  };
  const bool has_l = r.fl != kInvalid, has_r = r.fr != kInvalid;  // a cut vertex with each face
  // The split's scattered writes are known from the record alone: asking for their lines now overlaps
  // those cache misses with the ring walk instead of paying them one after another.
  prefetch_line(&nodes_[r.vt]);
  prefetch_line(&nodes_[r.vu]);
  prefetch_line(&nodes_[active_list_.back()]);
  if (r.fl != kInvalid) prefetch_line(&faces_[r.fl]);
  if (r.fr != kInvalid) prefetch_line(&faces_[r.fr]);
  for (;;) {
    ecn_.vs = kInvalid;  // ring_ is overwritten
    gather_ring(nodes_[vs].corner, ring_);
    const std::size_t nn = ring_.size() + (ring_.closed ? 0 : 1);
    Index vl = kInvalid, vr = kInvalid;
    int pl = -1, pr = -1;
    if (nn <= kLongRing) {
      // The cut vertices are the ring neighbours that are ancestors of vl^ and vr^: at most one each, as
      // the active nodes are never ancestors of one another. The last place of a cut vertex is kept, as a
      // physical split needs one place per cut vertex. Split::nl/nr are such ancestors, so when one of them
      // is in the ring it is the cut vertex (always in the PM order); otherwise the section 4.3 keys of the
      // neighbours are tested.
      for (std::size_t i = 0; i < nn; ++i) {
        const Index n = ring_neighbor(ring_, i);
        if (n == r.nl) pl = static_cast<int>(i);
        if (n == r.nr) pr = static_cast<int>(i);
      }
      if (pl >= 0) vl = r.nl;
      if (pr >= 0) vr = r.nr;
      const bool need_l = has_l && vl == kInvalid, need_r = has_r && vr == kInvalid;
      if (need_l || need_r) {
        const Leaf kl = need_l ? leaf_of(r.kl) : Leaf{}, kr = need_r ? leaf_of(r.kr) : Leaf{};
        for (std::size_t i = 0; i < nn; ++i) {
          const Index n = ring_neighbor(ring_, i);
          if (need_l && vl == kInvalid && is_ancestor(h_->key(n).value, kl)) vl = n;
          if (need_r && vr == kInvalid && is_ancestor(h_->key(n).value, kr)) vr = n;
          if (need_l && n == vl) pl = static_cast<int>(i);
          if (need_r && n == vr) pr = static_cast<int>(i);
        }
      }
    } else {
      // A high-valence vertex (the coarse side of an adaptive mesh): the one active ancestor of each leaf
      // is found by walking up in O(depth) instead of testing every neighbour; then its place in the ring.
      const CollapseRecord& rec = h_->record(vs);
      const Index al = has_l ? active_ancestor(rec.vl_hat) : kInvalid, ar = has_r ? active_ancestor(rec.vr_hat) : kInvalid;
      for (std::size_t i = 0; i < nn; ++i) {
        const Index n = ring_neighbor(ring_, i);
        if (n == al) vl = n, pl = static_cast<int>(i);
        if (n == ar) vr = n, pr = static_cast<int>(i);
      }
    }
    if ((has_l && vl == kInvalid) || (has_r && vr == kInvalid))
      throw std::logic_error("SrMesh: no cut vertex of node " + std::to_string(vs) + " in its 1-ring");
    if (vl != kInvalid && vl == vr) {
      // Section 4.4: both cut vertices are one active vertex; split it first. A leaf cannot be split: the
      // records would be inconsistent (the reader rejects such files; this guards the arrays).
      if (h_->is_leaf(vl)) throw std::logic_error("SrMesh: both cut vertices of node " + std::to_string(vs) + " are leaf " + std::to_string(vl));
      vsplit_kim_lee(vl, Why::kPresplit);
      continue;
    }
    do_vsplit(vs, vl, vr, pl, pr, why);
    return true;
  }
}

bool SrMesh::vsplit_hoppe(Index target) {
  std::vector<Index> stack{target};
  while (!stack.empty()) {
    const Index v = stack.back();
    if (node_refined(v)) {
      stack.pop_back();
      continue;
    }
    if (node_below(v)) {
      stack.push_back(h_->parent(v));
      continue;
    }
    bool missing = false;
    for (Index f : h_->record(v).fn)
      if (f != kInvalid && !face_active(f)) {
        const Index creator = h_->face_creator(f);
        if (creator == kInvalid) throw std::logic_error("SrMesh: base face " + std::to_string(f) + " inactive");
        stack.push_back(creator);
        missing = true;
      }
    if (missing) continue;
    stack.pop_back();
    // Legal: the same physical split (a coincident cut vertex is split first, as in Kim-Lee, and counted as
    // a presplit only, as under the other rules).
    vsplit_kim_lee(v, v != target ? Why::kForced : Why::kRequested);
  }
  return node_refined(target);
}

bool SrMesh::make_active_xv(Index n, int depth) {
  while (node_below(n)) {
    Index a = h_->parent(n);
    while (node_below(a)) a = h_->parent(a);
    if (!vsplit_xv(a, depth + 1)) return false;
  }
  if (node_refined(n) && !ecol_xv(n, depth + 1)) return false;
  return node_active(n);
}

// Marks a node for the Xia-Varshney cycle guard while its operation runs, and unmarks it however the
// operation ends: an exception from refine()'s sink unwinds the whole recursion, and a node left marked had
// every later split or collapse refused as a cycle.
struct SrMesh::InProgress {
  std::uint8_t& mark;
  explicit InProgress(std::uint8_t& m) noexcept : mark(m) { mark = 1; }
  ~InProgress() { mark = 0; }
  InProgress(const InProgress&) = delete;
  InProgress& operator=(const InProgress&) = delete;
};

bool SrMesh::vsplit_xv(Index vs, int depth) {
  if (depth > kXvMaxDepth || in_progress_[vs]) return false;
  const InProgress guard(in_progress_[vs]);
  bool ok = true;
  for (Index n : h_->stored_ring(vs))
    if (!make_active_xv(n, depth)) {
      ok = false;
      break;
    }
  ok = ok && node_active(vs) && xv_ring_matches(vs);
  // Depth 0 is vsplit()'s request; deeper ones are make_active_xv's forced splits.
  if (ok) vsplit_kim_lee(vs, depth > 0 ? Why::kForced : Why::kRequested);
  return ok;
}

bool SrMesh::ecol_xv(Index vs, int depth) {
  if (depth > kXvMaxDepth || in_progress_[vs]) return false;
  const InProgress guard(in_progress_[vs]);
  const CollapseRecord& r = h_->record(vs);
  bool ok = true;
  for (Index c : {r.vt, r.vu})
    if (ok && node_refined(c)) ok = ecol_xv(c, depth + 1);
  if (ok)
    for (Index n : h_->stored_ring(vs))
      if (!make_active_xv(n, depth)) {
        ok = false;
        break;
      }
  ok = ok && collapsible(vs) && xv_ring_matches(vs) && !extra_common_neighbors_kept(vs);
  if (ok) do_ecol(vs, depth > 0 ? Why::kForced : Why::kRequested);
  return ok;
}

bool SrMesh::vsplit(Index vs) {
  check_node(vs, "vsplit");
  if (!node_active(vs)) throw InvalidInput("vsplit: node " + std::to_string(vs) + " is not active");
  switch (scheme_) {
    case RefinementScheme::kKimLee: return vsplit_kim_lee(vs, Why::kRequested);
    case RefinementScheme::kHoppe97: return vsplit_hoppe(vs);
    case RefinementScheme::kXiaVarshney: {
      const bool ok = vsplit_xv(vs, 0);
      if (!ok) ++stats_.failed_vsplits;
      return ok;
    }
  }
  return false;
}

bool SrMesh::ecol(Index vs) {
  check_node(vs, "ecol");
  if (!collapsible(vs))
    throw InvalidInput("ecol: the children of node " + std::to_string(vs) + " are not both active");
  switch (scheme_) {
    case RefinementScheme::kKimLee:
      if (extra_common_neighbors_kept(vs)) {
        ++stats_.degenerate_cases;  // section 4.4: postponed
        ++stats_.postponed_ecols;
        ++stats_.refused_ecols;
        return false;
      }
      do_ecol(vs, Why::kRequested);
      return true;
    case RefinementScheme::kHoppe97:
      if (!hoppe_ecol_legal(vs) || extra_common_neighbors_kept(vs)) {
        ++stats_.refused_ecols;
        return false;
      }
      do_ecol(vs, Why::kRequested);
      return true;
    case RefinementScheme::kXiaVarshney: {
      const bool ok = ecol_xv(vs, 0);
      if (!ok) ++stats_.refused_ecols;
      return ok;
    }
  }
  return false;
}

void SrMesh::refine_forced(Index e) {
  while (node_below(e)) {
    Index a = h_->parent(e);
    while (node_below(a)) a = h_->parent(a);
    if (!vsplit(a)) return;
  }
  if (node_active(e)) vsplit(e);
}

void SrMesh::prefetch_fan(Index h, int steps) const noexcept {
  Index fwd = h, back = h;
  for (int i = 0; i < steps; ++i) {
    if (fwd != kInvalid) {
      fwd = faces_[fwd >> 2].twin[prev_corner(fwd & 3)];
    }
    if (back != kInvalid) {
      const Index t = faces_[back >> 2].twin[back & 3];
      back = t == kInvalid ? kInvalid : (t & ~Index{3}) | next_corner(t & 3);
    }
  }
  if (fwd != kInvalid) prefetch_line(&faces_[fwd >> 2]);
  if (back != kInvalid) prefetch_line(&faces_[back >> 2]);
}

// Stage s of the look-ahead for the vsplit of vs (stage 0 first, kLookStages - 1 just before the split).
void SrMesh::prefetch_vsplit(Index vs, int stage) const noexcept {
  if (!node_active(vs)) return;
  const Index c = nodes_[vs].corner;
  if (stage == 0) {
    const Split& r = split_of(vs);
    prefetch_line(&nodes_[r.vt]);
    prefetch_line(&nodes_[r.vu]);
  }
  prefetch_fan(c, stage);
}

void SrMesh::prefetch_ecol(Index vs, int stage) const noexcept {
  const Split& r = split_of(vs);
  if (stage == 0) {
    prefetch_line(&nodes_[r.vt]);
    prefetch_line(&nodes_[r.vu]);
    if (r.fl != kInvalid) prefetch_line(&faces_[r.fl]);
    if (r.fr != kInvalid) prefetch_line(&faces_[r.fr]);
    return;
  }
  if (!collapsible(vs)) return;
  const Index f = r.fl != kInvalid ? r.fl : r.fr;
  if (stage == 1) {
    for (Index g : {r.fl, r.fr})
      if (g != kInvalid && faces_[g].v[2] != kInvalid) prefetch_line(&nodes_[faces_[g].v[2]]);
  }
  prefetch_fan(he(f, 0), stage - 1);
  prefetch_fan(he(f, 1), stage - 1);
}

void SrMesh::suspend_collapsible() {
  collapsible_.reserve(h_->num_leaves() / 2 + 1);  // as the constructor does (a copy has no spare room)
  for (Index p : collapsible_) nodes_[p].corner = kInvalid;
  collapsible_.clear();
  track_collapsible_ = false;
}

void SrMesh::rebuild_collapsible() {
  // One pass over the split records in node order; the children's states, scattered, are asked for a
  // few records ahead.
  track_collapsible_ = true;
  collapsible_.clear();
  if (num_active_ == h_->num_roots()) return;  // the base mesh (each vsplit adds one active node): none refined
  const std::size_t lo = h_->num_leaves(), n = h_->num_nodes();
  constexpr std::size_t kAhead = 16;
  for (std::size_t v = lo; v < n; ++v) {
    if (v + kAhead < n) {
      const Split& a = split_of(static_cast<Index>(v + kAhead));
      prefetch_line(&nodes_[a.vt]);
      prefetch_line(&nodes_[a.vu]);
    }
    if (collapsible(static_cast<Index>(v))) add_collapsible(static_cast<Index>(v));
  }
}

// The bulk walks below keep no collapsible list while they run (its upkeep would cost each operation
// scattered reads of the parent and sibling) and rebuild it at the end, in one pass over the split records.
struct SrMesh::BulkScope {
  SrMesh& m;
  explicit BulkScope(SrMesh& mesh) : m(mesh) { m.suspend_collapsible(); }
  ~BulkScope() { m.rebuild_collapsible(); }
  BulkScope(const BulkScope&) = delete;
  BulkScope& operator=(const BulkScope&) = delete;
};

// refine_all and coarsen_all know the operations to come: the nodes in order of ids. On a big mesh an
// operation's cost is its chain of cache misses (a fan walk is a pointer chase), so while doing operation
// i they walk the fans of the next ones a few faces further each time (kLookStages stages, kLookGap
// operations apart): the operations themselves then find their faces in cache. The same operations are
// done in the same order; the look-ahead only reads.
std::size_t SrMesh::refine_all() {
  const BulkScope bulk(*this);
  const std::size_t before = stats_.vsplits;
  refine_passes();
  return stats_.vsplits - before;
}

std::size_t SrMesh::coarsen_all() {
  const BulkScope bulk(*this);
  const std::size_t before = stats_.ecols;
  coarsen_passes();
  // Stuck above the base mesh: every collapse left is postponed by section 4.4 (a collapse gave the
  // children of another refined node a common neighbour besides its cut vertices, and no split is coming
  // to take it away). From the original mesh the collapses in id order are the analysis's own, each legal
  // in turn, so refining everything and coarsening again reaches the base mesh.
  if (num_active_ > h_->num_roots()) {
    refine_passes();
    coarsen_passes();
  }
  VARMESH_ASSERT(num_active_ == h_->num_roots());
  return stats_.ecols - before;
}

void SrMesh::refine_passes() {
  const std::size_t lo = h_->num_leaves();
  bool progress = true;
  while (progress) {
    progress = false;
    for (std::size_t v = h_->num_nodes(); v-- > lo;) {
      for (int s = 0; s < kLookStages; ++s) {
        const std::size_t d = static_cast<std::size_t>((kLookStages - s) * kLookGap);
        if (v >= lo + d) prefetch_vsplit(static_cast<Index>(v - d), s);
      }
      if (node_active(v) && vsplit(static_cast<Index>(v))) progress = true;
    }
  }
}

void SrMesh::coarsen_passes() {
  const std::size_t n = h_->num_nodes();
  bool progress = true;
  while (progress) {
    progress = false;
    for (std::size_t v = h_->num_leaves(); v < n; ++v) {
      for (int s = 0; s < kLookStages; ++s) {
        const std::size_t d = static_cast<std::size_t>((kLookStages - s) * kLookGap);
        if (v + d < n) prefetch_ecol(static_cast<Index>(v + d), s);
      }
      const Index vs = static_cast<Index>(v);
      if (collapsible(vs) && ecol(vs)) progress = true;
    }
  }
}

std::vector<Index> SrMesh::active_vertices() const {
  std::vector<Index> out;
  out.reserve(num_active_);
  for (std::size_t v = 0; v < nodes_.size(); ++v)
    if (node_active(v)) out.push_back(static_cast<Index>(v));
  return out;
}

TriMesh SrMesh::to_mesh(std::vector<Index>* vertex_nodes) const {
  TriMesh m;
  std::vector<Index> remap(nodes_.size(), kInvalid);
  std::vector<Index> nodes;
  for (std::size_t v = 0; v < nodes_.size(); ++v)
    if (node_active(v)) {
      remap[v] = static_cast<Index>(nodes.size());
      nodes.push_back(static_cast<Index>(v));
      m.positions.push_back(h_->position(static_cast<Index>(v)));
      if (h_->has_colors()) m.colors.push_back(h_->color(static_cast<Index>(v)));
    }
  m.indices.reserve(3 * num_faces_);
  for_each_face([&](Index, Index a, Index b, Index c) { m.indices.insert(m.indices.end(), {remap[a], remap[b], remap[c]}); });
  if (vertex_nodes) *vertex_nodes = std::move(nodes);
  return m;
}

void SrMesh::validate() const {
  auto fail = [](const std::string& what) { throw std::logic_error("SrMesh::validate: " + what); };
  std::size_t faces = 0, active = 0, num_collapsible = 0;
  std::vector<Index> incident(nodes_.size(), 0);
  for (Index f = 0; f < num_slots_; ++f) {
    const FaceSlot& fs = faces_[f];
    if (fs.v[0] == kInvalid) {
      if (fs.v[1] != kInvalid || fs.v[2] != kInvalid || fs.twin[0] != kInvalid || fs.twin[1] != kInvalid || fs.twin[2] != kInvalid)
        fail("inactive face " + std::to_string(face_of_[f]) + " not cleared");
      continue;
    }
    ++faces;
    // Built only when a check fails: a string per face was a fifth of a test walk's time.
    const auto name = [&] { return "face " + std::to_string(face_of_[f]) + " (slot " + std::to_string(f) + ")"; };
    for (Index k = 0; k < 3; ++k) {
      const Index v = fs.v[k];
      if (v == kInvalid || v >= nodes_.size() || !node_active(v)) fail(name() + ": corner " + std::to_string(v) + " not active");
      ++incident[v];
      const Index w = fs.v[next_corner(k)];
      if (v == w) fail(name() + ": repeated corner");
      const Index t = fs.twin[k];
      if (t == kInvalid) continue;
      const Index n = t >> 2;
      if (n >= num_slots_ || (t & 3) == 3) fail(name() + ": twin " + std::to_string(t) + " out of range");
      if (faces_[n].v[0] == kInvalid) fail(name() + ": neighbour " + std::to_string(n) + " inactive");
      if (faces_[n].v[t & 3] != w || faces_[n].v[next_corner(t & 3)] != v || faces_[n].twin[t & 3] != he(f, static_cast<int>(k)))
        fail(name() + ": neighbour " + std::to_string(n) + " across edge " + std::to_string(k) + " does not match back");
    }
  }
  if (faces != num_faces_) fail("face count");
  Ring ring;
  for (std::size_t v = 0; v < nodes_.size(); ++v) {
    const Index p = h_->parent(static_cast<Index>(v));
    if (node_active(v)) {
      ++active;
      if (p != kInvalid && !node_refined(p)) fail("node " + std::to_string(v) + ": active under a parent that is not refined");
      if (incident[v] == 0) fail("node " + std::to_string(v) + ": active without a face");
      const Index c = nodes_[v].corner;
      if (c == kInvalid || (c >> 2) >= num_slots_ || (c & 3) == 3 || corner_node(c) != v)
        fail("node " + std::to_string(v) + ": incident corner wrong");
      gather_ring(c, ring);
      if (ring.size() != incident[v]) fail("node " + std::to_string(v) + ": faces form more than one fan");
    } else {
      if (node_refined(v)) {
        if (p != kInvalid && !node_refined(p)) fail("node " + std::to_string(v) + ": refined under a parent that is not refined");
        const CollapseRecord& r = h_->record(static_cast<Index>(v));
        if (node_below(r.vt) || node_below(r.vu)) fail("node " + std::to_string(v) + ": refined with an inactive child below");
        const bool listed = collapsible(static_cast<Index>(v));
        const Index at = nodes_[v].corner;
        if (listed ? (at >= collapsible_.size() || collapsible_[at] != v) : at != kInvalid)
          fail("node " + std::to_string(v) + ": collapsible list entry wrong");
        num_collapsible += listed ? 1 : 0;
      } else if (nodes_[v].corner != kInvalid) {
        fail("node " + std::to_string(v) + ": below the front with an incident corner");
      } else if (p != kInvalid && node_refined(p)) {
        fail("node " + std::to_string(v) + ": below the front under a refined parent");
      }
    }
  }
  if (active != num_active_) fail("active count");
  if (num_collapsible != collapsible_.size()) fail("collapsible list size");
  if (active_list_.size() != num_active_) fail("active list size");
  for (std::size_t i = 0; i < active_list_.size(); ++i)
    if (active_list_[i] >= nodes_.size() || nodes_[active_list_[i]].active_pos != i) fail("active list entry " + std::to_string(i));
}

std::size_t SrMesh::memory_bytes() const noexcept {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return sizeof(SrMesh) + bytes(faces_) + bytes(slot_of_) + bytes(face_of_) + bytes(splits_) + bytes(nodes_) +
         bytes(base_slots_) + bytes(base_corners_) + bytes(active_list_) + bytes(collapsible_) + bytes(list_buf_) + bytes(in_progress_) +
         (ring_.big.capacity() + ring2_.big.capacity() + ring3_.big.capacity()) * sizeof(Index);
}

}  // namespace varmesh
