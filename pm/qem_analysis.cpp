// Analysis phase of Kim-Lee 2001 (section 4.2) with Garland-Heckbert 1997 quadric ordering.
// Papers: J. Kim, S. Lee, "Truly selective refinement of progressive meshes", GI 2001; M. Garland,
// P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997 (GH97) and the 1998
// colour extension (GH98); H. Hoppe, "View-dependent refinement of progressive meshes", SIGGRAPH 1997 (the
// fn0..fn3 details); J. Xia, A. Varshney, "Dynamic view-dependent simplification for polygonal models",
// Visualization 1996 (the stored 1-ring); H. Hoppe et al., "Mesh optimization", 1993 (link condition).
//
// Faces keep their original corners (leaves) and carry current corners (nodes); a collapse relabels the
// faces around vt and vu to vs, so the cut vertices' leaves vl^, vr^ are read off the two faces that die.
// Quadrics are accumulated in coordinates centred on the model and scaled to a unit diagonal (see the
// precision note of quadric.hpp); positions are stored back in object units.
#include "pm/qem_analysis.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "pm/qem_heap.hpp"
#include "pm/quadric.hpp"

namespace varmesh {

namespace {

// Costs and legality are recomputed only where they can change. Node ids are never reused (a collapse
// makes a new node vs), and a candidate's cost depends only on its two ends' quadrics and positions, so a
// candidate edge stays valid until one of its ends dies: then it is erased from the indexed heap, and the
// edges of vs are the only new costs. A rejected edge leaves the heap and comes back, cost unchanged, when
// the neighbourhood of one of its ends changes.
class Analysis {
 public:
  Analysis(ManifoldInput&& in, const QemOptions& opt) : in_(std::move(in)), opt_(opt) {}
  VertexHierarchy run(QemStats& stats);

 private:
  // Variable-arity relation per node (faces around it, candidate edges at it): a run of a pool. A new node's
  // run is appended; the runs of dead nodes are left behind (no allocation per collapse).
  struct Run {
    Index off = 0, cnt = 0;
  };
  struct Edge {
    Index a, b;  // a < b
    double cost;
  };
  // An edge as seen from one end: the other end is kept with the slot so that walking a node's edges
  // touches only its own run.
  struct EdgeRef {
    Index edge, to;
  };
  struct Placement {
    glm::dvec3 p;
    glm::dvec3 color{0.0};
    double cost;
  };
  enum class Verdict { kOk, kLink, kFlip, kDepth, kLocked };

  // Geometry in normalised coordinates.
  glm::dvec3 to_unit(const glm::vec3& p) const { return (glm::dvec3(p) - center_) / scale_; }
  glm::vec3 to_object(const glm::dvec3& p) const { return glm::vec3(p * scale_ + center_); }
  glm::dvec3 face_normal(Index f, Index moved, const glm::dvec3& p) const {
    glm::dvec3 c[3];
    for (int k = 0; k < 3; ++k) {
      const Index v = cur_[3 * f + k];
      c[k] = v == moved ? p : upos_[v];
    }
    return glm::cross(c[1] - c[0], c[2] - c[0]);
  }
  // Unit normal from the current corners, or 0 for a degenerate face.
  void update_normal(Index f) {
    const glm::dvec3 n = face_normal(f, kInvalid, glm::dvec3(0.0));
    const double len = glm::length(n);
    fnormal_[f] = len > 0.0 ? n / len : glm::dvec3(0.0);
  }
  const Index* faces_begin(Index v) const { return fpool_.data() + fadj_[v].off; }
  const Index* faces_end(Index v) const { return fpool_.data() + fadj_[v].off + fadj_[v].cnt; }
  const EdgeRef* edges_begin(Index v) const { return epool_.data() + eadj_[v].off; }
  const EdgeRef* edges_end(Index v) const { return epool_.data() + eadj_[v].off + eadj_[v].cnt; }
  static std::uint64_t tie_key(const Edge& e) { return (std::uint64_t{e.a} << 32) | e.b; }

  Placement place(Index a, Index b) const;
  void set_edge(Index e, Index a, Index b);
  void reinsert_edges_of(Index v);
  double local_error(Index a, Index b, const glm::dvec3& p) const;
  Verdict check(Index a, Index b, const glm::dvec3& p, Index& fl, Index& fr);
  void collapse(Index a, Index b, const Placement& pl, Index fl, Index fr, double local);
  void init_faces();
  void init_edges();

  ManifoldInput in_;
  QemOptions opt_;
  glm::dvec3 center_{0.0};
  double scale_ = 1.0;
  std::size_t nl_ = 0, nf_ = 0;

