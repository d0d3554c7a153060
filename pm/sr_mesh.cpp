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
inline int corner_of(const std::vector<Index>& corners, Index f, Index v) {
  return corners[3 * f] == v ? 0 : (corners[3 * f + 1] == v ? 1 : 2);
}
}  // namespace

SrMesh::SrMesh(const VertexHierarchy& h, RefinementScheme scheme) : h_(&h), scheme_(scheme) {
  num_slots_ = static_cast<Index>(h.num_faces());
  corners_.assign(3 * static_cast<std::size_t>(num_slots_), kInvalid);
  adj_.assign(3 * static_cast<std::size_t>(num_slots_), kInvalid);
  vface_.assign(h.num_nodes(), kInvalid);
  state_.assign(h.num_nodes(), 0);
  mark_.assign(h.num_nodes(), 0);
  in_progress_.assign(h.num_nodes(), 0);
  reset();
}

void SrMesh::reset() {
  std::fill(corners_.begin(), corners_.end(), kInvalid);
  std::fill(adj_.begin(), adj_.end(), kInvalid);
  std::fill(vface_.begin(), vface_.end(), kInvalid);
  std::fill(state_.begin(), state_.end(), std::uint8_t{0});
  active_list_.clear();
  active_pos_.assign(h_->num_nodes(), kInvalid);
  for (Index r : h_->roots()) {
    state_[r] = 1;
    activate(r);
  }
  num_active_ = h_->num_roots();
  num_faces_ = 0;
  // Root of each leaf: nodes are numbered children first, so propagate from the top down.
  std::vector<Index> top(h_->num_nodes());
  for (std::size_t v = h_->num_nodes(); v-- > 0;) {
    const Index p = h_->parent(static_cast<Index>(v));
    top[v] = p == kInvalid ? static_cast<Index>(v) : top[p];
  }
  std::vector<std::pair<std::uint64_t, Index>> edges;
  for (Index f : h_->base_faces()) {
    const auto c = h_->face(f);
    for (int k = 0; k < 3; ++k) corners_[3 * f + k] = top[c[k]];
    for (int k = 0; k < 3; ++k) {
      vface_[corners_[3 * f + k]] = f;
      edges.push_back({(static_cast<std::uint64_t>(corners_[3 * f + k]) << 32) | corners_[3 * f + (k + 1) % 3], 3 * f + k});
    }
    ++num_faces_;
  }
  std::sort(edges.begin(), edges.end());
  for (const auto& [key, slot] : edges) {
    const std::uint64_t twin = (key << 32) | (key >> 32);
    const auto it = std::lower_bound(edges.begin(), edges.end(), std::pair<std::uint64_t, Index>{twin, 0});
    if (it != edges.end() && it->first == twin) adj_[slot] = it->second / 3;
  }
}

void SrMesh::check_node(Index v, const char* what) const {
  if (v >= h_->num_nodes()) throw InvalidInput(std::string(what) + ": node " + std::to_string(v) + " out of range");
  if (h_->is_leaf(v)) throw InvalidInput(std::string(what) + ": node " + std::to_string(v) + " is a leaf");
}

bool SrMesh::gather_ring(Index v, std::vector<RingFace>& ring) const {
  // Counter-clockwise from the stored face; only when a border stops the walk, the clockwise part before
  // the stored face is walked too and put in front (so an interior vertex costs one turn).
  ring.clear();
  const Index f0 = vface_[v];
  Index f = f0;
  for (;;) {
    const int k = corner_of(corners_, f, v);
    ring.push_back({f, k});
    const Index next = adj_[3 * f + (k + 2) % 3];
    if (next == f0) return true;
    if (next == kInvalid) break;
    f = next;
  }
  const std::size_t ccw = ring.size();
  f = f0;
  for (;;) {
    const Index prev = adj_[3 * f + corner_of(corners_, f, v)];
    if (prev == kInvalid) break;
    f = prev;
    ring.push_back({f, corner_of(corners_, f, v)});
  }
  std::reverse(ring.begin() + static_cast<std::ptrdiff_t>(ccw), ring.end());
  std::rotate(ring.begin(), ring.begin() + static_cast<std::ptrdiff_t>(ccw), ring.end());
  return false;
}

Index SrMesh::find_cut_vertex(Index leaf, std::span<const RingFace> ring, bool closed) const {
  for (const RingFace& rf : ring) {
    const Index n = neighbor_a(rf);
    if (h_->is_ancestor_or_self(n, leaf)) return n;
  }
  if (!closed && !ring.empty()) {
    const Index n = neighbor_b(ring.back());
    if (h_->is_ancestor_or_self(n, leaf)) return n;
  }
  return kInvalid;
}

