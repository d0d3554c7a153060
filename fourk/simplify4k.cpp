// Four-face-cluster simplification exported as an increasing 4-k Multi-Triangulation.
//
// Papers: L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000): 8.2 (simplification-based
// construction: collapse four-face clusters around degree-4 vertices, edge swaps where the connectivity is
// irregular, interleaved levels, stored as an increasing structure), Figure 21 (the cow levels), 7.1/7.2
// (the two node kinds: internal edge split 2 -> 4 and internal edge swap 2 -> 2), 3.1 (minimally compatible
// modifications, non-redundancy). The projection-mode bound is the "successive mapping" idea of J. Cohen,
// D. Manocha, M. Olano, "Simplifying polygonal models using successive mappings" (1997): one planar
// projection shared by the old and new triangulations gives a point-to-point correspondence whose distance
// is affine on the cells of their overlay. Point-to-triangle distances come from multitri/mesh_distance.hpp.
//
// Why plans: removing a vertex v of degree d by d - 4 spoke swaps and one 4 -> 2 collapse retriangulates v's
// star polygon, and every triangulation of a polygon can be peeled ear by ear down to a quadrilateral, so
// trying every ear order reaches every triangulation. All steps of one vertex touch only its star (plus one
// outer face for degree 3), which is what makes the clusters of a level independent.
#include "fourk/simplify4k.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <queue>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"
#include "multitri/mesh_distance.hpp"

namespace varmesh {

namespace {

using DVec = glm::dvec3;

std::uint64_t dkey(VertexId a, VertexId b) { return (std::uint64_t(a) << 32) | b; }

struct Triple {
  VertexId a, b, c;  // sorted
  bool operator==(const Triple&) const = default;
};
Triple triple(VertexId x, VertexId y, VertexId z) {
  std::array<VertexId, 3> t{x, y, z};
  std::sort(t.begin(), t.end());
  return {t[0], t[1], t[2]};
}
struct TripleHash {
  std::size_t operator()(const Triple& t) const noexcept {
    std::uint64_t h = t.a * 0x9E3779B97F4A7C15ull;
    h ^= (t.b + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
    h ^= (t.c * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2));
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};


// Unit normal (zero when degenerate) and radius-ratio quality 4*sqrt(3)*area / sum of squared edges.
struct FaceShape {
  DVec n{0.0};
  double q = 0.0;
};
FaceShape face_shape(const DVec& a, const DVec& b, const DVec& c) {
  const DVec cr = glm::cross(b - a, c - a);
  const double len = glm::length(cr);  // twice the area
  const DVec e0 = b - a, e1 = c - b, e2 = a - c;
  const double s = glm::dot(e0, e0) + glm::dot(e1, e1) + glm::dot(e2, e2);
  FaceShape f;
  if (len > 0.0 && std::isfinite(len)) f.n = cr / len;
  if (s > 0.0) f.q = 2.0 * std::sqrt(3.0) * len / s;
  return f;
}

// A triangle in projection coordinates: x, y in the plane, z = height along the axis.
using Tri2 = std::array<DVec, 3>;

// Largest height difference between two counter-clockwise triangles over the overlap of their projections
// (the vertices of the clipped polygon suffice: the difference of two linear height functions is affine
// there); -1 when the overlap has no area.
double overlap_height_gap(const Tri2& A, const Tri2& F) {
  auto cross = [](const DVec& o, const DVec& a, const DVec& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  // Separated (touching at most): the overlap has no area, and its points are also vertices of the
  // overlaps with the neighbouring faces, so it adds nothing.
  for (int e = 0; e < 3; ++e) {
    const DVec &a0 = A[e], &a1 = A[(e + 1) % 3], &f0 = F[e], &f1 = F[(e + 1) % 3];
    if (cross(a0, a1, F[0]) <= 0.0 && cross(a0, a1, F[1]) <= 0.0 && cross(a0, a1, F[2]) <= 0.0) return -1.0;
    if (cross(f0, f1, A[0]) <= 0.0 && cross(f0, f1, A[1]) <= 0.0 && cross(f0, f1, A[2]) <= 0.0) return -1.0;
  }
  std::array<DVec, 9> poly{}, next{};
  std::size_t n = 3;
  std::copy(F.begin(), F.end(), poly.begin());
  for (int e = 0; e < 3 && n > 0; ++e) {  // Sutherland-Hodgman against the anchor's edges
    const DVec &a = A[e], &b = A[(e + 1) % 3];
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const DVec& p = poly[i];
      const DVec& q = poly[(i + 1) % n];
      const double sp = cross(a, b, p), sq = cross(a, b, q);
      if (sp >= 0.0 && m < next.size()) next[m++] = p;
      if (((sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0)) && m < next.size()) next[m++] = p + (q - p) * (sp / (sp - sq));
    }
    poly = next;
    n = m;
  }
  if (n == 0) return -1.0;
  auto height = [&](const Tri2& T, const DVec& q) {
    const double det = cross(T[0], T[1], T[2]);
    const double l0 = cross(q, T[1], T[2]) / det, l1 = cross(T[0], q, T[2]) / det;
    return l0 * T[0].z + l1 * T[1].z + (1.0 - l0 - l1) * T[2].z;
  };
  double worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(height(A, poly[i]) - height(F, poly[i])));
  return worst;
}

// A vector of at most 16 items without heap allocation (the rings of a plan search).
template <class T>
struct SmallVec {
  std::array<T, 16> items{};
  std::size_t count = 0;
  SmallVec() = default;
  SmallVec(std::initializer_list<T> list) { for (const T& x : list) push_back(x); }
  template <class It>
  void assign(It first, It last) {
    count = 0;
    for (; first != last; ++first) push_back(*first);
  }
  void push_back(const T& x) {
    if (count == items.size()) throw std::logic_error("simplify4k: ring too large");
    items[count++] = x;
  }
  void erase_at(std::size_t i) {
    for (std::size_t j = i + 1; j < count; ++j) items[j - 1] = items[j];
    --count;
  }
  std::size_t size() const noexcept { return count; }
  T& operator[](std::size_t i) noexcept { return items[i]; }
  const T& operator[](std::size_t i) const noexcept { return items[i]; }
};

// A face of a plan: an existing face (id set) or one the plan would create.
struct PFace {
  std::array<VertexId, 3> v{};
  double h = 0.0;
  DVec n{0.0};
  double q = 0.0;
  FaceId id = kInvalid;
};

// One modification of a plan, in simplification order: kSwap 2 -> 2, kSplit 4 -> 2 (interior collapse) or
// 2 -> 1 (border collapse). Faces are indices into the plan's pool.
struct PStep {
  NodeKind kind = NodeKind::kSwap;
  std::uint8_t n_old = 0, n_new = 0;
  std::array<Index, 4> old{};
  std::array<Index, 2> created{};
};

struct Plan {
  std::vector<PFace> pool;
  std::vector<PStep> steps;
  double cost = std::numeric_limits<double>::infinity();  // largest h of the faces left at the end
  double quality = -1.0;                                    // worst quality of those faces
  int swaps = 0;
  bool blocked = false;  // no plan because of faces frozen at this level (may change next level)
  bool valid() const noexcept { return !steps.empty(); }
};

// Smallest cosine between a face normal and the projection axis in projection mode (about 87 degrees).
constexpr double kMinProjectedDot = 0.05;

enum VertexState : std::uint8_t { kFree = 0, kLocked = 1, kGone = 2, kUnused = 3 };

class Simplifier {
 public:
  Simplifier(const TriMesh& mesh, const Simplify4kOptions& options) : in_(mesh), opt_(options) {}
  Simplify4kResult run();