  std::vector<glm::dvec3> upos_;  // per node, unit coordinates
  std::vector<glm::dvec3> ucol_;  // per node, scaled colours (with colours only)
  std::vector<Quadric> q_;
  std::vector<AttributeQuadric> aq_;
  bool colors_ = false;
  std::vector<Run> fadj_;                   // per node: its live faces (only live nodes' runs are kept up to date)
  std::vector<Index> fpool_;
  std::vector<Run> eadj_;                   // per node: its candidate edges
  std::vector<EdgeRef> epool_;
  std::vector<Edge> edges_;                 // slots: a collapse hands those of a and b on to vs
  detail::EdgeHeap heap_;                   // edges awaiting a verdict
  std::vector<Index> cur_;                  // current corners per face
  std::vector<glm::dvec3> fnormal_;         // per face: unit normal of the current corners
  std::vector<std::uint8_t> alive_;         // per face
  std::vector<std::uint8_t> node_alive_;    // per node: in the current mesh
  std::vector<std::uint8_t> border_;        // per node: its dual piece touches the border
  std::vector<std::uint8_t> rejected_;      // per node: some edge of it was rejected and left the heap
  std::vector<std::uint16_t> height_;
  std::size_t alive_vertices_ = 0, alive_faces_ = 0;
  std::vector<std::uint32_t> mark_;         // per node, stamps
  std::vector<Index> link_;                 // per node, scratch (valid where mark_ == stamp_)
  std::uint32_t stamp_ = 0;
  std::vector<Index> ring_;  // scratch
  std::vector<EdgeRef> new_edges_;