void SrMesh::do_vsplit(Index vs, Index vl, Index vr, bool closed) {
  // ring_ holds the 1-ring of vs (gather_ring), `closed` its kind.
  const CollapseRecord& r = h_->record(vs);
  const int m = static_cast<int>(ring_.size());
  const int nn = closed ? m : m + 1;  // neighbours a_0 .. a_{m-1} (+ b_{m-1} when open)
  auto nb = [&](int i) { return i < m ? neighbor_a(ring_[static_cast<std::size_t>(i)]) : neighbor_b(ring_.back()); };
  int pl = -1, pr = -1;
  for (int i = 0; i < nn; ++i) {
    const Index n = nb(i);
    if (n == vl) pl = i;
    if (n == vr) pr = i;
  }
  if ((vl != kInvalid && pl < 0) || (vr != kInvalid && pr < 0))
    throw std::logic_error("SrMesh: cut vertex of node " + std::to_string(vs) + " not in its 1-ring");
  auto goes_to_t = [&](int j) {
    // On an open fan with both cut vertices, pl > pr means vt takes both ends of the fan (vt stays on the
    // border, vu becomes interior); pl < pr the other way round.
    if (pl >= 0 && pr >= 0) return pl <= pr ? (j >= pl && j < pr) : (j >= pl || j < pr);
    return pr >= 0 ? j < pr : j >= pl;
  };
  for (int j = 0; j < m; ++j) {
    const RingFace& rf = ring_[static_cast<std::size_t>(j)];
    corners_[3 * rf.face + rf.corner] = goes_to_t(j) ? r.vt : r.vu;
  }
  auto face_at = [&](int j) -> const RingFace* {
    if (closed) return &ring_[static_cast<std::size_t>(((j % m) + m) % m)];
    return (j >= 0 && j < m) ? &ring_[static_cast<std::size_t>(j)] : nullptr;
  };
  const Index fl = r.fl_hat, fr = r.fr_hat;
  if (fl != kInvalid) {
    corners_[3 * fl] = r.vt;
    corners_[3 * fl + 1] = r.vu;
    corners_[3 * fl + 2] = vl;
    adj_[3 * fl] = fr;
    const RingFace* a = face_at(pl - 1);  // (vu, x, vl): its edge vl -> vu
    const RingFace* b = face_at(pl);      // (vt, vl, y): its edge vt -> vl
    adj_[3 * fl + 1] = a ? a->face : kInvalid;
    adj_[3 * fl + 2] = b ? b->face : kInvalid;
    if (a) adj_[3 * a->face + (a->corner + 2) % 3] = fl;
    if (b) adj_[3 * b->face + b->corner] = fl;
    ++num_faces_;
  }
  if (fr != kInvalid) {
    corners_[3 * fr] = r.vu;
    corners_[3 * fr + 1] = r.vt;
    corners_[3 * fr + 2] = vr;
    adj_[3 * fr] = fl;
    const RingFace* c = face_at(pr - 1);  // (vt, x, vr): its edge vr -> vt
    const RingFace* d = face_at(pr);      // (vu, vr, y): its edge vu -> vr
    adj_[3 * fr + 1] = c ? c->face : kInvalid;
    adj_[3 * fr + 2] = d ? d->face : kInvalid;
    if (c) adj_[3 * c->face + (c->corner + 2) % 3] = fr;
    if (d) adj_[3 * d->face + d->corner] = fr;
    ++num_faces_;
  }
  const Index any = fl != kInvalid ? fl : fr;
  vface_[r.vt] = vface_[r.vu] = any;
  vface_[vs] = kInvalid;
  state_[vs] = 2;
  state_[r.vt] = state_[r.vu] = 1;
  deactivate(vs);
  activate(r.vt);
  activate(r.vu);
  ++num_active_;
  ++stats_.vsplits;
  report(vs);
}

