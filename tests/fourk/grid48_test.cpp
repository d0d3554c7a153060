// Regular 4-8 terrain hierarchies: structure, error bounds measured over every sample, crack-free
// view-dependent meshes, agreement with the explicit MT, and extract/update equality.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

// The two fronts refine exactly the same diamonds (an incrementally moved front against extract()).
void expect_same_front(const Grid48& g, const Grid48Front& moving, const Grid48Front& fresh, const char* what, int at) {
  ASSERT_EQ(moving.num_faces(), fresh.num_faces()) << what << " " << at;
  for (Index p = 0; p < g.num_points(); ++p)
    ASSERT_EQ(moving.is_refined(p), fresh.is_refined(p)) << what << " " << at << " point " << p;
}

// Every interior edge shared by exactly two consistently oriented triangles, boundary edges only on the
// grid rectangle, no T-junction (a vertex lying inside another triangle's edge), area = rectangle's area.
void expect_conforming_cover(const TriMesh& m, double width, double height) {
  std::map<std::pair<Index, Index>, int> directed;
  double area = 0.0;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const glm::dvec3 a(m.positions[m.corner(f, 0)]), b(m.positions[m.corner(f, 1)]), c(m.positions[m.corner(f, 2)]);
    const double sa = 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
    ASSERT_GT(sa, 0.0) << "face " << f << " is not counter-clockwise";
    area += sa;
    for (int k = 0; k < 3; ++k) {
      const auto key = std::make_pair(m.corner(f, k), m.corner(f, (k + 1) % 3));
      ASSERT_EQ(directed[key]++, 0) << "directed edge used twice";
    }
  }
  EXPECT_NEAR(area, width * height, 1e-6 * width * height);
  for (const auto& [e, n] : directed) {
    if (directed.count({e.second, e.first})) continue;
    // A boundary edge must lie on the rectangle's border.
    const glm::vec3 a = m.positions[e.first], b = m.positions[e.second];
    const bool on_border = (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) ||
                           (std::abs(a.x - width) < 1e-4 && std::abs(b.x - width) < 1e-4) ||
                           (std::abs(a.y - height) < 1e-4 && std::abs(b.y - height) < 1e-4);
    ASSERT_TRUE(on_border) << "crack: boundary edge inside the domain at (" << a.x << "," << a.y << ")-(" << b.x
                           << "," << b.y << ")";
  }
}

TEST(Grid48, StructureOfA9x9Grid) {
  const HeightField f = make_fractal_terrain(9, 9, 1);
  const Grid48 g(f, {1.0, 8});
  EXPECT_EQ(g.tile_size(), 8u);
  EXPECT_EQ(g.num_nodes(), 81u - 4u);
  EXPECT_EQ(g.num_levels(), 6);
  // Every node's children list it as a parent and vice versa.
  for (Index p = 0; p < g.num_points(); ++p) {
    if (!g.is_node(p)) continue;
    g.for_each_child(p, [&](Index c) {
      bool found = false;
      g.for_each_parent(c, [&](Index q) { found = found || q == p; });
      EXPECT_TRUE(found) << "child " << c << " of " << p << " does not list it as a parent";
      EXPECT_EQ(g.level(c), g.level(p) + 1);
    });
  }
}

TEST(Grid48, FullRefinementIsTheGridAndExplicitMtAgrees) {
  const HeightField f = make_fractal_terrain(17, 17, 2);
  const Grid48 g(f, {1.0, 16});
  Grid48Front front(g);
  Query q;
  q.criterion = Criterion::object_error(0.0f);
  extract(front, q);
  front.validate();
  // Zero error on a rough terrain refines everything: 2 triangles per cell.
  EXPECT_EQ(front.num_faces(), 2u * 16u * 16u);
  const Mt mt = g.to_mt();
  mt.validate();
  EXPECT_EQ(mt.num_nodes(), 1 + g.num_nodes());
  // Same query on the explicit MT through the same API gives the same triangles.
  for (float e : {0.0f, 1.0f, 5.0f, 20.0f, 200.0f}) {
    Query qe;
    qe.criterion = Criterion::object_error(e);
    Grid48Front gf(g);
    extract(gf, qe);
    MtFront mf(mt);
    extract(mf, qe);
    mf.validate();
    std::multiset<std::array<Index, 3>> a, b;
    gf.for_each_triangle([&](Index x, Index y, Index z) {
      std::array<Index, 3> t{x, y, z};
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
      a.insert(t);
    });
    for (FaceId fc : mf.faces()) {
      auto t = mt.face(fc);
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
      b.insert(t);
    }
    EXPECT_EQ(a, b) << "threshold " << e;
  }
}

