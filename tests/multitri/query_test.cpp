// The one query API on MtFront: extract() against a slow reference (the least fixpoint reached by scanning
// every current face until nothing changes), independence from candidate order, update() == extract() for
// monotone criteria from many earlier fronts, triangle budgets against the sorted priority order, focus
// sets, and the ready-made criteria on hand-built bounds whose answer is known by geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"
#include "mt_grid_fixture.hpp"

namespace varmesh {
namespace {

using testing::applied_set;
using testing::GridMt;
using testing::GridMtOptions;
using testing::make_grid_mt;
using testing::projected_area;

// MtFront seen through a shuffle: every candidate list comes out in a random order, so extract()/update()
// visit elements in an order unrelated to the front's face list.
class ShuffledFront {
 public:
  ShuffledFront(MtFront& f, std::uint32_t seed) : f_(&f), rng_(seed) {}
  ElementBound element_bound(Index e) const { return f_->element_bound(e); }
  bool is_refined(Index e) const { return f_->is_refined(e); }
  bool is_coarsenable(Index e) const { return f_->is_coarsenable(e); }
  std::size_t num_faces() const { return f_->num_faces(); }
  std::uint64_t tie_key(Index e) const { return f_->tie_key(e); }
  void reset() { f_->reset(); }
  template <class Sink> void refine(Index e, Sink&& sink) { f_->refine(e, sink); }
  void coarsen_one(Index e) { f_->coarsen_one(e); }
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const {
    emit([&](auto&& g) { f_->for_each_refine_candidate(g); }, fn);
  }
  template <class Fn> void for_each_child_candidate(Index e, Fn&& fn) const {
    emit([&](auto&& g) { f_->for_each_child_candidate(e, g); }, fn);
  }
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const {
    emit([&](auto&& g) { f_->for_each_coarsen_candidate(g); }, fn);
  }
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) const {
    emit([&](auto&& g) { f_->for_each_parent_candidate(e, g); }, fn);
  }

 private:
  template <class Enumerate, class Fn> void emit(Enumerate&& enumerate, Fn&& fn) const {
    std::vector<Index> items;
    enumerate([&](Index e) { items.push_back(e); });
    std::shuffle(items.begin(), items.end(), rng_);
    for (Index e : items) fn(e);
  }
  MtFront* f_;
  mutable std::mt19937 rng_;
};
static_assert(RefinableFront<ShuffledFront>);
static_assert(RefinableFront<MtFront>);

// The slow reference: from the base mesh, scan all current faces (in a random order) and refine the node
// that removes a face whenever the query wants it, until a full scan changes nothing.
std::vector<char> reference_fixpoint(const Mt& mt, const Query& q, std::uint32_t seed) {
  MtFront f(mt);
  std::mt19937 rng(seed);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<FaceId> faces(f.faces().begin(), f.faces().end());
    std::shuffle(faces.begin(), faces.end(), rng);
    for (FaceId face : faces) {
      if (!f.has_face(face)) continue;
      const NodeId d = mt.destroyer(face);
      if (d == kInvalid || f.is_applied(d) || !q.wants(mt.bound(d))) continue;
      f.refine(d);
      changed = true;
    }
  }
  return applied_set(f);
}

std::vector<char> wanted_set(const Mt& mt, const Query& q) {
  std::vector<char> w(mt.num_nodes(), 0);
  w[0] = 1;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) w[n] = q.wants(mt.bound(n)) ? 1 : 0;
  return w;
}

// Budget reference: the wanted nodes sorted by decreasing priority, parents first on ties; the answer is the
// longest prefix applied one by one that stays within the budget. The order must be a linear extension of
// the DAG (every parent before its child) when the criterion is monotone.
std::vector<char> reference_budget(const Mt& mt, const Query& q, bool* stopped_by_budget) {
  std::vector<NodeId> order;
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    if (q.wants(mt.bound(n))) order.push_back(n);
  std::sort(order.begin(), order.end(), [&](NodeId a, NodeId b) {
    const float pa = q.criterion.priority(mt.bound(a)), pb = q.criterion.priority(mt.bound(b));
    return pa > pb || (pa == pb && a < b);
  });
  MtFront f(mt);
  *stopped_by_budget = false;
  for (NodeId n : order) {
    EXPECT_TRUE(f.can_apply(n)) << "priority order is not parents-first at node " << n;
    if (!f.can_apply(n)) break;
    f.apply(n);
    if (f.num_faces() > q.triangle_budget) {
      f.undo(n);
      *stopped_by_budget = true;
      break;
    }
  }
  return applied_set(f);
}

void expect_conforming(const MtFront& f, double domain_area) {
  ASSERT_NO_THROW(f.validate());
  EXPECT_NEAR(projected_area(f), domain_area, 1e-6 * domain_area);
}

// No element exposed by the current mesh is wanted (the fixpoint property).
void expect_nothing_exposed_is_wanted(const MtFront& f, const Query& q) {
  for (FaceId face : f.faces()) {
    const NodeId d = f.mt().destroyer(face);
    if (d != kInvalid) { EXPECT_FALSE(q.wants(f.mt().bound(d))) << "exposed node " << d << " is still wanted"; }
  }
}

void expect_ideal(const Mt& mt, const std::vector<char>& s, const char* what) {
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    if (s[n]) {
      for (NodeId p : mt.parents(n)) EXPECT_TRUE(s[p]) << what << ": node " << n << " wanted, parent " << p << " not";
    }
}

std::size_t count(const std::vector<char>& s) { return static_cast<std::size_t>(std::count(s.begin(), s.end(), 1)); }

float uniform(std::mt19937& rng, float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(rng); }

Camera random_camera(std::mt19937& rng, float domain) {
  Camera c;
  c.eye = {uniform(rng, -0.5f * domain, 1.5f * domain), uniform(rng, -0.5f * domain, 1.5f * domain),
           uniform(rng, 0.3f, 1.2f * domain)};
  c.target = {uniform(rng, 0.2f * domain, 0.8f * domain), uniform(rng, 0.2f * domain, 0.8f * domain), 0.0f};
  c.fov_y_deg = uniform(rng, 30.0f, 70.0f);
  c.aspect = 4.0f / 3.0f;
  c.z_near = 0.05f;
  c.z_far = 10.0f * domain;
  return c;
}

// The families of monotone queries the tests draw from.
enum class Family { kObjectError, kScreenError, kFrustumBackFace, kFeaturePoints, kSilhouette, kFocusBox, kCount };

const char* family_name(Family f) {
  switch (f) {
    case Family::kObjectError: return "object_error";
    case Family::kScreenError: return "screen_error";
    case Family::kFrustumBackFace: return "frustum+back_facing";
    case Family::kFeaturePoints: return "feature points";
    case Family::kSilhouette: return "silhouette";
    case Family::kFocusBox: return "focus box";
    case Family::kCount: break;
  }
  return "?";
}

Query make_query(Family family, std::mt19937& rng, float domain) {
  Query q;
  const float e = 0.6f * std::pow(uniform(rng, 0.0f, 1.0f), 3.0f);
  switch (family) {
    case Family::kObjectError:
      q.criterion = Criterion::object_error(e);
      break;
    case Family::kScreenError: {
      const Camera cam = random_camera(rng, domain);
      q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()),
                                       Criterion::screen_error(cam, 600.0f, uniform(rng, 1.0f, 40.0f))});
      break;
    }
    case Family::kFrustumBackFace: {
      Camera cam = random_camera(rng, domain);
      cam.eye.z = uniform(rng, 0.2f, 0.7f);  // low: some slopes face away
      q.criterion = Criterion::any_of(
          {Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye), Criterion::object_error(e)});
      break;
    }
    case Family::kFeaturePoints: {
      std::vector<glm::vec3> pts;
      for (int k = 0; k < 3; ++k) pts.push_back({uniform(rng, 0.0f, domain), uniform(rng, 0.0f, domain), 0.0f});
      q.criterion = Criterion::any_of({Criterion::away_from_points(pts, uniform(rng, 0.0f, 0.3f)),
                                       Criterion::object_error(0.25f * e)});
      break;
    }
    case Family::kSilhouette: {
      Camera cam = random_camera(rng, domain);
      cam.eye.z = uniform(rng, 0.2f, 0.7f);
      q.criterion = Criterion::any_of({Criterion::away_from_silhouette(cam.eye), Criterion::object_error(0.5f * e)});
      break;
    }
    case Family::kFocusBox: {
      Box3 box;
      box.add({uniform(rng, 0.0f, domain), uniform(rng, 0.0f, domain), -1.0f});
      box.add({uniform(rng, 0.0f, domain), uniform(rng, 0.0f, domain), 1.0f});
      q.focus.boxes.push_back(box);
      q.criterion = Criterion::all_of({Criterion::object_error(0.5f * e), Criterion::object_error(e)});
      break;
    }
    case Family::kCount: break;
  }
  return q;
}