  VertexHierarchyBuilder::Raw raw_;
  std::vector<double> uerr_;  // per node, unit coordinates
};

Analysis::Placement Analysis::place(Index a, Index b) const {
  Placement out{};
  if (colors_) {
    const AttributeQuadric q = aq_[a] + aq_[b];
    const AttributeOptimum o = q.optimal_on_segment({upos_[a], ucol_[a]}, {upos_[b], ucol_[b]});
    out.p = o.point.position;
    out.color = o.point.color;
    out.cost = o.error;
  } else {
    const Quadric q = q_[a] + q_[b];
    const QuadricOptimum o = q.optimal_on_segment(upos_[a], upos_[b]);
    out.p = o.point;
    out.cost = o.error;
  }
  return out;
}

// Slot e becomes candidate (a, b), with its cost, in the heap; the caller fixes the nodes' runs.
void Analysis::set_edge(Index e, Index a, Index b) {
  edges_[e] = {std::min(a, b), std::max(a, b), place(a, b).cost};
  heap_.update(e, edges_[e].cost, tie_key(edges_[e]));
}

void Analysis::reinsert_edges_of(Index v) {
  for (const EdgeRef* e = edges_begin(v); e != edges_end(v); ++e)
    if (!heap_.contains(e->edge)) heap_.push(e->edge, edges_[e->edge].cost, tie_key(edges_[e->edge]));
}

// Largest distance from p to the current planes of the faces around a and b (the node error increment).
double Analysis::local_error(Index a, Index b, const glm::dvec3& p) const {
  double local = 0.0;
  for (Index v : {a, b})
    for (const Index* f = faces_begin(v); f != faces_end(v); ++f)
      local = std::max(local, std::abs(glm::dot(fnormal_[*f], p - upos_[cur_[3 * *f]])));
  return local;
}

Analysis::Verdict Analysis::check(Index a, Index b, const glm::dvec3& p, Index& fl, Index& fr) {
  if ((a < nl_ && in_.locked[a]) || (b < nl_ && in_.locked[b])) return Verdict::kLocked;
  if (std::max(height_[a], height_[b]) + 1 > opt_.max_depth) return Verdict::kDepth;
  // Faces on the edge: fl has a->b, fr has b->a (from a's point of view; swapped later as needed).
  fl = fr = kInvalid;
  int shared = 0;
  for (const Index* it = faces_begin(a); it != faces_end(a); ++it) {
    const Index f = *it;
    for (int k = 0; k < 3; ++k) {
      if (cur_[3 * f + k] != b) continue;
      ++shared;
      const int ka = cur_[3 * f + (k + 1) % 3] == a ? (k + 1) % 3 : (k + 2) % 3;
      if (cur_[3 * f + (ka + 1) % 3] == b) fl = f; else fr = f;
    }
  }
  if (shared == 0 || shared > 2) return Verdict::kLink;
  if (shared == 1 && border_[a] == 0) return Verdict::kLink;  // cannot happen on a manifold; be safe
  if (shared == 2 && border_[a] && border_[b]) return Verdict::kLink;
  auto apex = [&](Index f) {
    for (int k = 0; k < 3; ++k)
      if (cur_[3 * f + k] != a && cur_[3 * f + k] != b) return cur_[3 * f + k];
    return kInvalid;
  };
  const Index vl = fl == kInvalid ? kInvalid : apex(fl), vr = fr == kInvalid ? kInvalid : apex(fr);
  // Link condition: common neighbours are exactly the apexes (the candidate edges are the neighbours).
  ++stamp_;
  for (const EdgeRef* e = edges_begin(a); e != edges_end(a); ++e) mark_[e->to] = stamp_;
  for (const EdgeRef* e = edges_begin(b); e != edges_end(b); ++e) {
    const Index w = e->to;
    if (w != a && w != vl && w != vr && mark_[w] == stamp_) return Verdict::kLink;
  }
  // An apex must keep a face, and faces (a|b, vl, vr) would become duplicates (the tetrahedron case).
  for (Index x : {vl, vr})
    if (x != kInvalid && fadj_[x].cnt <= 1) return Verdict::kLink;
  if (vl != kInvalid && vr != kInvalid) {
    // Faces (a, vl, vr) and (b, vr, vl) would both become (vs, vl, vr): the tetrahedron case.
    auto has_face_with_apexes = [&](Index v) {
      for (const Index* it = faces_begin(v); it != faces_end(v); ++it) {
        int hit = 0;
        for (int k = 0; k < 3; ++k) hit += cur_[3 * *it + k] == vl || cur_[3 * *it + k] == vr;
        if (hit == 2) return true;
      }
      return false;
    };
    if (has_face_with_apexes(a) && has_face_with_apexes(b)) return Verdict::kLink;
  }
  // No face turns over or collapses to zero area: the new normal keeps an angle under ~89.94 degrees with
  // the current one (cached as a unit vector).
  for (Index v : {a, b})
    for (const Index* it = faces_begin(v); it != faces_end(v); ++it) {
      const Index f = *it;
      if (f == fl || f == fr) continue;
      const glm::dvec3& n0 = fnormal_[f];
      const glm::dvec3 n1 = face_normal(f, v, p);
      const double l1 = glm::dot(n1, n1);
      if (n0 == glm::dvec3(0.0)) {
        if (l1 == 0.0) return Verdict::kFlip;
        continue;
      }
      if (!(glm::dot(n0, n1) > 1e-3 * std::sqrt(l1))) return Verdict::kFlip;
    }
  return Verdict::kOk;
}

void Analysis::collapse(Index a, Index b, const Placement& pl, Index fl, Index fr, double local) {
  const Index vs = static_cast<Index>(upos_.size());
  // Kim-Lee orientation: fl = (vt, vu, vl) holds vt->vu. Our fl holds a->b, so vt = a, vu = b.
  CollapseRecord rec;
  rec.vt = a;
  rec.vu = b;
  auto apex_corner = [&](Index f) {
    for (int k = 0; k < 3; ++k)
      if (cur_[3 * f + k] != a && cur_[3 * f + k] != b) return k;
    return -1;
  };
  // Face across directed edge (x -> y): the live face holding y -> x.
  auto across = [&](Index x, Index y) {
    for (const Index* it = faces_begin(x); it != faces_end(x); ++it)
      for (int k = 0; k < 3; ++k)
        if (cur_[3 * *it + k] == y && cur_[3 * *it + (k + 1) % 3] == x) return *it;
    return kInvalid;
  };
  Index vl = kInvalid, vr = kInvalid;
  if (fl != kInvalid) {
    const int k = apex_corner(fl);
    vl = cur_[3 * fl + k];
    rec.vl_hat = in_.faces[3 * fl + k];
    rec.fl_hat = fl;
    rec.fn[0] = across(b, vl);
    rec.fn[1] = across(vl, a);
  }
  if (fr != kInvalid) {
    const int k = apex_corner(fr);
    vr = cur_[3 * fr + k];
    rec.vr_hat = in_.faces[3 * fr + k];
    rec.fr_hat = fr;
    rec.fn[2] = across(a, vr);
    rec.fn[3] = across(vr, b);
  }
  // Error: accumulated largest distance from vs to the planes of the faces it replaces.
  const double err = std::max(uerr_[a], uerr_[b]) + local;

  // The new node.
  upos_.push_back(pl.p);
  if (colors_) {
    ucol_.push_back(pl.color);
    aq_.push_back(aq_[a] + aq_[b]);
  } else {
    q_.push_back(q_[a] + q_[b]);
  }
  node_alive_[a] = node_alive_[b] = 0;
  node_alive_.push_back(1);
  border_.push_back(border_[a] | border_[b]);
  rejected_.push_back(0);
  height_.push_back(static_cast<std::uint16_t>(std::max(height_[a], height_[b]) + 1));
  uerr_.push_back(err);
  mark_.push_back(0);
  link_.push_back(kInvalid);
  --alive_vertices_;

  // Faces: fl and fr die, the others of a and b move to vs (in that order: the ring order follows it).
  if (fl != kInvalid) alive_[fl] = 0;
  if (fr != kInvalid) alive_[fr] = 0;
  alive_faces_ -= (fl != kInvalid) + (fr != kInvalid);
  const Index foff = static_cast<Index>(fpool_.size());
  NormalCone cone = enclose(raw_.bounds[a].cone, raw_.bounds[b].cone);
  for (Index v : {a, b})
    for (Index i = fadj_[v].off, end = i + fadj_[v].cnt; i < end; ++i) {
      const Index f = fpool_[i];  // by index: the push_back below may move the pool
      if (f == fl || f == fr) continue;
      for (int k = 0; k < 3; ++k)
        if (cur_[3 * f + k] == v) cur_[3 * f + k] = vs;
      fpool_.push_back(f);
      update_normal(f);
      const glm::dvec3& n = fnormal_[f];
      if (n == glm::dvec3(0.0) || cone.is_full()) continue;
      // A normal already inside the cone leaves it unchanged (enclose() would return it): skip its acos.
      const glm::vec3 nf(n);
      if (glm::dot(cone.axis, nf) >= cone.cos_half_angle) continue;
      cone = enclose(cone, NormalCone{nf, 1.0f});
    }
  fadj_.push_back({foff, static_cast<Index>(fpool_.size()) - foff});
  for (Index x : {vl, vr}) {
    if (x == kInvalid) continue;
    Index* it = fpool_.data() + fadj_[x].off;
    Index* out = std::remove_if(it, it + fadj_[x].cnt, [&](Index f) { return f == fl || f == fr; });
    fadj_[x].cnt = static_cast<Index>(out - it);
  }

  // Xia-Varshney stored ring: the neighbours of vs now.
  ++stamp_;
  ring_.clear();
  for (Index i = foff; i < foff + fadj_[vs].cnt; ++i)
    for (int k = 0; k < 3; ++k) {
      const Index w = cur_[3 * fpool_[i] + k];
      if (w == vs || mark_[w] == stamp_) continue;
      mark_[w] = stamp_;
      link_[w] = kInvalid;
      ring_.push_back(w);
    }
  raw_.ring_items.insert(raw_.ring_items.end(), ring_.begin(), ring_.end());
  raw_.ring_offsets.push_back(static_cast<Index>(raw_.ring_items.size()));

  // Candidate edges: the edge of each neighbour w of vs to a (or b) becomes the edge (vs, w), keeping its
  // slot and heap entry (a key update is cheaper than an erase plus a push); when w was a neighbour of both
  // (the apexes vl, vr) its second edge dies. The edge (a, b) itself has left the heap already.
  new_edges_.clear();
  // The loop below is bound by cache misses on the neighbours' runs: request them all up front so that
  // they overlap instead of arriving one after another.
  for (Index v : {a, b})
    for (Index i = eadj_[v].off, end = i + eadj_[v].cnt; i < end; ++i) {
      __builtin_prefetch(&eadj_[epool_[i].to]);
      heap_.prefetch(epool_[i].edge);
    }
  for (Index v : {a, b})
    for (Index i = eadj_[v].off, end = i + eadj_[v].cnt; i < end; ++i)
      __builtin_prefetch(epool_.data() + eadj_[epool_[i].to].off);
  for (Index v : {a, b})
    for (Index i = eadj_[v].off, end = i + eadj_[v].cnt; i < end; ++i) {
      const Index e = epool_[i].edge, w = epool_[i].to;
      if (w == a || w == b) continue;
      EdgeRef* run = epool_.data() + eadj_[w].off;
      EdgeRef* pos = std::find_if(run, run + eadj_[w].cnt, [&](const EdgeRef& r) { return r.edge == e; });
      if (link_[w] == kInvalid) {
        link_[w] = e;
        set_edge(e, vs, w);
        new_edges_.push_back({e, w});
        pos->to = vs;
      } else {
        heap_.erase(e);
        *pos = run[--eadj_[w].cnt];  // its slot stays unused
      }
    }
  eadj_.push_back({static_cast<Index>(epool_.size()), static_cast<Index>(new_edges_.size())});
  epool_.insert(epool_.end(), new_edges_.begin(), new_edges_.end());

  ElementBound bound;
  Sphere s = enclose(Sphere{raw_.bounds[a].center, raw_.bounds[a].radius}, Sphere{raw_.bounds[b].center, raw_.bounds[b].radius});
  s = enclose(s, Sphere{to_object(pl.p), 0.0f});
  bound.center = s.center;
  bound.radius = s.radius;
  bound.cone = cone;
  bound.error = static_cast<float>(err * scale_);
  bound.error = std::max({bound.error, raw_.bounds[a].error, raw_.bounds[b].error});
  raw_.bounds.push_back(bound);
  raw_.positions.push_back(to_object(pl.p));
  if (colors_) raw_.colors.push_back(glm::vec3(pl.color / (opt_.color_weight > 0 ? opt_.color_weight : 1.0)));
  raw_.records.push_back(rec);

  // Neighbours that had an edge rejected get their edges re-examined: their neighbourhood just changed.
  for (Index w : ring_)
    if (rejected_[w]) {
      rejected_[w] = 0;
      reinsert_edges_of(w);
    }
}

void Analysis::init_faces() {
  // Faces around each leaf, in face order.
  fadj_.assign(nl_, Run{});
  for (Index c : cur_) ++fadj_[c].cnt;
  Index off = 0;
  for (Run& r : fadj_) {
    r.off = off;
    off += r.cnt;
    r.cnt = 0;
  }
  // Room for the runs of the new nodes: each collapse appends about one degree's worth.
  fpool_.reserve(2 * cur_.size());
  fpool_.resize(cur_.size());
  for (std::size_t f = 0; f < nf_; ++f)
    for (int k = 0; k < 3; ++k) {
      Run& r = fadj_[cur_[3 * f + k]];
      fpool_[r.off + r.cnt++] = static_cast<Index>(f);
    }
  fnormal_.resize(nf_);
  for (std::size_t f = 0; f < nf_; ++f) update_normal(static_cast<Index>(f));
}

void Analysis::init_edges() {
  // Candidate edges: one per pair of neighbours, in each end's run.
  eadj_.assign(nl_, Run{});
  for (std::size_t v = 0; v < nl_; ++v) {
    ++stamp_;
    for (const Index* it = faces_begin(static_cast<Index>(v)); it != faces_end(static_cast<Index>(v)); ++it)
      for (int k = 0; k < 3; ++k) {
        const Index w = cur_[3 * *it + k];
        if (w != v && mark_[w] != stamp_) {
          mark_[w] = stamp_;
          ++eadj_[v].off;  // degree, for now
        }
      }
  }
  Index off = 0;
  for (Run& r : eadj_) {
    const Index deg = r.off;
    r.off = off;
    off += deg;
  }
  epool_.reserve(2 * static_cast<std::size_t>(off));
  epool_.resize(off);
  edges_.reserve(off / 2);
  for (std::size_t v = 0; v < nl_; ++v) {
    ++stamp_;
    for (const Index* it = faces_begin(static_cast<Index>(v)); it != faces_end(static_cast<Index>(v)); ++it)
      for (int k = 0; k < 3; ++k) {
        const Index w = cur_[3 * *it + k];
        if (w > v && mark_[w] != stamp_) {
          mark_[w] = stamp_;
          const Index id = static_cast<Index>(edges_.size());
          edges_.push_back({static_cast<Index>(v), w, place(static_cast<Index>(v), w).cost});
          epool_[eadj_[v].off + eadj_[v].cnt++] = {id, w};
          epool_[eadj_[w].off + eadj_[w].cnt++] = {id, static_cast<Index>(v)};
        }
      }
  }
  heap_.grow_ids(edges_.capacity());
  for (Index id = 0; id < edges_.size(); ++id) heap_.push_unordered(id, edges_[id].cost, tie_key(edges_[id]));
  heap_.heapify();
}

VertexHierarchy Analysis::run(QemStats& stats) {
  const auto t0 = std::chrono::steady_clock::now();
  nl_ = in_.positions.size();
  nf_ = in_.faces.size() / 3;
  Box3 box;
  for (const glm::vec3& p : in_.positions) box.add(p);
  center_ = glm::dvec3(box.center());
  scale_ = std::max(1e-30, static_cast<double>(box.diagonal()));
  colors_ = opt_.use_colors && !in_.colors.empty();

  // Per-node arrays hold at most 2 nl - 1 nodes.
  const std::size_t max_nodes = 2 * nl_;
  upos_.reserve(max_nodes);
  upos_.resize(nl_);
  for (std::size_t v = 0; v < nl_; ++v) upos_[v] = to_unit(in_.positions[v]);
  cur_ = in_.faces;
  alive_.assign(nf_, 1);
  alive_faces_ = nf_;
  node_alive_.reserve(max_nodes);
  node_alive_.assign(nl_, 1);
  alive_vertices_ = nl_;
  border_.reserve(max_nodes);
  border_.assign(nl_, 0);
  rejected_.reserve(max_nodes);
  rejected_.assign(nl_, 0);
  height_.reserve(max_nodes);
  height_.assign(nl_, 0);
  uerr_.reserve(max_nodes);
  uerr_.assign(nl_, 0.0);
  mark_.reserve(max_nodes);
  mark_.assign(nl_, 0);
  link_.reserve(max_nodes);
  link_.assign(nl_, kInvalid);
  fadj_.reserve(max_nodes);
  eadj_.reserve(max_nodes);

  // Quadrics: area-weighted face planes plus border constraints (GH97).
  if (colors_) {
    aq_.reserve(max_nodes);
    aq_.assign(nl_, AttributeQuadric{});
    ucol_.reserve(max_nodes);
    ucol_.resize(nl_);
    for (std::size_t v = 0; v < nl_; ++v) ucol_[v] = glm::dvec3(in_.colors[v]) * opt_.color_weight;
  } else {
    q_.reserve(max_nodes);
    q_.assign(nl_, Quadric{});
  }
  init_faces();
  // Directed edge x -> y exists when a face of x holds it: scan x's faces (cache-friendly, O(degree)).
  auto has_edge = [&](Index x, Index y) {
    for (const Index* it = faces_begin(x); it != faces_end(x); ++it) {
      const Index f = *it;
      const int k = cur_[3 * f] == x ? 0 : (cur_[3 * f + 1] == x ? 1 : 2);
      if (cur_[3 * f + (k + 1) % 3] == y) return true;
    }
    return false;
  };
  for (std::size_t f = 0; f < nf_; ++f) {
    const Index c0 = cur_[3 * f], c1 = cur_[3 * f + 1], c2 = cur_[3 * f + 2];
    if (colors_) {
      const AttributeQuadric q = AttributeQuadric::from_triangle({upos_[c0], ucol_[c0]}, {upos_[c1], ucol_[c1]}, {upos_[c2], ucol_[c2]});
      aq_[c0] += q;
      aq_[c1] += q;
      aq_[c2] += q;
    } else {
      const Quadric q = Quadric::from_triangle(upos_[c0], upos_[c1], upos_[c2]);
      q_[c0] += q;
      q_[c1] += q;
      q_[c2] += q;
    }
    for (int k = 0; k < 3; ++k) {
      const Index x = cur_[3 * f + k], y = cur_[3 * f + (k + 1) % 3], z = cur_[3 * f + (k + 2) % 3];
      if (has_edge(y, x)) continue;
      border_[x] = border_[y] = 1;
      const Quadric bq = Quadric::from_border_edge(upos_[x], upos_[y], upos_[z], opt_.border_penalty);
      if (colors_) {
        // Border planes constrain position only: embed the 3x3 part in the 6x6 quadric.
        AttributeQuadric aq;
        const double m[3][3] = {{bq.a00, bq.a01, bq.a02}, {bq.a01, bq.a11, bq.a12}, {bq.a02, bq.a12, bq.a22}};
        std::size_t idx = 0;
        for (int i = 0; i < 6; ++i)
          for (int j = i; j < 6; ++j, ++idx) aq.a[idx] = (i < 3 && j < 3) ? m[i][j] : 0.0;
        aq.b = {bq.b0, bq.b1, bq.b2, 0, 0, 0};
        aq.c = bq.c;
        aq_[x] += aq;
        aq_[y] += aq;
      } else {
        q_[x] += bq;
        q_[y] += bq;
      }
    }
  }

  // Raw hierarchy: leaves first.
  raw_.num_leaves = nl_;
  raw_.positions.reserve(max_nodes);
  raw_.positions = in_.positions;
  if (colors_) {
    raw_.colors.reserve(max_nodes);
    raw_.colors = in_.colors;
  }
  raw_.bounds.reserve(max_nodes);
  raw_.bounds.resize(nl_);
  raw_.records.reserve(nl_);
  raw_.ring_offsets.reserve(nl_ + 1);
  raw_.ring_items.reserve(8 * nl_);
  {
    std::vector<float> radius(nl_, 0.0f);
    std::vector<NormalCone> cone(nl_);
    std::vector<std::uint8_t> has_cone(nl_, 0);
    for (std::size_t f = 0; f < nf_; ++f) {
      const glm::vec3 p0 = in_.positions[cur_[3 * f]], p1 = in_.positions[cur_[3 * f + 1]], p2 = in_.positions[cur_[3 * f + 2]];
      const glm::vec3 n = glm::cross(p1 - p0, p2 - p0);
      const float len = glm::length(n);
      for (int k = 0; k < 3; ++k) {
        const Index v = cur_[3 * f + k];
        const glm::vec3 pv = in_.positions[v];
        radius[v] = std::max({radius[v], glm::length(p0 - pv), glm::length(p1 - pv), glm::length(p2 - pv)});
        if (len > 0.0f) {
          const NormalCone c{n / len, 1.0f};
          cone[v] = has_cone[v] ? enclose(cone[v], c) : c;
          has_cone[v] = 1;
        }
      }
    }
    for (std::size_t v = 0; v < nl_; ++v) raw_.bounds[v] = ElementBound{in_.positions[v], radius[v], 0.0f, cone[v]};
  }

  init_edges();
  const std::size_t target_v = opt_.target_vertices;
  const std::size_t target_f = opt_.target_faces;
  auto done = [&] {
    return (target_v > 0 && alive_vertices_ <= target_v) || (target_f > 0 && alive_faces_ <= target_f);
  };
  std::size_t since_rebuild = 0;
  while (!done()) {
    if (heap_.empty()) {
      if (since_rebuild == 0) break;
      since_rebuild = 0;
      ++stats.queue_rebuilds;
      for (std::size_t v = 0; v < node_alive_.size(); ++v)
        if (node_alive_[v]) {
          rejected_[v] = 0;
          reinsert_edges_of(static_cast<Index>(v));
        }
      continue;
    }
    const Index e = heap_.top();
    heap_.pop();
    const Index a = edges_[e].a, b = edges_[e].b;
    const Placement pl = place(a, b);
    Index fl, fr;
    const Verdict verdict = check(a, b, pl.p, fl, fr);
    if (verdict == Verdict::kOk) {
      const double local = local_error(a, b, pl.p);
      // Stop before the first collapse whose recorded error would exceed the limit.
      if (std::isfinite(opt_.max_error) && (std::max(uerr_[a], uerr_[b]) + local) * scale_ > opt_.max_error) break;
      collapse(a, b, pl, fl, fr, local);
      ++stats.collapses;
      ++since_rebuild;
      if (opt_.progress && (stats.collapses & 4095u) == 0) opt_.progress(stats.collapses, alive_vertices_);
    } else {
      switch (verdict) {
        case Verdict::kLink: ++stats.rejected_link; break;
        case Verdict::kFlip: ++stats.rejected_flip; break;
        case Verdict::kDepth: ++stats.rejected_depth; break;
        case Verdict::kLocked: ++stats.rejected_locked; break;
        case Verdict::kOk: break;
      }
      if (verdict != Verdict::kLocked && verdict != Verdict::kDepth) rejected_[a] = rejected_[b] = 1;
    }
  }

  raw_.faces = in_.faces;
  raw_.leaf_to_input = std::move(in_.leaf_to_input);
  raw_.face_to_input = std::move(in_.face_to_input);
  raw_.locked = std::move(in_.locked);
  raw_.repair = in_.report;
  stats.base_vertices = alive_vertices_;
  stats.base_faces = alive_faces_;
  VertexHierarchy h = VertexHierarchyBuilder::finish(std::move(raw_));
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return h;
}

// make_manifold_input() of an input that needs no repair, in O(n) instead of its sorts: the same leaves
// (numbered by first use), faces and report, or false when any repair step would apply (or a vertex is
// too busy for the quadratic fan walk), leaving the caller to the general path. Clean means: no degenerate
// face; every directed edge used once; no two faces on the same three corners; the faces around each
// vertex form one fan (successive faces share an edge used in both directions).
bool clean_manifold_input(const TriMesh& mesh, ManifoldInput& out) {
  const std::size_t nf = mesh.num_faces();
  if (nf == 0) return false;
  const Index* idx = mesh.indices.data();
  std::vector<Index> leaf_of(mesh.num_vertices(), kInvalid);
  std::vector<Index> leaf_to_input;
  leaf_to_input.reserve(mesh.num_vertices());
  std::vector<Index> corners(3 * nf);
  for (std::size_t i = 0; i < 3 * nf; i += 3) {
    if (idx[i] == idx[i + 1] || idx[i + 1] == idx[i + 2] || idx[i] == idx[i + 2]) return false;
    for (std::size_t k = 0; k < 3; ++k) {
      Index& l = leaf_of[idx[i + k]];
      if (l == kInvalid) {
        l = static_cast<Index>(leaf_to_input.size());
        leaf_to_input.push_back(idx[i + k]);
      }
      corners[i + k] = l;
    }
  }
  const std::size_t nl = leaf_to_input.size();
  // Faces around each leaf as (next, prev) corner pairs: face f at v holds v -> next and prev -> v.
  std::vector<Index> off(nl + 1, 0);
  for (Index c : corners) ++off[c + 1];
  for (std::size_t v = 0; v < nl; ++v) off[v + 1] += off[v];
  std::vector<std::array<Index, 2>> np(corners.size());
  {
    std::vector<Index> fill(off.begin(), off.end() - 1);
    for (std::size_t i = 0; i < corners.size(); i += 3)
      for (std::size_t k = 0; k < 3; ++k)
        np[fill[corners[i + k]]++] = {corners[i + (k + 1) % 3], corners[i + (k + 2) % 3]};
  }
  constexpr Index kMaxWalk = 64;
  for (std::size_t v = 0; v < nl; ++v) {
    const std::array<Index, 2>* r = np.data() + off[v];
    const Index d = off[v + 1] - off[v];
    if (d > kMaxWalk) return false;
    Index start = 0, starts = 0;
    for (Index i = 0; i < d; ++i) {
      bool has_pred = false;
      for (Index j = 0; j < d; ++j) {
        if (j == i) continue;
        if (r[j][0] == r[i][0]) return false;  // directed edge v -> next used twice
        if (r[j][0] == r[i][1]) {
          if (r[j][1] == r[i][0]) return false;  // the same corners in the other orientation
          has_pred = true;
        }
      }
      if (!has_pred && starts++ == 0) start = i;
    }
    if (starts > 1) return false;
    // Walk the successors (the face holding next -> v) from the start: one fan covers all d faces.
    Index seen = 1;
    for (Index i = start;;) {
      Index succ = kInvalid;
      for (Index j = 0; j < d && succ == kInvalid; ++j)
        if (r[j][1] == r[i][0]) succ = j;
      if (succ == kInvalid || succ == start) break;
      ++seen;
      i = succ;
    }
    if (seen != d) return false;
  }
  InputRepairReport& rep = out.report;
  rep = {};
  rep.input_vertices = mesh.num_vertices();
  rep.input_faces = nf;
  rep.unreferenced_vertices = mesh.num_vertices() - nl;
  out.positions.resize(nl);
  for (std::size_t l = 0; l < nl; ++l) out.positions[l] = mesh.positions[leaf_to_input[l]];
  out.colors.clear();
  if (mesh.has_colors()) {
    out.colors.resize(nl);
    for (std::size_t l = 0; l < nl; ++l) out.colors[l] = mesh.colors[leaf_to_input[l]];
  }
  out.faces = std::move(corners);
  out.leaf_to_input = std::move(leaf_to_input);
  out.face_to_input.resize(nf);
  std::iota(out.face_to_input.begin(), out.face_to_input.end(), Index{0});
  out.locked.assign(nl, 0);
  return true;
}

}  // namespace

VertexHierarchy build_vertex_hierarchy(const TriMesh& mesh, const QemOptions& options, QemStats* stats) {
  if (!(options.border_penalty >= 0.0) || !std::isfinite(options.border_penalty))
    throw InvalidInput("QemOptions::border_penalty must be finite and >= 0");
  if (!(options.color_weight > 0.0) || !std::isfinite(options.color_weight))
    throw InvalidInput("QemOptions::color_weight must be finite and > 0");
  if (std::isnan(options.max_error) || options.max_error < 0.0) throw InvalidInput("QemOptions::max_error must be >= 0");
  if (options.max_depth < 1 || options.max_depth > 62) throw InvalidInput("QemOptions::max_depth must be in [1, 62]");
  mesh.validate();
  ManifoldInput in;
  if (!clean_manifold_input(mesh, in)) in = make_manifold_input(mesh, options.non_manifold);
  QemStats local;
  if (stats) *stats = {};
  Analysis analysis(std::move(in), options);
  return analysis.run(stats ? *stats : local);
}

TriMesh mesh_after_collapses(const VertexHierarchy& h, std::size_t collapses) {
  collapses = std::min(collapses, h.num_collapses());
  const std::size_t nl = h.num_leaves();
  const std::size_t nn = nl + collapses;
  // Ancestor among nodes < nn: walk parents while the parent exists within the prefix.
  std::vector<Index> top(nn);
  for (std::size_t v = nn; v-- > 0;) {
    const Index p = h.parent(static_cast<Index>(v));
    top[v] = (p != kInvalid && p < nn) ? top[p] : static_cast<Index>(v);
  }
  TriMesh m;
  m.positions.assign(h.positions().begin(), h.positions().begin() + static_cast<std::ptrdiff_t>(nn));
  if (h.has_colors()) m.colors.assign(h.colors().begin(), h.colors().begin() + static_cast<std::ptrdiff_t>(nn));
  for (std::size_t f = 0; f < h.num_faces(); ++f) {
    const auto c = h.face(static_cast<Index>(f));
    const Index a = top[c[0]], b = top[c[1]], d = top[c[2]];
    if (a == b || b == d || a == d) continue;
    m.indices.insert(m.indices.end(), {a, b, d});
  }
  return m;
}

}  // namespace varmesh