void check_error_bound(const HeightField& f, const std::vector<float>& thresholds) {
  const Grid48 g(f);
  for (float e : thresholds) {
    Grid48Front front(g);
    Query q;
    q.criterion = Criterion::object_error(e);
    extract(front, q);
    const TriMesh m = front.to_mesh();
    const double measured = g.max_vertical_error(m);
    EXPECT_LE(measured, double(e)) << "threshold " << e << " violated on a " << f.width << "x" << f.height << " grid";
    expect_conforming_cover(m, double(f.width - 1), double(f.height - 1));
  }
}

// extract_mesh's one-pass descent against the two-step path it replaces (extract_fast, then to_mesh):
// the same triangles (compared by their corner positions, since vertex numbering may differ), the same
// lattice ids per vertex, the same front afterwards, and the error bound. Grid sizes include padded ones
// (not 2^k + 1) and forced tile sizes; thresholds include 0 (full refinement).
TEST(Grid48, ExtractMeshEqualsExtractFastThenToMesh) {
  using Tri = std::array<std::array<float, 3>, 3>;
  auto triangles = [](const TriMesh& m, const std::vector<Index>& ids, std::map<std::array<float, 3>, Index>& id_of) {
    std::multiset<Tri> out;
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      Tri t;
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 p = m.positions[m.corner(f, k)];
        t[k] = {p.x, p.y, p.z};
        const auto [it, fresh] = id_of.emplace(t[k], ids[m.corner(f, k)]);
        EXPECT_EQ(it->second, ids[m.corner(f, k)]) << "one position, two lattice ids";
      }
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());  // keeps the orientation
      out.insert(t);
    }
    return out;
  };
  std::mt19937 rng(2026);
  for (int round = 0; round < 12; ++round) {
    const auto w = static_cast<std::size_t>(2 + rng() % 90), h = static_cast<std::size_t>(2 + rng() % 90);
    const HeightField f = make_fractal_terrain(w, h, 100 + static_cast<std::uint32_t>(round), 40.0f);
    Grid48Options o;
    if (round % 3 == 1) o.tile_size = std::size_t{1} << (1 + rng() % 4);
    const Grid48 g(f, o);
    for (float e : {0.0f, 0.5f, 3.0f, 15.0f, 200.0f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      Grid48Front two_step(g), one_pass(g);
      two_step.extract_fast(q);
      std::vector<Index> ids_a, ids_b;
      const TriMesh a = two_step.to_mesh(&ids_a);
      const TriMesh b = one_pass.extract_mesh(q, &ids_b);
      ASSERT_EQ(ids_b.size(), b.num_vertices());
      std::map<std::array<float, 3>, Index> id_a, id_b;
      EXPECT_EQ(triangles(a, ids_a, id_a), triangles(b, ids_b, id_b)) << w << "x" << h << " threshold " << e;
      EXPECT_EQ(id_a, id_b) << w << "x" << h << " threshold " << e;
      EXPECT_EQ(a.num_vertices(), b.num_vertices()) << "no unreferenced or duplicated vertices";
      // The front itself: the same state as extract() leaves.
      std::vector<Index> ids_c;
      const TriMesh c = one_pass.to_mesh(&ids_c);
      EXPECT_EQ(c.indices, a.indices);
      EXPECT_EQ(c.positions, a.positions);
      EXPECT_LE(g.max_vertical_error(b), double(e)) << w << "x" << h << " threshold " << e;
    }
  }
}
// One front reused across thresholds (finer, coarser, full refinement, none): extract_mesh's vertex map is
// left uninitialised and holds the previous descent's ids, which must never leak into the new mesh.
TEST(Grid48, ExtractMeshOnAReusedFrontEqualsTheTwoStepPath) {
  for (const auto& [w, h, tile] : {std::tuple{65, 65, 0}, std::tuple{70, 41, 0}, std::tuple{33, 90, 4}, std::tuple{2, 3, 0}}) {
    const HeightField f = make_fractal_terrain(static_cast<std::size_t>(w), static_cast<std::size_t>(h), 31, 30.0f);
    Grid48Options o;
    o.tile_size = static_cast<std::size_t>(tile);
    const Grid48 g(f, o);
    Grid48Front reused(g);
    for (float e : {3.0f, 0.5f, 12.0f, 0.0f, 1e9f, 1.0f, 0.2f}) {
      Query q;
      q.criterion = Criterion::object_error(e);
      Grid48Front two_step(g);
      two_step.extract_fast(q);
      std::vector<Index> ids_a, ids_b;
      const TriMesh a = two_step.to_mesh(&ids_a);
      const TriMesh b = reused.extract_mesh(q, &ids_b);
      ASSERT_EQ(a.num_faces(), b.num_faces()) << w << "x" << h << " threshold " << e;
      ASSERT_EQ(a.num_vertices(), b.num_vertices());
      std::map<Index, glm::vec3> pa, pb;  // lattice id -> position (clip vertices compared by the walk below)
      for (std::size_t v = 0; v < a.num_vertices(); ++v)
        if (ids_a[v] != kInvalid) pa[ids_a[v]] = a.positions[v];
      for (std::size_t v = 0; v < b.num_vertices(); ++v)
        if (ids_b[v] != kInvalid) pb[ids_b[v]] = b.positions[v];
      EXPECT_EQ(pa, pb);
      std::multiset<std::array<float, 9>> ta, tb;
      for (const auto& [m, t] : {std::pair{&a, &ta}, std::pair{&b, &tb}})
        for (std::size_t i = 0; i < m->num_faces(); ++i) {
          int k0 = 0;  // rotate so the lexicographically smallest corner comes first (keeps orientation)
          for (int k = 1; k < 3; ++k) {
            const glm::vec3 p = m->positions[m->corner(i, k)], q0 = m->positions[m->corner(i, k0)];
            if (std::tie(p.x, p.y, p.z) < std::tie(q0.x, q0.y, q0.z)) k0 = k;
          }
          std::array<float, 9> key{};
          for (int k = 0; k < 3; ++k) {
            const glm::vec3 p = m->positions[m->corner(i, (k0 + k) % 3)];
            key[3 * k] = p.x, key[3 * k + 1] = p.y, key[3 * k + 2] = p.z;
          }
          t->insert(key);
        }
      EXPECT_EQ(ta, tb) << w << "x" << h << " threshold " << e;
      EXPECT_EQ(reused.num_faces(), two_step.num_faces());
      reused.validate();
      expect_conforming_cover(b, double(w - 1), double(h - 1));
    }
  }
}