 private:
  struct Star {
    bool border = false;
    std::vector<VertexId> ring;  // interior: face i = (v, ring[i], ring[i+1 mod d]); border: i < k = ring.size()-1
    std::vector<FaceId> faces;
  };
  // The state of one plan search.
  struct Search {
    VertexId v = kInvalid;
    bool closed = true;
    SmallVec<VertexId> ring;
    SmallVec<Index> ringf;  // pool indices, same convention as Star::faces
    std::vector<Index> ears;   // pool indices of faces a swap left outside the shrinking star
    std::vector<Index> anchors;  // pool indices of the existing faces the plan replaces
    double qthr = 0.0;
    // Projection mode (see try_step): the region projects one-to-one along `axis` onto the (e1, e2) plane.
    bool proj = false;
    DVec axis{0.0}, e1{0.0}, e2{0.0};
    std::vector<std::pair<VertexId, DVec>> projected;  // region vertex -> (e1, e2, axis) coordinates
    std::vector<Tri2> anchors2;                         // the anchors in those coordinates
    // What does not depend on the path to a face (many ear orders reach the same faces): its shape, whether
    // its triple ever existed, which of its edges exist (bit k: edge k, bit k+3: edge k reversed was ever
    // made), and in projection mode its bound.
    struct Known {
      std::array<VertexId, 3> v;
      FaceShape shape;
      bool seen;
      std::uint8_t edges;
      double h;  // < 0: not computed yet
    };
    std::vector<Known> known;
    // Faces are triples of region vertices (v, its ring, the outer vertex at degree 3): `slot` maps their
    // local indices (4 bits each) to an entry of `known`, -1 when absent.
    SmallVec<VertexId> region;
    std::array<std::int16_t, 4096> slot;
    Plan cur, best;
  };

  void check_options() const;
  void load_input();
  bool collect_star(VertexId v, Star& s, std::size_t cap) const;
  bool edge_exists(VertexId a, VertexId b) const { return he_.count(dkey(a, b)) || he_.count(dkey(b, a)); }
  PFace existing(FaceId f) const;
  Plan best_plan(VertexId v, std::uint16_t level);
  bool setup_projection(Search& s, std::size_t star_faces) const;
  Search::Known& know(Search& s, const std::array<VertexId, 3>& t) const;
  double projected_bound(Search& s, Index known) const;
  static const DVec& projected(const Search& s, VertexId v) {
    for (const auto& [w, c] : s.projected)
      if (w == v) return c;
    throw std::logic_error("simplify4k: vertex outside the projected region");
  }
  bool try_step(Search& s, NodeKind kind, std::span<const Index> old,
                std::span<const std::array<VertexId, 3>> created);
  void search_ring(Search& s);
  void finish(Search& s);
  bool better(const Plan& a, const Plan& b) const;
  bool dihedral_ok(const std::vector<PFace>& pool, std::span<const Index> fin) const;
  bool still_valid(const Plan& p, std::uint16_t level) const;
  std::uint64_t signature(VertexId v) const;
  void execute(const Plan& plan, VertexId v, std::uint16_t level, Simplify4kLevel& stats);
  void remove_face(FaceId f);
  FaceId add_face(const std::array<VertexId, 3>& v, double h, std::uint16_t frozen);
  TriMesh snapshot() const;
  Simplify4kResult build_mt(std::vector<Simplify4kLevel> levels, std::vector<TriMesh> meshes);

  const TriMesh& in_;
  const Simplify4kOptions& opt_;
  double tol_ = 0.0;  // cost comparison tolerance, relative to the model size

  std::vector<DVec> pos_;
  std::vector<VertexId> fv_;  // 3 per face, every face ever made
  std::vector<std::uint8_t> alive_;
  std::vector<double> h_;
  std::vector<std::uint16_t> frozen_;   // per face: level whose collapse created it (0: input or a swap)
  std::vector<std::uint16_t> blocked_;  // per vertex: the last level that froze one of its faces
  std::vector<std::uint32_t> touch_;    // per vertex: faces created or removed at it so far
  std::vector<FaceId> vface_;           // per vertex: an alive face at it
  std::vector<std::uint8_t> vstate_;
  std::unordered_map<std::uint64_t, FaceId> he_;  // directed edge of an alive face -> face
  std::unordered_set<Triple, TripleHash> triples_;  // every vertex triple ever made (non-redundancy)
  std::unordered_set<std::uint64_t> directed_;      // every directed edge ever made (border edges)
  std::size_t num_alive_ = 0;
  std::size_t locked_ = 0;

