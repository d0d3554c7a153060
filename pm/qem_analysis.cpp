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
#include <chrono>
#include <cmath>
#include <queue>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "pm/quadric.hpp"

namespace varmesh {

namespace {

struct Candidate {
  double cost;
  Index a, b;
  bool operator<(const Candidate& o) const { return cost > o.cost || (cost == o.cost && (a > o.a || (a == o.a && b > o.b))); }
};

class Analysis {
 public:
  Analysis(ManifoldInput&& in, const QemOptions& opt) : in_(std::move(in)), opt_(opt) {}
  VertexHierarchy run(QemStats& stats);

 private:
  // Geometry in normalised coordinates.
  glm::dvec3 to_unit(const glm::vec3& p) const { return (glm::dvec3(p) - center_) / scale_; }
  glm::vec3 to_object(const glm::dvec3& p) const { return glm::vec3(p * scale_ + center_); }
  glm::dvec3 pos(Index v) const { return upos_[v]; }
  glm::dvec3 face_normal(Index f, Index moved, const glm::dvec3& p) const {
    glm::dvec3 c[3];
    for (int k = 0; k < 3; ++k) {
      const Index v = cur_[3 * f + k];
      c[k] = v == moved ? p : upos_[v];
    }
    return glm::cross(c[1] - c[0], c[2] - c[0]);
  }
  template <class Fn> void for_each_face(Index v, Fn&& fn) const {
    for (Index f : vfaces_[v])
      if (alive_[f]) fn(f);
  }
  struct Placement {
    glm::dvec3 p;
    glm::dvec3 color{0.0};
    double cost;
  };
  Placement place(Index a, Index b) const;
  void push_edges_of(Index v);
  enum class Verdict { kOk, kLink, kFlip, kDepth, kLocked };
  Verdict check(Index a, Index b, const glm::dvec3& p, Index& fl, Index& fr);
  void collapse(Index a, Index b, const Placement& pl, Index fl, Index fr);
  std::size_t alive_vertex_count() const { return alive_vertices_; }

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
  std::vector<std::vector<Index>> vfaces_;  // per node; may hold dead faces
  std::vector<Index> cur_;                  // current corners per face
  std::vector<std::uint8_t> alive_;         // per face
  std::vector<std::uint8_t> node_alive_;    // per node: in the current mesh
  std::vector<std::uint8_t> border_;        // per node: its dual piece touches the border
  std::vector<std::uint8_t> rejected_;      // per node: some edge of it was rejected and dropped
  std::vector<std::uint16_t> height_;
  std::size_t alive_vertices_ = 0, alive_faces_ = 0;
  std::priority_queue<Candidate> queue_;
  std::vector<std::uint32_t> mark_;
  std::uint32_t stamp_ = 0;
  std::vector<Index> scratch_;