// The histogram bounds that size extract_mesh's output: never below the true counts, and close to them.
TEST(Grid48, OutputSizeBoundsFromTheErrorHistogram) {
  const HeightField f = make_fractal_terrain(257, 200, 12, 80.0f);
  const Grid48 g(f);
  Grid48Front front(g);
  for (float e : {0.0f, 1e-6f, 0.01f, 0.1f, 0.5f, 1.0f, 2.5f, 10.0f, 40.0f, 1e6f}) {
    Query q;
    q.criterion = Criterion::object_error(e);
    front.extract_fast(q);
    EXPECT_GE(g.max_refined_above(e), front.num_refined()) << "threshold " << e;
    EXPECT_GE(g.max_faces_above(e), front.num_faces()) << "threshold " << e;
    // 1/32-octave slots: only the diamonds in the threshold's own slot can be counted in excess.
    EXPECT_LE(double(g.max_faces_above(e)), 1.1 * double(front.num_faces()) + 64.0) << "threshold " << e;
  }
}


TEST(Grid48, ErrorBoundHoldsOnGeneratedTerrainsOfAnySize) {
  check_error_bound(make_fractal_terrain(65, 65, 3), {0.5f, 2.0f, 8.0f, 30.0f});
  check_error_bound(make_fractal_terrain(100, 37, 4), {0.5f, 2.0f, 8.0f, 30.0f});
  check_error_bound(make_fractal_terrain(2, 2, 5), {0.0f, 1.0f});
  check_error_bound(make_fractal_terrain(131, 77, 6), {1.0f, 10.0f});
}

