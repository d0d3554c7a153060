// Adaptive (irregular) 4-k refinement of parametric, implicit and sampled surfaces as a Multi-Triangulation.
//
// Papers: L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000): 7.1 (internal edge split as the only
// modification), 8.1 (irregular refinement, Figure 20: the torus as a parametric and as an implicit surface,
// the Cyberware scan). L. Velho, L. H. de Figueiredo, J. Gomes, "A unified approach for hierarchical adaptive
// tessellation of surfaces" (ACM TOG 1999): faces are subdivided while samples of the surface deviate from
// them, for parametric and implicit descriptions alike. W. F. Mitchell (1991): newest-vertex bisection and
// its recursive conforming refinement; P. Binev, W. Dahmen, R. DeVore (2004): with a compatible marking the
// face across a refinement edge is either its twin or one level coarser, so forced splits stop. J. Edmonds
// (1965): maximum matching in general graphs (pairs of base faces). H. Freudenthal (1942) / H. W. Kuhn
// (1960): the cube cut into 6 tetrahedra around its main diagonal, consistent across cells. F. Labelle,
// J. R. Shewchuk, "Isosurface stuffing" (SIGGRAPH 2007), section 3: lattice vertices near the surface snapped
// onto it, so that marching tetrahedra makes no needle faces.
#include "fourk/adaptive.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include <glm/geometric.hpp>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

