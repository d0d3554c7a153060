// The contracts of Grid48 and Grid48Front at the API boundary: argument checks, lifetimes (temporaries
// refused, moved-from grids), exceptions thrown by a criterion, const members called from two threads,
// and the read-only candidate listings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "fourk/grid48.hpp"
#include "grid48_boundary.hpp"
#include "multitri/errors.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

namespace varmesh {
namespace {

// A front keeps a pointer to its grid: building one from a temporary does not compile.
static_assert(!std::is_constructible_v<Grid48Front, Grid48>);
static_assert(!std::is_constructible_v<Grid48Front, const Grid48>);
static_assert(std::is_constructible_v<Grid48Front, Grid48&>);
static_assert(std::is_constructible_v<Grid48Front, const Grid48&>);

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "(no InvalidInput)";
}

// The two fronts refine the same diamonds.
void expect_same_refined(const Grid48Front& a, const Grid48Front& b) {
  ASSERT_EQ(a.num_faces(), b.num_faces());
  ASSERT_EQ(a.num_refined(), b.num_refined());
  for (Index p = 0; p < a.grid().num_points(); ++p) ASSERT_EQ(a.is_refined(p), b.is_refined(p)) << "point " << p;
}

Query throwing_query(int& calls, int throw_at) {
  Query q;
  q.criterion = Criterion::custom([&calls, throw_at](const ElementBound& b) {
    if (++calls == throw_at) throw std::runtime_error("criterion failed");
    return b.error <= 0.5f;
  });
  return q;
}

Query object_query(float e) {
  Query q;
  q.criterion = Criterion::object_error(e);
  return q;
}

TEST(Grid48Contract, ThrowingCriterionLeavesExtractFastAtTheBase) {
  // 65 x 65 fits the lattice; 60 x 45 is clipped (extract_mesh then clips too).
  for (auto [w, h] : {std::pair<std::size_t, std::size_t>{65, 65}, {60, 45}}) {
    const HeightField f = make_fractal_terrain(w, h, 1);
    const Grid48 g(f);
    Grid48Front ref(g);
    extract(ref, object_query(0.5f));
    for (int which = 0; which < 2; ++which) {
      Grid48Front fr(g);
      fr.extract_fast(object_query(2.0f));  // some front to lose
      int calls = 0;
      const Query bad = throwing_query(calls, 300);
      if (which == 0)
        EXPECT_THROW(fr.extract_fast(bad), std::runtime_error);
      else
        EXPECT_THROW(fr.extract_mesh(bad), std::runtime_error);
      EXPECT_EQ(calls, 300);
      EXPECT_NO_THROW(fr.validate());
      EXPECT_EQ(fr.num_faces(), 2 * g.tiles_x() * g.tiles_y()) << "not back at the base mesh";
      EXPECT_EQ(fr.num_refined(), 0u);
      // Every path afterwards gives the fresh answer.
      update(fr, object_query(0.5f));
      fr.validate();
      expect_same_refined(fr, ref);
      fr.extract_fast(bad);  // calls is past 300: no throw now
      fr.extract_fast(object_query(0.5f));
      expect_same_refined(fr, ref);
      EXPECT_EQ(fr.to_mesh().num_faces(), ref.to_mesh().num_faces());
    }
  }
}

TEST(Grid48Contract, ThrowingCriterionOrSinkLeavesGenericMovesValid) {
  const HeightField f = make_fractal_terrain(65, 65, 2);
  const Grid48 g(f);
  Grid48Front fr(g);
  int calls = 0;
  EXPECT_THROW(extract(fr, throwing_query(calls, 200)), std::runtime_error);
  EXPECT_NO_THROW(fr.validate());
  fr.extract_fast(object_query(1.0f));
  calls = 0;
  EXPECT_THROW(update(fr, throwing_query(calls, 50)), std::runtime_error);
  EXPECT_NO_THROW(fr.validate());
  // A sink that throws after the first diamond: that diamond and its ancestors stay refined.
  fr.reset();
  Index deep = kInvalid;
  for (Index p = 0; p < g.num_points() && deep == kInvalid; ++p)
    if (g.is_node(p) && g.level(p) == 4) deep = p;
  ASSERT_NE(deep, kInvalid);
  EXPECT_THROW(fr.refine(deep, [](Index) { throw std::runtime_error("sink"); }), std::runtime_error);
  EXPECT_NO_THROW(fr.validate());
  EXPECT_EQ(fr.num_refined(), 1u);
}

using testing::expect_candidates_by_definition;

TEST(Grid48Contract, CandidateListingsMatchTheDefinitionInEveryState) {
  const HeightField f = make_fractal_terrain(129, 97, 3);
  const Grid48 g(f);
  Grid48Front fr(g);
  expect_candidates_by_definition(fr, "base");
  // Sparse and dense fronts after extract_fast (listed from the touched list, or by a lattice scan).
  for (float e : {20.0f, 2.0f, 0.05f}) {
    fr.extract_fast(object_query(e));
    expect_candidates_by_definition(fr, "after extract_fast");
    fr.extract_mesh(object_query(e));
    expect_candidates_by_definition(fr, "after extract_mesh");
  }
  // A view query: the descent also evaluates diamonds it leaves unrefined.
  Camera cam;
  cam.eye = {10, -20, 60};
  cam.target = {64, 48, 0};
  Query qv;
  qv.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080, 1)});
  fr.extract_fast(qv);
  expect_candidates_by_definition(fr, "after a view extract_fast");
  // After moves (the sets maintained incrementally).
  Index some = kInvalid;
  fr.for_each_coarsen_candidate([&](Index p) { some = p; });
  ASSERT_NE(some, kInvalid);
  fr.coarsen_one(some);
  expect_candidates_by_definition(fr, "after coarsen_one");
  update(fr, object_query(1.0f));
  expect_candidates_by_definition(fr, "after update");
}

