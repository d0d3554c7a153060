// Tests of fourk/strips.hpp: hierarchical generalized triangle strips maintained on MT fronts
// (Velho-Gomes 2000, 9.2). Properties checked: each front face exactly once, consecutive faces of a run
// share an edge, one run on uniform and adaptive 4-8 refinement (the Sierpinski rule), incremental ==
// from scratch, undo-all == base strip, and the index encoding decodes to exactly the front's triangles.
#include "fourk/strips.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "fourk/adaptive.hpp"
#include "fourk/bisection.hpp"
#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

namespace varmesh {
namespace {

// Fixtures.

TriMesh square() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

// n x n unit cells; `union_jack`: diagonals alternate so that they meet at every other vertex (the 4-8
// pattern, a uniform level of the square's refinement); otherwise every diagonal goes (i, j)-(i+1, j+1).
TriMesh grid(int n, bool union_jack) {
  TriMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.positions.push_back({float(i), float(j), 0.0f});
  auto id = [n](int i, int j) { return static_cast<Index>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if (!union_jack || (i + j) % 2 == 0) m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      else m.indices.insert(m.indices.end(), {a, b, d, b, c, d});
    }
  return m;
}

// Octahedron, faces outward; paired along its equator (the 4-cycle +x, +y, -x, -y).
TriMesh octahedron() {
  TriMesh m;
  m.positions = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (Index k = 0; k < 4; ++k) {
    const Index a = k, b = (k + 1) % 4;
    m.indices.insert(m.indices.end(), {a, b, 4});
    m.indices.insert(m.indices.end(), {b, a, 5});
  }
  return m;
}
std::vector<std::uint8_t> equator_marking(const TriMesh& octa) {
  const std::array<std::array<VertexId, 2>, 4> eq{{{0, 1}, {1, 2}, {2, 3}, {3, 0}}};
  return mark_edges(octa, eq);
}

TriMesh tetrahedron() {
  TriMesh m;
  m.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  m.indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  return m;
}

float bumps(float x, float y) {
  return 0.4f * std::exp(-((x - 0.3f) * (x - 0.3f) + (y - 0.65f) * (y - 0.65f)) / 0.01f) +
         0.05f * std::sin(7.0f * x) * std::cos(5.0f * y);
}

// A terrain-like 4-8 MT: uniform bisection whose new vertices sit on a height function, node error = the
// vertical deviation of the new vertex from its edge (saturated by MtBuilder, hence nested).
Mt height_mt(const TriMesh& base, int levels, float scale = 1.0f) {
  BisectionOptions opt;
  opt.place_vertex = [scale](const BisectionSplit& s) {
    const glm::vec3 m = (s.positions[s.e0] + s.positions[s.e1]) * 0.5f;
    return glm::vec3(m.x, m.y, bumps(m.x / scale, m.y / scale));
  };
  opt.node_error = [](const BisectionSplit& s) {
    const float avg = 0.5f * (s.positions[s.e0].z + s.positions[s.e1].z);
    return std::fabs(s.positions[s.mid].z - avg);
  };
  return build_bisection_mt(base, mark_longest_edges(base), levels, opt);
}

// Checks shared by the tests.

std::array<VertexId, 3> canonical(std::array<VertexId, 3> t) {
  while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
  return t;
}

// The encoding decodes to exactly the front's oriented triangles.
void expect_round_trip(const Mt& mt, std::span<const FaceId> faces, const StripRuns& runs) {
  std::size_t swaps = 0;
  const std::vector<Index> idx = encode_strip(mt, runs, {}, &swaps);
  std::vector<std::array<VertexId, 3>> got = decode_strip(idx);
  std::vector<std::array<VertexId, 3>> want;
  for (FaceId f : faces) want.push_back(canonical(mt.face(f)));
  for (auto& t : got) t = canonical(t);
  std::sort(got.begin(), got.end());
  std::sort(want.begin(), want.end());
  EXPECT_EQ(got, want);
  EXPECT_EQ(std::count(idx.begin(), idx.end(), kStripRestart), std::ptrdiff_t(runs.size()) - 1);
}

// Everything a strip front must satisfy: its invariants, a valid strip of the front, the same as from
// scratch, and an encoding that decodes to the front. Returns the check.
StripCheck expect_valid(const StripFront& sf) {
  sf.validate();
  const StripRuns runs = sf.runs();
  const StripCheck c = check_strip(sf.mt(), sf.front().faces(), runs);
  EXPECT_TRUE(c.ok) << c.problem;
  EXPECT_EQ(c.num_runs, sf.num_runs());
  EXPECT_EQ(c.num_faces, sf.num_faces());
  EXPECT_EQ(runs, hierarchical_strip(sf.plan(), sf.front().faces()));
  return c;
}

void refine_uniform_level(StripFront& sf, const BisectionInfo& info, int level) {
  for (NodeId n = 1; n < sf.mt().num_nodes(); ++n)
    if (info.node_level[n] == level) sf.apply(n);
}

void coarsen_all(StripFront& sf) {
  for (NodeId n = static_cast<NodeId>(sf.mt().num_nodes()); n-- > 1;) sf.coarsen(n);
}

// The ordered key set.

TEST(StripKeySet, MatchesStdSet) {
  for (std::size_t n : {1u, 63u, 64u, 65u, 4096u, 4097u, 300000u}) {
    detail::StripKeySet ks;
    ks.reset(n);
    std::set<Index> ref;
    std::mt19937 rng(static_cast<unsigned>(n));
    for (int step = 0; step < 3000; ++step) {
      const Index k = static_cast<Index>(rng() % n);
      if (rng() % 3 == 0) {
        ks.erase(k);
        ref.erase(k);
      } else {
        ks.insert(k);
        ref.insert(k);
      }
      ASSERT_EQ(ks.size(), ref.size());
      const Index q = static_cast<Index>(rng() % n);
      auto it = ref.upper_bound(q);
      ASSERT_EQ(ks.next(q), it == ref.end() ? kInvalid : *it) << n << " " << q;
      auto lo = ref.lower_bound(q);
      ASSERT_EQ(ks.prev(q), lo == ref.begin() ? kInvalid : *std::prev(lo)) << n << " " << q;
      ASSERT_EQ(ks.contains(q), ref.count(q) == 1);
    }
    EXPECT_EQ(ks.next(kInvalid), ref.empty() ? kInvalid : *ref.begin());
    EXPECT_EQ(ks.prev(kInvalid), ref.empty() ? kInvalid : *ref.rbegin());
  }
}

// Uniform 4-8 refinement: one run at every level (the Sierpinski rule)

struct UniformCase {
  const char* name;
  TriMesh base;
  std::vector<std::uint8_t> marking;
  int levels;
};

std::vector<UniformCase> sierpinski_cases() {
  std::vector<UniformCase> cases;
  const TriMesh sq = square();
  cases.push_back({"square", sq, mark_longest_edges(sq), 11});
  const TriMesh uj = grid(4, true);
  cases.push_back({"union_jack_4x4", uj, mark_longest_edges(uj), 7});
  const TriMesh oc = octahedron();
  cases.push_back({"octahedron_equator", oc, equator_marking(oc), 8});
  return cases;
}

TEST(HierarchicalStrip, UniformRefinementKeepsOneRun) {
  for (const UniformCase& uc : sierpinski_cases()) {
    SCOPED_TRACE(uc.name);
    BisectionInfo info;
    const Mt mt = build_bisection_mt(uc.base, uc.marking, uc.levels, {}, &info);
    const StripPlan plan(mt);
    EXPECT_TRUE(plan.stats().is_sierpinski())
        << "runs " << plan.stats().base_runs << " mismatches " << plan.stats().base_mismatches << " misaligned "
        << plan.stats().misaligned_faces << " defects " << plan.stats().local_defects;
    EXPECT_EQ(plan.stats().generic_nodes, 0u);
    StripFront sf(plan);
    std::vector<FaceId> base_seq = sf.sequence();
    EXPECT_EQ(base_seq, std::vector<FaceId>(plan.base_order().begin(), plan.base_order().end()));
    std::size_t total_swaps = 0, total_tris = 0;
    for (int level = 0; level <= uc.levels; ++level) {
      if (level > 0) refine_uniform_level(sf, info, level);
      ASSERT_EQ(sf.num_faces(), uc.base.num_faces() << level);
      const StripCheck c = expect_valid(sf);
      EXPECT_EQ(sf.num_runs(), 1u) << "level " << level;
      if (level <= 7 || level == uc.levels) expect_round_trip(mt, sf.front().faces(), sf.runs());
      total_swaps += c.num_swaps;
      total_tris += c.num_faces;
    }
    std::printf("[ strips   ] %s: %d levels, one run each; %zu swaps over %zu triangles (generalized strip)\n",
                uc.name, uc.levels, total_swaps, total_tris);
    coarsen_all(sf);
    EXPECT_EQ(sf.sequence(), base_seq);
  }
}

// A paired mesh whose base admits no Sierpinski strip: the break count is bounded by the base's links
// (each base link is one link of every front), at every level, and only inner links are ever good.
TEST(HierarchicalStrip, PairedMeshWithoutSierpinskiBaseHasBoundedRuns) {
  struct Case {
    const char* name;
    TriMesh base;
    std::vector<std::uint8_t> marking;
    int levels;
  };
  const TriMesh sl = grid(3, false), tet = tetrahedron();
  const std::array<std::array<VertexId, 2>, 2> tet_edges{{{0, 1}, {2, 3}}};
  const std::vector<Case> cases{{"slash_grid_3x3", sl, mark_longest_edges(sl), 7},
                                {"tetrahedron", tet, mark_edges(tet, tet_edges), 8}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    BisectionInfo info;
    const Mt mt = build_bisection_mt(c.base, c.marking, c.levels, {}, &info);
    const StripPlan plan(mt);
    const StripPlanStats& st = plan.stats();
    EXPECT_EQ(st.misaligned_faces, 0u);
    EXPECT_EQ(st.local_defects, 0u);
    const std::size_t bound = st.base_runs + st.base_mismatches;
    StripFront sf(plan);
    std::printf("[ strips   ] %s: base %zu faces, %zu runs, %zu mismatched links; runs per level:", c.name,
                st.base_faces, st.base_runs, st.base_mismatches);
    for (int level = 0; level <= c.levels; ++level) {
      if (level > 0) refine_uniform_level(sf, info, level);
      expect_valid(sf);
      EXPECT_LE(sf.num_runs(), bound) << "level " << level;
      std::printf(" %zu", sf.num_runs());
    }
    std::printf(" (bound %zu)\n", bound);
    // The greedy from-scratch strip of the finest front, for comparison.
    const StripRuns greedy = greedy_strip(mt, sf.front().faces());
    const StripCheck gc = check_strip(mt, sf.front().faces(), greedy);
    EXPECT_TRUE(gc.ok) << gc.problem;
    std::printf("[ strips   ] %s finest (%zu faces): hierarchical %zu runs, greedy from scratch %zu runs\n", c.name,
                sf.num_faces(), sf.num_runs(), greedy.size());
  }
}

// Selective refinement on a terrain-like 4-8 MT

TEST(HierarchicalStrip, QueriesAndRandomWalksOnHeightMt) {
  const Mt mt = height_mt(square(), 11);
  const StripPlan plan(mt);
  ASSERT_TRUE(plan.stats().is_sierpinski());
  StripFront sf(plan);
  const std::vector<FaceId> base_seq = sf.sequence();

  // extract() and update() through the query API keep the strip.
  std::size_t max_runs = 0;
  for (float e : {0.05f, 0.02f, 0.01f, 0.004f}) {
    Query q;
    q.criterion = Criterion::object_error(e);
    extract(sf, q);
    expect_valid(sf);
    max_runs = std::max(max_runs, sf.num_runs());
    EXPECT_EQ(sf.num_runs(), 1u) << "extract e = " << e << ", " << sf.num_faces() << " faces";
  }
  for (float e : {0.03f, 0.006f, 0.08f, 0.002f}) {
    Query q;
    q.criterion = Criterion::object_error(e);
    q.focus.spheres.push_back(Sphere{{0.3f, 0.6f, 0.0f}, 0.3f});
    update(sf, q);
    const StripCheck c = expect_valid(sf);
    EXPECT_EQ(sf.num_runs(), 1u) << "update e = " << e;
    expect_round_trip(mt, sf.front().faces(), sf.runs());
    std::printf("[ strips   ] height MT update e=%g (focus): %zu faces, %zu runs, %zu swaps\n", double(e),
                sf.num_faces(), sf.num_runs(), c.num_swaps);
  }

  // Random refine/coarsen walks (MtFront::refine / coarsen semantics).
  std::mt19937 rng(7);
  for (int step = 0; step < 300; ++step) {
    const NodeId n = 1 + static_cast<NodeId>(rng() % (mt.num_nodes() - 1));
    if (rng() % 2 == 0 && sf.num_faces() < 2000) sf.refine(n);
    else sf.coarsen(n);
    if (step % 8 == 0) expect_valid(sf);
    max_runs = std::max(max_runs, sf.num_runs());
    ASSERT_EQ(sf.num_runs(), 1u) << "step " << step;
  }
  coarsen_all(sf);
  expect_valid(sf);
  EXPECT_EQ(sf.sequence(), base_seq);
  EXPECT_EQ(max_runs, 1u);
}

// Applying then undoing one node restores the strip exactly (keys are fixed), on every front of a walk.
TEST(HierarchicalStrip, ApplyUndoIsExact) {
  const Mt mt = height_mt(grid(2, true), 8);
  const StripPlan plan(mt);
  StripFront sf(plan);
  std::mt19937 rng(3);
  for (int step = 0; step < 300; ++step) {
    std::vector<NodeId> legal;
    for (NodeId n = 1; n < mt.num_nodes(); ++n)
      if (sf.front().can_apply(n)) legal.push_back(n);
    if (legal.empty()) break;
    const NodeId n = legal[rng() % legal.size()];
    const std::vector<FaceId> before = sf.sequence();
    const std::size_t runs_before = sf.num_runs();
    sf.apply(n);
    sf.undo(n);
    ASSERT_EQ(sf.sequence(), before);
    ASSERT_EQ(sf.num_runs(), runs_before);
    sf.apply(n);
    if (rng() % 4 == 0) {
      // Undo a random undoable node instead.
      std::vector<NodeId> undoable;
      for (NodeId m = 1; m < mt.num_nodes(); ++m)
        if (sf.front().can_undo(m)) undoable.push_back(m);
      sf.undo(undoable[rng() % undoable.size()]);
    }
  }
  expect_valid(sf);
  EXPECT_EQ(sf.num_runs(), 1u);
}

// The strip follows the front through the faces it walks: next/prev agree with sequence().
TEST(HierarchicalStrip, WalkingTheStrip) {
  const Mt mt = height_mt(square(), 6);
  const StripPlan plan(mt);
  StripFront sf(plan);
  for (NodeId n = 1; n < mt.num_nodes(); n += 3) sf.refine(n);
  const std::vector<FaceId> seq = sf.sequence();
  std::vector<FaceId> walked;
  for (FaceId f = sf.first_face(); f != kInvalid; f = sf.next_face(f)) walked.push_back(f);
  EXPECT_EQ(walked, seq);
  std::vector<FaceId> back;
  for (FaceId f = seq.back(); f != kInvalid; f = sf.prev_face(f)) back.push_back(f);
  std::reverse(back.begin(), back.end());
  EXPECT_EQ(back, seq);
  for (std::size_t i = 1; i < seq.size(); ++i) {
    const auto a = mt.face(seq[i - 1]), b = mt.face(seq[i]);
    int common = 0;
    for (VertexId v : a) common += int(std::count(b.begin(), b.end(), v));
    EXPECT_EQ(common, 2);
  }
}

// Other 4-8 builders.

TEST(HierarchicalStrip, Grid48SingleTileIsOneRunMultiTileBounded) {
  {
    const Grid48 g(make_fractal_terrain(33, 33, 5, 20.0f));
    ASSERT_EQ(g.tiles_x() * g.tiles_y(), 1u);
    const Mt mt = g.to_mt();
    const StripPlan plan(mt);
    EXPECT_TRUE(plan.stats().is_sierpinski());
    StripFront sf(plan);
    for (float e : {4.0f, 1.0f, 0.25f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      extract(sf, q);
      expect_valid(sf);
      EXPECT_EQ(sf.num_runs(), 1u) << e;
    }
  }
  {
    Grid48Options opt;
    opt.tile_size = 8;
    const Grid48 g(make_fractal_terrain(33, 17, 6, 20.0f), opt);
    const Mt mt = g.to_mt();
    const StripPlan plan(mt);
    const StripPlanStats& st = plan.stats();
    EXPECT_EQ(st.misaligned_faces, 0u);
    EXPECT_EQ(st.local_defects, 0u);
    StripFront sf(plan);
    std::printf("[ strips   ] Grid48 %zu tiles: base mismatches %zu, runs at e=", g.tiles_x() * g.tiles_y(),
                st.base_mismatches);
    for (float e : {4.0f, 1.0f, 0.25f, 0.0f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      extract(sf, q);
      expect_valid(sf);
      EXPECT_LE(sf.num_runs(), st.base_runs + st.base_mismatches);
      std::printf(" %g:%zu", double(e), sf.num_runs());
    }
    std::printf("\n");
  }
}

TEST(HierarchicalStrip, AdaptiveSurfaces) {
  {
    AdaptiveOptions opt;
    opt.tolerance = 4e-3f;
    const AdaptiveHierarchy h = build_adaptive_parametric(saddle_parametric(), opt);
    const StripPlan plan(h.mt);
    EXPECT_TRUE(plan.stats().is_sierpinski());
    StripFront sf(plan);
    for (float e : {0.05f, 0.01f, 4e-3f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      extract(sf, q);
      expect_valid(sf);
      EXPECT_EQ(sf.num_runs(), 1u);
    }
    std::printf("[ strips   ] adaptive saddle: %zu faces at the finest, 1 run\n", sf.num_faces());
  }
  {
    AdaptiveOptions opt;
    opt.tolerance = 0.08f;
    const AdaptiveHierarchy h = build_adaptive_implicit(torus_implicit(), opt);
    const StripPlan plan(h.mt);
    const StripPlanStats& st = plan.stats();
    EXPECT_EQ(st.generic_nodes, 0u);
    EXPECT_EQ(st.misaligned_faces, 0u);
    EXPECT_EQ(st.local_defects, 0u);
    const std::size_t bound = st.base_runs + st.base_mismatches;
    StripFront sf(plan);
    std::printf("[ strips   ] implicit torus: base %zu faces, %zu base runs, %zu mismatches%s; runs at e=",
                st.base_faces, st.base_runs, st.base_mismatches, st.base_search_exhausted ? " (search budget hit)" : "");
    for (float e : {0.5f, 0.2f, 0.08f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      extract(sf, q);
      expect_valid(sf);
      EXPECT_LE(sf.num_runs(), bound);
      const StripRuns greedy = greedy_strip(h.mt, sf.front().faces());
      EXPECT_TRUE(check_strip(h.mt, sf.front().faces(), greedy).ok);
      std::printf(" %g:%zu/%zu faces (greedy %zu)", double(e), sf.num_runs(), sf.num_faces(), greedy.size());
    }
    std::printf("\n");
  }
}

// Generic nodes: a random history of vertex insertions (1 -> 3), swaps (2 -> 2), edge splits
// (2 -> 4, 1 -> 2) and vertex removals (4 -> 2) in the plane.

class RandomHistory {
 public:
  explicit RandomHistory(unsigned seed) : rng_(seed) {
    const TriMesh base = grid(3, true);
    for (const glm::vec3& p : base.positions) add_vertex(p);
    std::vector<FaceId> faces;
    for (std::size_t f = 0; f < base.num_faces(); ++f)
      faces.push_back(add_face(base.corner(f, 0), base.corner(f, 1), base.corner(f, 2)));
    b_.set_base(faces);
  }

  Mt build(int ops) {
    for (int i = 0; i < ops; ++i) {
      switch (rng_() % 4) {
        case 0: insert(); break;
        case 1: swap(); break;
        case 2: split(); break;
        default: remove(); break;
      }
    }
    return std::move(b_).build();
  }
  int generic = 0, swaps = 0, splits = 0;

 private:
  using Tri = std::array<VertexId, 3>;
  VertexId add_vertex(const glm::vec3& p) {
    pos_.push_back(p);
    return b_.add_vertex(p);
  }
  FaceId add_face(VertexId a, VertexId b, VertexId c) {
    const FaceId f = b_.add_face(a, b, c);
    tris_.push_back({a, b, c});
    cur_.insert(f);
    Tri k{a, b, c};
    std::sort(k.begin(), k.end());
    used_.insert(k);
    return f;
  }
  bool fresh(VertexId a, VertexId b, VertexId c) const {
    Tri k{a, b, c};
    std::sort(k.begin(), k.end());
    return !used_.count(k);
  }
  float cross(VertexId a, VertexId b, VertexId c) const {
    const glm::vec3 u = pos_[b] - pos_[a], v = pos_[c] - pos_[a];
    return u.x * v.y - u.y * v.x;
  }
  FaceId random_face() {
    auto it = cur_.begin();
    std::advance(it, static_cast<long>(rng_() % cur_.size()));
    return *it;
  }
  // The face using directed edge (b, a), if any.
  FaceId twin(VertexId a, VertexId b) const {
    for (FaceId g : cur_)
      for (int k = 0; k < 3; ++k)
        if (tris_[g][k] == b && tris_[g][(k + 1) % 3] == a) return g;
    return kInvalid;
  }
  void node(NodeKind kind, std::vector<FaceId> removed, const std::vector<Tri>& created) {
    for (FaceId f : removed) cur_.erase(f);
    std::vector<FaceId> made;
    for (const Tri& t : created) made.push_back(add_face(t[0], t[1], t[2]));
    b_.add_node(kind, removed, made, 0.0f);
  }
  void insert() {
    const FaceId f = random_face();
    const Tri t = tris_[f];
    const VertexId m = add_vertex((pos_[t[0]] + pos_[t[1]] + pos_[t[2]]) / 3.0f);
    node(NodeKind::kGeneric, {f}, {{t[0], t[1], m}, {t[1], t[2], m}, {t[2], t[0], m}});
    ++generic;
  }
  void swap() {
    const FaceId f = random_face();
    const int k = static_cast<int>(rng_() % 3);
    const VertexId a = tris_[f][k], b = tris_[f][(k + 1) % 3], c = tris_[f][(k + 2) % 3];
    const FaceId g = twin(a, b);
    if (g == kInvalid) return;
    VertexId d = kInvalid;
    for (VertexId v : tris_[g])
      if (v != a && v != b) d = v;
    // Convex quad a, d, b, c: the new diagonal (c, d) crosses (a, b).
    if (cross(a, d, c) <= 1e-6f || cross(d, b, c) <= 1e-6f || !fresh(a, d, c) || !fresh(d, b, c)) return;
    node(NodeKind::kSwap, {f, g}, {{a, d, c}, {d, b, c}});
    ++swaps;
  }
  void split() {
    const FaceId f = random_face();
    const int k = static_cast<int>(rng_() % 3);
    const VertexId a = tris_[f][k], b = tris_[f][(k + 1) % 3], c = tris_[f][(k + 2) % 3];
    const FaceId g = twin(a, b);
    const VertexId m = add_vertex((pos_[a] + pos_[b]) * 0.5f);
    if (g == kInvalid) {
      node(NodeKind::kSplit, {f}, {{m, b, c}, {m, c, a}});
    } else {
      VertexId d = kInvalid;
      for (VertexId v : tris_[g])
        if (v != a && v != b) d = v;
      node(NodeKind::kSplit, {f, g}, {{m, b, c}, {m, c, a}, {m, a, d}, {m, d, b}});
    }
    ++splits;
  }
  // Removes an interior vertex of valence 4 whose link is a convex quad, re-triangulated by the diagonal
  // that gives new vertex triples.
  void remove() {
    const FaceId f = random_face();
    for (VertexId v : tris_[f]) {
      std::vector<FaceId> star;
      for (FaceId g : cur_)
        if (std::count(tris_[g].begin(), tris_[g].end(), v)) star.push_back(g);
      if (star.size() != 4) continue;
      // Link cycle: for each star face (v, x, y) in rotation, next(x) = y.
      std::map<VertexId, VertexId> next;
      for (FaceId g : star) {
        Tri t = tris_[g];
        while (t[0] != v) t = {t[1], t[2], t[0]};
        next[t[1]] = t[2];
      }
      if (next.size() != 4) continue;
      std::vector<VertexId> ring{next.begin()->first};
      bool closed = true;
      for (int i = 0; i < 3; ++i) {
        auto it = next.find(ring.back());
        if (it == next.end()) {
          closed = false;
          break;
        }
        ring.push_back(it->second);
      }
      if (!closed || next.count(ring.back()) == 0 || next[ring.back()] != ring[0]) continue;
      for (int s = 0; s < 2; ++s) {
        const VertexId p0 = ring[s], p1 = ring[s + 1], p2 = ring[s + 2], p3 = ring[(s + 3) % 4];
        if (cross(p0, p1, p2) > 1e-6f && cross(p0, p2, p3) > 1e-6f && fresh(p0, p1, p2) && fresh(p0, p2, p3)) {
          node(NodeKind::kGeneric, star, {{p0, p1, p2}, {p0, p2, p3}});
          ++generic;
          return;
        }
      }
    }
  }

  std::mt19937 rng_;
  MtBuilder b_;
  std::vector<glm::vec3> pos_;
  std::vector<Tri> tris_;
  std::set<FaceId> cur_;
  std::set<Tri> used_;
};

TEST(HierarchicalStrip, GenericNodesRandomWalks) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    RandomHistory history(seed);
    const Mt mt = history.build(160);
    const StripPlan plan(mt);
    EXPECT_GT(plan.stats().generic_nodes, 0u);
    StripFront sf(plan);
    const std::vector<FaceId> base_seq = sf.sequence();
    std::mt19937 rng(seed + 10);
    std::size_t max_runs = 0, sum_runs = 0, samples = 0, max_faces = 0;
    for (int step = 0; step < 200; ++step) {
      const NodeId n = 1 + static_cast<NodeId>(rng() % (mt.num_nodes() - 1));
      if (rng() % 2 == 0) sf.refine(n);
      else sf.coarsen(n);
      expect_valid(sf);
      if (step % 20 == 0) expect_round_trip(mt, sf.front().faces(), sf.runs());
      max_runs = std::max(max_runs, sf.num_runs());
      max_faces = std::max(max_faces, sf.num_faces());
      sum_runs += sf.num_runs();
      ++samples;
    }
    // The finest front, and back to the base.
    for (NodeId n = 1; n < mt.num_nodes(); ++n) sf.refine(n);
    expect_valid(sf);
    const std::size_t finest_runs = sf.num_runs(), finest_faces = sf.num_faces();
    const StripRuns greedy = greedy_strip(mt, sf.front().faces());
    EXPECT_TRUE(check_strip(mt, sf.front().faces(), greedy).ok);
    coarsen_all(sf);
    expect_valid(sf);
    EXPECT_EQ(sf.sequence(), base_seq);
    std::printf("[ strips   ] random history %u (%d generic, %d swap, %d split nodes; %zu defects, %zu misaligned): "
                "walk runs mean %.2f max %zu (<= %zu faces); finest %zu runs for %zu faces, greedy %zu\n",
                seed, history.generic, history.swaps, history.splits, plan.stats().local_defects,
                plan.stats().misaligned_faces, double(sum_runs) / double(samples), max_runs, max_faces, finest_runs,
                finest_faces, greedy.size());
  }
}

// Encoding, checks and bad input.

// Builds a tiny Mt holding exactly `mesh` as its base (no nodes).
Mt base_only(const TriMesh& mesh) { return build_bisection_mt(mesh, mark_longest_edges(mesh), 0); }

TEST(StripEncoding, SequentialAndGeneralized) {
  // A band of quads with parallel diagonals: a plain OpenGL strip (no swap).
  TriMesh band;
  for (int i = 0; i <= 4; ++i) {
    band.positions.push_back({float(i), 0, 0});
    band.positions.push_back({float(i), 1, 0});
  }
  for (Index i = 0; i < 4; ++i) {
    const Index a = 2 * i, b = 2 * i + 2, c = 2 * i + 3, d = 2 * i + 1;
    band.indices.insert(band.indices.end(), {a, b, c, a, c, d});
  }
  const Mt band_mt = base_only(band);
  // Per quad the upper-left triangle (a, c, d) first: it shares (a, d) with the previous quad.
  const StripRuns band_runs{{1, 0, 3, 2, 5, 4, 7, 6}};
  std::vector<FaceId> all(8);
  for (FaceId f = 0; f < 8; ++f) all[f] = f;
  const StripCheck bc = check_strip(band_mt, all, band_runs);
  ASSERT_TRUE(bc.ok) << bc.problem;
  EXPECT_TRUE(bc.is_sequential());
  EXPECT_EQ(bc.num_indices, 10u);  // n + 2
  expect_round_trip(band_mt, all, band_runs);

  // A fan of 6 triangles around a vertex: consecutive faces turn the same way, so swaps are needed.
  TriMesh fan;
  fan.positions.push_back({0, 0, 0});
  for (int k = 0; k < 6; ++k)
    fan.positions.push_back({std::cos(float(k) * 1.0472f), std::sin(float(k) * 1.0472f), 0});
  for (Index k = 0; k < 5; ++k) fan.indices.insert(fan.indices.end(), {0, 1 + k, 2 + k});
  const Mt fan_mt = base_only(fan);
  const StripRuns fan_runs{{0, 1, 2, 3, 4}};
  std::vector<FaceId> fan_faces{0, 1, 2, 3, 4};
  const StripCheck fc = check_strip(fan_mt, fan_faces, fan_runs);
  ASSERT_TRUE(fc.ok) << fc.problem;
  EXPECT_FALSE(fc.is_sequential());
  EXPECT_GT(fc.num_swaps, 0u);
  expect_round_trip(fan_mt, fan_faces, fan_runs);

  // Several runs: restarts; a vertex map is applied.
  const StripRuns two{{0, 1}, {3, 4}, {2}};
  expect_round_trip(fan_mt, fan_faces, two);
  std::vector<Index> map(fan_mt.num_vertices());
  for (Index v = 0; v < map.size(); ++v) map[v] = 100 + v;
  const std::vector<Index> mapped = encode_strip(fan_mt, two, map);
  for (Index i : mapped) EXPECT_TRUE(i == kStripRestart || i >= 100);
}

TEST(StripCheckTest, ReportsViolations) {
  const Mt mt = base_only(grid(2, true));
  std::vector<FaceId> all(mt.num_faces());
  for (FaceId f = 0; f < all.size(); ++f) all[f] = f;
  const StripRuns good = greedy_strip(mt, all);
  ASSERT_TRUE(check_strip(mt, all, good).ok);
  EXPECT_EQ(good.size(), 1u);  // the union jack has a Hamiltonian dual path

  StripRuns missing = good;
  missing[0].pop_back();
  EXPECT_FALSE(check_strip(mt, all, missing).ok);
  StripRuns twice = good;
  twice.push_back({good[0][0]});
  EXPECT_FALSE(check_strip(mt, all, twice).ok);
  StripRuns empty_run = good;
  empty_run.emplace_back();
  EXPECT_FALSE(check_strip(mt, all, empty_run).ok);
  StripRuns foreign = good;
  foreign.push_back({999});
  EXPECT_FALSE(check_strip(mt, all, foreign).ok);
  // Two faces that share only a vertex (or nothing) cannot be consecutive.
  std::vector<FaceId> order = good[0];
  bool found = false;
  for (std::size_t i = 0; i + 2 < order.size() && !found; ++i)
    for (std::size_t j = i + 2; j < order.size() && !found; ++j) {
      const auto a = mt.face(order[i]), b = mt.face(order[j]);
      int common = 0;
      for (VertexId v : a) common += int(std::count(b.begin(), b.end(), v));
      if (common < 2) {
        std::swap(order[i + 1], order[j]);
        found = true;
      }
    }
  ASSERT_TRUE(found);
  const StripCheck c = check_strip(mt, all, StripRuns{order});
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.problem.find("share no edge"), std::string::npos) << c.problem;
  EXPECT_THROW(encode_strip(mt, StripRuns{order}), InvalidInput);
}

TEST(StripBadInput, TypedErrors) {
  const Mt mt = height_mt(square(), 3);
  const StripPlan plan(mt);
  StripFront sf(plan);
  const std::vector<FaceId> before = sf.sequence();
  EXPECT_THROW(sf.apply(static_cast<NodeId>(mt.num_nodes())), InvalidInput);
  EXPECT_THROW(sf.undo(0), InvalidInput);
  NodeId deep = 0;
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    if (!sf.front().can_apply(n)) deep = n;
  ASSERT_NE(deep, 0u);
  EXPECT_THROW(sf.apply(deep), InvalidInput);
  sf.validate();
  EXPECT_EQ(sf.sequence(), before);
  const std::vector<FaceId> bad{0, static_cast<FaceId>(mt.num_faces())};
  EXPECT_THROW(hierarchical_strip(plan, bad), InvalidInput);
  EXPECT_THROW(greedy_strip(mt, bad), InvalidInput);
  const std::vector<FaceId> dup{0, 0};
  EXPECT_THROW(greedy_strip(mt, dup), InvalidInput);
  EXPECT_THROW(encode_strip(mt, StripRuns{{}}), InvalidInput);
  EXPECT_TRUE(decode_strip(std::vector<Index>{}).empty());
  EXPECT_TRUE(decode_strip(std::vector<Index>{kStripRestart, 1, 2, kStripRestart}).empty());
}

// A plan refers to its Mt and a front to its plan: temporaries are refused at compile time.
static_assert(!std::is_constructible_v<StripPlan, Mt>);
static_assert(!std::is_constructible_v<StripPlan, Mt, const StripPlanOptions&>);
static_assert(std::is_constructible_v<StripPlan, const Mt&>);
static_assert(!std::is_constructible_v<StripFront, StripPlan>);
static_assert(std::is_constructible_v<StripFront, const StripPlan&>);

// A criterion or a sink that throws interrupts the query between moves: the strip stays that of the front.
TEST(StripBadInput, ThrowingCriterionOrSinkLeavesAValidStrip) {
  const Mt mt = height_mt(square(), 9);
  const StripPlan plan(mt);
  StripFront sf(plan);
  int calls = 0;
  Query q;
  q.criterion = Criterion::custom([&calls](const ElementBound& b) {
    if (++calls == 40) throw std::runtime_error("criterion failed");
    return b.error <= 0.01f;
  });
  EXPECT_THROW(extract(sf, q), std::runtime_error);
  expect_valid(sf);
  NodeId deep = 0;
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    if (!sf.front().is_applied(n) && !sf.front().can_apply(n)) deep = n;
  ASSERT_NE(deep, 0u);
  EXPECT_THROW(sf.refine(deep, [](NodeId) { throw std::runtime_error("sink"); }), std::runtime_error);
  expect_valid(sf);
  EXPECT_EQ(hierarchical_strip(plan, sf.front().faces()), sf.runs());
}

}  // namespace
}  // namespace varmesh
