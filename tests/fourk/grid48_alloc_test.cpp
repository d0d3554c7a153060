// Grid48Front when memory runs out. Each operation is run again and again with its n-th allocation failing
// (n = 1, 2, ... until it completes); after every std::bad_alloc the front must be valid, list exactly the
// boundary of its refined set as candidates, keep the state its contract promises (unchanged, the base mesh,
// or stopped between two moves), and then reach the same fronts as a front that never failed.
//
// Own executable: tests/alloc_guard.hpp replaces the global operator new and delete (its countdown).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <functional>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include "fourk/grid48.hpp"
#include "grid48_boundary.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

#include "alloc_guard.hpp"  // replaces operator new for this executable; its countdown fails the n-th allocation

namespace varmesh {
namespace {

std::vector<Index> refined_set(const Grid48Front& fr) {
  std::vector<Index> out;
  for (Index p = 0; p < fr.grid().num_points(); ++p)
    if (fr.is_refined(p)) out.push_back(p);
  return out;
}

using testing::expect_candidates_by_definition;

void expect_same_front(const Grid48Front& a, const Grid48Front& b) {
  EXPECT_EQ(a.num_faces(), b.num_faces());
  EXPECT_EQ(a.num_refined(), b.num_refined());
  EXPECT_EQ(refined_set(a), refined_set(b));
}

Query object_query(float e) {
  Query q;
  q.criterion = Criterion::object_error(e);
  return q;
}

enum class After { kUnchanged, kBase, kValid };

// Runs op on a front made by setup with its n-th allocation failing, for n = 1, 2, ... until op completes.
// After each failure: the checks above, the promised state, then `follow` (without failures) must leave the
// front as it leaves a front that never failed. Returns the number of failures injected.
long fail_each_allocation(const std::function<Grid48Front()>& setup, const std::function<void(Grid48Front&)>& op,
                          After after, const std::function<void(Grid48Front&)>& follow) {
  Grid48Front reference = setup();
  op(reference);
  follow(reference);
  for (long n = 1;; ++n) {
    Grid48Front fr = setup();
    const std::vector<Index> before = refined_set(fr);
    g_countdown.store(n);
    bool threw = false;
    try {
      op(fr);
    } catch (const std::bad_alloc&) {
      threw = true;
    }
    g_countdown.store(0);
    if (!threw) return n - 1;
    SCOPED_TRACE("allocation " + std::to_string(n) + " failed");
    EXPECT_NO_THROW(fr.validate());
    expect_candidates_by_definition(fr);
    if (after == After::kUnchanged) {
      EXPECT_EQ(refined_set(fr), before);
    }
    if (after == After::kBase) {
      EXPECT_EQ(fr.num_refined(), 0u);
    }
    follow(fr);
    fr.validate();
    expect_candidates_by_definition(fr);
    expect_same_front(fr, reference);
    if (::testing::Test::HasFailure() || n > 100000) return n;
  }
}

const Grid48& grid() {
  static const Grid48 g(make_fractal_terrain(129, 97, 7, 40.0f));  // padded lattice
  return g;
}

// A diamond deep in the hierarchy, with many missing ancestors on the base front.
Index deep_diamond() {
  const Grid48& g = grid();
  for (Index p = static_cast<Index>(g.num_points() / 2);; ++p)
    if (g.is_node(p) && g.level(p) == g.num_levels() - 1) return p;
}

ViewQuery view_at(float x) {
  ViewQuery v;
  v.camera.eye = {x, -10.0f, 40.0f};
  v.camera.target = {x + 30.0f, 60.0f, 0.0f};
  v.camera.z_near = 0.5f;
  v.camera.z_far = 1000.0f;
  v.pixels = 1.0f;
  return v;
}

TEST(Grid48Alloc, RefineKeepsTheAncestorsItHadRefined) {
  const Index p = deep_diamond();
  const long failures = fail_each_allocation([] { return Grid48Front(grid()); }, [&](Grid48Front& fr) { fr.refine(p); },
                                             After::kValid, [&](Grid48Front& fr) { fr.refine(p); });
  EXPECT_GT(failures, 3);  // the boundary sets grew several times
}

TEST(Grid48Alloc, SingleMovesCompleteOrChangeNothing) {
  // One move at a time, from a front whose sets have just enough room for what it holds.
  const Query fine = object_query(0.3f);
  auto setup = [&] {
    Grid48Front fr(grid());
    extract(fr, object_query(2.0f));
    return Grid48Front(fr);  // a copy: capacities trimmed to the sizes
  };
  Grid48Front probe = setup();
  std::vector<Index> refine_candidates, coarsen_candidates;
  probe.for_each_refine_candidate([&](Index p) { refine_candidates.push_back(p); });
  probe.for_each_coarsen_candidate([&](Index p) { coarsen_candidates.push_back(p); });
  ASSERT_GT(refine_candidates.size(), 10u);
  ASSERT_GT(coarsen_candidates.size(), 10u);
  long failures = 0;
  for (std::size_t k = 0; k < 10; ++k) {
    const Index r = refine_candidates[k], c = coarsen_candidates[k];
    failures += fail_each_allocation(setup, [&](Grid48Front& fr) { fr.refine(r); }, After::kUnchanged,
                                     [&](Grid48Front& fr) { update(fr, fine); });
    failures += fail_each_allocation(setup, [&](Grid48Front& fr) { fr.coarsen_one(c); }, After::kUnchanged,
                                     [&](Grid48Front& fr) { update(fr, fine); });
  }
  EXPECT_GT(failures, 0);
}

TEST(Grid48Alloc, GenericExtractAndUpdateStopBetweenMoves) {
  const Query coarse = object_query(3.0f), fine = object_query(0.2f);
  Query budget = object_query(0.1f);
  budget.triangle_budget = 3000;
  auto from_coarse = [&] {
    Grid48Front fr(grid());
    extract(fr, coarse);
    return fr;
  };
  auto from_fine = [&] {
    Grid48Front fr(grid());
    extract(fr, fine);
    return fr;
  };
  EXPECT_GT(fail_each_allocation(from_coarse, [&](Grid48Front& fr) { update(fr, fine); }, After::kValid,
                                 [&](Grid48Front& fr) { update(fr, fine); }),
            3);
  EXPECT_GT(fail_each_allocation(from_fine, [&](Grid48Front& fr) { update(fr, coarse); }, After::kValid,
                                 [&](Grid48Front& fr) { update(fr, coarse); }),
            0);
  EXPECT_GT(fail_each_allocation(from_coarse, [&](Grid48Front& fr) { extract(fr, budget); }, After::kValid,
                                 [&](Grid48Front& fr) { extract(fr, budget); }),
            3);
  // After extract_fast the sets are stale: the next move rebuilds them.
  auto after_fast = [&] {
    Grid48Front fr(grid());
    fr.extract_fast(fine);
    return fr;
  };
  EXPECT_GT(fail_each_allocation(after_fast, [&](Grid48Front& fr) { update(fr, coarse); }, After::kValid,
                                 [&](Grid48Front& fr) { update(fr, coarse); }),
            0);
}

TEST(Grid48Alloc, UpdateViewStopsBetweenMovesAndStartsAfresh) {
  const ViewQuery a = view_at(10.0f), b = view_at(14.0f), c = view_at(30.0f);
  auto setup = [&] {
    Grid48Front fr(grid());
    fr.update_view(a);
    return Grid48Front(fr);  // trimmed capacities; the motion records are copied
  };
  Grid48Front at_b(grid());
  update(at_b, b.to_query());
  // Then the same frame again and a further one: the records the failed call left (diamonds found wanted
  // and not yet refined, say) must not hide a change.
  auto follow = [&](Grid48Front& fr) {
    fr.update_view(b);
    expect_same_front(fr, at_b);
    fr.update_view(c);
  };
  EXPECT_GT(fail_each_allocation(setup, [&](Grid48Front& fr) { fr.update_view(b); }, After::kValid, follow), 0);
  EXPECT_GT(fail_each_allocation(setup, [&](Grid48Front& fr) { fr.update_view(c); }, After::kValid, follow), 0);
  // And the same fronts as the generic update.
  Grid48Front moved = setup(), fresh(grid());
  follow(moved);
  update(fresh, c.to_query());
  expect_same_front(moved, fresh);
}

TEST(Grid48Alloc, RebuildsLeaveTheBaseMesh) {
  const Query fine = object_query(0.2f);
  Camera cam = view_at(20.0f).camera;
  Query view;
  view.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080, 1)});
  auto setup = [&] {
    Grid48Front fr(grid());
    extract(fr, object_query(2.0f));
    return fr;
  };
  auto again = [](const Query& q) { return [q](Grid48Front& fr) { fr.extract_fast(q); }; };
  // extract_mesh: the fused descent, and extract_fast + to_mesh for a view query.
  EXPECT_GT(fail_each_allocation(setup, [&](Grid48Front& fr) { fr.extract_mesh(fine); }, After::kBase, again(fine)), 0);
  EXPECT_GT(fail_each_allocation(setup, [&](Grid48Front& fr) { fr.extract_mesh(view); }, After::kBase, again(view)), 0);
  EXPECT_GT(fail_each_allocation(setup, [](Grid48Front& fr) { (void)fr.to_mesh(); }, After::kUnchanged,
                                 [&](Grid48Front& fr) { update(fr, fine); }),
            0);
}

TEST(Grid48Alloc, CopyAssignmentLeavesTheTargetUnchanged) {
  static_assert(std::is_nothrow_move_assignable_v<Grid48Front>);
  static_assert(std::is_nothrow_move_constructible_v<Grid48Front>);
  Grid48Front source(grid());
  extract(source, object_query(0.3f));
  auto setup = [] {
    Grid48Front fr(grid());
    extract(fr, object_query(4.0f));
    return Grid48Front(fr);
  };
  const Query fine = object_query(0.5f);
  EXPECT_GT(fail_each_allocation(setup, [&](Grid48Front& fr) { fr = source; }, After::kUnchanged,
                                 [&](Grid48Front& fr) { update(fr, fine); }),
            2);
}

}  // namespace
}  // namespace varmesh