GridMt terrain_mt(int n, int levels, std::uint32_t seed, double swaps = 0.1) {
  GridMtOptions o;
  o.n = n;
  o.levels = levels;
  o.swap_probability = swaps;
  o.height = testing::hills;
  o.seed = seed;
  return make_grid_mt(o);
}

TEST(QueryExtract, MatchesReferenceFixpointForEveryFamily) {
  const GridMt g = terrain_mt(3, 6, 21);
  const Mt& mt = g.mt;
  const float domain = 3.0f;
  std::mt19937 rng(77);
  for (int fam = 0; fam < static_cast<int>(Family::kCount); ++fam) {
    std::size_t nontrivial = 0;
    for (int trial = 0; trial < 12; ++trial) {
      const Family family = static_cast<Family>(fam);
      SCOPED_TRACE(std::string(family_name(family)) + " trial " + std::to_string(trial));
      const Query q = make_query(family, rng, domain);
      MtFront f(mt);
      extract(f, q);
      const auto got = applied_set(f);
      expect_conforming(f, g.domain_area);
      expect_nothing_exposed_is_wanted(f, q);
      EXPECT_EQ(got, reference_fixpoint(mt, q, static_cast<std::uint32_t>(trial)));
      // Monotone criterion on nested bounds: the answer is exactly the wanted nodes (and the source).
      const auto wanted = wanted_set(mt, q);
      expect_ideal(mt, wanted, family_name(family));
      EXPECT_EQ(got, wanted);
      // Visiting order does not matter.
      for (std::uint32_t seed = 1; seed <= 2; ++seed) {
        MtFront f2(mt);
        ShuffledFront sf(f2, seed * 1000u + static_cast<std::uint32_t>(trial));
        extract(sf, q);
        EXPECT_EQ(applied_set(f2), got);
      }
      if (count(got) > 1 && count(got) < mt.num_nodes()) ++nontrivial;
    }
    EXPECT_GE(nontrivial, 4u) << family_name(static_cast<Family>(fam)) << ": too few non-trivial answers";
  }
}

TEST(QueryExtract, ZeroErrorEverywhereIsTheFullMesh) {
  const GridMt g = terrain_mt(2, 5, 3);
  MtFront f(g.mt);
  Query q;
  q.criterion = Criterion::object_error(0.0f);
  extract(f, q);
  EXPECT_EQ(f.num_applied(), g.mt.num_nodes());
  expect_conforming(f, g.domain_area);
  // A threshold above every error keeps the base mesh.
  q.criterion = Criterion::object_error(1e9f);
  extract(f, q);
  EXPECT_EQ(f.num_applied(), 1u);
}

// A criterion that says yes or no at random per element: not monotone.
Criterion random_criterion(std::uint32_t salt, std::uint32_t one_in) {
  return Criterion::custom([salt, one_in](const ElementBound& b) {
    std::uint32_t h = salt;
    for (float v : {b.center.x, b.center.y, b.center.z, b.radius, b.error}) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &v, sizeof bits);
      h = (h ^ bits) * 16777619u;
      h ^= h >> 15;
    }
    return h % one_in != 0;
  });
}

TEST(QueryExtract, NonMonotoneCriterionIsStillALeastFixpointAndConforming) {
  for (bool saturate : {true, false}) {
    GridMtOptions o;
    o.n = 3;
    o.levels = 6;
    o.swap_probability = 0.15;
    o.errors = GridMtOptions::Errors::kRandom;
    o.saturate = saturate;
    o.height = testing::hills;
    o.seed = 5;
    const GridMt g = make_grid_mt(o);
    const Mt& mt = g.mt;
    std::mt19937 rng(8);
    bool saw_non_monotone = false;
    for (std::uint32_t salt = 0; salt < 10; ++salt) {
      SCOPED_TRACE("salt " + std::to_string(salt) + (saturate ? " saturated" : " raw"));
      Query q;
      q.criterion = random_criterion(salt, 2 + salt % 3);
      if (salt % 2) {
        Box3 box;
        box.add({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), -1.0f});
        box.add({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), 1.0f});
        q.focus.boxes.push_back(box);
      }
      const auto wanted = wanted_set(mt, q);
      for (NodeId n = 1; n < mt.num_nodes(); ++n)
        for (NodeId p : mt.parents(n)) saw_non_monotone = saw_non_monotone || (wanted[n] && !wanted[p]);
      MtFront f(mt);
      extract(f, q);
      const auto got = applied_set(f);
      expect_conforming(f, g.domain_area);
      expect_nothing_exposed_is_wanted(f, q);
      EXPECT_EQ(got, reference_fixpoint(mt, q, salt));
      MtFront f2(mt);
      ShuffledFront sf(f2, salt + 99);
      extract(sf, q);
      EXPECT_EQ(applied_set(f2), got);
      // Least: every applied node is wanted or an ancestor of an applied wanted node.
      std::vector<char> needed(mt.num_nodes(), 0);
      needed[0] = 1;
      for (NodeId n = static_cast<NodeId>(mt.num_nodes()); n-- > 1;)
        if (got[n] && (wanted[n] || needed[n]))
          for (NodeId p : mt.parents(n)) needed[p] = 1;
      for (NodeId n = 1; n < mt.num_nodes(); ++n)
        if (got[n]) { EXPECT_TRUE(wanted[n] || needed[n]) << "node " << n << " applied for nothing"; }

      // update() from random fronts: conforming, nothing exposed wanted, at least the extract answer, and
      // every maximal applied node wanted (nothing kept for nothing).
      for (int k = 0; k < 4; ++k) {
        MtFront u(mt);
        for (int s = 0; s < 30; ++s) {
          const NodeId n = static_cast<NodeId>(rng() % mt.num_nodes());
          if (rng() % 3) u.refine(n); else u.coarsen(n);
        }
        update(u, q);
        expect_conforming(u, g.domain_area);
        expect_nothing_exposed_is_wanted(u, q);
        const auto ua = applied_set(u);
        for (NodeId n = 0; n < mt.num_nodes(); ++n) {
          if (got[n]) { EXPECT_TRUE(ua[n]) << "update lost node " << n << " of the least fixpoint"; }
          if (n != 0 && u.can_undo(n)) { EXPECT_TRUE(wanted[n]) << "update kept unwanted maximal node " << n; }
        }
      }
    }
    EXPECT_TRUE(saw_non_monotone);
  }
}

TEST(QueryUpdate, EqualsExtractFromEarlierFronts) {
  const GridMt g = terrain_mt(3, 6, 31);
  const Mt& mt = g.mt;
  const std::size_t base = mt.image_size(0);
  std::size_t finest = 0;
  for (FaceId f = 0; f < mt.num_faces(); ++f) finest += mt.destroyer(f) == kInvalid ? 1 : 0;
  std::mt19937 rng(123);
  MtFront moving(mt);
  MtFront shuffled_state(mt);
  int budget_hits = 0, moved_both_ways = 0, started_elsewhere = 0;
  for (int iter = 0; iter < 160; ++iter) {
    const Family family = static_cast<Family>(rng() % static_cast<unsigned>(Family::kCount));
    Query q = make_query(family, rng, 3.0f);
    if (rng() % 2) q.triangle_budget = base + rng() % (finest - base);
    SCOPED_TRACE(std::string(family_name(family)) + " iter " + std::to_string(iter) +
                 " budget " + std::to_string(q.triangle_budget));
    // Sometimes disturb the earlier front by hand before updating.
    if (iter % 5 == 4)
      for (int s = 0; s < 20; ++s) {
        const NodeId n = static_cast<NodeId>(rng() % mt.num_nodes());
        if (rng() % 2) moving.refine(n); else moving.coarsen(n);
      }
    const auto before = applied_set(moving);
    const QueryStats st = update(moving, q);
    ASSERT_NO_THROW(moving.validate());
    if (st.refined > 0 && st.coarsened > 0) ++moved_both_ways;
    MtFront fresh(mt);
    const QueryStats sx = extract(fresh, q);
    const auto expected = applied_set(fresh);
    EXPECT_EQ(applied_set(moving), expected) << "update() from an earlier front differs from extract()";
    // The same through shuffled candidate lists, from another earlier front.
    ShuffledFront sf(shuffled_state, static_cast<std::uint32_t>(iter));
    update(sf, q);
    EXPECT_EQ(applied_set(shuffled_state), expected) << "shuffled update() differs from extract()";
    if (q.triangle_budget == 0) {
      EXPECT_EQ(expected, wanted_set(mt, q));
    } else {
      bool stopped = false;
      EXPECT_EQ(expected, reference_budget(mt, q, &stopped)) << "extract() is not the largest fitting prefix";
      EXPECT_LE(fresh.num_faces(), q.triangle_budget);
      EXPECT_LE(moving.num_faces(), q.triangle_budget);
      EXPECT_EQ(sx.budget_reached, stopped);
      budget_hits += stopped ? 1 : 0;
    }
    started_elsewhere += before != expected;
  }
  EXPECT_GT(budget_hits, 10);
  EXPECT_GT(moved_both_ways, 10);
  EXPECT_GT(started_elsewhere, 120) << "update() should mostly start from a front other than its answer";
}