TEST(Grid48, ErrorBoundHoldsOnRealTerrainsSharedData) {
  VARMESH_REQUIRE_SHARED(jacks, "terrain/jacksboro_fault_dem_403x344.pgm");
  check_error_bound(read_heightfield(jacks), {1.0f, 5.0f, 20.0f, 80.0f});
  VARMESH_REQUIRE_SHARED(fuji, "terrain/fuji_elevation_512_f32le.raw");
  HeightFieldReadOptions o;
  o.raw_width = o.raw_height = 512;
  check_error_bound(read_heightfield(fuji, o), {2.0f, 10.0f, 50.0f});
}

Query view_query(const Grid48& g, const glm::vec3& eye, const glm::vec3& target, float pixels) {
  Camera cam;
  cam.eye = eye;
  cam.target = target;
  cam.z_near = 0.5f;
  cam.z_far = 5000.0f;
  Query q;
  q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 600.0f, pixels)});
  (void)g;
  return q;
}

TEST(Grid48, ViewDependentMeshesAreCrackFree) {
  const HeightField f = make_fractal_terrain(129, 97, 7);
  const Grid48 g(f);
  Grid48Front front(g);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 20; ++i) {
    const glm::vec3 eye{u(rng) * 128.0f, u(rng) * 96.0f, 20.0f + u(rng) * 80.0f};
    const glm::vec3 target{u(rng) * 128.0f, u(rng) * 96.0f, 0.0f};
    extract(front, view_query(g, eye, target, 0.5f + u(rng) * 4.0f));
    front.validate();
    expect_conforming_cover(front.to_mesh(), 128.0, 96.0);
  }
}

TEST(Grid48, UpdateFromAnyEarlierFrontEqualsExtract) {
  const HeightField f = make_fractal_terrain(97, 65, 8);
  const Grid48 g(f);
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Grid48Front moving(g);
  for (int i = 0; i < 40; ++i) {
    const glm::vec3 eye{u(rng) * 96.0f, u(rng) * 64.0f, 10.0f + u(rng) * 60.0f};
    const glm::vec3 target{u(rng) * 96.0f, u(rng) * 64.0f, 0.0f};
    Query q = view_query(g, eye, target, 0.5f + u(rng) * 3.0f);
    if (i % 3 == 1) q.triangle_budget = 200 + static_cast<std::size_t>(u(rng) * 3000.0f);
    update(moving, q);
    moving.validate();
    Grid48Front fresh(g);
    extract(fresh, q);
    ASSERT_NO_FATAL_FAILURE(expect_same_front(g, moving, fresh, "step", i));
    if (q.triangle_budget) {
      EXPECT_LE(fresh.num_faces(), q.triangle_budget);
    }
  }
}

TEST(Grid48, RandomRefineCoarsenWalksKeepTheFrontValid) {
  const HeightField f = make_fractal_terrain(33, 33, 9);
  const Grid48 g(f);
  Grid48Front front(g);
  std::mt19937 rng(13);
  std::vector<Index> nodes;
  for (Index p = 0; p < g.num_points(); ++p)
    if (g.is_node(p)) nodes.push_back(p);
  for (int step = 0; step < 10000; ++step) {
    const Index p = nodes[rng() % nodes.size()];
    if (rng() % 2) {
      front.refine(p);
    } else if (front.is_coarsenable(p)) {
      front.coarsen_one(p);
    }
    if (step % 50 == 0) {
      front.validate();
      expect_conforming_cover(front.to_mesh(), 32.0, 32.0);
    }
  }
}

// family() and has_refined_child() against for_each_parent / for_each_child, on a lattice with padding and
// border diamonds (non-square grid, several tiles).
TEST(Grid48, FamilyMatchesParentAndChildWalks) {
  const HeightField f = make_fractal_terrain(70, 45, 4);
  const Grid48 g(f);
  std::mt19937 rng(3);
  std::vector<std::uint8_t> refined(g.num_points());
  for (auto& r : refined) r = rng() % 5 == 0;
  for (Index p = 0; p < g.num_points(); ++p) {
    if (!g.is_node(p)) continue;
    const Grid48::Family fam = g.family(p);
    std::vector<Index> parents, children;
    g.for_each_parent(p, [&](Index q) { parents.push_back(q); });
    g.for_each_child(p, [&](Index c) { children.push_back(c); });
    ASSERT_EQ(std::vector<Index>(fam.parent, fam.parent + fam.num_parents), parents) << "node " << p;
    ASSERT_EQ(std::vector<Index>(fam.child, fam.child + fam.num_children), children) << "node " << p;
    bool any = false;
    for (int k = 0; k < fam.num_children; ++k) {
      any = any || refined[fam.child[k]];
      std::vector<Index> cp;
      g.for_each_parent(fam.child[k], [&](Index q) { cp.push_back(q); });
      std::vector<Index> expect{p};
      if (fam.co_parent[k] != kInvalid) expect.push_back(fam.co_parent[k]);
      std::sort(cp.begin(), cp.end());
      std::sort(expect.begin(), expect.end());
      ASSERT_EQ(cp, expect) << "node " << p << " child " << fam.child[k];
    }
    ASSERT_EQ(g.has_refined_child(p, refined.data()), any) << "node " << p;
  }
}

}  // namespace
}  // namespace varmesh