namespace {

// Domain lattice: 2^26 steps per side, so 52 bisection levels keep every midpoint on the lattice.
constexpr int kLatticeBits = 26;
constexpr std::int64_t kLatticeSize = std::int64_t(1) << kLatticeBits;
constexpr int kMaxLevel = 48;
// Error given to a sample whose distance to an implicit surface could not be measured: refine it.
constexpr double kUnmeasured = 1e30;
// Implicit surfaces: a face whose normal is further than this from the gradient of f at its centroid is split
// (a fold guard; see ImplicitRefiner::fold). 60 degrees: coarse faces of a well-polygonized surface stay
// below 45 (the torus's base faces that span a third of the tube reach 43), a back-facing fold is beyond 90.
constexpr double kMaxNormalDeviation = std::numbers::pi / 3.0;
// The fold guard splits a face only while fewer than kMaxFoldLevels of its ancestors in a row had their error
// within the tolerance (WorkFace::settled), and fewer than kMaxTurnedLevels if the face is turned over (normal
// more than 90 degrees from the gradient). Newest-vertex bisection halves a face's edges every two levels: the
// folds it removes (needles standing across a thin part) are gone within 7 levels on the genus-2 surface
// polygonized on 16 x 12 x 5 cells, while a face turned over on the surface (a pleat of the base) stays turned
// over in its children at every level.
constexpr int kMaxFoldLevels = 8;
constexpr int kMaxTurnedLevels = 4;
// Implicit surfaces: where the projection of an edge's midpoint onto the surface must land for the edge to be
// bisected there: within kMaxMidpointOffset of the edge's length from the midpoint along the edge, and at most
// kMaxHalfEdge of its length from either end (see ImplicitField::bisect_edge).
constexpr double kMaxMidpointOffset = 0.25;
constexpr double kMaxHalfEdge = 0.9;
// polygonize_freudenthal: a grid vertex with a root closer than this fraction of the edge's length moves onto
// the root (see there). Labelle and Shewchuk snap at up to about a quarter of an edge on their lattice.
constexpr double kSnapFraction = 0.2;

std::string num(double x) {
  std::ostringstream out;
  out << std::setprecision(9) << x;
  return out.str();
}

std::string point_text(const glm::dvec3& p) { return "(" + num(p.x) + ", " + num(p.y) + ", " + num(p.z) + ")"; }


bool finite(const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
bool finite(const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

glm::dvec3 unit(const glm::dvec3& v) {
  const double len = glm::length(v);
  return len > 0.0 ? v / len : glm::dvec3(0.0);
}

void check_options(const AdaptiveOptions& o, const std::string& who) {
  if (!std::isfinite(o.tolerance) || !(o.tolerance > 0.0f))
    throw InvalidInput(who + ": tolerance must be finite and > 0, got " + num(o.tolerance));
  if (o.sample_order < 2 || o.sample_order > 16)
    throw InvalidInput(who + ": sample_order must be in [2, 16], got " + std::to_string(o.sample_order));
  if (o.max_level < 1 || o.max_level > kMaxLevel)
    throw InvalidInput(who + ": max_level must be in [1, " + std::to_string(kMaxLevel) + "], got " +
                       std::to_string(o.max_level));
  if (o.max_faces < 16 || o.max_faces > (std::size_t(1) << 28))
    throw InvalidInput(who + ": max_faces must be in [16, 2^28], got " + std::to_string(o.max_faces));
}

// The barycentric points (i, j, l) / k with i + j + l = k, corners excluded.
std::vector<glm::dvec3> barycentric_samples(int k) {
  std::vector<glm::dvec3> out;
  for (int i = 0; i <= k; ++i)
    for (int j = 0; i + j <= k; ++j) {
      const int l = k - i - j;
      if (i == k || j == k || l == k) continue;
      out.push_back(glm::dvec3(i, j, l) / double(k));
    }
  return out;
}

// A face being refined. (apex, e0, e1) has the face's orientation; the marked (refinement) edge is e0 -> e1.
// settled: how many of its ancestors in a row, up to its parent, had their error within the tolerance (the levels
// that the fold guard and forced splits added below the last ancestor that needed splitting; at most 255).
struct WorkFace {
  VertexId apex, e0, e1;
  float error;
  std::uint8_t level;
  bool alive;
  std::uint8_t settled;
};

// Newest-vertex bisection driven by face errors, recorded as split nodes of an MtBuilder. Subclasses say
// which edges are the same edge (the key; periodic seams identify edges with different vertex ids), where a
// new vertex goes and what a face's error is.
class Refiner {
 public:
  Refiner(const AdaptiveOptions& options, std::string who) : options_(options), who_(std::move(who)) {
    samples_ = barycentric_samples(options.sample_order);
  }
  virtual ~Refiner() = default;
  Refiner(const Refiner&) = delete;
  Refiner& operator=(const Refiner&) = delete;

 protected:
  VertexId add_vertex(const glm::vec3& p) {
    positions_.push_back(p);
    return builder_.add_vertex(p);
  }
  // A base face with corners (c0, c1, c2) as given (the Mt keeps them) and marked edge k (corners k, k + 1).
  void add_base_face(VertexId c0, VertexId c1, VertexId c2, int k) {
    const std::array<VertexId, 3> c{c0, c1, c2};
    const FaceId id = builder_.add_face(c0, c1, c2);
    faces_.push_back({c[(k + 2) % 3], c[k], c[(k + 1) % 3], 0.0f, 0, true, 0});
    base_.push_back(id);
  }
  // Refines every face above the tolerance, then builds the Mt.
  AdaptiveHierarchy run(std::size_t num_unpaired);

  virtual std::uint64_t edge_key(VertexId a, VertexId b) const = 0;
  virtual VertexId midpoint(VertexId e0, VertexId e1) = 0;
  virtual double face_error(FaceId f, VertexId a, VertexId b, VertexId c) = 0;
  // A face that must be split whatever its error (implicit surfaces: a folded face, see ImplicitRefiner::fold);
  // kTurnedOver: folded so far that it faces away from the surface.
  enum class Fold { kNone, kFolded, kTurnedOver };
  virtual Fold fold(VertexId, VertexId, VertexId) { return Fold::kNone; }
  virtual std::vector<glm::vec2> domain() const { return {}; }

  const AdaptiveOptions& options_;
  std::string who_;
  std::vector<glm::vec3> positions_;
  std::vector<glm::dvec3> samples_;

 private:
  FaceId add_child(VertexId apex, VertexId e0, VertexId e1, std::uint8_t level, std::uint8_t settled);
  void measure(FaceId f);
  void link(FaceId f);
  void unlink(FaceId f);
  FaceId across(FaceId f) const;
  void refine(FaceId f);
  void split(FaceId t, FaceId u);

  MtBuilder builder_;
  std::vector<WorkFace> faces_;  // index = builder face id
  std::vector<FaceId> base_;
  std::unordered_map<std::uint64_t, std::array<FaceId, 2>> edges_;
  std::vector<FaceId> work_, stack_;
  int max_level_reached_ = 0;
  std::size_t num_folded_ = 0;
};

FaceId Refiner::add_child(VertexId apex, VertexId e0, VertexId e1, std::uint8_t level, std::uint8_t settled) {
  const FaceId id = builder_.add_face(apex, e0, e1);
  faces_.push_back({apex, e0, e1, 0.0f, level, true, settled});
  measure(id);
  link(id);
  max_level_reached_ = std::max<int>(max_level_reached_, level);
  return id;
}

void Refiner::measure(FaceId f) {
  const WorkFace& w = faces_[f];
  const double e = face_error(f, w.apex, w.e0, w.e1);
  faces_[f].error = static_cast<float>(std::min(e, double(std::numeric_limits<float>::max())));
  if (faces_[f].error > options_.tolerance) {
    work_.push_back(f);
  } else if (w.level < options_.max_level && w.settled < kMaxFoldLevels) {
    // Below max_level and within kMaxFoldLevels (kMaxTurnedLevels for a face turned over) of the last ancestor
    // above the tolerance only: the fold guard refines, it never fails a build nor refines without end (run()
    // counts the folds it leaves).
    const Fold fold = this->fold(w.apex, w.e0, w.e1);
    if (fold == Fold::kFolded || (fold == Fold::kTurnedOver && w.settled < kMaxTurnedLevels)) {
      work_.push_back(f);
      ++num_folded_;
    }
  }
}

void Refiner::link(FaceId f) {
  const WorkFace& w = faces_[f];
  for (const auto& [a, b] : {std::pair{w.apex, w.e0}, std::pair{w.e0, w.e1}, std::pair{w.e1, w.apex}}) {
    auto [it, inserted] = edges_.try_emplace(edge_key(a, b), std::array<FaceId, 2>{f, kInvalid});
    if (inserted) continue;
    if (it->second[1] != kInvalid)
      throw std::logic_error(who_ + ": edge shared by more than two faces at face " + std::to_string(f));
    it->second[1] = f;
  }
}

void Refiner::unlink(FaceId f) {
  const WorkFace& w = faces_[f];
  for (const auto& [a, b] : {std::pair{w.apex, w.e0}, std::pair{w.e0, w.e1}, std::pair{w.e1, w.apex}}) {
    const auto it = edges_.find(edge_key(a, b));
    if (it->second[0] == f) it->second[0] = it->second[1];
    it->second[1] = kInvalid;
    if (it->second[0] == kInvalid) edges_.erase(it);
  }
}

FaceId Refiner::across(FaceId f) const {
  const auto& slot = edges_.at(edge_key(faces_[f].e0, faces_[f].e1));
  return slot[0] == f ? slot[1] : slot[0];
}

// Mitchell's recursive refinement with an explicit stack: a face whose twin across its marked edge marks
// another edge waits until that neighbour is split; the neighbour's child on the shared edge then marks it.
void Refiner::refine(FaceId f) {
  // With a compatible marking each step goes one level coarser (Binev-Dahmen-DeVore); an unpaired base face
  // adds one step. Anything longer means the marking is broken: stop rather than loop.
  const std::size_t limit = 2 * static_cast<std::size_t>(options_.max_level) + 8;
  stack_.assign(1, f);
  while (!stack_.empty()) {
    const FaceId t = stack_.back();
    if (!faces_[t].alive) {
      stack_.pop_back();
      continue;
    }
    const FaceId u = across(t);
    if (u == kInvalid || edge_key(faces_[u].e0, faces_[u].e1) == edge_key(faces_[t].e0, faces_[t].e1)) {
      split(t, u);
      stack_.pop_back();
      continue;
    }
    if (stack_.size() > limit)
      throw std::logic_error(who_ + ": forced splits do not terminate at face " + std::to_string(f) +
                             " (incompatible marking)");
    stack_.push_back(u);
  }
}

void Refiner::split(FaceId t, FaceId u) {
  for (const FaceId g : {t, u}) {
    if (g == kInvalid) continue;
    if (faces_[g].level >= options_.max_level)
      throw InvalidInput(who_ + ": tolerance " + num(options_.tolerance) + " not met at max_level " +
                             std::to_string(options_.max_level) + " (face error " + num(faces_[g].error) +
                             "; is the surface continuous?)",
                         g);
  }
  if (faces_.size() + 4 > options_.max_faces)
    throw InvalidInput(who_ + ": tolerance " + num(options_.tolerance) + " needs more than max_faces = " +
                           std::to_string(options_.max_faces) + " faces",
                       t);
  const WorkFace ft = faces_[t];
  const VertexId mt = midpoint(ft.e0, ft.e1);
  std::array<FaceId, 2> removed{t, u};
  std::array<FaceId, 4> created{};
  std::size_t nc = 0;
  float error = ft.error;
  unlink(t);
  faces_[t].alive = false;
  auto bisect = [&](const WorkFace& w, VertexId m) {
    // Children (m, apex, e0) and (m, e1, apex) keep the orientation and mark the edges opposite m.
    const auto level = static_cast<std::uint8_t>(w.level + 1);
    const auto settled = static_cast<std::uint8_t>(w.error > options_.tolerance ? 0 : std::min(w.settled + 1, 255));
    created[nc++] = add_child(m, w.apex, w.e0, level, settled);
    created[nc++] = add_child(m, w.e1, w.apex, level, settled);
  };
  if (u != kInvalid) {
    const WorkFace fu = faces_[u];
    // Same vertex ids reversed: an ordinary shared edge. Otherwise the two copies of a periodic seam edge,
    // one new vertex on each side.
    const VertexId mu = (fu.e0 == ft.e1 && fu.e1 == ft.e0) ? mt : midpoint(fu.e0, fu.e1);
    unlink(u);
    faces_[u].alive = false;
    error = std::max(error, fu.error);
    bisect(ft, mt);
    bisect(fu, mu);
  } else {
    bisect(ft, mt);
  }
  builder_.add_node(NodeKind::kSplit, std::span<const FaceId>(removed.data(), u == kInvalid ? 1 : 2),
                    std::span<const FaceId>(created.data(), nc), error);
}

AdaptiveHierarchy Refiner::run(std::size_t num_unpaired) {
  builder_.set_base(base_);
  for (FaceId f = 0; f < faces_.size(); ++f) {
    measure(f);
    link(f);
  }
  while (!work_.empty()) {
    const FaceId f = work_.back();
    work_.pop_back();
    if (faces_[f].alive) refine(f);
  }
  AdaptiveHierarchy out;
  out.num_base_faces = base_.size();
  out.num_unpaired_base_faces = num_unpaired;
  out.max_level = max_level_reached_;
  out.num_folded_faces = num_folded_;
  // A finest face that is still folded was left by one of measure()'s limits (max_level, kMaxFoldLevels or
  // kMaxTurnedLevels): the others need no second look.
  for (const WorkFace& w : faces_)
    if (w.alive && (w.level >= options_.max_level || w.settled >= kMaxTurnedLevels) &&
        fold(w.apex, w.e0, w.e1) != Fold::kNone)
      ++out.num_unresolved_folds;
  out.domain = domain();
  std::vector<FaceId> face_new_to_old;
  out.mt = std::move(builder_).build(options_.build, nullptr, &face_new_to_old);
  out.face_error.resize(face_new_to_old.size());
  out.face_level.resize(face_new_to_old.size());
  for (std::size_t f = 0; f < face_new_to_old.size(); ++f) {
    const WorkFace& w = faces_[face_new_to_old[f]];
    out.face_error[f] = w.error;
    out.face_level[f] = w.level;
    if (w.alive) ++out.num_finest_faces;
  }
  return out;
}

// Parametric and sampled surfaces: vertices on the domain lattice.
struct DataGrid {
  std::size_t nu = 0, nv = 0;  // intervals per side (0: no data samples)
  std::function<glm::vec3(std::size_t, std::size_t)> node;  // sample position; never called with i == nu on a periodic side
};

class LatticeRefiner final : public Refiner {
 public:
  using Eval = std::function<glm::vec3(const glm::dvec2&)>;
  LatticeRefiner(const AdaptiveOptions& options, std::string who, Eval eval, glm::dvec2 lo, glm::dvec2 hi,
                 bool periodic_u, bool periodic_v, DataGrid grid)
      : Refiner(options, std::move(who)), eval_(std::move(eval)), lo_(lo), hi_(hi),
        periodic_{periodic_u, periodic_v}, grid_(std::move(grid)) {}

  AdaptiveHierarchy build() {
    // Figure 20(c): the domain rectangle cut along its diagonal; both faces mark the diagonal.
    const std::int64_t n = kLatticeSize;
    const VertexId v0 = lattice_vertex({0, 0}), v1 = lattice_vertex({n, 0}), v2 = lattice_vertex({n, n}),
                   v3 = lattice_vertex({0, n});
    add_base_face(v0, v1, v2, 2);  // marks (v2, v0)
    add_base_face(v0, v2, v3, 0);  // marks (v0, v2)
    return run(0);
  }

 protected:
  std::uint64_t edge_key(VertexId a, VertexId b) const override {
    // Twice the edge midpoint, wrapped on periodic sides: the two copies of a seam edge get one key, and
    // distinct edges of a conforming mesh never share a midpoint.
    std::array<std::int64_t, 2> m{lattice_[a][0] + lattice_[b][0], lattice_[a][1] + lattice_[b][1]};
    for (int d = 0; d < 2; ++d)
      if (periodic_[d] && m[d] == 2 * kLatticeSize) m[d] = 0;
    return (std::uint64_t(m[0]) << 32) | std::uint64_t(m[1]);
  }

  VertexId midpoint(VertexId e0, VertexId e1) override {
    const std::int64_t x = lattice_[e0][0] + lattice_[e1][0], y = lattice_[e0][1] + lattice_[e1][1];
    if ((x & 1) != 0 || (y & 1) != 0) throw std::logic_error(who_ + ": lattice exhausted");
    return lattice_vertex({x / 2, y / 2});
  }

  double face_error(FaceId f, VertexId a, VertexId b, VertexId c) override {
    const std::array<VertexId, 3> v{a, b, c};
    std::array<glm::dvec2, 3> l;
    std::array<glm::dvec3, 3> p;
    for (int k = 0; k < 3; ++k) {
      l[k] = glm::dvec2(double(lattice_[v[k]][0]), double(lattice_[v[k]][1]));
      p[k] = glm::dvec3(positions_[v[k]]);
    }
    double err = 0.0;
    for (const glm::dvec3& s : samples_) {
      const glm::dvec2 x = s[0] * l[0] + s[1] * l[1] + s[2] * l[2];
      const glm::dvec3 q = glm::dvec3(point_at(x, f));
      err = std::max(err, glm::length(q - (s[0] * p[0] + s[1] * p[1] + s[2] * p[2])));
    }
    if (grid_.nu > 0) err = std::max(err, data_error(l, p));
    return err;
  }

  std::vector<glm::vec2> domain() const override {
    std::vector<glm::vec2> out(lattice_.size());
    for (std::size_t i = 0; i < lattice_.size(); ++i) out[i] = glm::vec2(to_domain(glm::dvec2(lattice_[i][0], lattice_[i][1])));
    return out;
  }

 private:
  glm::dvec2 to_domain(const glm::dvec2& x) const { return lo_ + (hi_ - lo_) * (x / double(kLatticeSize)); }

  // The surface at lattice point x (doubles), evaluated on the wrapped copy so seam copies agree bit for bit.
  glm::vec3 point_at(glm::dvec2 x, std::uint64_t element) {
    for (int d = 0; d < 2; ++d)
      if (periodic_[d] && x[d] >= double(kLatticeSize)) x[d] -= double(kLatticeSize);
    const glm::dvec2 uv = to_domain(x);
    const glm::vec3 p = eval_(uv);
    if (!finite(p))
      throw InvalidInput(who_ + ": the surface is not finite at (u, v) = (" + num(uv.x) + ", " + num(uv.y) + ")",
                         element);
    return p;
  }

  VertexId lattice_vertex(const std::array<std::int64_t, 2>& x) {
    const glm::vec3 p = point_at(glm::dvec2(double(x[0]), double(x[1])), positions_.size());
    lattice_.push_back(x);
    return add_vertex(p);
  }

  // Deviation at the data samples inside the closed domain triangle l (lattice units).
  double data_error(const std::array<glm::dvec2, 3>& l, const std::array<glm::dvec3, 3>& p) const {
    const double n = double(kLatticeSize);
    const double du = n / double(grid_.nu), dv = n / double(grid_.nv);
    const glm::dvec2 lo = glm::min(l[0], glm::min(l[1], l[2])), hi = glm::max(l[0], glm::max(l[1], l[2]));
    const auto first = [](double a, double step) { return static_cast<std::int64_t>(std::ceil(a / step - 1e-9)); };
    const auto last = [](double a, double step) { return static_cast<std::int64_t>(std::floor(a / step + 1e-9)); };
    const std::int64_t i0 = std::max<std::int64_t>(0, first(lo.x, du));
    const std::int64_t i1 = std::min<std::int64_t>(static_cast<std::int64_t>(grid_.nu), last(hi.x, du));
    const std::int64_t j0 = std::max<std::int64_t>(0, first(lo.y, dv));
    const std::int64_t j1 = std::min<std::int64_t>(static_cast<std::int64_t>(grid_.nv), last(hi.y, dv));
    const glm::dvec2 e1 = l[1] - l[0], e2 = l[2] - l[0];
    const double det = e1.x * e2.y - e1.y * e2.x;
    double err = 0.0;
    for (std::int64_t j = j0; j <= j1; ++j)
      for (std::int64_t i = i0; i <= i1; ++i) {
        const glm::dvec2 d = glm::dvec2(double(i) * du, double(j) * dv) - l[0];
        const double b1 = (d.x * e2.y - d.y * e2.x) / det, b2 = (e1.x * d.y - e1.y * d.x) / det;
        const double b0 = 1.0 - b1 - b2;
        if (b0 < -1e-9 || b1 < -1e-9 || b2 < -1e-9) continue;
        std::size_t iu = static_cast<std::size_t>(i), jv = static_cast<std::size_t>(j);
        if (periodic_[0] && iu == grid_.nu) iu = 0;
        if (periodic_[1] && jv == grid_.nv) jv = 0;
        const glm::dvec3 q(grid_.node(iu, jv));
        err = std::max(err, glm::length(q - (b0 * p[0] + b1 * p[1] + b2 * p[2])));
      }
    return err;
  }

  Eval eval_;
  glm::dvec2 lo_, hi_;
  std::array<bool, 2> periodic_;
  DataGrid grid_;
  std::vector<std::array<std::int64_t, 2>> lattice_;  // per vertex
};

void check_domain(const glm::dvec2& lo, const glm::dvec2& hi, const std::string& who) {
  if (!std::isfinite(lo.x) || !std::isfinite(lo.y) || !std::isfinite(hi.x) || !std::isfinite(hi.y))
    throw InvalidInput(who + ": the domain bounds are not finite");
  if (!(lo.x < hi.x) || !(lo.y < hi.y))
    throw InvalidInput(who + ": domain_lo (" + num(lo.x) + ", " + num(lo.y) + ") must be below domain_hi (" +
                       num(hi.x) + ", " + num(hi.y) + ") in both coordinates");
}

// Implicit surfaces: f, its gradient, projection onto f = 0.
class ImplicitField {
 public:
  ImplicitField(const ImplicitSurface& s, double scale, std::string who)
      : s_(s), scale_(scale), who_(std::move(who)) {}

  double value(const glm::dvec3& p) const {
    const double v = s_.value(p);
    if (!std::isfinite(v)) throw InvalidInput(who_ + ": the implicit function is not finite at " + point_text(p));
    return v;
  }
  glm::dvec3 gradient(const glm::dvec3& p) const {
    glm::dvec3 g;
    if (s_.gradient) {
      g = s_.gradient(p);
    } else {
      const double h = 1e-6 * scale_;
      for (int d = 0; d < 3; ++d) {
        glm::dvec3 a = p, b = p;
        a[d] += h;
        b[d] -= h;
        g[d] = (value(a) - value(b)) / (2.0 * h);
      }
    }
    if (!finite(g)) throw InvalidInput(who_ + ": the gradient is not finite at " + point_text(p));
    return g;
  }

  // Newton steps p <- p - f grad / |grad|^2 (the first-order closest point), each at most max_step long.
  // Returns false when the gradient vanishes or 40 steps do not converge.
  bool newton(glm::dvec3& p, double max_step) const {
    const double eps = 1e-12 * scale_;
    for (int it = 0; it < 40; ++it) {
      const double f = value(p);
      const glm::dvec3 g = gradient(p);
      const double gg = glm::dot(g, g);
      if (!(gg > 1e-300)) return false;
      glm::dvec3 step = g * (f / gg);
      const double len = glm::length(step);
      if (len > max_step) step *= max_step / len;
      p -= step;
      if (len <= eps) return true;
    }
    const glm::dvec3 g = gradient(p);
    return std::abs(value(p)) <= 1e-9 * scale_ * glm::length(g);
  }

  // A root of f on the segment p + t d, t in [-reach, reach] (d unit): the sign change nearest to t = 0 among
  // 2 x 16 intervals, refined by bisection. Returns t, or NaN when f does not change sign.
  double line_root(const glm::dvec3& p, const glm::dvec3& d, double reach) const {
    constexpr int kSteps = 16;
    if (value(p) == 0.0) return 0.0;
    for (int k = 1; k <= kSteps; ++k) {
      for (const double sign : {1.0, -1.0}) {
        double a = sign * reach * double(k - 1) / kSteps, b = sign * reach * double(k) / kSteps;
        const bool neg_a = value(p + a * d) < 0.0;
        if (neg_a == (value(p + b * d) < 0.0)) continue;
        for (int i = 0; i < 60; ++i) {
          const double m = 0.5 * (a + b);
          ((value(p + m * d) < 0.0) == neg_a ? a : b) = m;
        }
        return 0.5 * (a + b);
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  }

  // Distance from p to the surface point Newton reaches, or to a root along the unit direction d.
  double distance(const glm::dvec3& p, const glm::dvec3& d, double reach) const {
    glm::dvec3 q = p;
    if (newton(q, reach)) return glm::length(q - p);
    if (glm::dot(d, d) == 0.0) return kUnmeasured;
    const double t = line_root(p, d, reach);
    return std::isnan(t) ? kUnmeasured : std::abs(t);
  }

  // The root of f on the segment p + t d, t in (0, reach] (d unit), nearest to p: the first of 16 intervals where
  // f changes sign, refined by bisection. Returns t, or NaN when f keeps its sign.
  double ray_root(const glm::dvec3& p, const glm::dvec3& d, double reach) const {
    constexpr int kSteps = 16;
    const bool neg = value(p) < 0.0;
    double a = 0.0;
    for (int k = 1; k <= kSteps; ++k) {
      double b = reach * double(k) / kSteps;
      if ((value(p + b * d) < 0.0) == neg) {
        a = b;
        continue;
      }
      for (int i = 0; i < 60; ++i) {
        const double m = 0.5 * (a + b);
        ((value(p + m * d) < 0.0) == neg ? a : b) = m;
      }
      return 0.5 * (a + b);
    }
    return std::numeric_limits<double>::quiet_NaN();
  }

  // The projection of p onto the surface: Newton steps, or when they fail a root along d (any length);
  // nullopt when neither works.
  std::optional<glm::dvec3> try_project(const glm::dvec3& p, const glm::dvec3& d, double reach) const {
    glm::dvec3 q = p;
    if (newton(q, reach)) return q;
    if (glm::dot(d, d) > 0.0) {
      const glm::dvec3 u = glm::normalize(d);
      if (const double t = line_root(p, u, reach); !std::isnan(t)) return p + t * u;
    }
    return std::nullopt;
  }

  // As try_project; throws naming `what` when it fails.
  glm::dvec3 project(const glm::dvec3& p, const glm::dvec3& d, double reach, const std::string& what,
                     std::uint64_t element) const {
    if (const std::optional<glm::dvec3> q = try_project(p, d, reach)) return *q;
    throw InvalidInput(who_ + ": cannot place " + what + " " + point_text(p) +
                           " on the surface (the gradient vanishes and f does not change sign nearby)",
                       element);
  }

  // The point that bisects the edge (a, b) of the surface: its midpoint projected onto the surface (project(),
  // with the ends' gradients averaged as the fallback direction). Where the surface is thinner than the edge is
  // long (a chord across a thin part, its ends' normals far apart), that projection can land next to one end or
  // past it, and bisecting there would not shorten the edge (see between_ends). Then the surface is searched
  // from the midpoint across the edge, along the ends' unit normals averaged and made perpendicular to the edge
  // (first towards the side where f changes sign, then the other), within the reach that keeps both halves at
  // most kMaxHalfEdge of the edge: for a tube the root on the side the normals face is the midpoint of the arc
  // between the ends. Falls back to the projection; nullopt when nothing is found.
  std::optional<glm::dvec3> bisect_edge(const glm::dvec3& a, const glm::dvec3& b) const {
    const double len = glm::length(b - a);
    const glm::dvec3 m = 0.5 * (a + b);
    const glm::dvec3 ga = gradient(a), gb = gradient(b);
    const std::optional<glm::dvec3> projected = try_project(m, ga + gb, std::max(len, 1e-30));
    if (!(len > 0.0) || (projected && between_ends(*projected, a, b))) return projected;
    const glm::dvec3 along = (b - a) / len;
    glm::dvec3 d = unit(ga) + unit(gb);
    d -= glm::dot(d, along) * along;
    if (glm::length(d) > 1e-6) {
      d = glm::normalize(d);
      const double reach = len * std::sqrt(kMaxHalfEdge * kMaxHalfEdge - 0.25);
      const double first = value(m) < 0.0 ? 1.0 : -1.0;  // inside: the surface lies the way the normals point
      for (const double sign : {first, -first})
        if (const double t = ray_root(m, sign * d, reach); !std::isnan(t)) return m + sign * t * d;
    }
    return projected;
  }

  // Whether q, the surface point found for edge (a, b), lies between the ends: at most kMaxMidpointOffset of the
  // edge's length from the midpoint along the edge and at most kMaxHalfEdge of it from either end, so that the
  // halves are shorter than the edge. A projection that lands elsewhere went around a thin part of the surface.
  static bool between_ends(const glm::dvec3& q, const glm::dvec3& a, const glm::dvec3& b) {
    const double len = glm::length(b - a);
    if (!(len > 0.0)) return true;  // nothing to shorten
    const double offset = std::abs(glm::dot(q - 0.5 * (a + b), b - a)) / len;
    return offset <= kMaxMidpointOffset * len && glm::length(q - a) <= kMaxHalfEdge * len &&
           glm::length(q - b) <= kMaxHalfEdge * len;
  }

 private:
  const ImplicitSurface& s_;
  double scale_;
  std::string who_;
};

glm::dvec3 face_normal(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double len = glm::length(n);
  return len > 0.0 ? n / len : glm::dvec3(0.0);
}

class ImplicitRefiner final : public Refiner {
 public:
  // side: +1 when the base's face normals point towards f > 0, -1 when towards f < 0.
  ImplicitRefiner(const AdaptiveOptions& options, std::string who, const ImplicitField& field, double side)
      : Refiner(options, std::move(who)), field_(field), side_(side) {}

  AdaptiveHierarchy build(const TriMesh& base, std::span<const std::uint8_t> marking, std::size_t num_unpaired) {
    for (const glm::vec3& p : base.positions) add_vertex(p);
    for (std::size_t f = 0; f < base.num_faces(); ++f)
      add_base_face(base.corner(f, 0), base.corner(f, 1), base.corner(f, 2), marking[f]);
    return run(num_unpaired);
  }

 protected:
  std::uint64_t edge_key(VertexId a, VertexId b) const override { return undirected_edge_key(a, b); }

  VertexId midpoint(VertexId e0, VertexId e1) override {
    const glm::dvec3 a(positions_[e0]), b(positions_[e1]);
    if (const std::optional<glm::dvec3> q = field_.bisect_edge(a, b)) return add_vertex(glm::vec3(*q));
    throw InvalidInput(who_ + ": cannot place the midpoint of edge (" + std::to_string(e0) + ", " +
                           std::to_string(e1) + ") " + point_text(0.5 * (a + b)) +
                           " on the surface (the gradient vanishes and f does not change sign nearby)",
                       positions_.size());
  }

  double face_error(FaceId, VertexId a, VertexId b, VertexId c) override {
    const glm::dvec3 pa(positions_[a]), pb(positions_[b]), pc(positions_[c]);
    const double reach = std::max({glm::length(pb - pa), glm::length(pc - pb), glm::length(pa - pc), 1e-30});
    const glm::dvec3 n = face_normal(pa, pb, pc);
    double err = 0.0;
    for (const glm::dvec3& s : samples_) err = std::max(err, field_.distance(s[0] * pa + s[1] * pb + s[2] * pc, n, reach));
    return err;
  }

  // The distance test cannot see a fold: a face standing across the surface (in the plane of a meridian of the
  // torus, say) keeps all its points close to the surface. So a face whose normal is more than
  // kMaxNormalDeviation from the gradient at its centroid is split too, while its longest edge exceeds the
  // tolerance: a fold from a projected midpoint (the sagitta of a long chord exceeding the face's width) goes
  // away as the faces shrink, a face turned over in the surface's tangent plane (a base that does not resolve
  // the surface) never does; Refiner::measure stops the guard after kMaxFoldLevels (kMaxTurnedLevels for
  // kTurnedOver, a normal more than 90 degrees off). side_ is +1 when the base's normals point towards f > 0,
  // -1 when towards f < 0.
  Fold fold(VertexId a, VertexId b, VertexId c) override {
    const glm::dvec3 pa(positions_[a]), pb(positions_[b]), pc(positions_[c]);
    const double longest = std::max({glm::length(pb - pa), glm::length(pc - pb), glm::length(pa - pc)});
    if (!(longest > double(options_.tolerance))) return Fold::kNone;
    const glm::dvec3 g = field_.gradient((pa + pb + pc) / 3.0);
    const double len = glm::length(g);
    if (!(len > 0.0)) return Fold::kNone;  // no normal to compare with (a critical point of f)
    const double cosine = side_ * glm::dot(face_normal(pa, pb, pc), g) / len;
    return cosine < 0.0 ? Fold::kTurnedOver : cosine < std::cos(kMaxNormalDeviation) ? Fold::kFolded : Fold::kNone;
  }

 private:
  const ImplicitField& field_;
  double side_;
};

// Faces across each edge k (corners k, k + 1) of a validated base mesh; kInvalid on the border. Throws,
// naming TopologyProblem::element(), when the mesh breaks a FourKMesh's manifold rules (a repeated corner, an
// edge used twice in one direction, two faces on one vertex triple: a closed "pillow" shares all three edges,
// and its first split would make an edge of three faces). `what` names the mesh ("base mesh", "polygonization").
std::vector<std::array<FaceId, 3>> face_neighbours(const TriMesh& mesh, const std::string& who, const char* what) {
  std::vector<Index> opposite;
  if (const TopologyProblem problem = find_topology_problem(mesh, kFourKMeshRules, &opposite))
    throw InvalidInput(who + ": " + what + ": " + describe_topology_problem(problem), problem.element());
  std::vector<std::array<FaceId, 3>> nbr(mesh.num_faces());
  for (std::size_t f = 0; f < nbr.size(); ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const Index o = opposite[3 * f + k];
      nbr[f][k] = o == kInvalid ? kInvalid : o / 3;
    }
  return nbr;
}

// Vertices where the mesh is not a manifold: an edge used twice in one direction (or by more than two faces),
// two faces on one vertex triple, or faces around a vertex that form more than one fan (faces joined across
// the edges at the vertex; the surface is pinched there). O(faces).
std::vector<Index> non_manifold_vertices(const TriMesh& mesh) {
  const std::size_t nc = mesh.indices.size();
  const auto next = [](std::size_t c) { return c - c % 3 + (c % 3 + 1) % 3; };
  std::vector<Index> out;
  std::unordered_map<std::uint64_t, std::size_t> corner_of_edge;  // directed edge (a, b) -> the corner at a
  std::vector<std::array<Index, 3>> triples(mesh.num_faces());
  for (std::size_t c = 0; c < nc; ++c) {
    const Index a = mesh.indices[c], b = mesh.indices[next(c)];
    if (!corner_of_edge.emplace(directed_edge_key(a, b), c).second) out.insert(out.end(), {a, b});
    triples[c / 3][c % 3] = a;
  }
  for (auto& t : triples) std::sort(t.begin(), t.end());
  std::sort(triples.begin(), triples.end());
  for (std::size_t f = 1; f < triples.size(); ++f)
    if (triples[f] == triples[f - 1]) out.insert(out.end(), triples[f].begin(), triples[f].end());
  std::vector<std::size_t> parent(nc);
  for (std::size_t c = 0; c < nc; ++c) parent[c] = c;
  auto find = [&](std::size_t c) {
    while (parent[c] != c) c = parent[c] = parent[parent[c]];
    return c;
  };
  for (std::size_t c = 0; c < nc; ++c) {
    // Corner c at a with edge (a, b); the twin face has (b, a): its corner at b is `twin`, the one at a next(twin).
    const Index a = mesh.indices[c], b = mesh.indices[next(c)];
    const auto it = corner_of_edge.find(directed_edge_key(b, a));
    if (it == corner_of_edge.end()) continue;
    parent[find(c)] = find(next(it->second));
  }
  std::vector<Index> fans(mesh.positions.size(), 0);
  for (std::size_t c = 0; c < nc; ++c)
    if (find(c) == c) ++fans[mesh.indices[c]];
  for (std::size_t v = 0; v < fans.size(); ++v)
    if (fans[v] > 1) out.push_back(static_cast<Index>(v));
  return out;
}

// Euler characteristic and number of connected components of the faces. O(faces).
std::array<long, 2> topology(const TriMesh& mesh) {
  std::vector<Index> parent(mesh.positions.size());
  for (std::size_t v = 0; v < parent.size(); ++v) parent[v] = static_cast<Index>(v);
  auto find = [&](Index v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  std::vector<std::uint8_t> used(mesh.positions.size(), 0);
  std::unordered_map<std::uint64_t, std::uint8_t> edges;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.corner(f, k), b = mesh.corner(f, (k + 1) % 3);
      used[a] = 1;
      edges.emplace(undirected_edge_key(a, b), 0);
      parent[find(a)] = find(b);
    }
  long vertices = 0, components = 0;
  for (std::size_t v = 0; v < used.size(); ++v) {
    vertices += used[v];
    components += used[v] && find(static_cast<Index>(v)) == v;
  }
  return {vertices - static_cast<long>(edges.size()) + static_cast<long>(mesh.num_faces()), components};
}

// Edmonds' blossom algorithm (augmenting paths with odd cycles shrunk) on the dual graph, started from a
// matching. O(F) per search plus O(F) per blossom.
class BlossomMatcher {
 public:
  BlossomMatcher(const std::vector<std::array<FaceId, 3>>& adj, std::vector<FaceId>& match)
      : adj_(adj), match_(match), parent_(adj.size()), base_(adj.size()), used_(adj.size()), blossom_(adj.size()),
        seen_(adj.size()) {}

  // Augments along a path from the free vertex root if there is one. `work` counts elementary steps.
  bool augment(FaceId root, std::size_t& work) {
    FaceId v = find_path(root, work);
    if (v == kInvalid) return false;
    while (v != kInvalid) {
      const FaceId pv = parent_[v], ppv = match_[pv];
      match_[v] = pv;
      match_[pv] = v;
      v = ppv;
    }
    return true;
  }

 private:
  FaceId lca(FaceId a, FaceId b) {
    std::fill(seen_.begin(), seen_.end(), 0);
    while (true) {
      a = base_[a];
      seen_[a] = 1;
      if (match_[a] == kInvalid) break;
      a = parent_[match_[a]];
    }
    while (true) {
      b = base_[b];
      if (seen_[b]) return b;
      b = parent_[match_[b]];
    }
  }

  void mark_path(FaceId v, FaceId b, FaceId child) {
    while (base_[v] != b) {
      blossom_[base_[v]] = 1;
      blossom_[base_[match_[v]]] = 1;
      parent_[v] = child;
      child = match_[v];
      v = parent_[match_[v]];
    }
  }

  FaceId find_path(FaceId root, std::size_t& work) {
    const std::size_t n = adj_.size();
    std::fill(used_.begin(), used_.end(), 0);
    std::fill(parent_.begin(), parent_.end(), kInvalid);
    for (std::size_t i = 0; i < n; ++i) base_[i] = static_cast<FaceId>(i);
    work += n;
    used_[root] = 1;
    queue_.assign(1, root);
    for (std::size_t head = 0; head < queue_.size(); ++head) {
      const FaceId v = queue_[head];
      for (const FaceId to : adj_[v]) {
        if (to == kInvalid || base_[v] == base_[to] || match_[v] == to) continue;
        if (to == root || (match_[to] != kInvalid && parent_[match_[to]] != kInvalid)) {
          const FaceId cur = lca(v, to);
          std::fill(blossom_.begin(), blossom_.end(), 0);
          mark_path(v, cur, to);
          mark_path(to, cur, v);
          for (std::size_t i = 0; i < n; ++i)
            if (blossom_[base_[i]]) {
              base_[i] = cur;
              if (!used_[i]) {
                used_[i] = 1;
                queue_.push_back(static_cast<FaceId>(i));
              }
            }
          work += 3 * n;
        } else if (parent_[to] == kInvalid) {
          parent_[to] = v;
          if (match_[to] == kInvalid) return to;
          used_[match_[to]] = 1;
          queue_.push_back(match_[to]);
        }
      }
    }
    return kInvalid;
  }

  const std::vector<std::array<FaceId, 3>>& adj_;
  std::vector<FaceId>& match_;
  std::vector<FaceId> parent_, base_, queue_;
  std::vector<std::uint8_t> used_, blossom_, seen_;
};

double edge_length2(const TriMesh& mesh, VertexId a, VertexId b) {
  if (b < a) std::swap(a, b);  // same arithmetic on both sides of a shared edge
  const glm::dvec3 d = glm::dvec3(mesh.positions[b]) - glm::dvec3(mesh.positions[a]);
  return glm::dot(d, d);
}

// Marks the base faces for bisection (see adaptive.hpp): pairs from a maximum matching of the dual graph
// mark their shared edge. Returns the marking; `num_unpaired` receives the faces left out.
std::vector<std::uint8_t> pair_and_mark(const TriMesh& mesh, const std::vector<std::array<FaceId, 3>>& nbr,
                                        std::size_t& num_unpaired) {
  const std::size_t nf = mesh.num_faces();
  std::vector<FaceId> match(nf, kInvalid);
  // Greedy on the longest shared edges first: pairs across long edges give better shaped children.
  std::vector<std::tuple<double, FaceId, FaceId>> dual;
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      if (const FaceId g = nbr[f][k]; g != kInvalid && f < g)
        dual.emplace_back(-edge_length2(mesh, mesh.corner(f, k), mesh.corner(f, (k + 1) % 3)), static_cast<FaceId>(f), g);
  std::sort(dual.begin(), dual.end());
  for (const auto& [len, f, g] : dual)
    if (match[f] == kInvalid && match[g] == kInvalid) {
      match[f] = g;
      match[g] = f;
    }
  // Augmenting paths, within a work budget so that huge bases stay near-linear (the greedy matching is
  // already maximal, which is all the marking needs).
  BlossomMatcher matcher(nbr, match);
  std::size_t work = 0;
  constexpr std::size_t kWorkBudget = std::size_t(1) << 26;
  for (std::size_t f = 0; f < nf && work < kWorkBudget; ++f)
    if (match[f] == kInvalid) matcher.augment(static_cast<FaceId>(f), work);

  std::vector<std::uint8_t> mark(nf, 0);
  num_unpaired = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    // Among the allowed edges, the longest (ties: smallest vertex pair), computed alike on both sides.
    auto best_of = [&](auto allowed) {
      int best = -1;
      double best_len = -1.0;
      std::uint64_t best_key = 0;
      for (int k = 0; k < 3; ++k) {
        if (!allowed(k)) continue;
        const VertexId a = mesh.corner(f, k), b = mesh.corner(f, (k + 1) % 3);
        const double len = edge_length2(mesh, a, b);
        const std::uint64_t key = undirected_edge_key(a, b);
        if (len > best_len || (len == best_len && key < best_key)) {
          best = k;
          best_len = len;
          best_key = key;
        }
      }
      return best;
    };
    int k = -1;
    if (match[f] != kInvalid) {
      k = best_of([&](int e) { return nbr[f][e] == match[f]; });
    } else {
      ++num_unpaired;
      k = best_of([&](int e) { return nbr[f][e] == kInvalid; });
      if (k < 0) k = best_of([](int) { return true; });
    }
    mark[f] = static_cast<std::uint8_t>(k);
  }
  return mark;
}

void check_implicit(const ImplicitSurface& s, const std::string& who) {
  if (!s.value) throw InvalidInput(who + ": the implicit function (value) is empty");
  if (!finite(s.box_lo) || !finite(s.box_hi)) throw InvalidInput(who + ": the box bounds are not finite");
  if (!(s.box_lo.x < s.box_hi.x) || !(s.box_lo.y < s.box_hi.y) || !(s.box_lo.z < s.box_hi.z))
    throw InvalidInput(who + ": box_lo " + point_text(s.box_lo) + " must be below box_hi " + point_text(s.box_hi) +
                       " in every coordinate");
  std::size_t total = 1;
  for (int d = 0; d < 3; ++d) {
    if (s.cells[d] < 1 || s.cells[d] > 256)
      throw InvalidInput(who + ": cells[" + std::to_string(d) + "] = " + std::to_string(s.cells[d]) +
                         " is outside [1, 256]");
    total *= static_cast<std::size_t>(s.cells[d]);
  }
  if (total > (std::size_t(1) << 21))
    throw InvalidInput(who + ": " + std::to_string(total) + " grid cells exceed 2^21");
}

// Whether an edge of the mesh has its midpoint projected onto the surface somewhere other than between its ends
// (ImplicitField::between_ends). Edges whose midpoint cannot be projected are left to the refiner. O(edges)
// projections.
bool has_unresolved_edge(const TriMesh& mesh, const ImplicitField& field) {
  std::unordered_set<std::uint64_t> seen;
  seen.reserve(mesh.indices.size());
  for (std::size_t f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Index i = mesh.corner(f, k), j = mesh.corner(f, (k + 1) % 3);
      if (!seen.insert(undirected_edge_key(i, j)).second) continue;
      const glm::dvec3 a(mesh.positions[i]), b(mesh.positions[j]);
      const double len = glm::length(b - a);
      const std::optional<glm::dvec3> q =
          field.try_project(0.5 * (a + b), field.gradient(a) + field.gradient(b), std::max(len, 1e-30));
      if (q && !ImplicitField::between_ends(*q, a, b)) return true;
    }
  return false;
}

// Whether twice the cells per axis stays within polygonize_freudenthal's limits (check_implicit).
bool can_double(const std::array<int, 3>& cells) {
  std::size_t total = 1;
  for (const int c : cells) {
    if (2 * c > 256) return false;
    total *= 2 * static_cast<std::size_t>(c);
  }
  return total <= (std::size_t(1) << 21);
}

AdaptiveHierarchy implicit_from_base(const ImplicitSurface& surface, const TriMesh& base, bool project,
                                     const AdaptiveOptions& options, const std::string& who) {
  check_options(options, who);
  check_implicit(surface, who);
  base.validate();
  if (base.num_faces() == 0) throw InvalidInput(who + ": the base mesh has no face");
  const auto nbr = face_neighbours(base, who, "base mesh");
  const double scale = glm::length(surface.box_hi - surface.box_lo);
  const ImplicitField field(surface, scale, who);
  TriMesh placed = base;
  if (project) {
    // Vertex normals of the base as the fallback direction of each projection.
    const std::vector<glm::vec3> normals = compute_vertex_normals(base);
    const double reach = base.bounds().diagonal();
    for (std::size_t v = 0; v < placed.positions.size(); ++v)
      placed.positions[v] = glm::vec3(field.project(glm::dvec3(base.positions[v]), glm::dvec3(normals[v]),
                                                    std::max(reach, 1e-30), "base vertex " + std::to_string(v), v));
  }
  std::size_t unpaired = 0;
  const std::vector<std::uint8_t> marking = pair_and_mark(placed, nbr, unpaired);
  // The side the base's normals face: a vote of the faces weighted by area (polygonize_freudenthal's face f > 0;
  // a caller's base may face either way).
  double vote = 0.0;
  for (std::size_t f = 0; f < placed.num_faces(); ++f) {
    const glm::dvec3 a(placed.positions[placed.corner(f, 0)]), b(placed.positions[placed.corner(f, 1)]),
        c(placed.positions[placed.corner(f, 2)]);
    const glm::dvec3 g = field.gradient((a + b + c) / 3.0);
    if (const double len = glm::length(g); len > 0.0) vote += glm::dot(glm::cross(b - a, c - a), g) / len;
  }
  ImplicitRefiner refiner(options, who, field, vote < 0.0 ? -1.0 : 1.0);
  return refiner.build(placed, marking, unpaired);
}

}  // namespace

ParametricSurface torus_parametric(float r) {
  ParametricSurface s;
  s.eval = [r](glm::vec2 uv) {
    const float ring = r + std::cos(uv.y);
    return glm::vec3(std::cos(uv.x) * ring, std::sin(uv.x) * ring, std::sin(uv.y));
  };
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  s.domain_lo = {0.0f, 0.0f};
  s.domain_hi = {two_pi, two_pi};
  s.periodic_u = s.periodic_v = true;
  return s;
}

ParametricSurface saddle_parametric() {
  ParametricSurface s;
  s.eval = [](glm::vec2 uv) {
    const float w = uv.x * uv.y;
    return glm::vec3(uv.x, uv.y, w * w * w);
  };
  return s;
}

ImplicitSurface torus_implicit(double r) {
  ImplicitSurface s;
  const double r2 = r * r;
  s.value = [r2](const glm::dvec3& p) {
    const double a = glm::dot(p, p) - r2 - 1.0;
    return a * a - 4.0 * r2 * (1.0 - p.z * p.z);
  };
  s.gradient = [r2](const glm::dvec3& p) {
    const double a = glm::dot(p, p) - r2 - 1.0;
    return glm::dvec3(4.0 * a * p.x, 4.0 * a * p.y, 4.0 * a * p.z + 8.0 * r2 * p.z);
  };
  s.box_lo = {-3.0, -3.0, -1.0};
  s.box_hi = {3.0, 3.0, 1.0};
  s.cells = {4, 4, 2};
  return s;
}

void CylindricalScan::validate() const {
  if (num_angles < 3 || num_heights < 2)
    throw InvalidInput("cylindrical scan: needs >= 3 angles and >= 2 heights, got " + std::to_string(num_angles) +
                       " x " + std::to_string(num_heights));
  if (num_angles > (std::size_t(1) << 28) / num_heights)
    throw InvalidInput("cylindrical scan: " + std::to_string(num_angles) + " x " + std::to_string(num_heights) +
                       " samples exceed 2^28");
  if (radius.size() != num_angles * num_heights)
    throw InvalidInput("cylindrical scan: " + std::to_string(radius.size()) + " radii for " +
                       std::to_string(num_angles) + " x " + std::to_string(num_heights) + " samples");
  if (!std::isfinite(height_min) || !std::isfinite(height_step) || !(height_step > 0.0f) ||
      !std::isfinite(height_min + height_step * static_cast<float>(num_heights - 1)))
    throw InvalidInput("cylindrical scan: height_min and height_step must be finite, height_step > 0");
  for (std::size_t i = 0; i < radius.size(); ++i)
    if (!std::isfinite(radius[i]) || radius[i] < 0.0f)
      throw InvalidInput("cylindrical scan: radius of sample (angle " + std::to_string(i % num_angles) +
                             ", height " + std::to_string(i / num_angles) + ") is " + num(radius[i]) +
                             " (must be finite and >= 0)",
                         i);
}

AdaptiveHierarchy build_adaptive_parametric(const ParametricSurface& surface, const AdaptiveOptions& options) {
  const std::string who = "build_adaptive_parametric";
  check_options(options, who);
  if (!surface.eval) throw InvalidInput(who + ": the surface function (eval) is empty");
  const glm::dvec2 lo(surface.domain_lo), hi(surface.domain_hi);
  check_domain(lo, hi, who);
  const auto& eval = surface.eval;
  LatticeRefiner refiner(options, who, [&eval](const glm::dvec2& uv) { return eval(glm::vec2(uv)); }, lo, hi,
                         surface.periodic_u, surface.periodic_v, DataGrid{});
  return refiner.build();
}

AdaptiveHierarchy build_adaptive_heightfield(const HeightField& field, const AdaptiveOptions& options) {
  const std::string who = "build_adaptive_heightfield";
  check_options(options, who);
  field.validate();
  if (field.width < 2 || field.height < 2)
    throw InvalidInput(who + ": the height field needs at least 2 x 2 samples, got " + std::to_string(field.width) +
                       " x " + std::to_string(field.height));
  const double sx = field.spacing_x, sy = field.spacing_y;
  const std::size_t w = field.width, h = field.height;
  auto eval = [&field, sx, sy, w, h](const glm::dvec2& uv) {
    // Bilinear between samples.
    const double fu = std::clamp(uv.x, 0.0, double(w - 1)), fv = std::clamp(uv.y, 0.0, double(h - 1));
    const std::size_t i = std::min(static_cast<std::size_t>(fu), w - 2), j = std::min(static_cast<std::size_t>(fv), h - 2);
    const double s = fu - double(i), t = fv - double(j);
    const double z = (1 - s) * (1 - t) * field.at(i, j) + s * (1 - t) * field.at(i + 1, j) +
                     (1 - s) * t * field.at(i, j + 1) + s * t * field.at(i + 1, j + 1);
    return glm::vec3(static_cast<float>(uv.x * sx), static_cast<float>(uv.y * sy), static_cast<float>(z));
  };
  DataGrid grid{w - 1, h - 1, [&field](std::size_t i, std::size_t j) { return field.to_world(i, j); }};
  LatticeRefiner refiner(options, who, eval, glm::dvec2(0.0), glm::dvec2(double(w - 1), double(h - 1)), false, false,
                         std::move(grid));
  return refiner.build();
}

AdaptiveHierarchy build_adaptive_cylindrical(const CylindricalScan& scan, const AdaptiveOptions& options) {
  const std::string who = "build_adaptive_cylindrical";
  check_options(options, who);
  scan.validate();
  const std::size_t na = scan.num_angles, nh = scan.num_heights;
  const double two_pi = 2.0 * std::numbers::pi, h0 = scan.height_min, dh = scan.height_step;
  auto eval = [&scan, na, nh, two_pi, h0, dh](const glm::dvec2& uv) {
    // Radius bilinear in (angle, height), wrapping in angle.
    const double a = std::clamp(uv.x / two_pi * double(na), 0.0, double(na));
    const double c = std::clamp((uv.y - h0) / dh, 0.0, double(nh - 1));
    const std::size_t i = std::min(static_cast<std::size_t>(a), na - 1), j = std::min(static_cast<std::size_t>(c), nh - 2);
    const double s = a - double(i), t = c - double(j);
    const std::size_t i1 = (i + 1) % na;
    const double r = (1 - s) * (1 - t) * scan.at(i, j) + s * (1 - t) * scan.at(i1, j) + (1 - s) * t * scan.at(i, j + 1) +
                     s * t * scan.at(i1, j + 1);
    return glm::vec3(static_cast<float>(r * std::cos(uv.x)), static_cast<float>(r * std::sin(uv.x)),
                     static_cast<float>(uv.y));
  };
  DataGrid grid{na, nh - 1, [&scan, na, two_pi, h0, dh](std::size_t i, std::size_t j) {
                  const double angle = two_pi * double(i) / double(na), r = scan.at(i, j);
                  return glm::vec3(static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)),
                                   static_cast<float>(h0 + double(j) * dh));
                }};
  LatticeRefiner refiner(options, who, eval, glm::dvec2(0.0, h0), glm::dvec2(two_pi, h0 + double(nh - 1) * dh), true,
                         false, std::move(grid));
  return refiner.build();
}

TriMesh polygonize_freudenthal(const ImplicitSurface& surface) {
  const std::string who = "polygonize_freudenthal";
  check_implicit(surface, who);
  const auto nx = static_cast<std::size_t>(surface.cells[0]), ny = static_cast<std::size_t>(surface.cells[1]),
             nz = static_cast<std::size_t>(surface.cells[2]);
  const std::size_t sx = nx + 1, sy = ny + 1;
  auto grid_point = [&](std::size_t i, std::size_t j, std::size_t k) {
    const glm::dvec3 t(double(i) / double(nx), double(j) / double(ny), double(k) / double(nz));
    return surface.box_lo + (surface.box_hi - surface.box_lo) * t;
  };
  std::vector<glm::dvec3> gp(sx * sy * (nz + 1));
  std::vector<double> gv(gp.size());
  for (std::size_t k = 0; k <= nz; ++k)
    for (std::size_t j = 0; j <= ny; ++j)
      for (std::size_t i = 0; i <= nx; ++i) {
        const std::size_t id = i + sx * (j + sy * k);
        gp[id] = grid_point(i, j, k);
        gv[id] = surface.value(gp[id]);
        if (!std::isfinite(gv[id]))
          throw InvalidInput(who + ": f is not finite at grid vertex (" + std::to_string(i) + ", " + std::to_string(j) +
                                 ", " + std::to_string(k) + ") " + point_text(gp[id]),
                             id);
      }

  // A grid value that is zero up to rounding counts as zero. Otherwise the roots on the vertex's edges land
  // within rounding of it and of each other: faces of no area, whose orientation is noise and whose edges are
  // too short to project a midpoint onto the surface. Zero means here: every root on an axis edge at the
  // vertex would lie within 1e-6 of that edge's length from the vertex.
  {
    std::vector<double> snapped = gv;
    for (std::size_t k = 0; k <= nz; ++k)
      for (std::size_t j = 0; j <= ny; ++j)
        for (std::size_t i = 0; i <= nx; ++i) {
          const std::size_t id = i + sx * (j + sy * k);
          double rise = 0.0;  // the largest change of f along an axis edge at the vertex
          const std::array<std::size_t, 3> at{i, j, k}, last{nx, ny, nz}, step{1, sx, sx * sy};
          for (int axis = 0; axis < 3; ++axis) {
            if (at[axis] > 0) rise = std::max(rise, std::abs(gv[id - step[axis]] - gv[id]));
            if (at[axis] < last[axis]) rise = std::max(rise, std::abs(gv[id + step[axis]] - gv[id]));
          }
          if (std::abs(gv[id]) <= 1e-6 * rise) snapped[id] = 0.0;
        }
    gv = std::move(snapped);
  }

  // Roots on the edges of the Kuhn tetrahedra, from the inside end (f < 0) to the outside end, by bisection:
  // on the surface to double precision.
  std::unordered_map<std::uint64_t, glm::dvec3> root_of;
  auto root = [&](Index in, Index out) {
    if (const auto it = root_of.find(undirected_edge_key(in, out)); it != root_of.end()) return it->second;
    glm::dvec3 a = gp[in], b = gp[out];
    for (int it = 0; it < 64; ++it) {
      const glm::dvec3 m = 0.5 * (a + b);
      const double fm = surface.value(m);
      if (!std::isfinite(fm)) throw InvalidInput(who + ": f is not finite at " + point_text(m));
      (fm < 0.0 ? a : b) = m;
    }
    return root_of[undirected_edge_key(in, out)] = 0.5 * (a + b);
  };

  // Snapping (Labelle-Shewchuk 2007, "Isosurface stuffing", section 3: a lattice vertex near a cutting point is
  // moved onto it). A root close to a grid vertex makes faces with very short edges next to long ones (the
  // 4 x 4 x 2 torus had faces of quality 0.004, edges of 0.008 next to edges of 1.5), and the bisection of such
  // a needle folds across the surface once a long edge's midpoint is projected: the sagitta of a long chord
  // exceeds the needle's width. So a grid vertex with a root closer than kSnapFraction of that edge's length
  // moves onto its nearest such root, and the roots on all its crossing edges are welded into it, as for a grid
  // vertex with f == 0; unlike a zero it keeps its side (inside or outside), so every tetrahedron keeps its sign
  // pattern and the faces around the vertex collapse. When both ends of a crossing edge are welded, the edge's
  // point is the outside end's. Faces are oriented on the unmoved grid points. A snap that turns a face against
  // that orientation or makes a vertex or an edge non-manifold (the surface thinner than the grid) is undone;
  // if a defect remains that no undo removes, or the topology (Euler characteristic, components) differs from
  // the polygonization without snaps, or undoing takes more than kMaxSnapRounds rounds, no vertex is snapped.
  constexpr std::array<std::array<std::size_t, 3>, 7> kKuhnEdges{
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}}};
  auto for_each_kuhn_edge = [&](auto&& fn) {
    for (std::size_t k = 0; k <= nz; ++k)
      for (std::size_t j = 0; j <= ny; ++j)
        for (std::size_t i = 0; i <= nx; ++i)
          for (const auto& d : kKuhnEdges) {
            if (i + d[0] > nx || j + d[1] > ny || k + d[2] > nz) continue;
            const auto a = static_cast<Index>(i + sx * (j + sy * k));
            fn(a, static_cast<Index>(a + d[0] + sx * (d[1] + sy * d[2])));
          }
  };
  // Welded at the grid vertex: f == 0 there (outside), or snapped (its own side), at position weld_at.
  std::vector<std::uint8_t> welded(gp.size(), 0);
  for (std::size_t v = 0; v < gp.size(); ++v) welded[v] = gv[v] == 0.0 ? 1 : 0;
  std::vector<glm::dvec3> weld_at = gp;

  struct Polygonization {
    TriMesh mesh;
    std::vector<glm::dvec3> exact;  // welded vertices at their grid points: the faces are oriented on these
    std::vector<Index> grid_of;     // per vertex: its grid vertex if welded there, else kInvalid
  };
  auto polygonize = [&]() {
    Polygonization out;
    TriMesh& mesh = out.mesh;
    std::unordered_map<std::uint64_t, Index> vertex_of;  // grid edge (a < b), or (a, a) for a welded grid vertex
    auto edge_vertex = [&](Index in, Index outside) -> Index {
      const Index at = welded[outside] ? outside : welded[in] ? in : kInvalid;
      const std::uint64_t key = at != kInvalid ? directed_edge_key(at, at) : undirected_edge_key(in, outside);
      const auto [it, inserted] = vertex_of.try_emplace(key, static_cast<Index>(mesh.positions.size()));
      if (!inserted) return it->second;
      const glm::dvec3 p = at != kInvalid ? weld_at[at] : root(in, outside);
      mesh.positions.push_back(glm::vec3(p));
      out.exact.push_back(at != kInvalid ? gp[at] : p);
      out.grid_of.push_back(at);
      return it->second;
    };
    auto emit = [&](std::array<Index, 3> t, const glm::dvec3& outward) {
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return;
      const glm::dvec3 &a = out.exact[t[0]], &b = out.exact[t[1]], &c = out.exact[t[2]];
      if (glm::dot(glm::cross(b - a, c - a), outward) < 0.0) std::swap(t[1], t[2]);
      mesh.indices.insert(mesh.indices.end(), t.begin(), t.end());
    };
    // Kuhn's 6 tetrahedra of a cell: paths from corner (0,0,0) to (1,1,1) along the axes in each order.
    constexpr std::array<std::array<int, 3>, 6> kOrders{
        {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
    const std::array<std::size_t, 3> stride{1, sx, sx * sy};
    for (std::size_t k = 0; k < nz; ++k)
      for (std::size_t j = 0; j < ny; ++j)
        for (std::size_t i = 0; i < nx; ++i)
          for (const auto& order : kOrders) {
            std::array<Index, 4> v;
            v[0] = static_cast<Index>(i + sx * (j + sy * k));
            for (int s = 0; s < 3; ++s) v[s + 1] = static_cast<Index>(v[s] + stride[order[s]]);
            std::array<Index, 4> in{}, ou{};
            std::size_t ni = 0, no = 0;
            for (const Index g : v) (gv[g] < 0.0 ? in[ni++] : ou[no++]) = g;
            if (ni == 0 || no == 0) continue;
            // The linear interpolant grows from the inside corners to the outside ones.
            glm::dvec3 cin(0.0), cout(0.0);
            for (std::size_t q = 0; q < ni; ++q) cin += gp[in[q]] / double(ni);
            for (std::size_t q = 0; q < no; ++q) cout += gp[ou[q]] / double(no);
            const glm::dvec3 outward = cout - cin;
            if (ni == 1) {
              emit({edge_vertex(in[0], ou[0]), edge_vertex(in[0], ou[1]), edge_vertex(in[0], ou[2])}, outward);
            } else if (ni == 3) {
              emit({edge_vertex(in[0], ou[0]), edge_vertex(in[1], ou[0]), edge_vertex(in[2], ou[0])}, outward);
            } else {
              // Quad (a-c, a-d, b-d, b-c) cut along its shorter diagonal (a welded corner makes it a triangle).
              const Index ac = edge_vertex(in[0], ou[0]), ad = edge_vertex(in[0], ou[1]),
                          bd = edge_vertex(in[1], ou[1]), bc = edge_vertex(in[1], ou[0]);
              const auto d2 = [&](Index p, Index q) {
                const glm::vec3 e = mesh.positions[p] - mesh.positions[q];
                return glm::dot(e, e);
              };
              if (d2(ac, bd) <= d2(ad, bc)) {
                emit({ac, ad, bd}, outward);
                emit({ac, bd, bc}, outward);
              } else {
                emit({ad, bd, bc}, outward);
                emit({ad, bc, ac}, outward);
              }
            }
          }
    return out;
  };

  Polygonization plain = polygonize();
  std::vector<std::tuple<double, Index, glm::dvec3>> candidates;  // (distance, grid vertex, root)
  for_each_kuhn_edge([&](Index a, Index b) {
    if (gv[a] == 0.0 || gv[b] == 0.0 || (gv[a] < 0.0) == (gv[b] < 0.0)) return;
    const glm::dvec3 p = gv[a] < 0.0 ? root(a, b) : root(b, a);
    const double len = glm::length(gp[b] - gp[a]);
    for (const Index e : {a, b})
      if (const double dist = glm::length(p - gp[e]); dist < kSnapFraction * len) candidates.emplace_back(dist, e, p);
  });
  std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
    return std::tie(std::get<0>(x), std::get<1>(x)) < std::tie(std::get<0>(y), std::get<1>(y));
  });
  // A vertex between two sheets (inside a tube thinner than the grid, or in a gap between two parts) has roots on
  // both, with opposite normals: welding them would bridge the sheets, so it is not snapped.
  const ImplicitField field(surface, glm::length(surface.box_hi - surface.box_lo), who);
  auto one_sheet = [&](Index v, const glm::dvec3& target) {
    const glm::dvec3 g = field.gradient(target);
    const std::array<std::size_t, 3> at{v % sx, v / sx % sy, v / (sx * sy)}, last{nx, ny, nz};
    for (const auto& d : kKuhnEdges)
      for (const bool forward : {true, false}) {
        // The grid vertex at -d or +d from v, if it is inside the grid.
        std::size_t w = 0;
        for (int axis = 2; axis >= 0; --axis) {
          const std::size_t n = axis == 0 ? 1 : axis == 1 ? sx : sx * sy;
          if (forward ? at[axis] + d[axis] > last[axis] : at[axis] < d[axis]) {
            w = std::numeric_limits<std::size_t>::max();
            break;
          }
          w += n * (forward ? at[axis] + d[axis] : at[axis] - d[axis]);
        }
        if (w == std::numeric_limits<std::size_t>::max() || (gv[v] < 0.0) == (gv[w] < 0.0)) continue;
        const auto u = static_cast<Index>(w);
        if (glm::dot(field.gradient(gv[v] < 0.0 ? root(v, u) : root(u, v)), g) <= 0.0) return false;
      }
    return true;
  };
  std::vector<std::uint8_t> snapped(gp.size(), 0);
  for (const auto& [dist, v, p] : candidates) {
    if (welded[v] || !one_sheet(v, p)) continue;
    welded[v] = snapped[v] = 1;
    weld_at[v] = p;
  }
  constexpr int kMaxSnapRounds = 8;
  auto any_snapped = [&] { return std::find(snapped.begin(), snapped.end(), std::uint8_t{1}) != snapped.end(); };
  for (int round = 0; round < kMaxSnapRounds && any_snapped(); ++round) {
    Polygonization snap = polygonize();
    std::vector<Index> undo = non_manifold_vertices(snap.mesh);
    for (std::size_t f = 0; f < snap.mesh.num_faces(); ++f) {
      const std::array<Index, 3> t{snap.mesh.corner(f, 0), snap.mesh.corner(f, 1), snap.mesh.corner(f, 2)};
      const auto& p = snap.mesh.positions;
      const glm::dvec3 reference = glm::cross(snap.exact[t[1]] - snap.exact[t[0]], snap.exact[t[2]] - snap.exact[t[0]]);
      const glm::dvec3 moved = glm::cross(glm::dvec3(p[t[1]] - p[t[0]]), glm::dvec3(p[t[2]] - p[t[0]]));
      if (!(glm::dot(reference, moved) > 0.0)) undo.insert(undo.end(), t.begin(), t.end());
    }
    bool changed = false;
    for (const Index v : undo)
      if (const Index g = snap.grid_of[v]; g != kInvalid && snapped[g]) {
        snapped[g] = welded[g] = 0;
        weld_at[g] = gp[g];
        changed = true;
      }
    if (changed) continue;
    if (!undo.empty()) break;  // a defect no snap of its own vertices caused
    if (topology(snap.mesh) != topology(plain.mesh)) break;
    face_neighbours(snap.mesh, who, "polygonization");  // manifold and consistently oriented, or a named error
    return std::move(snap.mesh);
  }
  face_neighbours(plain.mesh, who, "polygonization");
  return std::move(plain.mesh);
}