TEST(QueryBudget, ExtractIsTheLargestPrefixOfThePriorityOrderThatFits) {
  const GridMt g = terrain_mt(3, 6, 41, 0.2);
  const Mt& mt = g.mt;
  std::mt19937 rng(5);
  int cut = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Family family = static_cast<Family>(trial % static_cast<int>(Family::kCount));
    Query q = make_query(family, rng, 3.0f);
    bool stopped = false;
    q.triangle_budget = 1u << 20;
    const auto all = reference_budget(mt, q, &stopped);
    ASSERT_FALSE(stopped);
    // Budgets between the base mesh and the unbudgeted answer, plus one exactly at it.
    MtFront full(mt);
    extract(full, Query{q.criterion, q.focus, 0, 0.0});
    ASSERT_EQ(applied_set(full), all);
    for (std::size_t budget : {mt.image_size(0), mt.image_size(0) + 1, (mt.image_size(0) + full.num_faces()) / 2,
                               full.num_faces() - 1, full.num_faces()}) {
      SCOPED_TRACE(std::string(family_name(family)) + " trial " + std::to_string(trial) + " budget " +
                   std::to_string(budget));
      q.triangle_budget = budget;
      MtFront f(mt);
      const QueryStats st = extract(f, q);
      expect_conforming(f, g.domain_area);
      EXPECT_LE(f.num_faces(), budget);
      const auto expected = reference_budget(mt, q, &stopped);
      EXPECT_EQ(applied_set(f), expected);
      EXPECT_EQ(st.budget_reached, stopped);
      cut += st.budget_reached ? 1 : 0;
      if (budget == full.num_faces()) {
        EXPECT_EQ(applied_set(f), all);
        EXPECT_FALSE(st.budget_reached);
      }
      MtFront f2(mt);
      ShuffledFront sf(f2, static_cast<std::uint32_t>(trial));
      extract(sf, q);
      EXPECT_EQ(applied_set(f2), expected);
    }
  }
  EXPECT_GT(cut, 120) << "most budgets below the unbudgeted answer should stop the refinement";
}

TEST(QueryBudget, TiesAreBrokenBySmallerTieKeyInExtractAndUpdate) {
  // Every node of a level has the same error: the budget cuts through runs of equal priority.
  GridMtOptions o;
  o.n = 3;
  o.levels = 6;
  o.swap_probability = 0.1;
  o.jitter = false;
  o.height = testing::hills;
  o.seed = 12;
  const GridMt g = make_grid_mt(o);
  const Mt& mt = g.mt;
  const std::size_t base = mt.image_size(0);
  std::mt19937 rng(10);
  MtFront moving(mt);
  int stopped_count = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Query q;
    q.criterion = Criterion::object_error(trial % 3 == 0 ? 0.0f : 0.05f);
    if (trial % 4 == 1) q.focus.spheres.push_back({{uniform(rng, 0, 3), uniform(rng, 0, 3), 0.0f}, uniform(rng, 0.3f, 1.5f)});
    q.triangle_budget = base + 1 + rng() % 900;
    SCOPED_TRACE("trial " + std::to_string(trial) + " budget " + std::to_string(q.triangle_budget));
    MtFront f(mt);
    extract(f, q);
    bool stopped = false;
    EXPECT_EQ(applied_set(f), reference_budget(mt, q, &stopped));
    stopped_count += stopped ? 1 : 0;
    update(moving, q);
    EXPECT_EQ(applied_set(moving), applied_set(f));
  }
  EXPECT_GT(stopped_count, 20);
}

TEST(QueryBudget, BudgetBelowTheBaseMeshKeepsTheBaseMesh) {
  const GridMt g = terrain_mt(2, 5, 4);
  Query q;
  q.criterion = Criterion::object_error(0.0f);
  q.triangle_budget = 1;
  MtFront f(g.mt);
  const QueryStats st = extract(f, q);
  EXPECT_EQ(f.num_applied(), 1u);
  EXPECT_TRUE(st.budget_reached);
  MtFront deep(g.mt);
  for (NodeId n = 0; n < g.mt.num_nodes(); ++n) deep.refine(n);
  update(deep, q);
  EXPECT_EQ(deep.num_applied(), 1u);
  expect_conforming(deep, g.domain_area);
}

TEST(QueryBudget, TimeBudgetGivesAConformingSubsetOfTheAnswer) {
  const GridMt g = terrain_mt(3, 6, 2);
  Query q;
  q.criterion = Criterion::object_error(0.0f);
  q.time_budget_ms = 1e-9;
  MtFront f(g.mt);
  const QueryStats st = extract(f, q);
  expect_conforming(f, g.domain_area);
  EXPECT_TRUE(st.time_reached);
  EXPECT_LT(f.num_applied(), g.mt.num_nodes());
  q.triangle_budget = 100000;
  update(f, q);
  expect_conforming(f, g.domain_area);
}

// A budget too large for integer nanoseconds (or infinite) overflowed into a deadline in the past: the
// query stopped after its first steps.
TEST(QueryBudget, HugeTimeBudgetsAreNoBudget) {
  const GridMt g = terrain_mt(3, 6, 2);
  Query q;
  q.criterion = Criterion::object_error(0.0f);
  MtFront unlimited(g.mt);
  extract(unlimited, q);
  for (const double ms : {1e13, 1e300, std::numeric_limits<double>::infinity()}) {
    q.time_budget_ms = ms;
    MtFront f(g.mt);
    const QueryStats st = extract(f, q);
    EXPECT_FALSE(st.time_reached) << ms;
    EXPECT_EQ(f.num_applied(), unlimited.num_applied()) << ms;
  }
}

TEST(QueryFocus, OutsideTheFocusNothingIsRefined) {
  const GridMt g = terrain_mt(3, 6, 17);
  const Mt& mt = g.mt;
  std::mt19937 rng(3);
  for (int trial = 0; trial < 16; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    Query q;
    q.criterion = Criterion::object_error(0.0f);  // refine everything in focus
    const int shape = trial % 4;
    if (shape == 0) {
      Box3 box;
      box.add({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), -1.0f});
      box.add({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), 1.0f});
      q.focus.boxes.push_back(box);
    } else if (shape == 1) {
      q.focus.spheres.push_back({{uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), 0.0f}, uniform(rng, 0.0f, 0.5f)});
    } else if (shape == 2) {
      q.focus.points.push_back({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), 0.0f});
      q.focus.points.push_back({uniform(rng, 0.0f, 3.0f), uniform(rng, 0.0f, 3.0f), 0.0f});
      q.focus.point_radius = uniform(rng, 0.0f, 0.2f);
    } else {
      q.focus.frusta.push_back(random_camera(rng, 3.0f).frustum());
    }
    MtFront f(mt);
    extract(f, q);
    expect_conforming(f, g.domain_area);
    const auto got = applied_set(f);
    // Exactly the nodes whose sphere meets the focus, and every face not from the base mesh was created
    // by such a node.
    for (NodeId n = 1; n < mt.num_nodes(); ++n)
      EXPECT_EQ(got[n] != 0, q.focus.intersects(mt.bound(n).center, mt.bound(n).radius)) << "node " << n;
    for (FaceId face : f.faces()) {
      const NodeId c = mt.creator(face);
      if (c != 0) { EXPECT_TRUE(q.focus.intersects(mt.bound(c).center, mt.bound(c).radius)); }
    }
    EXPECT_EQ(got, reference_fixpoint(mt, q, static_cast<std::uint32_t>(trial)));
    EXPECT_LT(count(got), mt.num_nodes());
  }
}