  VertexHierarchyBuilder::Raw raw_;
  std::vector<double> uerr_;  // per node, unit coordinates
  QemStats* stats_ = nullptr;
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

void Analysis::push_edges_of(Index v) {
  ++stamp_;
  for_each_face(v, [&](Index f) {
    for (int k = 0; k < 3; ++k) {
      const Index w = cur_[3 * f + k];
      if (w == v || mark_[w] == stamp_) continue;
      mark_[w] = stamp_;
      queue_.push({place(v, w).cost, std::min(v, w), std::max(v, w)});
    }
  });
}

Analysis::Verdict Analysis::check(Index a, Index b, const glm::dvec3& p, Index& fl, Index& fr) {
  if ((a < nl_ && in_.locked[a]) || (b < nl_ && in_.locked[b])) return Verdict::kLocked;
  if (std::max(height_[a], height_[b]) + 1 > opt_.max_depth) return Verdict::kDepth;
  // Faces on the edge: fl has a->b, fr has b->a (from a's point of view; swapped later as needed).
  fl = fr = kInvalid;
  int shared = 0;
  for_each_face(a, [&](Index f) {
    for (int k = 0; k < 3; ++k) {
      if (cur_[3 * f + k] != b) continue;
      ++shared;
      const int ka = cur_[3 * f + (k + 1) % 3] == a ? (k + 1) % 3 : (k + 2) % 3;
      if (cur_[3 * f + (ka + 1) % 3] == b) fl = f; else fr = f;
    }
  });
  if (shared == 0 || shared > 2) return Verdict::kLink;
  if (shared == 1 && border_[a] == 0) return Verdict::kLink;  // cannot happen on a manifold; be safe
  if (shared == 2 && border_[a] && border_[b]) return Verdict::kLink;
  auto apex = [&](Index f) {
    for (int k = 0; k < 3; ++k)
      if (cur_[3 * f + k] != a && cur_[3 * f + k] != b) return cur_[3 * f + k];
    return kInvalid;
  };
  const Index vl = fl == kInvalid ? kInvalid : apex(fl), vr = fr == kInvalid ? kInvalid : apex(fr);
  // Link condition: common neighbours are exactly the apexes.
  ++stamp_;
  for_each_face(a, [&](Index f) {
    for (int k = 0; k < 3; ++k) mark_[cur_[3 * f + k]] = stamp_;
  });
  bool link_ok = true;
  for_each_face(b, [&](Index f) {
    for (int k = 0; k < 3; ++k) {
      const Index w = cur_[3 * f + k];
      if (w != a && w != b && w != vl && w != vr && mark_[w] == stamp_) link_ok = false;
    }
  });
  if (!link_ok) return Verdict::kLink;
  // An apex must keep a face, and faces (a|b, vl, vr) would become duplicates (the tetrahedron case).
  for (Index x : {vl, vr}) {
    if (x == kInvalid) continue;
    int n = 0;
    for_each_face(x, [&](Index) { ++n; });
    if (n <= 1) return Verdict::kLink;
  }
  if (vl != kInvalid && vr != kInvalid) {
    // Faces (a, vl, vr) and (b, vr, vl) would both become (vs, vl, vr): the tetrahedron case.
    auto has_face_with_apexes = [&](Index v) {
      bool found = false;
      for_each_face(v, [&](Index f) {
        int hit = 0;
        for (int k = 0; k < 3; ++k) hit += cur_[3 * f + k] == vl || cur_[3 * f + k] == vr;
        if (hit == 2) found = true;
      });
      return found;
    };
    if (has_face_with_apexes(a) && has_face_with_apexes(b)) return Verdict::kLink;
  }
  // No face turns over or collapses to zero area.
  bool flip = false;
  for (Index v : {a, b})
    for_each_face(v, [&](Index f) {
      if (flip || f == fl || f == fr) return;
      const glm::dvec3 n0 = face_normal(f, kInvalid, p);
      const glm::dvec3 n1 = face_normal(f, v, p);
      const double l0 = glm::dot(n0, n0);
      if (l0 == 0.0) {
        if (glm::dot(n1, n1) == 0.0) flip = true;
        return;
      }
      if (!(glm::dot(n0, n1) > 1e-3 * std::sqrt(l0 * glm::dot(n1, n1)))) flip = true;
    });
  if (flip) return Verdict::kFlip;
  return Verdict::kOk;
}

void Analysis::collapse(Index a, Index b, const Placement& pl, Index fl, Index fr) {
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
    Index found = kInvalid;
    for_each_face(x, [&](Index f) {
      for (int k = 0; k < 3; ++k)
        if (cur_[3 * f + k] == y && cur_[3 * f + (k + 1) % 3] == x) found = f;
    });
    return found;
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
  double local = 0.0;
  for (Index v : {a, b})
    for_each_face(v, [&](Index f) {
      const glm::dvec3 n = face_normal(f, kInvalid, pl.p);
      const double len = glm::length(n);
      if (len > 0.0) local = std::max(local, std::abs(glm::dot(n / len, pl.p - upos_[cur_[3 * f]])));
    });
  const double err = std::max(uerr_[a], uerr_[b]) + local;

  // Relabel and merge incidence.
  alive_[fl == kInvalid ? fr : fl] = 0;
  if (fl != kInvalid) alive_[fl] = 0;
  if (fr != kInvalid) alive_[fr] = 0;
  alive_faces_ -= (fl != kInvalid) + (fr != kInvalid);
  std::vector<Index> merged;
  merged.reserve(vfaces_[a].size() + vfaces_[b].size());
  NormalCone cone = enclose(raw_.bounds[a].cone, raw_.bounds[b].cone);
  for (Index v : {a, b}) {
    for (Index f : vfaces_[v]) {
      if (!alive_[f]) continue;
      for (int k = 0; k < 3; ++k)
        if (cur_[3 * f + k] == v) cur_[3 * f + k] = vs;
      merged.push_back(f);
    }
    std::vector<Index>().swap(vfaces_[v]);
  }
  for (Index f : merged) {
    const glm::dvec3 n = face_normal(f, vs, pl.p);
    const double len = glm::length(n);
    if (len > 0.0) cone = enclose(cone, NormalCone{glm::vec3(n / len), 1.0f});
  }
  vfaces_.push_back(std::move(merged));
  for (Index x : {vl, vr})
    if (x != kInvalid) std::erase_if(vfaces_[x], [&](Index f) { return !alive_[f]; });

  // Xia-Varshney stored ring: the neighbours of vs now.
  ++stamp_;
  mark_.push_back(0);
  for (Index f : vfaces_[vs])
    for (int k = 0; k < 3; ++k) {
      const Index w = cur_[3 * f + k];
      if (w == vs || mark_[w] == stamp_) continue;
      mark_[w] = stamp_;
      raw_.ring_items.push_back(w);
    }
  raw_.ring_offsets.push_back(static_cast<Index>(raw_.ring_items.size()));

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
  --alive_vertices_;

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

  push_edges_of(vs);
  // Neighbours that had an edge rejected get their edges re-examined: their neighbourhood just changed.
  scratch_.clear();
  for (Index f : vfaces_[vs])
    for (int k = 0; k < 3; ++k) {
      const Index w = cur_[3 * f + k];
      if (w != vs && rejected_[w]) {
        rejected_[w] = 0;
        scratch_.push_back(w);
      }
    }
  for (Index w : scratch_) push_edges_of(w);
}

VertexHierarchy Analysis::run(QemStats& stats) {
  stats_ = &stats;
  const auto t0 = std::chrono::steady_clock::now();
  nl_ = in_.positions.size();
  nf_ = in_.faces.size() / 3;
  Box3 box;
  for (const glm::vec3& p : in_.positions) box.add(p);
  center_ = glm::dvec3(box.center());
  scale_ = std::max(1e-30, static_cast<double>(box.diagonal()));
  colors_ = opt_.use_colors && !in_.colors.empty();

  upos_.resize(nl_);
  for (std::size_t v = 0; v < nl_; ++v) upos_[v] = to_unit(in_.positions[v]);
  cur_ = in_.faces;
  alive_.assign(nf_, 1);
  alive_faces_ = nf_;
  vfaces_.resize(nl_);
  for (std::size_t f = 0; f < nf_; ++f)
    for (int k = 0; k < 3; ++k) vfaces_[cur_[3 * f + k]].push_back(static_cast<Index>(f));
  node_alive_.assign(nl_, 1);
  alive_vertices_ = nl_;
  border_.assign(nl_, 0);
  rejected_.assign(nl_, 0);
  height_.assign(nl_, 0);
  uerr_.assign(nl_, 0.0);
  mark_.assign(nl_, 0);

  // Quadrics: area-weighted face planes plus border constraints (GH97).
  if (colors_) {
    aq_.assign(nl_, AttributeQuadric{});
    ucol_.resize(nl_);
    for (std::size_t v = 0; v < nl_; ++v) ucol_[v] = glm::dvec3(in_.colors[v]) * opt_.color_weight;
  } else {
    q_.assign(nl_, Quadric{});
  }
  // Directed edge x -> y exists when a face of x holds it: scan x's faces (cache-friendly, O(degree)).
  auto has_edge = [&](Index x, Index y) {
    for (Index f : vfaces_[x]) {
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
        AttributeQuadric a;
        const double m[3][3] = {{bq.a00, bq.a01, bq.a02}, {bq.a01, bq.a11, bq.a12}, {bq.a02, bq.a12, bq.a22}};
        std::size_t idx = 0;
        for (int i = 0; i < 6; ++i)
          for (int j = i; j < 6; ++j, ++idx) a.a[idx] = (i < 3 && j < 3) ? m[i][j] : 0.0;
        a.b = {bq.b0, bq.b1, bq.b2, 0, 0, 0};
        a.c = bq.c;
        aq_[x] += a;
        aq_[y] += a;
      } else {
        q_[x] += bq;
        q_[y] += bq;
      }
    }
  }