TEST(Grid48Contract, ConstMembersFromTwoThreadsAgreeWithOneThread) {
  const HeightField f = make_fractal_terrain(129, 129, 1);
  const Grid48 g(f);
  Grid48Front fr(g);
  fr.extract_fast(object_query(0.5f));
  const Grid48Front& cf = fr;
  std::vector<Index> ref_ids;
  const TriMesh ref = cf.to_mesh(&ref_ids);
  bool same[2] = {true, true};
  auto many_meshes = [&](int t) {
    for (int i = 0; i < 20; ++i) {
      std::vector<Index> ids;
      const TriMesh m = cf.to_mesh(&ids);
      same[t] = same[t] && m.positions == ref.positions && m.indices == ref.indices && ids == ref_ids;
    }
  };
  std::thread t0(many_meshes, 0), t1(many_meshes, 1);
  t0.join();
  t1.join();
  EXPECT_TRUE(same[0]);
  EXPECT_TRUE(same[1]);

  // The candidate listings on a front just extracted (its boundary sets not yet rebuilt), one listing
  // per thread; the reference comes from another front in the same state.
  Grid48Front other(g);
  other.extract_fast(object_query(0.5f));
  std::vector<Index> ref_exposed, ref_maximal;
  other.for_each_refine_candidate([&](Index p) { ref_exposed.push_back(p); });
  other.for_each_coarsen_candidate([&](Index p) { ref_maximal.push_back(p); });
  std::vector<Index> exposed, maximal;
  std::thread a([&] { cf.for_each_refine_candidate([&](Index p) { exposed.push_back(p); }); });
  std::thread b([&] { cf.for_each_coarsen_candidate([&](Index p) { maximal.push_back(p); }); });
  a.join();
  b.join();
  EXPECT_EQ(exposed, ref_exposed);
  EXPECT_EQ(maximal, ref_maximal);
}

TEST(Grid48Contract, MovedFromGridIsEmptyAndRefused) {
  const HeightField f = make_fractal_terrain(33, 33, 1);
  Grid48 g(f);
  const std::size_t points = g.num_points();
  Grid48 h(std::move(g));
  EXPECT_EQ(g.num_points(), 0u);
  EXPECT_EQ(g.num_nodes(), 0u);
  EXPECT_EQ(g.memory_bytes(), 0u);
  EXPECT_THROW(Grid48Front{g}, InvalidInput);
  EXPECT_EQ(h.num_points(), points);
  Grid48 k(make_fractal_terrain(9, 9, 2));
  k = std::move(h);
  EXPECT_EQ(h.num_points(), 0u);
  EXPECT_THROW(Grid48Front{h}, InvalidInput);
  // The moved-to grid answers as a fresh one.
  const Grid48 fresh(f);
  Grid48Front a(k), b(fresh);
  extract(a, object_query(1.0f));
  extract(b, object_query(1.0f));
  expect_same_refined(a, b);
  EXPECT_EQ(a.to_mesh().positions, b.to_mesh().positions);
}