TEST(QueryFocus, BoxFocusRefinesOnlyElementsWhoseSphereMeetsTheBox) {
  GridMtOptions o;
  o.n = 4;
  o.levels = 6;
  const GridMt g = make_grid_mt(o);  // planar
  const Mt& mt = g.mt;
  Box3 box;
  box.add({0.2f, 0.3f, -0.1f});
  box.add({0.9f, 1.1f, 0.1f});
  Query q;
  q.focus.boxes.push_back(box);
  q.criterion = Criterion::object_error(0.01f);
  MtFront f(mt);
  extract(f, q);
  expect_conforming(f, g.domain_area);
  std::size_t inside = 0;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    const ElementBound& b = mt.bound(n);
    const bool meets = sphere_intersects_box(b.center, b.radius, box);
    if (f.is_applied(n)) { EXPECT_TRUE(meets) << "node " << n << " refined outside the focus box"; }
    if (meets && b.error > 0.01f) { EXPECT_TRUE(f.is_applied(n)) << "node " << n << " in focus left coarse"; }
    inside += f.is_applied(n) ? 1 : 0;
  }
  EXPECT_GT(inside, 10u);
  // Far corner of the domain: only base faces there.
  for (FaceId face : f.faces()) {
    const auto v = mt.face(face);
    bool far = true;
    for (VertexId x : v) far = far && mt.position(x).x > 2.5f && mt.position(x).y > 2.5f;
    if (far) { EXPECT_EQ(mt.creator(face), 0u) << "face " << face << " far from the box was refined"; }
  }
  // Moving the box with update() equals extracting at the new place.
  Box3 moved;
  moved.add({2.0f, 2.1f, -0.1f});
  moved.add({3.0f, 3.0f, 0.1f});
  q.focus.boxes[0] = moved;
  update(f, q);
  MtFront fresh(mt);
  extract(fresh, q);
  EXPECT_EQ(applied_set(f), applied_set(fresh));
}

// Criteria on hand-built bounds.

ElementBound bound_at(glm::vec3 c, float r, float error = 1.0f, glm::vec3 axis = {0, 0, 1}, float half_deg = 181.0f) {
  ElementBound b;
  b.center = c;
  b.radius = r;
  b.error = error;
  if (half_deg <= 180.0f) b.cone = {glm::normalize(axis), std::cos(glm::radians(half_deg))};
  return b;
}

TEST(QueryCriteria, BackFacingByGeometry) {
  const glm::vec3 eye(0.0f);
  const Criterion c = Criterion::back_facing(eye);
  // Sphere at distance 10, radius 1 (angular radius 5.74 deg); normals within 10 deg of the viewing ray:
  // the viewer sees the back.
  EXPECT_TRUE(c.is_fine(bound_at({0, 0, 10}, 1.0f, 1.0f, {0, 0, 1}, 10.0f)));
  // The same facing the viewer, or sideways: not back-facing.
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 10}, 1.0f, 1.0f, {0, 0, -1}, 10.0f)));
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 10}, 1.0f, 1.0f, {1, 0, 0}, 10.0f)));
  // Threshold: tilt + half angle + angular radius against 90 degrees.
  const float beta = glm::degrees(std::asin(0.1f));
  for (float tilt : {20.0f, 50.0f, 70.0f}) {
    const float half = 90.0f - beta - tilt;
    const glm::vec3 axis(std::sin(glm::radians(tilt)), 0.0f, std::cos(glm::radians(tilt)));
    EXPECT_TRUE(c.is_fine(bound_at({0, 0, 10}, 1.0f, 1.0f, axis, half - 1.0f))) << tilt;
    EXPECT_FALSE(c.is_fine(bound_at({0, 0, 10}, 1.0f, 1.0f, axis, half + 1.0f))) << tilt;
  }
  // No normal information, or the eye inside the sphere: never fine.
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 10}, 1.0f)));
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 0.5f}, 1.0f, 1.0f, {0, 0, 1}, 1.0f)));
  // A NaN cone carries no normal information either, wherever the eye is, and the margin says so: for the
  // silhouette criterion too, and with the margin's answer equal to is_fine's.
  ElementBound nan_cone = bound_at({0, 0, 10}, 1.0f, 1.0f, {0, 0, 1}, 10.0f);
  nan_cone.cone.cos_half_angle = std::numeric_limits<float>::quiet_NaN();
  for (const glm::vec3 e : {glm::vec3(0.0f), glm::vec3(0, 0, 20), glm::vec3(5, 0, 10)})
    for (const Criterion& k : {Criterion::back_facing(e), Criterion::away_from_silhouette(e)}) {
      float margin = 0.0f;
      EXPECT_FALSE(k.is_fine(nan_cone));
      EXPECT_FALSE(k.is_fine_with_margin(nan_cone, margin));
    }
}

TEST(QueryCriteria, AwayFromSilhouetteByGeometry) {
  const glm::vec3 eye(0.0f, 0.0f, 5.0f);
  const Criterion c = Criterion::away_from_silhouette(eye);
  // A flat patch below the eye facing up (towards it): entirely front-facing.
  EXPECT_TRUE(c.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {0, 0, 1}, 5.0f)));
  // Facing down (away): entirely back-facing.
  EXPECT_TRUE(c.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {0, 0, -1}, 5.0f)));
  // Normals perpendicular to the viewing direction: a silhouette may pass there.
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {1, 0, 0}, 5.0f)));
  // A wide cone straddles front and back.
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {0, 0, 1}, 89.0f)));
  EXPECT_FALSE(c.is_fine(bound_at({0, 0, 0}, 0.5f)));
  // Grazing view of the same upward patch from far to the side: the sphere's extent decides.
  const Criterion side = Criterion::away_from_silhouette({100.0f, 0.0f, 1.0f});
  EXPECT_FALSE(side.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {0, 0, 1}, 5.0f)));
  const Criterion above = Criterion::away_from_silhouette({100.0f, 0.0f, 40.0f});
  EXPECT_TRUE(above.is_fine(bound_at({0, 0, 0}, 0.5f, 1.0f, {0, 0, 1}, 5.0f)));
}

TEST(QueryCriteria, OutsideFrustumByGeometry) {
  Camera cam;
  cam.eye = {0, 0, 0};
  cam.target = {0, 10, 0};
  cam.up = {0, 0, 1};
  cam.fov_y_deg = 90.0f;
  cam.aspect = 1.0f;
  cam.z_near = 1.0f;
  cam.z_far = 100.0f;
  const Criterion c = Criterion::outside_frustum(cam.frustum());
  EXPECT_FALSE(c.is_fine(bound_at({0, 10, 0}, 1.0f)));    // straight ahead
  EXPECT_TRUE(c.is_fine(bound_at({0, -10, 0}, 1.0f)));    // behind the eye
  EXPECT_TRUE(c.is_fine(bound_at({0, 200, 0}, 1.0f)));    // beyond the far plane
  EXPECT_TRUE(c.is_fine(bound_at({0, 0.5f, 0}, 0.4f)));   // before the near plane
  EXPECT_FALSE(c.is_fine(bound_at({0, 0.5f, 0}, 0.6f)));  // reaching through the near plane
  // The right plane at 90 degrees of view is x = y: distance of (x, 10, 0) to it is (x - 10) / sqrt 2.
  const float s2 = std::sqrt(2.0f);
  EXPECT_TRUE(c.is_fine(bound_at({14, 10, 0}, 4.0f / s2 - 0.01f)));
  EXPECT_FALSE(c.is_fine(bound_at({14, 10, 0}, 4.0f / s2 + 0.01f)));
  // Above (the top plane is z = y).
  EXPECT_TRUE(c.is_fine(bound_at({0, 10, 13}, 3.0f / s2 - 0.01f)));
  EXPECT_FALSE(c.is_fine(bound_at({0, 10, 13}, 3.0f / s2 + 0.01f)));
}