  // Modifications in simplification order: old faces (finer) -> new faces (coarser).
  std::vector<NodeKind> op_kind_;
  std::vector<std::uint16_t> op_level_;
  std::vector<double> op_err_;
  std::vector<Index> op_old_off_{0}, op_old_, op_new_off_{0}, op_new_;
};

void Simplifier::check_options() const {
  auto bad = [](const std::string& why) { throw InvalidInput("simplify4k: option " + why); };
  if (opt_.max_levels < 0 || opt_.max_levels > 65535) bad("max_levels must be in [0, 65535]");
  if (opt_.max_swap_degree < 4 || opt_.max_swap_degree > 10) bad("max_swap_degree must be in [4, 10]");
  if (opt_.max_border_faces < 2 || opt_.max_border_faces > 8) bad("max_border_faces must be in [2, 8]");
  if (!(opt_.max_error >= 0.0)) bad("max_error must be >= 0");
  if (!(opt_.min_normal_dot >= -1.0 && opt_.min_normal_dot <= 1.0)) bad("min_normal_dot must be in [-1, 1]");
  if (!(opt_.min_dihedral_cos >= -1.0 && opt_.min_dihedral_cos <= 1.0)) bad("min_dihedral_cos must be in [-1, 1]");
  if (!(opt_.min_quality >= 0.0 && opt_.min_quality <= 1.0)) bad("min_quality must be in [0, 1]");
}

void Simplifier::load_input() {
  in_.validate();
  const std::size_t nf = in_.num_faces(), nv = in_.num_vertices();
  if (nf == 0) throw InvalidInput("simplify4k: empty mesh (no faces)");
  if (nf >= (std::size_t(1) << 31) || nv >= (std::size_t(1) << 31))
    throw InvalidInput("simplify4k: 2^31 or more faces or vertices");
  pos_.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) pos_[i] = DVec(in_.positions[i]);
  const Box3 box = in_.bounds();
  tol_ = 1e-12 * std::max(1.0, static_cast<double>(box.diagonal()));
  fv_.assign(in_.indices.begin(), in_.indices.end());
  alive_.assign(nf, 1);
  h_.assign(nf, 0.0);
  frozen_.assign(nf, 0);
  num_alive_ = nf;
  he_.reserve(3 * nf * 2);
  directed_.reserve(3 * nf * 2);
  triples_.reserve(nf * 2);
  vface_.assign(nv, kInvalid);
  blocked_.assign(nv, 0);
  touch_.assign(nv, 0);
  std::vector<Index> incident(nv, 0);
  // The half-edge map and the vertex triples serve the simplification; a repeated corner, directed edge or
  // triple met while they fill means a broken manifold rule of a FourKMesh (kFourKMeshRules), and none means
  // none. Which rule and which face to name is find_topology_problem's to say: it checks each rule over the
  // whole mesh, in the order the FourKMesh constructor reports them. It is asked only then: on every mesh it
  // would add its sort of the sides to the maps built here anyway (0.1 to 0.17 s on 2M triangles, where
  // loading them takes 3 s).
  auto refuse = [this] {
    const TopologyProblem problem = find_topology_problem(in_, kFourKMeshRules);
    if (!problem)
      throw std::logic_error("simplify4k: the half-edge map saw a broken rule find_topology_problem does not");
    throw InvalidInput("simplify4k: " + describe_topology_problem(problem), problem.element());
  };
  for (std::size_t f = 0; f < nf; ++f) {
    const VertexId a = fv_[3 * f], b = fv_[3 * f + 1], c = fv_[3 * f + 2];
    if (a == b || b == c || a == c) refuse();
    for (int k = 0; k < 3; ++k) {
      const VertexId p = fv_[3 * f + k], q = fv_[3 * f + (k + 1) % 3];
      if (!he_.try_emplace(dkey(p, q), static_cast<FaceId>(f)).second) refuse();
      directed_.insert(dkey(p, q));
      ++incident[p];
      vface_[p] = static_cast<FaceId>(f);
    }
    if (!triples_.insert(triple(a, b, c)).second) refuse();
  }
  // A vertex whose faces form several fans is non-manifold: classify it and lock it.
  vstate_.assign(nv, kUnused);
  Star s;
  for (VertexId v = 0; v < nv; ++v) {
    if (incident[v] == 0) continue;
    vstate_[v] = kFree;
    if (!collect_star(v, s, incident[v]) || s.faces.size() != incident[v]) {
      vstate_[v] = kLocked;
      ++locked_;
    }
  }
}

// The fan of faces around v in counter-clockwise order (see Star). False when it has more than `cap` faces.
bool Simplifier::collect_star(VertexId v, Star& s, std::size_t cap) const {
  s.ring.clear();
  s.faces.clear();
  s.border = false;
  const FaceId f0 = vface_[v];
  auto corner = [&](FaceId f) {
    for (int k = 0; k < 3; ++k)
      if (fv_[3 * f + k] == v) return k;
    throw std::logic_error("simplify4k: vertex/face incidence broken");
  };
  // Forward: from face (v, a, b) to the face that holds v -> b.
  FaceId f = f0;
  while (true) {
    const int k = corner(f);
    s.faces.push_back(f);
    s.ring.push_back(fv_[3 * f + (k + 1) % 3]);
    if (s.faces.size() > cap) return false;
    const VertexId b = fv_[3 * f + (k + 2) % 3];
    const auto it = he_.find(dkey(v, b));
    if (it == he_.end()) {
      s.border = true;
      s.ring.push_back(b);
      break;
    }
    f = it->second;
    if (f == f0) return true;
  }
  // Border: go backward from f0 (face (v, a, b) to the face that holds a -> v) and prepend.
  std::vector<FaceId> back_faces;
  std::vector<VertexId> back_ring;
  f = f0;
  while (true) {
    const int k = corner(f);
    const VertexId a = fv_[3 * f + (k + 1) % 3];
    const auto it = he_.find(dkey(a, v));
    if (it == he_.end()) break;
    f = it->second;
    const int kk = corner(f);
    back_faces.push_back(f);
    back_ring.push_back(fv_[3 * f + (kk + 1) % 3]);
    if (s.faces.size() + back_faces.size() > cap) return false;
  }
  s.faces.insert(s.faces.begin(), back_faces.rbegin(), back_faces.rend());
  s.ring.insert(s.ring.begin(), back_ring.rbegin(), back_ring.rend());
  return true;
}

// Changes whenever a face at v or at one of its neighbours is created or removed: everything a plan for v
// depends on besides the level (its star, the faces beyond its ring, the edges between its ring vertices).
std::uint64_t Simplifier::signature(VertexId v) const {
  Star s;
  std::uint64_t sum = touch_[v];
  if (collect_star(v, s, 64))
    for (VertexId w : s.ring) sum += touch_[w];
  return sum;
}

PFace Simplifier::existing(FaceId f) const {
  PFace p;
  p.v = {fv_[3 * f], fv_[3 * f + 1], fv_[3 * f + 2]};
  const FaceShape sh = face_shape(pos_[p.v[0]], pos_[p.v[1]], pos_[p.v[2]]);
  p.n = sh.n;
  p.q = sh.q;
  p.h = h_[f];
  p.id = f;
  return p;
}

bool Simplifier::better(const Plan& a, const Plan& b) const {
  if (a.cost < b.cost - tol_) return true;
  if (a.cost > b.cost + tol_) return false;
  if (a.quality != b.quality) return a.quality > b.quality;
  return a.swaps < b.swaps;
}

// Checks one step of the current plan and appends it (with its new faces) when legal. See the header for
// the criteria; the error bound update is the one documented there.
bool Simplifier::try_step(Search& s, NodeKind kind, std::span<const Index> old,
                          std::span<const std::array<VertexId, 3>> created) {
  Plan& p = s.cur;
  auto undirected = [](VertexId a, VertexId b) { return a < b ? dkey(a, b) : dkey(b, a); };
  std::array<std::uint64_t, 12> old_edges{};
  std::size_t n_old_edges = 0;
  for (Index o : old)
    for (int k = 0; k < 3; ++k) old_edges[n_old_edges++] = undirected(p.pool[o].v[k], p.pool[o].v[(k + 1) % 3]);
  auto is_old_edge = [&](std::uint64_t e) {
    for (std::size_t j = 0; j < n_old_edges; ++j)
      if (old_edges[j] == e) return true;
    return false;
  };
  std::array<PFace, 2> nf;
  std::array<Index, 2> known{};
  for (std::size_t i = 0; i < created.size(); ++i) {
    const auto& t = created[i];
    const Search::Known& kn = know(s, t);
    known[i] = static_cast<Index>(&kn - s.known.data());
    if (kn.seen) return false;  // a face that existed once: the MT would be redundant
    if (!(kn.shape.q >= s.qthr) || kn.shape.q <= 1e-9) return false;
    nf[i].v = t;
    nf[i].n = kn.shape.n;
    nf[i].q = kn.shape.q;
    for (int k = 0; k < 3; ++k) {
      const VertexId a = t[k], b = t[(k + 1) % 3];
      if (is_old_edge(undirected(a, b))) continue;
      if (kn.edges >> k & 1u) return false;  // would make a non-manifold edge
      bool shared = false;
      for (std::size_t j = 0; j < created.size(); ++j)
        for (int kk = 0; kk < 3; ++kk)
          if (j != i && created[j][kk] == b && created[j][(kk + 1) % 3] == a) shared = true;
      // A new edge no other new face shares is a border edge: MtBuilder requires that no face of the
      // structure ever used it in the other direction.
      if (!shared && (kn.edges >> (k + 3) & 1u)) return false;
    }
  }
  // No fold-over: compare each new face with the old faces of the step it shares an edge with.
  for (std::size_t i = 0; i < created.size(); ++i)
    for (Index o : old) {
      const PFace& t = p.pool[o];
      bool shares = false;
      for (int k = 0; k < 3 && !shares; ++k)
        shares = is_old_edge(undirected(nf[i].v[k], nf[i].v[(k + 1) % 3])) &&
                 (std::count(t.v.begin(), t.v.end(), nf[i].v[k]) != 0) &&
                 (std::count(t.v.begin(), t.v.end(), nf[i].v[(k + 1) % 3]) != 0);
      if (shares && glm::dot(t.n, t.n) > 0.0 && glm::dot(nf[i].n, t.n) < opt_.min_normal_dot) return false;
    }
  if (s.proj) {
    // Projection mode: every stage of the plan triangulates the same projected polygon, so a point of an
    // anchor face corresponds to the point of the new face with the same projection; their distance along
    // the axis bounds how far the new face is from the anchor (header, "error bound"). No accumulation
    // within the plan.
    for (std::size_t i = 0; i < created.size(); ++i) {
      if (glm::dot(nf[i].n, s.axis) < kMinProjectedDot) return false;
      // A face around v is consumed later in the plan: its bound matters only for the chosen plan.
      nf[i].h = std::find(nf[i].v.begin(), nf[i].v.end(), s.v) != nf[i].v.end() ? -1.0 : projected_bound(s, known[i]);
    }
  } else {
    // Fallback: each old face goes to the new face its corners are nearest to; distance to a triangle is
    // convex, so the corners bound the whole old face, and the triangle inequality accumulates.
    for (Index o : old) {
      const PFace& t = p.pool[o];
      double best = std::numeric_limits<double>::infinity();
      std::size_t at = 0;
      for (std::size_t i = 0; i < created.size(); ++i) {
        double d = 0.0;
        for (VertexId c : t.v)
          if (std::find(nf[i].v.begin(), nf[i].v.end(), c) == nf[i].v.end())
            d = std::max(d, std::sqrt(point_triangle_distance_sq(pos_[c], pos_[nf[i].v[0]], pos_[nf[i].v[1]], pos_[nf[i].v[2]])));
        if (d < best) {
          best = d;
          at = i;
        }
      }
      nf[at].h = std::max(nf[at].h, t.h + best);
    }
  }
  for (std::size_t i = 0; i < created.size(); ++i)
    if (nf[i].h > opt_.max_error) return false;  // -1: not computed yet (see finish)
  PStep step;
  step.kind = kind;
  step.n_old = static_cast<std::uint8_t>(old.size());
  step.n_new = static_cast<std::uint8_t>(created.size());
  std::copy(old.begin(), old.end(), step.old.begin());
  for (std::size_t i = 0; i < created.size(); ++i) {
    step.created[i] = static_cast<Index>(p.pool.size());
    p.pool.push_back(nf[i]);
  }
  p.steps.push_back(step);
  return true;
}

// The projection-mode bound of a face (cached: it depends on the face only, not on the path to it).
double Simplifier::projected_bound(Search& s, Index known) const {
  if (s.known[known].h < 0.0) {
    Tri2 f;
    for (int k = 0; k < 3; ++k) f[k] = projected(s, s.known[known].v[k]);
    double h = 0.0;
    for (std::size_t a = 0; a < s.anchors.size(); ++a) {
      const double d = overlap_height_gap(s.anchors2[a], f);
      if (d >= 0.0) h = std::max(h, s.cur.pool[s.anchors[a]].h + d);
    }
    s.known[known].h = h;
  }
  return s.known[known].h;
}

Simplifier::Search::Known& Simplifier::know(Search& s, const std::array<VertexId, 3>& t) const {
  std::size_t key = 0;
  for (int i = 0; i < 3; ++i) {
    std::size_t l = 0;
    while (l < s.region.size() && s.region[l] != t[i]) ++l;
    if (l == s.region.size()) s.region.push_back(t[i]);
    key = key * 16 + l;
  }
  if (s.slot[key] >= 0) return s.known[static_cast<std::size_t>(s.slot[key])];
  s.slot[key] = static_cast<std::int16_t>(s.known.size());
  Search::Known k{t, face_shape(pos_[t[0]], pos_[t[1]], pos_[t[2]]), triples_.count(triple(t[0], t[1], t[2])) != 0,
                  0, -1.0};
  for (int i = 0; i < 3; ++i) {
    const VertexId a = t[i], b = t[(i + 1) % 3];
    if (edge_exists(a, b)) k.edges = static_cast<std::uint8_t>(k.edges | (1u << i));
    if (directed_.count(dkey(b, a))) k.edges = static_cast<std::uint8_t>(k.edges | (8u << i));
  }
  s.known.push_back(k);
  return s.known.back();
}

// Peels ears off the star polygon (one spoke swap each) until the last step fits, trying every order.
void Simplifier::search_ring(Search& s) {
  const std::size_t d = s.ring.size();
  const std::size_t final_size = s.closed ? 4 : 3;
  if (d == final_size) {
    finish(s);
    return;
  }
  const VertexId v = s.v;
  const std::size_t first = s.closed ? 0 : 1, last = s.closed ? d : d - 1;
  // Legal ears first, then recurse from the cheapest (its bound prunes the others sooner).
  struct Ear {
    double h;
    std::size_t i;
    PStep step;
    std::array<PFace, 2> faces;
  };
  std::array<Ear, 16> ears{};
  std::size_t n_ears = 0;
  const std::size_t pool_mark = s.cur.pool.size(), step_mark = s.cur.steps.size();
  for (std::size_t i = first; i < last; ++i) {
    const std::size_t pi = (i + d - 1) % d, ni = (i + 1) % d;
    const std::array<Index, 2> old{s.ringf[pi], s.ringf[i]};
    const std::array<std::array<VertexId, 3>, 2> created{{{v, s.ring[pi], s.ring[ni]}, {s.ring[pi], s.ring[i], s.ring[ni]}}};
    if (try_step(s, NodeKind::kSwap, old, created))
      ears[n_ears++] = {s.cur.pool.back().h, i, s.cur.steps.back(), {s.cur.pool[pool_mark], s.cur.pool[pool_mark + 1]}};
    s.cur.pool.resize(pool_mark);
    s.cur.steps.resize(step_mark);
  }
  std::sort(ears.begin(), ears.begin() + static_cast<std::ptrdiff_t>(n_ears),
            [](const Ear& a, const Ear& b) { return a.h < b.h || (a.h == b.h && a.i < b.i); });
  for (std::size_t e = 0; e < n_ears; ++e) {
    const std::size_t i = ears[e].i;
    if (ears[e].h > s.best.cost + tol_) break;  // the ear stays: its bound is a lower bound of the cost
    const std::size_t pi = (i + d - 1) % d;
    s.cur.pool.push_back(ears[e].faces[0]);  // at pool_mark and pool_mark + 1, as when it was tried
    s.cur.pool.push_back(ears[e].faces[1]);
    s.cur.steps.push_back(ears[e].step);
    const auto ring = s.ring;
    const auto ringf = s.ringf;
    s.ringf[pi] = static_cast<Index>(pool_mark);
    s.ring.erase_at(i);
    s.ringf.erase_at(i);
    s.ears.push_back(static_cast<Index>(pool_mark + 1));
    ++s.cur.swaps;
    search_ring(s);
    --s.cur.swaps;
    s.ears.pop_back();
    s.ring = ring;
    s.ringf = ringf;
    s.cur.pool.resize(pool_mark);
    s.cur.steps.resize(step_mark);
  }
}

// Dihedral criterion across every edge of the plan's final faces `fin` (pool indices): between two final
// faces, and on the cluster's ring against the unchanged face outside (at least what was there before).
bool Simplifier::dihedral_ok(const std::vector<PFace>& pool, std::span<const Index> fin) const {
  for (Index f : fin) {
    const PFace& F = pool[f];
    for (int k = 0; k < 3; ++k) {
      const VertexId a = F.v[k], b = F.v[(k + 1) % 3];
      bool inner = false;
      for (Index g : fin) {
        const PFace& G = pool[g];
        for (int kk = 0; kk < 3; ++kk)
          if (G.v[kk] == b && G.v[(kk + 1) % 3] == a) {
            inner = true;
            if (glm::dot(F.n, G.n) < opt_.min_dihedral_cos) return false;
          }
      }
      if (inner) continue;
      const auto out = he_.find(dkey(b, a));
      const auto own = he_.find(dkey(a, b));
      if (out == he_.end() || own == he_.end()) continue;  // mesh border (or the new border edge)
      const DVec no = face_shape(pos_[fv_[3 * out->second]], pos_[fv_[3 * out->second + 1]],
                                 pos_[fv_[3 * out->second + 2]]).n;
      const DVec nr = face_shape(pos_[fv_[3 * own->second]], pos_[fv_[3 * own->second + 1]],
                                 pos_[fv_[3 * own->second + 2]]).n;
      if (glm::dot(F.n, no) < std::min(opt_.min_dihedral_cos, glm::dot(nr, no))) return false;
    }
  }
  return true;
}

// Re-checks a plan made earlier in this level against the current mesh: its faces are untouched and not
// frozen, and what it creates is still legal (no existing edge or triple, border rule, dihedral criterion
// against the faces now around it). Geometry of the plan itself cannot have changed.
bool Simplifier::still_valid(const Plan& p, std::uint16_t level) const {
  auto undirected = [](VertexId a, VertexId b) { return a < b ? dkey(a, b) : dkey(b, a); };
  std::vector<std::uint64_t> anchor_edges;
  for (const PFace& f : p.pool)
    if (f.id != kInvalid) {
      if (!alive_[f.id] || frozen_[f.id] == level) return false;
      for (int k = 0; k < 3; ++k) anchor_edges.push_back(undirected(f.v[k], f.v[(k + 1) % 3]));
    }
  std::vector<Index> fin;
  for (const PStep& st : p.steps) {
    for (int i = 0; i < st.n_new; ++i) {
      const PFace& f = p.pool[st.created[i]];
      if (triples_.count(triple(f.v[0], f.v[1], f.v[2]))) return false;
      for (int k = 0; k < 3; ++k) {
        const VertexId a = f.v[k], b = f.v[(k + 1) % 3];
        if (std::find(anchor_edges.begin(), anchor_edges.end(), undirected(a, b)) != anchor_edges.end()) continue;
        if (edge_exists(a, b)) return false;
        bool shared = false;
        for (int j = 0; j < st.n_new; ++j)
          for (int kk = 0; kk < 3; ++kk)
            if (j != i && p.pool[st.created[j]].v[kk] == b && p.pool[st.created[j]].v[(kk + 1) % 3] == a) shared = true;
        if (!shared && directed_.count(dkey(b, a))) return false;
      }
      fin.push_back(st.created[i]);
    }
    for (int i = 0; i < st.n_old; ++i) fin.erase(std::remove(fin.begin(), fin.end(), st.old[i]), fin.end());
  }
  return dihedral_ok(p.pool, fin);
}

// The last step (4 -> 2 by either diagonal, or the border 2 -> 1), then the plan-wide dihedral checks.
void Simplifier::finish(Search& s) {
  auto evaluate = [&]() {
    std::vector<Index> fin = s.ears;
    const PStep& last = s.cur.steps.back();
    for (int i = 0; i < last.n_new; ++i) fin.push_back(last.created[i]);
    double cost = 0.0, quality = 1.0;
    for (Index f : fin) {
      cost = std::max(cost, s.cur.pool[f].h);
      quality = std::min(quality, s.cur.pool[f].q);
    }
    Plan& c = s.cur;
    c.cost = cost;
    c.quality = quality;
    if (s.best.valid() && !better(c, s.best)) return;
    if (!dihedral_ok(c.pool, fin)) return;
    // Bounds of the faces around v that the plan consumes again (left open by try_step; they depend on the
    // face only, so filling them in the shared prefix of the search is harmless).
    for (PFace& f : c.pool)
      if (f.h < 0.0) {
        f.h = projected_bound(s, static_cast<Index>(&know(s, f.v) - s.known.data()));
        if (f.h > opt_.max_error) return;
      }
    s.best = c;
  };
  const std::size_t pool_mark = s.cur.pool.size(), step_mark = s.cur.steps.size();
  if (s.closed) {
    const auto& r = s.ring;
    const std::array<Index, 4> old{s.ringf[0], s.ringf[1], s.ringf[2], s.ringf[3]};
    const std::array<std::array<std::array<VertexId, 3>, 2>, 2> diagonals{
        {{{{r[0], r[1], r[2]}, {r[0], r[2], r[3]}}}, {{{r[1], r[2], r[3]}, {r[1], r[3], r[0]}}}}};
    for (const auto& created : diagonals) {
      if (try_step(s, NodeKind::kSplit, old, created)) evaluate();
      s.cur.pool.resize(pool_mark);
      s.cur.steps.resize(step_mark);
    }
  } else {
    const std::array<Index, 2> old{s.ringf[0], s.ringf[1]};
    const std::array<std::array<VertexId, 3>, 1> created{{{s.ring[0], s.ring[1], s.ring[2]}}};
    if (try_step(s, NodeKind::kSplit, old, created)) evaluate();
    s.cur.pool.resize(pool_mark);
    s.cur.steps.resize(step_mark);
  }
}

// Projection mode needs every anchor face to face the mean normal and, around an interior vertex, the
// projected star to wind once (angles at v summing to 2 pi), so the region projects one-to-one.
bool Simplifier::setup_projection(Search& s, std::size_t star_faces) const {
  DVec axis(0.0);
  for (Index a : s.anchors) {
    const auto& v = s.cur.pool[a].v;
    axis += glm::cross(pos_[v[1]] - pos_[v[0]], pos_[v[2]] - pos_[v[0]]);
  }
  const double len = glm::length(axis);
  if (!(len > 0.0)) return false;
  axis /= len;
  for (Index a : s.anchors)
    if (glm::dot(s.cur.pool[a].n, axis) < kMinProjectedDot) return false;
  const DVec helper = std::abs(axis.x) < 0.6 ? DVec(1.0, 0.0, 0.0) : DVec(0.0, 1.0, 0.0);
  s.axis = axis;
  s.e1 = glm::normalize(glm::cross(axis, helper));
  s.e2 = glm::cross(axis, s.e1);
  s.projected.clear();
  for (Index a : s.anchors)
    for (VertexId w : s.cur.pool[a].v)
      if (std::none_of(s.projected.begin(), s.projected.end(), [&](const auto& q) { return q.first == w; }))
        s.projected.push_back({w, DVec(glm::dot(pos_[w], s.e1), glm::dot(pos_[w], s.e2), glm::dot(pos_[w], axis))});
  s.anchors2.clear();
  for (Index a : s.anchors) {
    Tri2 t;
    for (int k = 0; k < 3; ++k) t[k] = projected(s, s.cur.pool[a].v[k]);
    s.anchors2.push_back(t);
  }
  double turn = 0.0;
  for (std::size_t i = 0; i < star_faces; ++i) {
    const auto& v = s.cur.pool[s.anchors[i]].v;
    int k = 0;
    while (v[k] != s.v) ++k;
    const DVec a = pos_[v[(k + 1) % 3]] - pos_[s.v], b = pos_[v[(k + 2) % 3]] - pos_[s.v];
    const double ax = glm::dot(a, s.e1), ay = glm::dot(a, s.e2), bx = glm::dot(b, s.e1), by = glm::dot(b, s.e2);
    turn += std::atan2(ax * by - ay * bx, ax * bx + ay * by);
  }
  s.proj = std::abs(turn - 2.0 * std::numbers::pi) < 1e-3;
  return s.proj;
}

// The best legal way to remove v at this level, or an invalid plan. Plans in projection mode are preferred
// (tighter bounds); the fallback bound is used where the region does not project one-to-one.
Plan Simplifier::best_plan(VertexId v, std::uint16_t level) {
  if (vstate_[v] != kFree) return {};
  Star star;
  const std::size_t cap = static_cast<std::size_t>(std::max(opt_.max_swap_degree, opt_.max_border_faces));
  if (!collect_star(v, star, cap)) return {};
  if (star.border) {
    if (opt_.lock_border || star.faces.size() < 2 || star.faces.size() > std::size_t(opt_.max_border_faces))
      return {};
  } else if (star.faces.size() < 3 || star.faces.size() > std::size_t(opt_.max_swap_degree)) {
    return {};
  }
  for (FaceId f : star.faces)
    if (frozen_[f] == level) {  // a cluster collapsed at this level: its faces wait a level
      Plan blocked;
      blocked.blocked = true;
      return blocked;
    }
  Search base;
  base.slot.fill(-1);
  base.v = v;
  base.closed = !star.border;
  base.ring.assign(star.ring.begin(), star.ring.end());
  double worst_q = 1.0;
  for (FaceId f : star.faces) {
    base.ringf.push_back(static_cast<Index>(base.cur.pool.size()));
    base.anchors.push_back(static_cast<Index>(base.cur.pool.size()));
    base.cur.pool.push_back(existing(f));
    worst_q = std::min(worst_q, base.cur.pool.back().q);
  }
  base.qthr = std::min(opt_.min_quality, worst_q);
  const std::size_t nstar = star.faces.size();
  if (star.border) {  // the border moves: the projection correspondence does not hold, use the fallback
    search_ring(base);
    return std::move(base.best);
  }
  if (nstar > 3) {
    Search s = base;
    if (setup_projection(s, nstar)) {
      search_ring(s);
      if (s.best.valid()) return std::move(s.best);
    }
    s = base;
    search_ring(s);
    return std::move(s.best);
  }
  // Degree 3: swap one ring edge (a, b) outward with the face (b, a, x) beyond it; v gets degree 4.
  Plan best;
  for (std::size_t i = 0; i < 3; ++i) {
    const VertexId a = star.ring[i], b = star.ring[(i + 1) % 3], c = star.ring[(i + 2) % 3];
    const auto it = he_.find(dkey(b, a));
    if (it == he_.end()) continue;
    if (frozen_[it->second] == level) {
      best.blocked = true;
      continue;
    }
    const PFace outer = existing(it->second);
    VertexId x = kInvalid;
    for (VertexId w : outer.v)
      if (w != a && w != b) x = w;
    if (x == v || x == c) continue;
    for (int mode = 0; mode < 2; ++mode) {
      Search s = base;
      const auto o = static_cast<Index>(s.cur.pool.size());
      s.cur.pool.push_back(outer);
      s.anchors.push_back(o);
      s.qthr = std::min(s.qthr, outer.q);
      if (mode == 0 && !setup_projection(s, nstar)) continue;
      const std::array<Index, 2> old{s.ringf[i], o};
      const std::array<std::array<VertexId, 3>, 2> created{{{v, a, x}, {v, x, b}}};
      if (!try_step(s, NodeKind::kSwap, old, created)) continue;
      const Index f1 = s.cur.steps.back().created[0], f2 = s.cur.steps.back().created[1];
      s.ring = {a, x, b, c};
      s.ringf = {f1, f2, s.ringf[(i + 1) % 3], s.ringf[(i + 2) % 3]};
      s.cur.swaps = 1;
      finish(s);
      if (!s.best.valid()) continue;
      if (!best.valid() || better(s.best, best)) {
        const bool blocked = best.blocked;
        best = std::move(s.best);
        best.blocked = blocked;
      }
      break;  // projection mode found a plan: no fallback for this edge
    }
  }
  return best;
}

void Simplifier::remove_face(FaceId f) {
  if (!alive_[f]) throw std::logic_error("simplify4k: removing a dead face");
  alive_[f] = 0;
  for (int k = 0; k < 3; ++k) {
    he_.erase(dkey(fv_[3 * f + k], fv_[3 * f + (k + 1) % 3]));
    ++touch_[fv_[3 * f + k]];
  }
  --num_alive_;
}

FaceId Simplifier::add_face(const std::array<VertexId, 3>& v, double h, std::uint16_t frozen) {
  const auto f = static_cast<FaceId>(alive_.size());
  fv_.insert(fv_.end(), v.begin(), v.end());
  alive_.push_back(1);
  h_.push_back(h);
  frozen_.push_back(frozen);
  if (frozen != 0)
    for (VertexId w : v) blocked_[w] = frozen;
  for (int k = 0; k < 3; ++k) {
    if (!he_.try_emplace(dkey(v[k], v[(k + 1) % 3]), f).second)
      throw std::logic_error("simplify4k: a plan created a non-manifold edge");
    directed_.insert(dkey(v[k], v[(k + 1) % 3]));
    vface_[v[k]] = f;
    ++touch_[v[k]];
  }
  triples_.insert(triple(v[0], v[1], v[2]));
  ++num_alive_;
  return f;
}

void Simplifier::execute(const Plan& plan, VertexId v, std::uint16_t level, Simplify4kLevel& stats) {
  std::vector<FaceId> real(plan.pool.size(), kInvalid);
  for (std::size_t i = 0; i < plan.pool.size(); ++i) real[i] = plan.pool[i].id;
  for (const PStep& st : plan.steps) {
    double err = 0.0;
    for (int i = 0; i < st.n_old; ++i) {
      const FaceId f = real[st.old[i]];
      remove_face(f);
      op_old_.push_back(f);
    }
    for (int i = 0; i < st.n_new; ++i) {
      const PFace& pf = plan.pool[st.created[i]];
      const FaceId f = add_face(pf.v, pf.h, st.kind == NodeKind::kSplit ? level : 0);
      real[st.created[i]] = f;
      op_new_.push_back(f);
      err = std::max(err, pf.h);
    }
    op_old_off_.push_back(static_cast<Index>(op_old_.size()));
    op_new_off_.push_back(static_cast<Index>(op_new_.size()));
    op_kind_.push_back(st.kind);
    op_level_.push_back(level);
    op_err_.push_back(err);
    if (st.kind == NodeKind::kSwap) ++stats.swaps;
    else if (st.n_new == 1) ++stats.border_collapses;
    else ++stats.collapses;
  }
  vstate_[v] = kGone;
}

TriMesh Simplifier::snapshot() const {
  TriMesh m;
  m.positions = in_.positions;
  for (std::size_t f = 0; f < alive_.size(); ++f)
    if (alive_[f]) m.indices.insert(m.indices.end(), fv_.begin() + 3 * static_cast<std::ptrdiff_t>(f),
                                    fv_.begin() + 3 * static_cast<std::ptrdiff_t>(f) + 3);
  return m;
}

Simplify4kResult Simplifier::build_mt(std::vector<Simplify4kLevel> levels, std::vector<TriMesh> meshes) {
  MtBuilder b;
  for (const auto& p : in_.positions) b.add_vertex(p);
  for (std::size_t f = 0; f < alive_.size(); ++f) b.add_face(fv_[3 * f], fv_[3 * f + 1], fv_[3 * f + 2]);
  std::vector<FaceId> base;
  for (std::size_t f = 0; f < alive_.size(); ++f)
    if (alive_[f]) base.push_back(static_cast<FaceId>(f));
  b.set_base(base);
  const std::size_t num_ops = op_kind_.size();
  // Reverse order: the coarsest modification first; the MT removes what the simplification created.
  for (std::size_t i = num_ops; i-- > 0;) {
    const std::span<const FaceId> created(op_old_.data() + op_old_off_[i], op_old_off_[i + 1] - op_old_off_[i]);
    const std::span<const FaceId> removed(op_new_.data() + op_new_off_[i], op_new_off_[i + 1] - op_new_off_[i]);
    float err = static_cast<float>(op_err_[i]);
    if (static_cast<double>(err) < op_err_[i]) err = std::nextafter(err, std::numeric_limits<float>::infinity());
    b.add_node(op_kind_[i], removed, created, err);
  }
  std::vector<NodeId> node_new_to_old;
  Simplify4kResult r;
  r.mt = std::move(b).build(opt_.build, &node_new_to_old);
  r.node_level.assign(r.mt.num_nodes(), 0);
  for (NodeId n = 1; n < r.mt.num_nodes(); ++n) r.node_level[n] = op_level_[num_ops - node_new_to_old[n]];
  for (NodeId n = 1; n < r.mt.num_nodes(); ++n) {
    if (r.mt.kind(n) == NodeKind::kSplit) ++r.num_split_nodes;
    if (r.mt.kind(n) == NodeKind::kSwap) ++r.num_swap_nodes;
  }
  r.levels = std::move(levels);
  r.level_meshes = std::move(meshes);
  r.locked_vertices = locked_;
  return r;
}

Simplify4kResult Simplifier::run() {
  check_options();
  load_input();
  auto used_vertices = [&]() {
    std::vector<std::uint8_t> used(pos_.size(), 0);
    for (std::size_t f = 0; f < alive_.size(); ++f)
      if (alive_[f])
        for (int k = 0; k < 3; ++k) used[fv_[3 * f + k]] = 1;
    return static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
  };
  std::vector<Simplify4kLevel> levels(1);
  levels[0].faces = num_alive_;
  levels[0].vertices = used_vertices();
  std::vector<TriMesh> meshes;
  if (opt_.keep_level_meshes) meshes.push_back(snapshot());
  // Greedy cover, best first (see the header). The key is (blocks, flatness): blocks starts as a lower
  // bound computed from the star alone (a collapse blocks at least the free ring vertices it keeps);
  // flatness is a cheap stand-in for the plan's error bound, the star's bound plus v's distance to the mean
  // plane of its ring. A popped candidate gets its real plan and is executed if it still comes first, else
  // it goes back with its real key and the plan is kept (re-checked by still_valid when popped again).
  // Candidates blocked by a neighbour before they are popped never need a plan search.
  struct Candidate {
    int blocks;
    double cost;
    VertexId v;
    std::uint32_t stamp;
    bool exact;
  };
  const bool cover = opt_.prefer_cover;
  auto after = [cover](const Candidate& a, const Candidate& b) {
    if (cover && a.blocks != b.blocks) return a.blocks > b.blocks;
    if (a.cost != b.cost) return a.cost > b.cost;
    if (a.exact != b.exact) return b.exact;
    return a.v > b.v;
  };
  std::vector<std::uint32_t> stamp(pos_.size(), 0);
  constexpr std::uint64_t kNoSignature = std::numeric_limits<std::uint64_t>::max();
  std::vector<std::uint64_t> no_plan(pos_.size(), kNoSignature);
  std::unordered_map<VertexId, std::pair<std::uint32_t, Plan>> kept;
  std::vector<VertexId> touched;
  Star star;
  for (int lv = 1; lv <= opt_.max_levels; ++lv) {
    if (opt_.target_faces != 0 && num_alive_ <= opt_.target_faces) break;
    const auto level = static_cast<std::uint16_t>(lv);
    std::priority_queue<Candidate, std::vector<Candidate>, decltype(after)> queue(after);
    kept.clear();
    auto free_here = [&](VertexId w) { return vstate_[w] == kFree && blocked_[w] != level; };
    auto blocks = [&](const Plan& p) {
      int n = 0;
      const PStep& last = p.steps.back();
      std::array<VertexId, 6> seen{};
      std::size_t ns = 0;
      for (int i = 0; i < last.n_new; ++i)
        for (VertexId w : p.pool[last.created[i]].v)
          if (std::find(seen.begin(), seen.begin() + static_cast<std::ptrdiff_t>(ns), w) == seen.begin() + static_cast<std::ptrdiff_t>(ns)) {
            seen[ns++] = w;
            if (free_here(w)) ++n;
          }
      return n;
    };
    auto push_estimate = [&](VertexId v) {
      ++stamp[v];
      if (vstate_[v] != kFree) return;
      if (!collect_star(v, star, static_cast<std::size_t>(std::max(opt_.max_swap_degree, opt_.max_border_faces))))
        return;
      if (no_plan[v] != kNoSignature) {  // nothing changed since the search found no plan: skip it
        std::uint64_t sig = touch_[v];
        for (VertexId w : star.ring) sig += touch_[w];
        if (sig == no_plan[v]) return;
      }
      int unblocked = 0;
      double cost = 0.0;
      DVec normal(0.0), centre(0.0);
      for (VertexId w : star.ring) {
        unblocked += free_here(w);
        centre += pos_[w];
      }
      centre /= static_cast<double>(star.ring.size());
      for (FaceId f : star.faces) {
        if (frozen_[f] == level) return;
        cost = std::max(cost, h_[f]);
        const DVec& a = pos_[fv_[3 * f]];
        normal += glm::cross(pos_[fv_[3 * f + 1]] - a, pos_[fv_[3 * f + 2]] - a);
      }
      const double len = glm::length(normal);
      cost += len > 0.0 ? std::abs(glm::dot(pos_[v] - centre, normal)) / len : glm::length(pos_[v] - centre);
      if (star.border) {  // the border moves: v's distance to the new border edge (w0, wk)
        const DVec a = pos_[star.ring.front()], e = pos_[star.ring.back()] - a;
        const double l2 = glm::dot(e, e);
        const double t = l2 > 0.0 ? std::clamp(glm::dot(pos_[v] - a, e) / l2, 0.0, 1.0) : 0.0;
        cost += glm::length(pos_[v] - (a + e * t));
      }
      const int kept_vertices = star.border ? 3 : 4;
      const int lb = std::max(0, unblocked - std::max(0, static_cast<int>(star.ring.size()) - kept_vertices));
      queue.push({lb, cost, v, stamp[v], false});
    };
    for (VertexId v = 0; v < pos_.size(); ++v) push_estimate(v);
    Simplify4kLevel stats;
    std::size_t done = 0;
    while (!queue.empty()) {
      if (opt_.target_faces != 0 && num_alive_ <= opt_.target_faces) break;
      const Candidate c = queue.top();
      queue.pop();
      if (c.stamp != stamp[c.v]) continue;
      Plan p;
      if (c.exact) {
        auto it = kept.find(c.v);
        if (it != kept.end() && it->second.first == c.stamp && still_valid(it->second.second, level))
          p = std::move(it->second.second);
        if (it != kept.end()) kept.erase(it);
      }
      if (!p.valid()) {
        p = best_plan(c.v, level);
        if (!p.valid()) {
          if (!p.blocked) no_plan[c.v] = signature(c.v);
          continue;
        }
      }
      const Candidate real{blocks(p), c.cost, c.v, c.stamp, true};
      if (!queue.empty() && after(real, queue.top())) {  // no longer first: wait with the real key
        queue.push(real);
        kept[c.v] = {c.stamp, std::move(p)};
        continue;
      }
      touched.clear();
      for (const PFace& f : p.pool)
        if (f.id != kInvalid)
          for (VertexId w : f.v)
            if (w != c.v) touched.push_back(w);
      execute(p, c.v, level, stats);
      ++done;
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      for (VertexId w : touched) push_estimate(w);
    }
    if (done == 0) break;
    stats.faces = num_alive_;
    stats.vertices = used_vertices();
    for (std::size_t f = 0; f < alive_.size(); ++f)
      if (alive_[f]) stats.max_error = std::max(stats.max_error, h_[f]);
    levels.push_back(stats);
    if (opt_.keep_level_meshes) meshes.push_back(snapshot());
  }
  return build_mt(std::move(levels), std::move(meshes));
}

}  // namespace