void SrMesh::do_ecol(Index vs) {
  // ring_ and ring2_ hold the 1-rings of vt and vu (left there by extra_common_neighbors).
  const CollapseRecord& r = h_->record(vs);
  for (const auto* ring : {&ring_, &ring2_})
    for (const RingFace& rf : *ring) corners_[3 * rf.face + rf.corner] = vs;
  Index keep = kInvalid;
  auto relink = [&](Index dying, Index x, Index y) {
    // x and y were across two edges of `dying`; they become neighbours of each other.
    if (x != kInvalid)
      for (int k = 0; k < 3; ++k)
        if (adj_[3 * x + k] == dying) adj_[3 * x + k] = y;
    if (y != kInvalid)
      for (int k = 0; k < 3; ++k)
        if (adj_[3 * y + k] == dying) adj_[3 * y + k] = x;
    if (keep == kInvalid) keep = x != kInvalid ? x : y;
  };
  auto kill = [&](Index f, Index apex) {
    if (f == kInvalid) return;
    const Index x = adj_[3 * f + 1], y = adj_[3 * f + 2];
    relink(f, x, y);
    if (vface_[apex] == f) vface_[apex] = x != kInvalid ? x : y;
    for (int k = 0; k < 3; ++k) corners_[3 * f + k] = adj_[3 * f + k] = kInvalid;
    --num_faces_;
  };
  const Index vl = r.fl_hat != kInvalid ? corners_[3 * r.fl_hat + 2] : kInvalid;
  const Index vr = r.fr_hat != kInvalid ? corners_[3 * r.fr_hat + 2] : kInvalid;
  kill(r.fl_hat, vl);
  kill(r.fr_hat, vr);
  if (keep == kInvalid) throw std::logic_error("SrMesh: ecol of node " + std::to_string(vs) + " leaves it without a face");
  vface_[vs] = keep;
  vface_[r.vt] = vface_[r.vu] = kInvalid;
  state_[vs] = 1;
  state_[r.vt] = state_[r.vu] = 0;
  deactivate(r.vt);
  deactivate(r.vu);
  activate(vs);
  --num_active_;
  ++stats_.ecols;
}

bool SrMesh::extra_common_neighbors(Index vs) const {
  const CollapseRecord& r = h_->record(vs);
  const Index vl = r.fl_hat != kInvalid ? corners_[3 * r.fl_hat + 2] : kInvalid;
  const Index vr = r.fr_hat != kInvalid ? corners_[3 * r.fr_hat + 2] : kInvalid;
  ++stamp_;
  const bool closed_t = gather_ring(r.vt, ring_);
  for (const RingFace& rf : ring_) mark_[neighbor_a(rf)] = stamp_;
  if (!closed_t && !ring_.empty()) mark_[neighbor_b(ring_.back())] = stamp_;
  const bool closed_u = gather_ring(r.vu, ring2_);
  auto extra = [&](Index n) { return n != vl && n != vr && n != r.vt && mark_[n] == stamp_; };
  for (const RingFace& rf : ring2_)
    if (extra(neighbor_a(rf))) return true;
  if (!closed_u && !ring2_.empty() && extra(neighbor_b(ring2_.back()))) return true;
  return false;
}

bool SrMesh::hoppe_ecol_legal(Index vs) const {
  const CollapseRecord& r = h_->record(vs);
  if (r.fl_hat != kInvalid && (adj_[3 * r.fl_hat + 1] != r.fn[0] || adj_[3 * r.fl_hat + 2] != r.fn[1])) return false;
  if (r.fr_hat != kInvalid && (adj_[3 * r.fr_hat + 1] != r.fn[2] || adj_[3 * r.fr_hat + 2] != r.fn[3])) return false;
  return true;
}

bool SrMesh::xv_ring_matches(Index vs) const {
  for (Index n : h_->stored_ring(vs))
    if (state_[n] != 1) return false;
  return true;
}

bool SrMesh::can_ecol(Index vs) const {
  if (vs >= h_->num_nodes() || h_->is_leaf(vs) || state_[vs] != 2) return false;
  const CollapseRecord& r = h_->record(vs);
  if (state_[r.vt] != 1 || state_[r.vu] != 1) return false;
  switch (scheme_) {
    case RefinementScheme::kKimLee: return !extra_common_neighbors(vs);
    case RefinementScheme::kHoppe97: return hoppe_ecol_legal(vs) && !extra_common_neighbors(vs);
    case RefinementScheme::kXiaVarshney: return xv_ring_matches(vs) && !extra_common_neighbors(vs);
  }
  return false;
}

bool SrMesh::vsplit_kim_lee(Index vs) {
  const CollapseRecord& r = h_->record(vs);
  for (;;) {
    const bool closed = gather_ring(vs, ring_);
    const Index vl = r.vl_hat != kInvalid ? find_cut_vertex(r.vl_hat, ring_, closed) : kInvalid;
    const Index vr = r.vr_hat != kInvalid ? find_cut_vertex(r.vr_hat, ring_, closed) : kInvalid;
    if ((r.vl_hat != kInvalid && vl == kInvalid) || (r.vr_hat != kInvalid && vr == kInvalid))
      throw std::logic_error("SrMesh: no cut vertex of node " + std::to_string(vs) + " in its 1-ring");
    if (vl != kInvalid && vl == vr) {
      // Section 4.4: both cut vertices are one active vertex; split it first.
      ++stats_.degenerate_cases;
      vsplit_kim_lee(vl);
      continue;
    }
    do_vsplit(vs, vl, vr, closed);
    return true;
  }
}