TEST(QueryCriteria, ScreenErrorByGeometry) {
  Camera cam;
  cam.eye = {0, 0, 0};
  cam.target = {0, 0, -1};
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 90.0f;  // tan(45) = 1: 200 pixels high -> 100 pixels per unit at distance 1
  EXPECT_NEAR(cam.pixels_per_unit_at_distance_one(200.0f), 100.0f, 1e-3f);
  const Criterion c5 = Criterion::screen_error(cam, 200.0f, 5.1f);
  const Criterion c49 = Criterion::screen_error(cam, 200.0f, 4.9f);
  // Distance to the sphere 10; error 0.5 -> 5 pixels.
  const ElementBound b = bound_at({0, 0, -11}, 1.0f, 0.5f);
  EXPECT_TRUE(c5.is_fine(b));
  EXPECT_FALSE(c49.is_fine(b));
  EXPECT_NEAR(c5.priority(b), 5.0f, 1e-4f);
  // Twice as far: half the pixels.
  EXPECT_NEAR(c5.priority(bound_at({0, 0, -21}, 1.0f, 0.5f)), 2.5f, 1e-4f);
  // In any direction (the criterion is about distance, not about the view direction).
  EXPECT_TRUE(c5.is_fine(bound_at({11, 0, 0}, 1.0f, 0.5f)));
  // Eye inside the sphere: only a zero error is fine.
  EXPECT_FALSE(c5.is_fine(bound_at({0, 0, -0.5f}, 1.0f, 1e-6f)));
  EXPECT_TRUE(c5.is_fine(bound_at({0, 0, -0.5f}, 1.0f, 0.0f)));
  EXPECT_THROW(Criterion::screen_error(cam, 200.0f, 0.0f), InvalidInput);
  EXPECT_THROW(Criterion::screen_error(cam, 0.0f, 1.0f), InvalidInput);
}

TEST(QueryCriteria, ObjectErrorPointsAndCombinators) {
  const Criterion e1 = Criterion::object_error(1.0f), e2 = Criterion::object_error(2.0f);
  EXPECT_TRUE(e1.is_fine(bound_at({}, 1.0f, 1.0f)));
  EXPECT_FALSE(e1.is_fine(bound_at({}, 1.0f, 1.5f)));
  const Criterion both = Criterion::all_of({e1, e2}), either = Criterion::any_of({e1, e2});
  for (float err : {0.5f, 1.5f, 2.5f}) {
    const ElementBound b = bound_at({}, 1.0f, err);
    EXPECT_EQ(both.is_fine(b), err <= 1.0f) << err;
    EXPECT_EQ(either.is_fine(b), err <= 2.0f) << err;
  }
  const Criterion yes = Criterion::custom([](const ElementBound&) { return true; });
  const Criterion no = Criterion::custom([](const ElementBound&) { return false; });
  const ElementBound b = bound_at({}, 1.0f);
  EXPECT_TRUE(Criterion::all_of({yes, yes}).is_fine(b));
  EXPECT_FALSE(Criterion::all_of({yes, no}).is_fine(b));
  EXPECT_TRUE(Criterion::any_of({no, yes}).is_fine(b));
  EXPECT_FALSE(Criterion::any_of({no, no}).is_fine(b));
  EXPECT_TRUE(Criterion::any_of({no, Criterion::all_of({yes, Criterion::any_of({no, yes})})}).is_fine(b));
  EXPECT_THROW(Criterion::all_of({}), InvalidInput);
  EXPECT_THROW(Criterion::any_of({}), InvalidInput);
  EXPECT_THROW(Criterion::object_error(-1.0f), InvalidInput);
  EXPECT_THROW(Criterion::custom({}), InvalidInput);

  const Criterion pts = Criterion::away_from_points({{0, 0, 0}, {10, 0, 0}}, 1.0f);
  EXPECT_FALSE(pts.is_fine(bound_at({1.5f, 0, 0}, 0.6f)));   // within radius 1 of the first point
  EXPECT_TRUE(pts.is_fine(bound_at({1.7f, 0, 0}, 0.6f)));
  EXPECT_FALSE(pts.is_fine(bound_at({8.5f, 0, 0}, 0.6f)));
  EXPECT_TRUE(pts.is_fine(bound_at({5.0f, 0, 0}, 0.6f)));
  EXPECT_TRUE(Criterion::away_from_points({}, 1.0f).is_fine(b));
  // Priority: object error without a screen leaf; the largest screen error of the screen leaves otherwise.
  EXPECT_EQ(both.priority(bound_at({}, 1.0f, 3.0f)), 3.0f);
  Camera cam;
  cam.eye = {0, 0, 0};
  cam.target = {0, 0, -1};
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 90.0f;
  const Criterion s = Criterion::any_of({Criterion::object_error(0.1f), Criterion::screen_error(cam, 200.0f, 1.0f),
                                         Criterion::all_of({Criterion::screen_error(cam, 400.0f, 1.0f)})});
  EXPECT_NEAR(s.priority(bound_at({0, 0, -11}, 1.0f, 0.5f)), 10.0f, 1e-4f);
}