namespace varmesh {
namespace {

TEST(Grid48, UpdateViewFollowsAMovingCameraExactly) {
  const HeightField f = make_fractal_terrain(257, 193, 21, 60.0f);
  const Grid48 g(f);
  Grid48Front moving(g), fresh(g);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  ViewQuery v;
  v.camera.eye = {20.0f, 20.0f, 80.0f};
  v.camera.target = {150.0f, 120.0f, 10.0f};
  v.camera.z_near = 0.5f;
  v.camera.z_far = 2000.0f;
  v.pixels = 1.5f;
  std::size_t evaluated = 0, boundary = 0;
  for (int frame = 0; frame < 120; ++frame) {
    // Small moves and turns, with an occasional jump and a change of parameters.
    v.camera.eye += glm::vec3(1.5f + u(rng), 1.0f + u(rng), 0.3f * u(rng));
    v.camera.target += glm::vec3(2.0f * u(rng), 2.0f * u(rng), u(rng));
    if (frame == 60) v.camera.eye = {200.0f, 30.0f, 50.0f};
    if (frame == 90) v.pixels = 3.0f;
    const QueryStats st = moving.update_view(v);
    fresh.extract_fast(v.to_query());
    moving.validate();
    ASSERT_NO_FATAL_FAILURE(expect_same_front(g, moving, fresh, "frame", frame));
    if (frame > 0 && frame != 60 && frame != 90) {
      evaluated += st.evaluated;
      boundary += fresh.num_faces();
    }
  }
  // Coherence pays: far fewer evaluations than there are triangles on the front.
  EXPECT_LT(evaluated, boundary / 2);
}

// update_view decides with its own copy of the view tests; diamonds exactly on the screen-error boundary
// (pixel threshold set to a diamond's own pixel error and its float neighbours) must be decided as
// Criterion::is_fine decides them, or update_view and extract disagree by a diamond.
TEST(Grid48, UpdateViewDecidesBoundaryDiamondsAsTheCriterion) {
  const HeightField f = make_fractal_terrain(65, 65, 31, 20.0f);
  const Grid48 g(f);
  Grid48Front moving(g), fresh(g);
  std::mt19937 rng(12);
  std::vector<Index> nodes;
  for (Index p = 0; p < g.num_points(); ++p)
    if (g.is_node(p) && g.error(p) > 0.0f) nodes.push_back(p);
  ASSERT_FALSE(nodes.empty());
  ViewQuery v;
  v.camera.eye = {-20.0f, -15.0f, 40.0f};
  v.camera.target = {32.0f, 32.0f, 0.0f};
  v.camera.z_near = 0.5f;
  v.camera.z_far = 1000.0f;
  int decided = 0;
  for (int frame = 0; frame < 150; ++frame) {
    v.camera.eye += glm::vec3(0.05f, 0.04f, 0.0f);
    const ElementBound b = g.bound(nodes[rng() % nodes.size()]);
    const float dist = glm::length(b.center - v.camera.eye) - b.radius;
    if (!(dist > 0.0f)) continue;
    const float at = b.error * v.camera.pixels_per_unit_at_distance_one(v.viewport_height) / dist;
    v.pixels = frame % 3 == 0 ? at : std::nextafter(at, frame % 3 == 1 ? 0.0f : 1e30f);
    if (!(v.pixels > 0.0f)) continue;
    moving.update_view(v);
    fresh.extract_fast(v.to_query());
    ++decided;
    ASSERT_NO_FATAL_FAILURE(expect_same_front(g, moving, fresh, "frame", frame));
  }
  EXPECT_GT(decided, 100);
}

// update_view keeps per-diamond records across frames and carries them when it moves a diamond between its
// boundary sets; generic refine/coarsen_one/update() calls in between must not leave a record that
// update_view would trust wrongly. Turning cameras, an object-error bound and repeated identical views too.
TEST(Grid48, UpdateViewMixedWithGenericEditsStaysExact) {
  const HeightField f = make_fractal_terrain(129, 97, 23, 40.0f);
  const Grid48 g(f);
  Grid48Front moving(g), fresh(g);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Index> nodes;
  for (Index p = 0; p < g.num_points(); ++p)
    if (g.is_node(p)) nodes.push_back(p);
  ViewQuery v;
  v.camera.eye = {10.0f, 10.0f, 50.0f};
  v.camera.target = {70.0f, 60.0f, 0.0f};
  v.camera.z_near = 0.5f;
  v.camera.z_far = 1000.0f;
  v.pixels = 1.0f;
  for (int frame = 0; frame < 90; ++frame) {
    if (frame % 4 != 3) {  // every fourth frame repeats the previous view
      v.camera.eye += glm::vec3(0.8f + 0.5f * u(rng), 0.5f + 0.5f * u(rng), 0.2f * u(rng));
      // Turning: the target circles around.
      const float angle = 0.05f * float(frame);
      v.camera.target = v.camera.eye + glm::vec3(40.0f * std::cos(angle), 40.0f * std::sin(angle), -30.0f);
    }
    if (frame == 45) v.object_error = 0.5f;
    if (frame % 7 == 2) {
      // Generic edits between two view updates.
      for (int k = 0; k < 30; ++k) {
        const Index p = nodes[rng() % nodes.size()];
        if (rng() % 2)
          moving.refine(p);
        else if (moving.is_coarsenable(p))
          moving.coarsen_one(p);
      }
    }
    if (frame % 11 == 5) update(moving, v.to_query());
    moving.update_view(v);
    fresh.extract_fast(v.to_query());
    moving.validate();
    ASSERT_NO_FATAL_FAILURE(expect_same_front(g, moving, fresh, "frame", frame));
  }
}

}  // namespace
}  // namespace varmesh