TEST(Grid48Contract, UpdateViewChecksTheViewAsToQueryDoes) {
  const HeightField f = make_fractal_terrain(33, 33, 1);
  const Grid48 g(f);
  Grid48Front fr(g);
  ViewQuery good;
  good.camera.eye = {-10, -10, 30};
  good.camera.target = {16, 16, 0};
  fr.update_view(good);
  const std::size_t faces = fr.num_faces();
  std::vector<ViewQuery> bad(5, good);
  bad[0].camera.target = bad[0].camera.eye;
  bad[1].camera.eye.x = std::numeric_limits<float>::quiet_NaN();
  bad[2].pixels = 0.0f;
  bad[3].viewport_height = -1.0f;
  bad[4].camera.z_near = 0.0f;
  for (std::size_t i = 0; i < bad.size(); ++i) {
    EXPECT_THROW(bad[i].to_query(), InvalidInput) << i;
    EXPECT_THROW(fr.update_view(bad[i]), InvalidInput) << i;
    EXPECT_EQ(fr.num_faces(), faces) << "the front changed on a refused view " << i;
  }
  // A camera whose view matrix overflows float (eye and target 1e20 apart) is refused on its first frame,
  // not on the frame after it (which compares two view matrices).
  ViewQuery far = good;
  far.camera.eye = {-1e20f, -1e20f, 30.0f};
  EXPECT_THROW(static_cast<void>(far.camera.view()), InvalidInput);
  for (int frame = 0; frame < 2; ++frame) {
    EXPECT_THROW(fr.update_view(far), InvalidInput) << frame;
    EXPECT_EQ(fr.num_faces(), faces) << frame;
  }
  fr.validate();
  // Still coherent with the last good view.
  Grid48Front ref(g);
  update(ref, good.to_query());
  fr.update_view(good);
  expect_same_refined(fr, ref);
}

TEST(Grid48Contract, BuildOptionsAndSpacingsAreChecked) {
  const HeightField f = make_fractal_terrain(9, 9, 1);
  for (std::size_t s : {std::size_t(1) << 16, std::size_t(1) << 31, std::size_t(3), std::size_t(1)}) {
    Grid48Options o;
    o.tile_size = s;
    EXPECT_NE(message_of([&] { Grid48 g(f, o); }).find("tile_size"), std::string::npos) << s;
  }
  Grid48Options o;
  o.tile_size = 8;
  EXPECT_NO_THROW(Grid48 g8(f, o));
  HeightField wide = make_fractal_terrain(33, 17, 1);
  wide.spacing_x = 3e37f;
  EXPECT_NE(message_of([&] { Grid48 g(wide); }).find("spacing_x 3e+37 times 32 lattice steps"), std::string::npos);
  wide.spacing_x = 1.0f;
  wide.spacing_y = 1e38f;
  EXPECT_NE(message_of([&] { Grid48 g(wide); }).find("spacing_y 1e+38 times 16 lattice steps"), std::string::npos);
  // Representable coordinates but unmeasurable distances: 16 rows 1e36 apart were accepted, with infinite
  // bounding spheres (their squared radii overflow float).
  wide.spacing_y = 1e36f;
  EXPECT_NE(message_of([&] { Grid48 g(wide); }).find("spacing_y 1e+36"), std::string::npos);
  // Neither direction alone, but the diagonal: 1.5e19 by 1.5e19.
  wide.spacing_x = 1.5e19f / 32.0f;
  wide.spacing_y = 1.5e19f / 16.0f;
  EXPECT_NE(message_of([&] { Grid48 g(wide); }).find("the lattice's box is 2.12132e+19 across (33 x 17 lattice points"),
            std::string::npos);
  // Just inside the limit (1.6e19 along y): accepted, every radius finite, and the mesh is finite.
  wide.spacing_x = 1.0f;
  wide.spacing_y = 1e18f;
  const Grid48 g(wide);
  for (Index p = 0; p < g.num_points(); ++p) ASSERT_TRUE(std::isfinite(g.radius(p))) << "point " << p;
  Grid48Front fr(g);
  extract(fr, object_query(0.0f));
  EXPECT_NO_THROW(fr.to_mesh().validate());
}

// Heights of +-3e38 (finite, so HeightField::validate passes) made infinite node errors and radii: every
// error-driven query then refined everything and a view query nothing. The rule: the lattice's box must
// have a diagonal whose square is finite in float (about 1.8e19), so the height span alone at most that.
TEST(Grid48Contract, HeightSpanBeyondFloatIsRefusedNamingTheSamples) {
  HeightField f = make_fractal_terrain(9, 9, 1);
  f.z[2 * 9 + 5] = 3e38f;   // (row 2, column 5)
  f.z[7 * 9 + 1] = -3e38f;  // (row 7, column 1)
  for (const bool exact : {true, false}) {
    Grid48Options o;
    o.exact_errors = exact;
    try {
      Grid48 g(f, o);
      ADD_FAILURE() << "accepted heights spanning 6e38";
    } catch (const InvalidInput& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("the heights span 6e+38, from -3e+38 at (row 7, column 1) to 3e+38 at (row 2, column 5)"),
                std::string::npos) << m;
      EXPECT_NE(m.find("too large to measure node errors"), std::string::npos) << m;
      EXPECT_EQ(e.element(), 2u * 9u + 5u);
    }
  }
  // A span alone past the limit, away from float's own end.
  f = make_fractal_terrain(9, 9, 1);
  f.z[3] = 9.25e18f;
  f.z[4] = -9.25e18f;
  EXPECT_NE(message_of([&] { Grid48 g(f); }).find("the heights span 1.85e+19"), std::string::npos);
  // Non-finite samples are refused by HeightField::validate, named by their index.
  f.z[4] = std::numeric_limits<float>::quiet_NaN();
  try {
    Grid48 g(f);
    ADD_FAILURE() << "accepted a NaN sample";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 4u);
  }
}