// Random nested bounds: the child's sphere inside the parent's, error not larger, cone inside.
void nested_pair(std::mt19937& rng, ElementBound& parent, ElementBound& child) {
  parent.center = {uniform(rng, -5, 5), uniform(rng, -5, 5), uniform(rng, -5, 5)};
  parent.radius = uniform(rng, 0.01f, 2.0f);
  parent.error = uniform(rng, 0.0f, 1.0f);
  const bool has_cone = rng() % 4 != 0;
  const float parent_half = uniform(rng, 0.0f, 80.0f);
  glm::vec3 axis{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
  if (glm::length(axis) < 0.1f) axis = {0, 0, 1};
  axis = glm::normalize(axis);
  if (has_cone) parent.cone = {axis, std::cos(glm::radians(parent_half))};
  const float shrink = uniform(rng, 0.0f, 1.0f);
  child.radius = parent.radius * shrink * 0.99f;
  glm::vec3 dir{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
  if (glm::length(dir) < 0.1f) dir = {1, 0, 0};
  child.center = parent.center + glm::normalize(dir) * (parent.radius * 0.99f - child.radius) * uniform(rng, 0.0f, 1.0f);
  child.error = parent.error * uniform(rng, 0.0f, 1.0f);
  if (rng() % 3 == 0) child.error = parent.error;
  if (has_cone) {
    const float child_half = parent_half * uniform(rng, 0.0f, 0.95f);
    // Tilt the child axis within the room left (minus a margin), about a random perpendicular.
    const float tilt = glm::radians((parent_half - child_half) * uniform(rng, 0.0f, 0.95f));
    glm::vec3 perp = glm::cross(axis, glm::vec3(0.3f, 0.5f, 0.8f));
    if (glm::length(perp) < 1e-3f) perp = glm::cross(axis, glm::vec3(1, 0, 0));
    perp = glm::normalize(perp);
    child.cone = {glm::normalize(axis * std::cos(tilt) + perp * std::sin(tilt)), std::cos(glm::radians(child_half))};
  } else {
    child.cone = {};
  }
}

// all_of / any_of evaluate their parts cheapest kind first and stop at the first deciding part; whatever
// order the parts are given in, the answer is the AND / OR of the parts' answers, and is_fine_with_margin()
// gives the same answer with a margin >= 0 (the margins' promise is checked in QueryCoherence below).
TEST(QueryCriteria, CombinatorsAreTheOrAndOfTheirLeavesInEveryOrder) {
  std::mt19937 rng(606);
  std::size_t fine_any = 0, fine_all = 0, cases = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Camera cam = random_camera(rng, 6.0f);
    const std::vector<Criterion> leaves = {
        Criterion::screen_error(cam, 600.0f, uniform(rng, 0.5f, 30.0f)),
        Criterion::back_facing(cam.eye),
        Criterion::object_error(uniform(rng, 0.0f, 1.0f)),
        Criterion::outside_frustum(cam.frustum()),
        Criterion::away_from_silhouette(cam.eye),
    };
    for (int k = 0; k < 8; ++k) {
      ElementBound b, unused;
      nested_pair(rng, b, unused);
      std::vector<bool> leaf_fine;
      for (const Criterion& c : leaves) leaf_fine.push_back(c.is_fine(b));
      std::vector<std::size_t> order = {0, 1, 2, 3, 4};
      do {
        std::vector<Criterion> parts;
        bool any = false, all = true;
        for (std::size_t i : order) {
          parts.push_back(leaves[i]);
          any = any || leaf_fine[i];
          all = all && leaf_fine[i];
        }
        const Criterion a = Criterion::any_of(parts), l = Criterion::all_of(parts);
        // Nested: any_of(first two, all_of(the rest)) in the given order.
        const Criterion nested = Criterion::any_of(
            {parts[0], Criterion::all_of({parts[2], parts[3], parts[4]}), parts[1]});
        const bool nested_expect =
            leaf_fine[order[0]] || leaf_fine[order[1]] || (leaf_fine[order[2]] && leaf_fine[order[3]] && leaf_fine[order[4]]);
        ASSERT_EQ(a.is_fine(b), any) << "trial " << trial;
        ASSERT_EQ(l.is_fine(b), all) << "trial " << trial;
        ASSERT_EQ(nested.is_fine(b), nested_expect) << "trial " << trial;
        for (const Criterion* c : {&a, &l, &nested}) {
          float margin = -1.0f;
          ASSERT_EQ(c->is_fine_with_margin(b, margin), c->is_fine(b)) << "trial " << trial;
          ASSERT_GE(margin, 0.0f);
        }
        fine_any += any;
        fine_all += all;
        ++cases;
      } while (std::next_permutation(order.begin(), order.end()));
    }
  }
  // Both answers occur for both combinators.
  EXPECT_GT(fine_any, cases / 20);
  EXPECT_LT(fine_any, cases);
  EXPECT_GT(fine_all, 0u);
  EXPECT_LT(fine_all, cases / 2);
}

TEST(QueryCriteria, MonotoneOnNestedBounds) {
  std::mt19937 rng(2024);
  std::size_t flips = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const Camera cam = random_camera(rng, 10.0f);
    Camera near_cam = cam;
    near_cam.eye = {uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
    std::vector<Criterion> all = {
        Criterion::object_error(uniform(rng, 0.0f, 1.0f)),
        Criterion::screen_error(cam, 600.0f, uniform(rng, 0.5f, 30.0f)),
        Criterion::screen_error(near_cam, 600.0f, uniform(rng, 0.5f, 30.0f)),
        Criterion::outside_frustum(cam.frustum()),
        Criterion::outside_frustum(near_cam.frustum()),
        Criterion::back_facing(near_cam.eye),
        Criterion::away_from_silhouette(near_cam.eye),
        Criterion::away_from_points({near_cam.eye, cam.target}, uniform(rng, 0.0f, 2.0f)),
    };
    all.push_back(Criterion::any_of({all[3], all[5], all[1]}));
    all.push_back(Criterion::all_of({all[2], all[6]}));
    ElementBound parent, child;
    nested_pair(rng, parent, child);
    for (std::size_t k = 0; k < all.size(); ++k) {
      const bool child_wanted = !all[k].is_fine(child), parent_wanted = !all[k].is_fine(parent);
      if (child_wanted) { EXPECT_TRUE(parent_wanted) << "criterion " << k << " trial " << trial; }
      EXPECT_GE(all[k].priority(parent), all[k].priority(child)) << "criterion " << k << " trial " << trial;
      flips += child_wanted != parent_wanted ? 1 : 0;
    }
  }
  EXPECT_GT(flips, 1000u);  // the pairs do exercise the thresholds
}

TEST(QueryCriteria, FocusSetShapes) {
  FocusSet everywhere;
  EXPECT_TRUE(everywhere.everywhere());
  EXPECT_TRUE(everywhere.intersects({1e6f, 0, 0}, 0.0f));
  FocusSet f;
  Box3 box;
  box.add({0, 0, 0});
  box.add({1, 1, 1});
  f.boxes.push_back(box);
  EXPECT_TRUE(f.intersects({0.5f, 0.5f, 0.5f}, 0.0f));
  EXPECT_TRUE(f.intersects({2.0f, 0.5f, 0.5f}, 1.01f));
  EXPECT_FALSE(f.intersects({2.0f, 0.5f, 0.5f}, 0.99f));
  // Near a corner the distance is Euclidean, not per axis.
  EXPECT_FALSE(f.intersects({2.0f, 2.0f, 0.5f}, 1.2f));
  EXPECT_TRUE(f.intersects({2.0f, 2.0f, 0.5f}, 1.5f));
  FocusSet p;
  p.points.push_back({5, 0, 0});
  p.point_radius = 1.0f;
  EXPECT_TRUE(p.intersects({3.5f, 0, 0}, 0.6f));
  EXPECT_FALSE(p.intersects({3.5f, 0, 0}, 0.4f));
  FocusSet s;
  s.spheres.push_back({{0, 0, 5}, 2.0f});
  EXPECT_TRUE(s.intersects({0, 0, 2.5f}, 0.6f));
  EXPECT_FALSE(s.intersects({0, 0, 2.5f}, 0.4f));
  // The union of the shapes.
  FocusSet u = p;
  u.spheres = s.spheres;
  EXPECT_TRUE(u.intersects({0, 0, 2.5f}, 0.6f));
  EXPECT_TRUE(u.intersects({3.5f, 0, 0}, 0.6f));
  EXPECT_FALSE(u.intersects({-5, 0, 0}, 0.6f));
}

// Bounds helpers (bounds.hpp): the enclosing sphere and cone really enclose, on random inputs.

glm::vec3 random_unit(std::mt19937& rng) {
  for (;;) {
    const glm::vec3 v(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
    const float l = glm::length(v);
    if (l > 0.1f && l <= 1.0f) return v / l;
  }
}

// A unit vector at angle `angle` (radians) from the unit vector `axis`, in a random direction around it.
glm::vec3 tilted(const glm::vec3& axis, float angle, std::mt19937& rng) {
  glm::vec3 perp = glm::cross(axis, random_unit(rng));
  while (glm::length(perp) < 1e-3f) perp = glm::cross(axis, random_unit(rng));
  perp = glm::normalize(perp);
  return glm::normalize(axis * std::cos(angle) + perp * std::sin(angle));
}

TEST(QueryBounds, EncloseSpheresContainsBoth) {
  std::mt19937 rng(6);
  for (int trial = 0; trial < 5000; ++trial) {
    const Sphere a{{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)}, uniform(rng, 0.0f, 5.0f)};
    Sphere b{{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)}, uniform(rng, 0.0f, 5.0f)};
    if (trial % 4 == 0) b.center = a.center + (b.center - a.center) * 0.01f;  // nearly concentric
    if (trial % 7 == 0) b = a;
    const Sphere s = enclose(a, b);
    for (const Sphere& x : {a, b}) EXPECT_LE(glm::length(x.center - s.center) + x.radius, s.radius) << trial;
    // And it is the smallest one (up to the documented slack).
    const float best = std::max({a.radius, b.radius, 0.5f * (glm::length(a.center - b.center) + a.radius + b.radius)});
    EXPECT_LE(s.radius, best * 1.0001f + 1e-5f) << trial;
  }
}

TEST(QueryBounds, BoundingSphereContainsThePoints) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<glm::vec3> pts(1 + rng() % 20);
    for (auto& p : pts) p = {uniform(rng, -100, 100), uniform(rng, -1, 1), uniform(rng, 0, 1000)};
    const Sphere s = bounding_sphere(pts.data(), pts.size());
    for (const auto& p : pts) EXPECT_LE(glm::length(p - s.center), s.radius);
  }
  EXPECT_EQ(bounding_sphere(nullptr, 0).radius, 0.0f);
}

TEST(QueryBounds, EncloseConesContainsBothOrIsFull) {
  std::mt19937 rng(8);
  int full = 0, partial = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    NormalCone a{random_unit(rng), std::cos(uniform(rng, 0.0f, 1.2f))};
    NormalCone b{trial % 5 == 0 ? tilted(a.axis, uniform(rng, 0.0f, 0.3f), rng) : random_unit(rng),
                 std::cos(uniform(rng, 0.0f, 1.2f))};
    if (trial % 11 == 0) b = a;
    const NormalCone c = enclose(a, b);
    if (c.is_full()) {
      ++full;
      continue;
    }
    ++partial;
    EXPECT_NEAR(glm::length(c.axis), 1.0f, 1e-5f);
    for (const NormalCone& x : {a, b})
      for (int k = 0; k < 20; ++k) {
        // Directions on the rim of x (the worst case) and inside it.
        const float half = std::acos(std::clamp(x.cos_half_angle, -1.0f, 1.0f));
        const glm::vec3 n = tilted(x.axis, k < 10 ? half : half * uniform(rng, 0.0f, 1.0f), rng);
        EXPECT_GE(glm::dot(n, c.axis), c.cos_half_angle - 1e-5f) << "trial " << trial;
      }
  }
  EXPECT_GT(partial, 500);
  EXPECT_GT(full, 100);
  // A full cone absorbs everything.
  EXPECT_TRUE(enclose(NormalCone{}, NormalCone{{0, 0, 1}, 0.9f}).is_full());
  EXPECT_TRUE(enclose(NormalCone{{0, 0, 1}, 0.9f}, NormalCone{{0, 0, -1}, 0.9f}).is_full());
}

// --- frame-to-frame coherence (QueryCoherence) -----------------------------------------------------------