AdaptiveHierarchy build_adaptive_implicit(const ImplicitSurface& surface, const AdaptiveOptions& options) {
  const std::string who = "build_adaptive_implicit";
  check_options(options, who);
  ImplicitSurface grid = surface;
  TriMesh base = polygonize_freudenthal(grid);
  if (base.num_faces() == 0) throw InvalidInput(who + ": the surface does not cross the grid (empty polygonization)");
  // A base edge whose midpoint projects onto the surface away from the edge's middle crosses a part of the
  // surface thinner than the grid (the genus-2 surface's ends on 14 x 10 x 4: one layer of grid vertices inside,
  // chords across 150 degrees of the tube): bisection cannot follow the surface there (see
  // ImplicitField::bisect_edge). Such a grid is polygonized again with twice the cells per axis, within
  // polygonize_freudenthal's limits.
  const ImplicitField field(surface, glm::length(surface.box_hi - surface.box_lo), who);
  while (has_unresolved_edge(base, field) && can_double(grid.cells)) {
    for (int& c : grid.cells) c *= 2;
    base = polygonize_freudenthal(grid);
  }
  AdaptiveHierarchy out = implicit_from_base(grid, base, false, options, who);
  out.base_cells = grid.cells;
  return out;
}

AdaptiveHierarchy build_adaptive_implicit(const ImplicitSurface& surface, const TriMesh& base,
                                          const AdaptiveOptions& options) {
  return implicit_from_base(surface, base, true, options, "build_adaptive_implicit");
}