  // Raw hierarchy: leaves first.
  raw_.num_leaves = nl_;
  raw_.positions = in_.positions;
  if (colors_) raw_.colors = in_.colors;
  raw_.bounds.resize(nl_);
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

  const std::size_t target_v = opt_.target_vertices;
  const std::size_t target_f = opt_.target_faces;
  auto done = [&] {
    return (target_v > 0 && alive_vertices_ <= target_v) || (target_f > 0 && alive_faces_ <= target_f);
  };
  for (std::size_t v = 0; v < nl_; ++v) {
    ++stamp_;
    for (Index f : vfaces_[v])
      for (int k = 0; k < 3; ++k) {
        const Index w = cur_[3 * f + k];
        if (w > v && mark_[w] != stamp_) {
          mark_[w] = stamp_;
          queue_.push({place(static_cast<Index>(v), w).cost, static_cast<Index>(v), w});
        }
      }
  }
  std::size_t since_rebuild = 0;
  bool stop = false;
  while (!stop && !done()) {
    if (queue_.empty()) {
      if (since_rebuild == 0) break;
      since_rebuild = 0;
      ++stats.queue_rebuilds;
      for (std::size_t v = 0; v < node_alive_.size(); ++v)
        if (node_alive_[v]) {
          rejected_[v] = 0;
          push_edges_of(static_cast<Index>(v));
        }
      continue;
    }
    const Candidate c = queue_.top();
    queue_.pop();
    if (!node_alive_[c.a] || !node_alive_[c.b]) continue;
    const Placement pl = place(c.a, c.b);
    Index fl, fr;
    Verdict verdict = check(c.a, c.b, pl.p, fl, fr);
    if (verdict == Verdict::kOk) {
      // Orientation: fl must hold vt -> vu; check() found fl holding a -> b.
      double local_err = 0.0;
      (void)local_err;
      if (std::isfinite(opt_.max_error)) {
        // Peek at the error this collapse would record.
        double local = 0.0;
        for (Index v : {c.a, c.b})
          for_each_face(v, [&](Index f) {
            const glm::dvec3 n = face_normal(f, kInvalid, pl.p);
            const double len = glm::length(n);
            if (len > 0.0) local = std::max(local, std::abs(glm::dot(n / len, pl.p - upos_[cur_[3 * f]])));
          });
        if ((std::max(uerr_[c.a], uerr_[c.b]) + local) * scale_ > opt_.max_error) {
          stop = true;
          break;
        }
      }
      collapse(c.a, c.b, pl, fl, fr);
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
      if (verdict != Verdict::kLocked && verdict != Verdict::kDepth) rejected_[c.a] = rejected_[c.b] = 1;
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

}  // namespace

VertexHierarchy build_vertex_hierarchy(const TriMesh& mesh, const QemOptions& options, QemStats* stats) {
  if (!(options.border_penalty >= 0.0) || !std::isfinite(options.border_penalty))
    throw InvalidInput("QemOptions::border_penalty must be finite and >= 0");
  if (!(options.color_weight > 0.0) || !std::isfinite(options.color_weight))
    throw InvalidInput("QemOptions::color_weight must be finite and > 0");
  if (std::isnan(options.max_error) || options.max_error < 0.0) throw InvalidInput("QemOptions::max_error must be >= 0");
  if (options.max_depth < 1 || options.max_depth > 62) throw InvalidInput("QemOptions::max_depth must be in [1, 62]");
  ManifoldInput in = make_manifold_input(mesh, options.non_manifold);
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