// A camera on a circle around the terrain, looking at its middle: step k of n per turn.
Camera orbit_camera(int k, int steps_per_turn, float domain, float height) {
  Camera c;
  const float a = 6.2831853f * float(k) / float(steps_per_turn);
  c.target = {0.5f * domain, 0.5f * domain, 0.0f};
  c.eye = c.target + glm::vec3(std::cos(a), std::sin(a), 0.0f) * (0.9f * domain) + glm::vec3(0.0f, 0.0f, height);
  c.fov_y_deg = 50.0f;
  c.aspect = 4.0f / 3.0f;
  c.z_near = 0.05f;
  c.z_far = 10.0f * domain;
  return c;
}

// The view-dependent criterion of the benches, plus the silhouette and feature-point leaves.
Criterion view_criterion(const Camera& cam, float pixels, int variant) {
  switch (variant % 3) {
    case 0:
      return Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                Criterion::screen_error(cam, 600.0f, pixels)});
    case 1:
      return Criterion::all_of({Criterion::any_of({Criterion::away_from_silhouette(cam.eye), Criterion::object_error(0.02f)}),
                                Criterion::screen_error(cam, 600.0f, pixels)});
    default:
      return Criterion::any_of({Criterion::outside_frustum(cam.frustum()),
                                Criterion::all_of({Criterion::screen_error(cam, 600.0f, pixels),
                                                   Criterion::away_from_points({{1.0f, 1.0f, 0.0f}}, 0.2f)})});
  }
}

// The margin is a promise: while the view moves less than it (as motion_to measures), is_fine() keeps its
// answer. Checked on random bounds against random small and large camera moves.
TEST(QueryCoherence, MarginsAreConservative) {
  std::mt19937 rng(77);
  std::size_t checked = 0, flipped = 0, kept_with_margin = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    ElementBound b, unused;
    nested_pair(rng, b, unused);
    Camera a = random_camera(rng, 6.0f);
    a.eye -= glm::vec3(3.0f, 3.0f, 0.0f);
    a.target -= glm::vec3(3.0f, 3.0f, 0.0f);
    Camera z = a;
    const float step = std::pow(10.0f, uniform(rng, -4.0f, 0.0f));
    z.eye += glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)) * step;
    z.target += glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)) * step;
    const int variant = static_cast<int>(rng() % 3);
    const float pixels = uniform(rng, 0.5f, 30.0f);
    const Criterion ca = view_criterion(a, pixels, variant), cz = view_criterion(z, pixels, variant);
    const glm::vec3 origin(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
    double turn = 0.0, shift = 0.0;
    ASSERT_TRUE(ca.motion_to(cz, origin, turn, shift));
    float margin = -1.0f;
    const bool fine_a = ca.is_fine_with_margin(b, margin);
    ASSERT_GE(margin, 0.0f);
    EXPECT_EQ(fine_a, ca.is_fine(b));
    const bool fine_z = cz.is_fine(b);
    flipped += fine_a != fine_z;
    const double move = turn * glm::length(b.center - origin) + shift;
    if (move < double(margin)) {
      ++checked;
      kept_with_margin += fine_a == fine_z;
      EXPECT_EQ(fine_a, fine_z) << "trial " << trial << ": margin " << margin << " but the move " << move
                                << " changed the answer";
    }
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_EQ(kept_with_margin, checked);
  EXPECT_GT(flipped, 20u);  // the moves are large enough to change answers
  // A changed threshold or feature point set carries nothing over.
  const Camera cam = orbit_camera(0, 8, 3.0f, 1.0f);
  double turn = 0.0, shift = 0.0;
  EXPECT_FALSE(view_criterion(cam, 2.0f, 0).motion_to(view_criterion(cam, 3.0f, 0), {}, turn, shift));
  EXPECT_FALSE(view_criterion(cam, 2.0f, 0).motion_to(view_criterion(cam, 2.0f, 1), {}, turn, shift));
  EXPECT_FALSE(Criterion::away_from_points({{0, 0, 0}}, 1.0f)
                   .motion_to(Criterion::away_from_points({{0, 0, 1}}, 1.0f), {}, turn, shift));
}

// The back-facing margin where it is tightest, checked through back_facing() and away_from_silhouette():
// tilt + half-angle + angular radius near 90 degrees; cones from nearly a ray (cos_half_angle a few ulps
// below 1) to nearly a half-space, and full ones; spheres of radius 0 to large, seen from far and from just
// outside. The eye moves by exactly the margin and by less, along c - eye (the distance, hence the angular
// radius, changes fastest) and perpendicular to it (c - eye turns fastest; in the plane of the axis the tilt
// changes fastest). A turn rate below 1 / dist, e.g. (pi / 4) / dist, fails here. The last kind of trial puts
// the eye just outside the sphere and near the origin at half an ulp of the centre's coordinates, where
// moves far below any margin carry c - eye to the neighbouring floats: the rounding of the decision grows
// like 1 / cos(beta) there, and a slack that ignores this fails.
TEST(QueryCoherence, FacingMarginsHoldForWorstCaseMoves) {
  constexpr float kHalfPi = 1.5707963f;
  std::mt19937 rng(2024);
  auto power_of_ten = [&rng](float lo, float hi) { return std::pow(10.0f, uniform(rng, lo, hi)); };
  std::size_t positive = 0, checked = 0, beyond = 0;
  for (int trial = 0; trial < 80000; ++trial) {
    const int kind = trial % 4;  // eye far, near, just outside the sphere, at a rounding boundary
    ElementBound b;
    glm::vec3 eye(0.0f);
    glm::vec3 half_ulp(0.0f);
    if (kind == 3) {
      b.radius = uniform(rng, 0.5f, 1.0f);
      b.center = random_unit(rng) * (b.radius * (1.0f + power_of_ten(-7.0f, -1.0f)));
      if (std::fabs(b.center.x) < 0.05f || std::fabs(b.center.y) < 0.05f || std::fabs(b.center.z) < 0.05f) continue;
      for (int i = 0; i < 3; ++i) {
        const float a = std::fabs(b.center[i]);
        half_ulp[i] = std::copysign(0.5f * (std::nextafter(a, 2.0f * a) - a), b.center[i]);
      }
    } else {
      const float scale = power_of_ten(-3.0f, 3.0f);
      b.center = glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)) * scale *
                 (trial % 7 == 0 ? 1000.0f : 1.0f);
      b.radius = trial % 5 == 0 ? 0.0f : scale * power_of_ten(-6.0f, 0.0f);
      const float dist = kind == 0   ? b.radius + scale * power_of_ten(-3.0f, 2.0f)
                         : kind == 1 ? b.radius + scale * uniform(rng, 0.0f, 3.0f)
                                     : b.radius * (1.0f + power_of_ten(-7.0f, -1.0f));
      eye = b.center - random_unit(rng) * dist;
    }
    // Eyes at the rounding boundary: each coordinate half an ulp of the centre's, less or more by 1e-5 of it.
    auto boundary_eye = [&half_ulp](unsigned mask) {
      glm::vec3 e;
      for (int i = 0; i < 3; ++i) e[i] = half_ulp[i] * ((mask >> i & 1u) ? 1.00001f : 0.99999f);
      return e;
    };
    if (kind == 3) eye = boundary_eye(static_cast<unsigned>(rng() % 8));
    const glm::vec3 d = b.center - eye;
    const float dist = glm::length(d);
    if (!(dist > b.radius)) continue;
    const glm::vec3 w = d / dist;
    const float beta = std::asin(std::min(1.0f, b.radius / dist));
    // The cone: tilt + half-angle + beta near 90 degrees, or anywhere.
    float alpha = 0.0f, tilt = 0.0f;
    const int shape = (trial / 4) % 4;
    if (kind == 3) {
      alpha = std::max(0.0f, kHalfPi - beta + uniform(rng, -1, 1) * power_of_ten(-6.0f, -2.0f));
      tilt = uniform(rng, 0.0f, 1.0f) * power_of_ten(-7.0f, -1.0f);
    } else {
      alpha = shape == 0 ? power_of_ten(-5.0f, -1.0f) : shape == 1 ? kHalfPi - power_of_ten(-5.0f, -1.0f)
                                                                   : uniform(rng, 0.0f, kHalfPi);
      const float off = trial % 3 == 0 ? uniform(rng, -1, 1) : (rng() & 1u ? 1.0f : -1.0f) * power_of_ten(-7.0f, -1.0f);
      tilt = std::clamp(kHalfPi - alpha - beta + off, 0.0f, 3.1415926f);
    }
    b.cone.axis = tilted(w, tilt, rng);
    b.cone.cos_half_angle = std::cos(alpha);
    if (kind != 3 && shape == 3)  // a few ulps below 1 (cos_half_angle^2 rounds worst near 1)
      b.cone.cos_half_angle = 1.0f - std::ldexp(float(1 + rng() % 3), -static_cast<int>(1 + rng() % 24));
    if (trial % 97 == 0) b.cone = NormalCone{};  // full: never fine, margin infinite
    if (trial % 8 == 5) b.cone.axis = -b.cone.axis;  // the front-facing side for the silhouette

    // Directions: along c - eye, perpendicular in the plane of the axis (both ways), out of that plane, random.
    glm::vec3 in_plane = glm::cross(glm::cross(w, b.cone.axis), w);
    in_plane = glm::length(in_plane) > 1e-6f ? glm::normalize(in_plane) : tilted(w, kHalfPi, rng);
    const glm::vec3 dirs[] = {w, -w, in_plane, -in_plane, glm::normalize(glm::cross(w, in_plane)), random_unit(rng)};
    for (int which = 0; which < 2; ++which) {
      const Criterion c = which == 0 ? Criterion::back_facing(eye) : Criterion::away_from_silhouette(eye);
      float margin = -1.0f;
      const bool fine = c.is_fine_with_margin(b, margin);
      ASSERT_EQ(fine, c.is_fine(b)) << "trial " << trial;
      ASSERT_GE(margin, 0.0f);
      if (!(margin > 0.0f)) continue;
      ++positive;
      auto expect_kept = [&](const glm::vec3& moved) {
        if (glm::length(glm::dvec3(moved) - glm::dvec3(eye)) > double(margin)) return;  // rounded beyond
        ++checked;
        const Criterion cm = which == 0 ? Criterion::back_facing(moved) : Criterion::away_from_silhouette(moved);
        EXPECT_EQ(cm.is_fine(b), fine) << "trial " << trial << " kind " << kind << ": margin " << margin
                                       << " but a move of " << glm::length(moved - eye) << " changed the answer";
      };
      if (kind == 3) {
        for (unsigned mask = 0; mask < 8; ++mask) expect_kept(boundary_eye(mask));
        continue;
      }
      const float step = std::isinf(margin) ? 1000.0f * dist : margin;
      for (const glm::vec3& v : dirs) {
        expect_kept(eye + v * step);
        expect_kept(eye + v * (step * uniform(rng, 0.0f, 1.0f)));
      }
      // The margins are not so small that no decision is near: 4 times as far, some answers change.
      if (!std::isinf(margin)) {
        for (const glm::vec3& v : {in_plane, -in_plane, w, -w}) {
          const glm::vec3 moved = eye + v * (4.0f * margin);
          const Criterion cm = which == 0 ? Criterion::back_facing(moved) : Criterion::away_from_silhouette(moved);
          beyond += cm.is_fine(b) != fine;
        }
      }
    }
  }
  EXPECT_GT(positive, 60000u);
  EXPECT_GT(checked, 600000u);
  EXPECT_GT(beyond, 10000u);
}