bool SrMesh::vsplit_hoppe(Index target) {
  std::vector<Index> stack{target};
  while (!stack.empty()) {
    const Index v = stack.back();
    if (state_[v] == 2) {
      stack.pop_back();
      continue;
    }
    if (state_[v] == 0) {
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
    // Legal: the same physical split (a coincident cut vertex is split first, as in Kim-Lee).
    const std::size_t dc = stats_.degenerate_cases;
    const std::size_t before = stats_.vsplits;
    vsplit_kim_lee(v);
    (void)dc;
    if (v != target) stats_.forced_vsplits += stats_.vsplits - before;
  }
  return state_[target] == 2;
}

bool SrMesh::make_active_xv(Index n, int depth) {
  while (state_[n] == 0) {
    Index a = h_->parent(n);
    while (state_[a] == 0) a = h_->parent(a);
    if (!vsplit_xv(a, depth + 1)) return false;
    ++stats_.forced_vsplits;
  }
  if (state_[n] == 2) {
    if (!ecol_xv(n, depth + 1)) return false;
    ++stats_.forced_ecols;
  }
  return state_[n] == 1;
}

bool SrMesh::vsplit_xv(Index vs, int depth) {
  if (depth > kXvMaxDepth || in_progress_[vs]) return false;
  in_progress_[vs] = 1;
  bool ok = true;
  for (Index n : h_->stored_ring(vs))
    if (!make_active_xv(n, depth)) {
      ok = false;
      break;
    }
  ok = ok && state_[vs] == 1 && xv_ring_matches(vs);
  if (ok) vsplit_kim_lee(vs);
  in_progress_[vs] = 0;
  return ok;
}

bool SrMesh::ecol_xv(Index vs, int depth) {
  if (depth > kXvMaxDepth || in_progress_[vs]) return false;
  in_progress_[vs] = 1;
  const CollapseRecord& r = h_->record(vs);
  bool ok = true;
  for (Index c : {r.vt, r.vu})
    if (ok && state_[c] == 2) {
      ok = ecol_xv(c, depth + 1);
      if (ok) ++stats_.forced_ecols;
    }
  if (ok)
    for (Index n : h_->stored_ring(vs))
      if (!make_active_xv(n, depth)) {
        ok = false;
        break;
      }
  ok = ok && state_[vs] == 2 && state_[r.vt] == 1 && state_[r.vu] == 1 && xv_ring_matches(vs) && !extra_common_neighbors(vs);
  if (ok) do_ecol(vs);
  in_progress_[vs] = 0;
  return ok;
}

bool SrMesh::vsplit(Index vs) {
  check_node(vs, "vsplit");
  if (state_[vs] != 1) throw InvalidInput("vsplit: node " + std::to_string(vs) + " is not active");
  switch (scheme_) {
    case RefinementScheme::kKimLee: return vsplit_kim_lee(vs);
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
  const CollapseRecord& r = h_->record(vs);
  if (state_[vs] != 2 || state_[r.vt] != 1 || state_[r.vu] != 1)
    throw InvalidInput("ecol: the children of node " + std::to_string(vs) + " are not both active");
  switch (scheme_) {
    case RefinementScheme::kKimLee:
      if (extra_common_neighbors(vs)) {
        ++stats_.degenerate_cases;  // section 4.4: postponed
        ++stats_.refused_ecols;
        return false;
      }
      do_ecol(vs);
      return true;
    case RefinementScheme::kHoppe97:
      if (!hoppe_ecol_legal(vs) || extra_common_neighbors(vs)) {
        ++stats_.refused_ecols;
        return false;
      }
      do_ecol(vs);
      return true;
    case RefinementScheme::kXiaVarshney: {
      const std::size_t before = stats_.ecols;
      const bool ok = ecol_xv(vs, 0);
      (void)before;
      if (!ok) ++stats_.refused_ecols;
      return ok;
    }
  }
  return false;
}

void SrMesh::refine_forced(Index e) {
  while (state_[e] == 0) {
    Index a = h_->parent(e);
    while (state_[a] == 0) a = h_->parent(a);
    if (!vsplit(a)) return;
  }
  if (state_[e] == 1) vsplit(e);
}

std::size_t SrMesh::refine_all() {
  const std::size_t before = stats_.vsplits;
  bool progress = true;
  while (progress) {
    progress = false;
    for (std::size_t v = h_->num_nodes(); v-- > h_->num_leaves();)
      if (state_[v] == 1 && vsplit(static_cast<Index>(v))) progress = true;
  }
  return stats_.vsplits - before;
}

std::size_t SrMesh::coarsen_all() {
  const std::size_t before = stats_.ecols;
  bool progress = true;
  while (progress) {
    progress = false;
    for (std::size_t v = h_->num_leaves(); v < h_->num_nodes(); ++v) {
      const Index vs = static_cast<Index>(v);
      const CollapseRecord& r = h_->record(vs);
      if (state_[vs] == 2 && state_[r.vt] == 1 && state_[r.vu] == 1 && ecol(vs)) progress = true;
    }
  }
  return stats_.ecols - before;
}

std::vector<Index> SrMesh::active_vertices() const {
  std::vector<Index> out;
  out.reserve(num_active_);
  for (std::size_t v = 0; v < state_.size(); ++v)
    if (state_[v] == 1) out.push_back(static_cast<Index>(v));
  return out;
}

TriMesh SrMesh::to_mesh(std::vector<Index>* vertex_nodes) const {
  TriMesh m;
  std::vector<Index> remap(state_.size(), kInvalid);
  std::vector<Index> nodes;
  for (std::size_t v = 0; v < state_.size(); ++v)
    if (state_[v] == 1) {
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
  std::size_t faces = 0, active = 0;
  std::vector<Index> incident(state_.size(), 0);
  for (Index f = 0; f < num_slots_; ++f) {
    if (corners_[3 * f] == kInvalid) continue;
    ++faces;
    const std::string name = "face " + std::to_string(f);
    for (int k = 0; k < 3; ++k) {
      const Index v = corners_[3 * f + k];
      if (v == kInvalid || state_[v] != 1) fail(name + ": corner " + std::to_string(v) + " not active");
      ++incident[v];
      const Index w = corners_[3 * f + (k + 1) % 3];
      if (v == w) fail(name + ": repeated corner");
      const Index n = adj_[3 * f + k];
      if (n == kInvalid) continue;
      if (corners_[3 * n] == kInvalid) fail(name + ": neighbour " + std::to_string(n) + " inactive");
      bool back = false;
      for (int j = 0; j < 3; ++j)
        if (corners_[3 * n + j] == w && corners_[3 * n + (j + 1) % 3] == v && adj_[3 * n + j] == f) back = true;
      if (!back) fail(name + ": neighbour " + std::to_string(n) + " across edge " + std::to_string(k) + " does not match back");
    }
  }
  if (faces != num_faces_) fail("face count");
  for (std::size_t v = 0; v < state_.size(); ++v) {
    const Index p = h_->parent(static_cast<Index>(v));
    if (state_[v] == 1) {
      ++active;
      if (p != kInvalid && state_[p] != 2) fail("node " + std::to_string(v) + ": active under a parent that is not refined");
      if (incident[v] == 0) fail("node " + std::to_string(v) + ": active without a face");
      const Index f = vface_[v];
      if (f == kInvalid || corners_[3 * f] == kInvalid ||
          (corners_[3 * f] != v && corners_[3 * f + 1] != v && corners_[3 * f + 2] != v))
        fail("node " + std::to_string(v) + ": incident face wrong");
      std::vector<RingFace> ring;
      gather_ring(static_cast<Index>(v), ring);
      if (ring.size() != incident[v]) fail("node " + std::to_string(v) + ": faces form more than one fan");
    } else if (state_[v] == 2) {
      if (p != kInvalid && state_[p] != 2) fail("node " + std::to_string(v) + ": refined under a parent that is not refined");
      const CollapseRecord& r = h_->record(static_cast<Index>(v));
      if (state_[r.vt] == 0 || state_[r.vu] == 0) fail("node " + std::to_string(v) + ": refined with an inactive child below");
    } else if (p != kInvalid && state_[p] == 2) {
      fail("node " + std::to_string(v) + ": below the front under a refined parent");
    }
  }
  if (active != num_active_) fail("active count");
  if (active_list_.size() != num_active_) fail("active list size");
  for (std::size_t i = 0; i < active_list_.size(); ++i)
    if (state_[active_list_[i]] != 1 || active_pos_[active_list_[i]] != i) fail("active list entry " + std::to_string(i));
}

}  // namespace varmesh