std::vector<FaceId> adaptive_finest_faces(const AdaptiveHierarchy& hierarchy) {
  std::vector<FaceId> out;
  out.reserve(hierarchy.num_finest_faces);
  for (FaceId f = 0; f < hierarchy.mt.num_faces(); ++f)
    if (hierarchy.mt.destroyer(f) == kInvalid) out.push_back(f);
  return out;
}

TriMesh adaptive_domain_mesh(const AdaptiveHierarchy& hierarchy, std::span<const FaceId> faces) {
  if (hierarchy.domain.size() != hierarchy.mt.num_vertices())
    throw InvalidInput("adaptive_domain_mesh: the hierarchy has no parameter domain (implicit surface)");
  std::vector<FaceId> finest;
  if (faces.empty()) {
    finest = adaptive_finest_faces(hierarchy);
    faces = finest;
  }
  TriMesh out;
  std::vector<Index> remap(hierarchy.mt.num_vertices(), kInvalid);
  out.indices.reserve(3 * faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const FaceId f = faces[i];
    if (f >= hierarchy.mt.num_faces())
      throw InvalidInput("adaptive_domain_mesh: face " + std::to_string(f) + " is not a face of the hierarchy", i);
    for (const VertexId v : hierarchy.mt.face(f)) {
      if (remap[v] == kInvalid) {
        remap[v] = static_cast<Index>(out.positions.size());
        out.positions.emplace_back(hierarchy.domain[v], 0.0f);
      }
      out.indices.push_back(remap[v]);
    }
  }
  return out;
}

}  // namespace varmesh