// update() with coherence returns exactly extract()'s front along camera paths (small steps, jumps,
// changed criteria, budgets and focus sets in between), and reuses answers on small steps.
TEST(QueryCoherence, UpdateWithCoherenceEqualsExtract) {
  const GridMt g = terrain_mt(3, 6, 41);
  const Mt& mt = g.mt;
  MtFront coherent(mt), plain(mt);
  QueryCoherence coherence;
  std::mt19937 rng(8);
  std::size_t reused = 0, evaluated_coherent = 0, evaluated_plain = 0;
  int variant = 0;
  float pixels = 2.0f, height = 1.0f;
  for (int frame = 0; frame < 240; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    if (frame % 60 == 59) variant++;                      // another criterion shape
    if (frame % 45 == 44) pixels *= 1.5f;                 // another threshold
    if (frame % 37 == 36) height = uniform(rng, 0.3f, 2.0f);  // a jump
    Query q;
    q.criterion = view_criterion(orbit_camera(frame, 120, 3.0f, height), pixels, variant);
    if (frame % 50 == 25) q.triangle_budget = 200;        // falls back to plain update()
    if (frame % 50 == 30) q.focus.spheres.push_back({{1.5f, 1.5f, 0.0f}, 0.7f});
    const QueryStats sc = update(coherent, q, coherence);
    const QueryStats sp = update(plain, q);
    reused += sc.reused;
    evaluated_coherent += sc.evaluated;
    evaluated_plain += sp.evaluated;
    MtFront fresh(mt);
    extract(fresh, q);
    ASSERT_EQ(applied_set(coherent), applied_set(fresh));
    ASSERT_EQ(applied_set(plain), applied_set(fresh));
    if (frame % 40 == 0) {
      ASSERT_NO_THROW(coherent.validate());
    }
  }
  EXPECT_GT(reused, evaluated_coherent / 2);  // most answers come from memory on a slow orbit
  EXPECT_LT(evaluated_coherent, evaluated_plain / 2);
}


TEST(QueryValidation, CriterionFactoriesRefuseBrokenViews) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Camera> broken(7);
  broken[0].target = broken[0].eye;
  broken[1].eye.x = nan;
  broken[2].fov_y_deg = 180.0f;
  broken[3].fov_y_deg = 270.0f;
  broken[4].aspect = 0.0f;
  broken[5].z_near = 10.0f;
  broken[5].z_far = 1.0f;
  broken[6].up = glm::vec3(0.0f);
  for (std::size_t i = 0; i < broken.size(); ++i)
    EXPECT_THROW(Criterion::screen_error(broken[i], 1080.0f, 1.0f), InvalidInput) << "camera " << i;
  EXPECT_THROW(Criterion::screen_error(Camera{}, std::numeric_limits<float>::infinity(), 1.0f), InvalidInput);
  Frustum nan_plane = Camera{}.frustum();
  nan_plane.planes[2].n.x = nan;
  EXPECT_THROW(Criterion::outside_frustum(nan_plane), InvalidInput);
  EXPECT_THROW(Criterion::back_facing({nan, 0.0f, 0.0f}), InvalidInput);
  EXPECT_THROW(Criterion::away_from_silhouette({0.0f, std::numeric_limits<float>::infinity(), 0.0f}), InvalidInput);
  try {
    Criterion::away_from_points({{0, 0, 0}, {nan, 0, 0}}, 1.0f);
    ADD_FAILURE() << "a NaN feature point was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 1u);
  }
  EXPECT_THROW(Criterion::away_from_points({}, std::numeric_limits<float>::infinity()), InvalidInput);
}

TEST(QueryValidation, ABrokenFocusSetIsRefusedBeforeTheFrontMoves) {
  const GridMt g = make_grid_mt(GridMtOptions{});
  MtFront front(g.mt);
  Query fine;
  fine.criterion = Criterion::object_error(0.1f);
  extract(front, fine);
  const std::size_t applied = front.num_applied();
  ASSERT_GT(applied, 1u);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<FocusSet> broken(6);
  broken[0].frusta.push_back(Camera{}.frustum());
  broken[0].frusta.back().planes[4].d = nan;  // as a camera with a NaN field would give
  Box3 box;
  box.lo = glm::vec3(nan);
  box.hi = glm::vec3(nan);
  broken[1].boxes.push_back(box);
  broken[2].spheres.push_back({glm::vec3(0.0f), -1.0f});
  broken[3].spheres.push_back({glm::vec3(nan), 1.0f});
  broken[4].points.push_back(glm::vec3(0.5f));
  broken[4].point_radius = -0.5f;
  broken[5].points.push_back({0.0f, nan, 0.0f});
  QueryCoherence coherence;
  for (std::size_t i = 0; i < broken.size(); ++i) {
    Query q;
    q.criterion = Criterion::object_error(0.0f);
    q.focus = broken[i];
    EXPECT_THROW(q.validate(), InvalidInput) << "focus " << i;
    EXPECT_THROW(extract(front, q), InvalidInput) << "focus " << i;
    EXPECT_THROW(update(front, q), InvalidInput) << "focus " << i;
    EXPECT_THROW(update(front, q, coherence), InvalidInput) << "focus " << i;
    EXPECT_EQ(front.num_applied(), applied) << "focus " << i;
  }
  // An empty box (lo > hi) is a valid focus: it meets nothing, so nothing is refined.
  Query empty_box;
  empty_box.criterion = Criterion::object_error(0.0f);
  empty_box.focus.boxes.push_back(Box3{});
  extract(front, empty_box);
  EXPECT_EQ(front.num_applied(), 1u);
}

}  // namespace
}  // namespace varmesh