Simplify4kResult simplify4k(const TriMesh& mesh, const Simplify4kOptions& options) {
  Simplifier s(mesh, options);
  return s.run();
}

MtFront simplify4k_level_front(const Simplify4kResult& result, std::size_t level) {
  if (level >= result.levels.size())
    throw InvalidInput("simplify4k_level_front: level " + std::to_string(level) + " of " +
                           std::to_string(result.levels.size()),
                       level);
  MtFront front(result.mt);
  // Nodes are numbered parents first and a node's parents come from the same or coarser levels, so one
  // pass in node order applies an order ideal.
  for (NodeId n = 1; n < result.mt.num_nodes(); ++n)
    if (result.node_level[n] > level) front.apply(n);
  return front;
}

TriMesh simplify4k_level_mesh(const Simplify4kResult& result, std::size_t level, std::vector<VertexId>* vertex_ids) {
  const MtFront front = simplify4k_level_front(result, level);
  return front.to_mesh(nullptr, vertex_ids);
}

std::size_t simplify4k_closest_level(const Simplify4kResult& result, std::size_t faces) {
  if (result.levels.empty()) throw InvalidInput("simplify4k_closest_level: the result has no level");
  std::size_t best = 0;
  auto gap = [&](std::size_t l) {
    const std::size_t f = result.levels[l].faces;
    return f > faces ? f - faces : faces - f;
  };
  for (std::size_t l = 1; l < result.levels.size(); ++l)
    if (gap(l) < gap(best)) best = l;
  return best;
}

}  // namespace varmesh