namespace varmesh {
namespace {

// The exact errors (per-row sample lists for small diamonds, row scans for large ones) against the
// reference that scans every diamond's rows, and the fast bound against both (never below the exact
// value). The reference build takes its radii from compute_radii() (lattice positions, one diamond at a
// time), the others mostly from the row kernel, so their equality checks the kernel (unequal spacings,
// padded and unpadded sizes).
TEST(Grid48, ExactErrorsMatchTheReferenceScan) {
  for (auto [w, h, seed] : {std::tuple{65, 65, 31u}, std::tuple{100, 37, 32u}, std::tuple{131, 77, 33u}, std::tuple{2, 2, 34u},
                            std::tuple{129, 129, 35u}, std::tuple{200, 90, 36u}}) {
    HeightField f = make_fractal_terrain(static_cast<std::size_t>(w), static_cast<std::size_t>(h), seed, 50.0f);
    if (seed % 2 == 0) {
      f.spacing_x = 0.7f;
      f.spacing_y = 1.3f;
    }
    Grid48Options exact, scan, fast;
    scan.reference_scan = true;
    fast.exact_errors = false;
    const Grid48 a(f, exact), b(f, scan), c(f, fast);
    for (Index p = 0; p < a.num_points(); ++p) {
      if (!a.is_node(p)) continue;
      ASSERT_NEAR(a.error(p), b.error(p), 1e-5f * (1.0f + b.error(p))) << w << "x" << h << " node " << p;
      ASSERT_GE(c.error(p), b.error(p) * (1.0f - 1e-6f)) << "the fast bound is below the exact error at " << p;
      ASSERT_FLOAT_EQ(b.radius(p), a.radius(p));
      ASSERT_FLOAT_EQ(b.radius(p), c.radius(p));
    }
  }
}

// The exact errors against a brute force that shares nothing with Grid48's error code: the hierarchy as an
// explicit Mt, each node's removed triangles, every grid sample inside them (barycentric coordinates in
// long double), the largest vertical distance to the triangle's plane, saturated over the node's
// descendants (the destroyers of its image). Each Mt node is matched to its lattice point through the
// vertex it inserts. Padded sizes, unequal spacings, a forced tile size.
TEST(Grid48, ExactErrorsMatchABruteForceOverTheMt) {
  struct Case {
    std::size_t w, h;
    float sx, sy;
    std::size_t tile;
  };
  for (const Case c : {Case{17, 17, 1.0f, 1.0f, 0}, Case{23, 12, 0.5f, 2.0f, 0}, Case{40, 33, 1.5f, 1.0f, 8}, Case{9, 30, 1.0f, 1.0f, 0}}) {
    HeightField f = make_fractal_terrain(c.w, c.h, 77u + static_cast<std::uint32_t>(c.w), 60.0f);
    f.spacing_x = c.sx;
    f.spacing_y = c.sy;
    Grid48Options o;
    o.tile_size = c.tile;
    const Grid48 g(f, o);
    const Mt mt = g.to_mt();
    using LD = long double;
    auto own_error = [&](NodeId n) {
      LD worst = 0;
      for (FaceId t : mt.pre_image(n)) {
        const auto v = mt.face(t);
        // Corners: lattice coordinates from the lattice point ids, heights from the Mt's positions.
        LD X[3], Y[3], Z[3];
        for (int k = 0; k < 3; ++k) {
          X[k] = LD(v[k] % g.lattice_width());
          Y[k] = LD(v[k] / g.lattice_width());
          Z[k] = LD(mt.position(v[k]).z);
        }
        const LD area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
        for (std::size_t y = 0; y < c.h; ++y)
          for (std::size_t x = 0; x < c.w; ++x) {
            const LD l1 = ((LD(x) - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (LD(y) - Y[0])) / area;
            const LD l2 = ((X[1] - X[0]) * (LD(y) - Y[0]) - (LD(x) - X[0]) * (Y[1] - Y[0])) / area;
            const LD l0 = 1 - l1 - l2;
            if (l0 < 0 || l1 < 0 || l2 < 0) continue;
            const LD plane = l0 * Z[0] + l1 * Z[1] + l2 * Z[2];
            worst = std::max(worst, std::fabs(LD(f.z[y * c.w + x]) - plane));
          }
      }
      return worst;
    };
    std::vector<LD> sat(mt.num_nodes(), -1);
    std::function<LD(NodeId)> saturated = [&](NodeId n) -> LD {
      if (sat[n] >= 0) return sat[n];
      LD e = own_error(n);
      for (FaceId t = mt.image_begin(n); t < mt.image_end(n); ++t)
        if (mt.destroyer(t) != kInvalid) e = std::max(e, saturated(mt.destroyer(t)));
      return sat[n] = e;
    };
    std::size_t checked = 0;
    for (NodeId n = 1; n < mt.num_nodes(); ++n) {
      std::set<VertexId> before, after;
      for (FaceId t : mt.pre_image(n))
        for (VertexId v : mt.face(t)) before.insert(v);
      for (FaceId t = mt.image_begin(n); t < mt.image_end(n); ++t)
        for (VertexId v : mt.face(t)) after.insert(v);
      std::vector<VertexId> inserted;
      std::set_difference(after.begin(), after.end(), before.begin(), before.end(), std::back_inserter(inserted));
      ASSERT_EQ(inserted.size(), 1u) << "node " << n;
      const Index p = inserted[0];
      const LD want = saturated(n);
      // The stored value is a float rounded up from a double computation.
      EXPECT_GE(LD(g.error(p)), want * (1 - 1e-12L)) << c.w << "x" << c.h << " point " << p;
      EXPECT_LE(LD(g.error(p)), want * (1 + 1e-6L) + 1e-9L) << c.w << "x" << c.h << " point " << p;
      ++checked;
    }
    EXPECT_EQ(checked, g.num_nodes());
  }
}

// Found by a review (each failed before its fix).

// extract_fast() falls back to extract() for a non-monotone criterion when its descent leaves a diamond
// refined without its parent; the check read parents the descent had rejected (still marked) as refined.
TEST(Grid48, ExtractFastFallsBackForNonMonotoneCriteria) {
  HeightField hf;
  hf.width = 45, hf.height = 38;
  hf.z.resize(hf.width * hf.height);
  for (std::size_t i = 0; i < hf.z.size(); ++i)
    hf.z[i] = std::sin(0.3f * static_cast<float>(i % 45)) * 3.0f + std::cos(0.2f * static_cast<float>(i / 45));
  const Grid48 g(hf);
  for (unsigned seed = 150; seed < 170; ++seed) {
    auto fn = [seed](const ElementBound& b) {
      const unsigned h = static_cast<unsigned>(b.center.x * 7 + b.center.y * 131) * 2654435761u ^ seed * 40503u;
      return (h >> 7) % 5 == 0 || b.error < 0.05f * static_cast<float>(seed % 7);
    };
    Query q;
    q.criterion = Criterion::custom(fn);
    q.focus.spheres.push_back({{20, 15, 0}, 10});
    Grid48Front a(g), b(g);
    extract(a, q);
    b.extract_fast(q);
    ASSERT_NO_THROW(b.validate()) << "seed " << seed;
    EXPECT_EQ(a.num_faces(), b.num_faces()) << "seed " << seed;
  }
}

// update_view() under a slow pan (eye fixed, 2e-4 rad per frame): the turn was measured as acos((tr R -
// 1) / 2) in float, which reads such a turn as ~1e-6, so records outlived their expiry and the front drifted
// from extract() (from frame 50 on).
TEST(Grid48, UpdateViewFollowsASlowPanExactly) {
  HeightField hf;
  hf.width = 129, hf.height = 129;
  hf.z.resize(hf.width * hf.height);
  for (std::size_t y = 0; y < hf.height; ++y)
    for (std::size_t x = 0; x < hf.width; ++x)
      hf.z[y * hf.width + x] = 6.0f * std::sin(0.11f * static_cast<float>(x)) * std::cos(0.07f * static_cast<float>(y)) +
                               0.5f * std::sin(1.3f * static_cast<float>(x) + 0.7f * static_cast<float>(y));
  const Grid48 g(hf);
  Grid48Front vf(g), ref(g);
  ViewQuery v;
  v.camera.eye = {64, 64, 20};
  v.camera.fov_y_deg = 40;
  v.camera.z_near = 0.1f;
  v.camera.z_far = 1000;
  v.viewport_height = 1000;
  v.pixels = 1.0f;
  for (int i = 0; i < 1200; ++i) {
    const float a = 2e-4f * static_cast<float>(i);
    v.camera.target = v.camera.eye + glm::vec3(std::cos(a), std::sin(a), -0.3f);
    vf.update_view(v);
    if (i % 100 != 99) continue;
    extract(ref, v.to_query());
    std::size_t differ = 0;
    for (Index p = 0; p < g.num_points(); ++p) differ += vf.is_refined(p) != ref.is_refined(p);
    EXPECT_EQ(differ, 0u) << "frame " << i;
  }
}

// refine() and coarsen_one() on an index that is no diamond: a tile corner looped until out of memory, an
// index out of range read past the arrays.
TEST(Grid48, FrontEditsCheckTheirIndex) {
  const Grid48 g(make_fractal_terrain(33, 33, 3, 10.0f));
  Grid48Front f(g);
  EXPECT_THROW(f.refine(0), InvalidInput);  // a tile corner
  EXPECT_THROW(f.refine(static_cast<Index>(g.num_points())), InvalidInput);
  EXPECT_THROW(f.coarsen_one(static_cast<Index>(g.num_points()) + 1000), InvalidInput);
  f.validate();
}

// The measure behind `terrain --measure` rebuilt lattice coordinates by dividing float positions by the
// spacing: border vertices landed an ulp inside the grid and border samples counted as holes (infinite).
TEST(Grid48, MeasuredErrorWithASpacing) {
  HeightField flat;
  flat.width = 65, flat.height = 60;
  flat.z.assign(flat.width * flat.height, 2.0f);
  for (const float spacing : {0.1f, 0.37f, 3.3f}) {
    HeightField h = flat;
    h.spacing_x = h.spacing_y = spacing;
    const Grid48 g(h);
    Grid48Front f(g);
    Query q;
    q.criterion = Criterion::object_error(0.5f);
    extract(f, q);
    EXPECT_LE(g.max_vertical_error(f.extract_mesh(q)), 1e-9) << "spacing " << spacing;  // was infinite
  }
}

}  // namespace
}  // namespace varmesh