// The largest accepted span (1.8e19, heights of +-9e18 in a rough pattern): finite errors and radii at every
// point, for each way of computing them, and extractions that keep their error bound.
TEST(Grid48Contract, LargestAcceptedHeightSpanGivesFiniteBounds) {
  HeightField f = make_fractal_terrain(35, 27, 3);  // tiles of 4, padded: the lattice repeats the border
  float lo = f.z[0], hi = f.z[0];
  for (const float z : f.z) lo = std::min(lo, z), hi = std::max(hi, z);
  for (std::size_t i = 0; i < f.z.size(); ++i) {
    const float t = (f.z[i] - lo) / (hi - lo);  // in [0, 1]
    f.z[i] = ((i * 7919) % 5 == 0 ? 9e18f : -9e18f) * (0.5f + 0.5f * t);
  }
  f.z[0] = 9e18f;
  f.z[1] = -9e18f;
  for (int mode = 0; mode < 3; ++mode) {
    SCOPED_TRACE(mode == 0 ? "exact" : mode == 1 ? "fast bound" : "reference scan");
    Grid48Options o;
    o.exact_errors = mode != 1;
    o.reference_scan = mode == 2;
    const Grid48 g(f, o);
    ASSERT_TRUE(g.needs_clip());
    float top = 0.0f;
    for (Index p = 0; p < g.num_points(); ++p) {
      ASSERT_TRUE(std::isfinite(g.error(p))) << "point " << p;
      ASSERT_TRUE(std::isfinite(g.radius(p))) << "point " << p;
      top = std::max(top, g.error(p));
    }
    EXPECT_GE(top, 9e18f);  // the span is really there
    Grid48Front fr(g);
    std::size_t faces = 0;
    for (const float e : {1e19f, 3e18f, 1e18f, 0.0f}) {
      fr.extract_fast(object_query(e));
      fr.validate();
      EXPECT_GE(fr.num_faces(), faces) << "threshold " << e;
      faces = fr.num_faces();
      const TriMesh m = fr.to_mesh();
      EXPECT_LE(g.max_vertical_error(m), double(e) * (1.0 + 1e-5) + 1e-6 * 1.8e19) << "threshold " << e;
    }
    EXPECT_GT(faces, 2 * g.tiles_x() * g.tiles_y());
  }
}

TEST(Grid48Contract, MaxVerticalErrorChecksTheMesh) {
  const HeightField f = make_fractal_terrain(33, 33, 1);
  const Grid48 g(f);
  Grid48Front fr(g);
  fr.extract_fast(object_query(1.0f));
  TriMesh m = fr.to_mesh();
  ASSERT_GT(m.num_faces(), 2u);
  EXPECT_LE(g.max_vertical_error(m), 1.0);
  TriMesh oob = m;
  oob.indices[3 * 2 + 1] = static_cast<Index>(m.num_vertices() + 7);
  try {
    g.max_vertical_error(oob);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 2u);
  }
  TriMesh nan = m;
  nan.positions[1].z = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(g.max_vertical_error(nan), InvalidInput);
}

#if defined(VARMESH_ENABLE_ASSERTS) || !defined(NDEBUG)
// The unchecked accessors check their documented preconditions in debug and sanitizer builds.
TEST(Grid48ContractDeathTest, UncheckedAccessorsAssert) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const HeightField f = make_fractal_terrain(33, 33, 1);
  const Grid48 g(f);
  Grid48Front fr(g);
  const Index far = 1u << 28;
  EXPECT_DEATH(fr.is_refined(far), "precondition");
  EXPECT_DEATH(fr.is_coarsenable(far), "precondition");
  EXPECT_DEATH(g.bound(far), "precondition");
  EXPECT_DEATH(g.level(0), "precondition");  // a tile corner has no level
  EXPECT_DEATH(g.for_each_child(0, [](Index) {}), "precondition");
}
#endif

}  // namespace
}  // namespace varmesh
