// SrMesh through the foundation's query API (multitri/query.hpp): extract and incremental update with the
// ready-made criteria, budgets, and the dual-piece oracle on every answer.
#include <filesystem>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "multitri/camera.hpp"
#include "multitri/mesh_distance.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "multitri/spatial_query.hpp"
#include "pm/dual_pieces.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

static_assert(RefinableFront<SrMesh>);
static_assert(SpatialFront<SrMesh>);  // for_each_face_geometry: pick, locate_point... take the pm front

// Fixpoint: no active non-leaf node is still wanted by the query.
bool is_fixpoint(const SrMesh& sr, const Query& q) {
  const VertexHierarchy& h = sr.hierarchy();
  for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v)
    if (sr.is_active(v) && q.wants(h.bound(v))) return false;
  return true;
}

// The faces and their corners are those of the dual pieces of the active set (pm_fixtures.hpp).
bool matches_oracle(const SrMesh& sr) { return testing::differs_from_dual_pieces(sr).empty(); }

Camera orbit_camera(float angle) {
  Camera c;
  c.eye = {3.0f * std::cos(angle), 3.0f * std::sin(angle), 0.8f};
  c.target = {0.0f, 0.0f, 0.0f};
  c.fov_y_deg = 35.0f;
  return c;
}

Query view_query(const Camera& cam, float pixels) {
  Query q;
  q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                   Criterion::screen_error(cam, 600.0f, pixels)});
  return q;
}

TEST(SrQuery, ObjectErrorExtractReachesFixpointAndRefinesWhereNeeded) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_icosphere(4));
  for (RefinementScheme s : {RefinementScheme::kKimLee, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
    SrMesh sr(h, s);
    Query q;
    q.criterion = Criterion::object_error(0.01f);
    extract(sr, q);
    sr.validate();
    EXPECT_TRUE(is_fixpoint(sr, q)) << scheme_name(s);
    EXPECT_TRUE(matches_oracle(sr));
    EXPECT_GT(sr.num_faces(), h.base_faces().size());
    EXPECT_LT(sr.num_faces(), h.num_faces());
    // Zero error everywhere gives the original mesh.
    q.criterion = Criterion::object_error(0.0f);
    extract(sr, q);
    EXPECT_EQ(sr.num_faces(), h.num_faces()) << scheme_name(s);
  }
}

// The node error bounds how far the surface moved also where it moves within its own plane: along a border.
// A flat disk used to go down to one triangle with every node error 0 (the planes of the faces do not see a
// border vertex slide), so object_error(0) returned that triangle, 0.55 away from the input's vertices.
TEST(SrQuery, ObjectErrorBoundsTheDistanceOnAFlatDisk) {
  TriMesh disk;
  const int rings = 8, around = 16;
  disk.positions.push_back({0.0f, 0.0f, 0.0f});
  for (int r = 1; r <= rings; ++r)
    for (int k = 0; k < around; ++k) {
      const float t = 6.2831853f * (float(k) + 0.5f * float(r % 2)) / float(around), rad = float(r) / float(rings);
      disk.positions.push_back({rad * std::cos(t), rad * std::sin(t), 0.0f});
    }
  auto id = [&](int r, int k) { return r == 0 ? Index{0} : static_cast<Index>(1 + (r - 1) * around + (k + around) % around); };
  for (int k = 0; k < around; ++k) disk.indices.insert(disk.indices.end(), {0, id(1, k), id(1, k + 1)});
  for (int r = 1; r < rings; ++r)
    for (int k = 0; k < around; ++k) {
      const Index a = id(r, k), b = id(r + 1, k), c = id(r + 1, k + 1), d = id(r, k + 1);
      if (r % 2) disk.indices.insert(disk.indices.end(), {a, b, c, a, c, d});
      else disk.indices.insert(disk.indices.end(), {a, b, d, b, c, d});
    }
  const VertexHierarchy h = build_vertex_hierarchy(disk);
  ASSERT_LT(h.base_faces().size(), disk.num_faces() / 4);
  for (float e : {0.0f, 0.01f, 0.05f, 0.2f}) {
    SrMesh sr(h, RefinementScheme::kKimLee);
    Query q;
    q.criterion = Criterion::object_error(e);
    extract(sr, q);
    const SurfaceDistance d = vertex_to_surface_distance(disk, sr.to_mesh());
    EXPECT_LE(d.max, double(e) + 1e-6) << "error " << e << ": " << sr.num_faces() << " faces";
  }
}

// On closed surfaces too: the node error used to count how far vs moved from the old faces' planes but not
// how far the old vertices ended up from the new fan, and pm query --error E measured up to 3x E on the
// knight and 2.6x on the cow of the data folder (helper-54). The same on icospheres with their vertices
// moved radially at random: 1.4-2.8x E before, at most 1.06x now, over errors from 0.1 % to 5 % of the
// diagonal. (The node error is an estimate, not a strict bound: 1.25x leaves room for the analysis to change.)
TEST(SrQuery, ObjectErrorBoundsTheDistanceOnClosedSurfaces) {
  struct Shape {
    int levels;
    float amplitude;
    unsigned seed;
  };
  for (const Shape& shape : {Shape{2, 0.6f, 1}, Shape{3, 0.3f, 1}, Shape{3, 0.3f, 2}, Shape{3, 0.6f, 3}}) {
    TriMesh m = testing::make_icosphere(shape.levels);
    std::mt19937 rng(shape.seed);
    std::uniform_real_distribution<float> radius(1.0f - shape.amplitude, 1.0f + shape.amplitude);
    for (glm::vec3& p : m.positions) p *= radius(rng);
    const VertexHierarchy h = build_vertex_hierarchy(m);
    const double diag = double(m.bounds().diagonal());
    for (double k : {0.001, 0.002, 0.003, 0.005, 0.007, 0.01, 0.015, 0.02, 0.03, 0.05}) {
      SrMesh sr(h, RefinementScheme::kKimLee);
      Query q;
      q.criterion = Criterion::object_error(static_cast<float>(k * diag));
      extract(sr, q);
      const SurfaceDistance d = vertex_to_surface_distance(m, sr.to_mesh());
      EXPECT_LE(d.max, 1.25 * k * diag) << "icosphere " << shape.levels << ", amplitude " << shape.amplitude << ", seed "
                                        << shape.seed << ", error " << k << " x diagonal: " << sr.num_faces()
                                        << " faces, max distance " << d.max / (k * diag) << " x the error";
    }
  }
}

// Max distance from the input's vertices to object_error(k x diagonal)'s extraction over k x diagonal, the
// worst over k = 0.05 % to 2 %; the face count of the worst goes to `faces`.
double worst_error_ratio(const TriMesh& m, const VertexHierarchy& h, std::size_t& faces) {
  const double diag = double(m.bounds().diagonal());
  double worst = 0.0;
  for (double k : {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02}) {
    SrMesh sr(h, RefinementScheme::kKimLee);
    Query q;
    q.criterion = Criterion::object_error(static_cast<float>(k * diag));
    extract(sr, q);
    const double r = vertex_to_surface_distance(m, sr.to_mesh()).max / (k * diag);
    if (r >= worst) worst = r, faces = sr.num_faces();
  }
  return worst;
}

// A view-dependent front puts a node next to the refined children of neighbours that were coarse when it was
// made; the node error measured its leaves only against the fan of those coarse neighbours, and bumpy
// icospheres with holes measured 1.3-2.0x E at such leaves (seeds 1, 2, 4, 5, 6 below), the elephant and
// the shark of the data folder 1.9x and 1.4x. Now at most 1.17x (the estimate is a heuristic: 1.25x).
TEST(SrQuery, ObjectErrorBoundsTheDistanceBesideRefinedNeighbours) {
  for (unsigned seed : {1u, 2u, 4u, 5u, 6u}) {
    TriMesh m = testing::make_icosphere(4);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> radius(0.7f, 1.3f);
    for (glm::vec3& p : m.positions) p *= radius(rng);
    // Three holes, cut by the directions of the face centres.
    std::vector<Index> kept;
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      glm::vec3 c(0.0f);
      for (int k = 0; k < 3; ++k) c += glm::normalize(m.positions[m.indices[3 * f + k]]) / 3.0f;
      if (c.z > 0.8f || c.x > 0.85f || c.y < -0.9f) continue;
      kept.insert(kept.end(), m.indices.begin() + 3 * std::ptrdiff_t(f), m.indices.begin() + 3 * std::ptrdiff_t(f) + 3);
    }
    ASSERT_LT(kept.size(), m.indices.size());
    m.indices = std::move(kept);
    const VertexHierarchy h = build_vertex_hierarchy(m);
    ASSERT_GT(h.num_collapses(), m.positions.size() / 2);
    std::size_t faces = 0;
    const double worst = worst_error_ratio(m, h, faces);
    EXPECT_LE(worst, 1.25) << "seed " << seed << ": " << faces << " faces";
  }
}

// The same on the meshes of the data folder, with holes and closed.
TEST(SrQuery, ObjectErrorBoundsTheDistanceOnTheDataMeshes) {
  for (const char* name : {"elephant-with-holes_2798v.off", "mech-holes-shark_5246v.off", "decimated-knight_502v.off",
                           "cow_cgal_2904v.off", "fandisk_6475v.obj"}) {
    VARMESH_REQUIRE_SHARED(path, std::string("meshes/") + name);
    const TriMesh m = read_mesh(path);
    const VertexHierarchy h = build_vertex_hierarchy(m);
    std::size_t faces = 0;
    const double worst = worst_error_ratio(m, h, faces);
    EXPECT_LE(worst, 1.25) << name << ": " << faces << " faces";
  }
}

TEST(SrQuery, KimLeeExtractIsMinimal) {
  // Kim-Lee refines exactly the wanted nodes: every refined node is wanted (no forced split), except
  // degenerate-case pre-splits, which are counted.
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_torus(40, 20));
  SrMesh sr(h);
  const Query q = view_query(orbit_camera(0.3f), 2.0f);
  extract(sr, q);
  std::size_t unwanted = 0;
  for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v)
    if (sr.is_refined(v) && !q.wants(h.bound(v))) ++unwanted;
  EXPECT_LE(unwanted, sr.stats().degenerate_cases);
  EXPECT_EQ(sr.stats().forced_vsplits, 0u);
}

TEST(SrQuery, OrbitUpdatesStayCorrect) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_torus(48, 24));
  for (RefinementScheme s : {RefinementScheme::kKimLee, RefinementScheme::kHoppe97}) {
    SrMesh inc(h, s), scratch(h, s);
    for (int frame = 0; frame < 40; ++frame) {
      const Query q = view_query(orbit_camera(0.08f * static_cast<float>(frame)), 1.5f);
      update(inc, q);
      extract(scratch, q);
      inc.validate();
      ASSERT_TRUE(matches_oracle(inc)) << "frame " << frame;
      EXPECT_TRUE(is_fixpoint(inc, q)) << "frame " << frame;
      // The incremental answer holds everything the fresh one refines (it may keep a postponed ecol).
      for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v)
        if (scratch.is_refined(v)) {
          ASSERT_TRUE(inc.is_refined(v)) << "frame " << frame << " node " << v;
        }
      EXPECT_LE(inc.num_faces(), scratch.num_faces() + scratch.num_faces() / 10 + 16);
    }
  }
}

// Views far apart (random directions), so that update() coarsens a lot between frames, for each scheme:
// update() leaves no node refined that the query does not want and that could be collapsed now, a second
// update() with the same query changes nothing, and the answer is extract()'s (Hoppe-97 and Xia-Varshney;
// Kim-Lee has its documented exception). An ecol refused at first can become legal once a neighbour has
// collapsed (Hoppe's fn faces, Xia-Varshney's stored rings, a Kim-Lee common neighbour gone); update() used
// to stop short there (1426 against 1242 faces on the torus under Hoppe-97).
void expect_update_reaches_extract(const VertexHierarchy& h, const std::function<Camera(float)>& camera, float pixels) {
  for (RefinementScheme s : {RefinementScheme::kKimLee, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
    SCOPED_TRACE(scheme_name(s));
    SrMesh inc(h, s), fresh(h, s);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> angle(0.0f, 6.283f);
    for (int frame = 0; frame < 40; ++frame) {
      const Query q = view_query(camera(angle(rng)), pixels);
      update(inc, q);
      extract(fresh, q);
      inc.validate();
      ASSERT_TRUE(matches_oracle(inc)) << "frame " << frame;
      EXPECT_TRUE(is_fixpoint(inc, q)) << "frame " << frame;
      std::size_t left = 0, differ = 0;
      for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v) {
        if (inc.is_refined(v) && !q.wants(h.bound(v)) && inc.is_coarsenable(v)) ++left;
        differ += inc.is_refined(v) != fresh.is_refined(v);
      }
      // Kim-Lee may keep an ecol postponed by the degenerate case (sr_mesh.hpp: a split in update()'s refine
      // step can remove the extra common neighbour after the coarsen step has passed); the others must agree.
      if (s == RefinementScheme::kKimLee) continue;
      EXPECT_EQ(left, 0u) << "frame " << frame << ": unwanted nodes that could be collapsed are left refined";
      EXPECT_EQ(differ, 0u) << "frame " << frame;
      const std::size_t faces = inc.num_faces();
      update(inc, q);
      EXPECT_EQ(inc.num_faces(), faces) << "frame " << frame << ": update() is not idempotent";
    }
  }
}

TEST(SrQuery, UpdateReachesExtractsAnswerUnderEveryScheme) {
  expect_update_reaches_extract(build_vertex_hierarchy(testing::make_torus(48, 24)), orbit_camera, 1.5f);
}

TEST(SrQuery, UpdateReachesExtractsAnswerOnTheSmallBunny) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bunny_libigl_3485v.off");
  const VertexHierarchy h = build_vertex_hierarchy(read_mesh(path));
  Box3 box;
  for (std::size_t l = 0; l < h.num_leaves(); ++l) box.add(h.position(static_cast<Index>(l)));
  const glm::vec3 c = box.center();
  const float r = 1.2f * box.diagonal();
  expect_update_reaches_extract(h, [&](float a) {
    Camera cam;
    cam.eye = c + glm::vec3(r * std::cos(a), 0.2f * r, r * std::sin(a));
    cam.target = c;
    cam.fov_y_deg = 35.0f;
    return cam;
  }, 1.5f);
}

TEST(SrQuery, TriangleBudgetIsRespected) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_icosphere(4));
  SrMesh sr(h);
  std::size_t previous = 0;
  for (std::size_t budget : {50u, 200u, 1000u, 3000u}) {
    Query q;
    q.criterion = Criterion::object_error(0.0f);
    q.triangle_budget = budget;
    const QueryStats st = extract(sr, q);
    sr.validate();
    EXPECT_LE(sr.num_faces(), budget);
    EXPECT_TRUE(st.budget_reached || sr.num_faces() == h.num_faces());
    EXPECT_TRUE(matches_oracle(sr));
    // Budget answers grow with the budget (the longest prefix of one priority order that fits), and use
    // at least half of it.
    EXPECT_GE(sr.num_faces(), previous) << "budget " << budget;
    EXPECT_GE(sr.num_faces() + 8, std::min<std::size_t>(budget, h.num_faces()) / 2);
    previous = sr.num_faces();
  }
}

// update() with a budget from selectively refined states under every scheme: never over the budget (above
// the base mesh). Under Kim-Lee every remaining collapse can be postponed (section 4.4) with the mesh still
// over the budget; update() stopped there (52 faces for a budget of 22 on this mesh, found by the pm soak)
// and now answers from the base mesh as extract() does. Random walks of splits and collapses reach such
// states; budgets from just above the base mesh make them bind.
// An SrMesh seen through RefinableFront with its resets counted: update() resets the front only when it
// answers from the base mesh (its fallback when it cannot coarsen down to the budget).
struct ResetCounter {
  SrMesh& sr;
  std::size_t resets = 0;
  ElementBound element_bound(Index e) const { return sr.element_bound(e); }
  bool is_refined(Index e) const { return sr.is_refined(e); }
  bool is_coarsenable(Index e) const { return sr.is_coarsenable(e); }
  std::size_t num_faces() const { return sr.num_faces(); }
  std::uint64_t tie_key(Index e) const { return sr.tie_key(e); }
  void reset() {
    ++resets;
    sr.reset();
  }
  template <class Sink> void refine(Index e, Sink&& sink) { sr.refine(e, sink); }
  void coarsen_one(Index e) { sr.coarsen_one(e); }
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const { std::as_const(sr).for_each_refine_candidate(fn); }
  template <class Fn> void for_each_child_candidate(Index e, Fn&& fn) const { sr.for_each_child_candidate(e, fn); }
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const { sr.for_each_coarsen_candidate(fn); }
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) const { sr.for_each_parent_candidate(e, fn); }
};
static_assert(RefinableFront<ResetCounter>);

// update() with a budget from selectively refined states under every scheme: never over the budget (above
// the base mesh). Under Kim-Lee every remaining collapse can be postponed (section 4.4) with the mesh still
// over the budget; update() stopped there (52 faces for a budget of 22 on this mesh with Lindstrom-Turk
// costs, found by the pm soak) and now answers from the base mesh as extract() does. View-dependent
// updates from random sides reach such states; budgets just above the base mesh make them bind.
TEST(SrQuery, UpdateRespectsTheBudgetFromSelectiveStates) {
  TriMesh bumpy = testing::make_icosphere(4);
  std::mt19937 shape(5);
  std::uniform_real_distribution<float> radius(0.7f, 1.3f);
  for (glm::vec3& p : bumpy.positions) p *= radius(shape);
  QemOptions o;
  o.cost = CollapseCost::kLindstromTurk;
  const VertexHierarchy h = build_vertex_hierarchy(bumpy, o);
  const std::size_t base = h.base_faces().size();
  std::size_t kim_lee_fallbacks = 0;
  for (const RefinementScheme scheme : {RefinementScheme::kKimLee, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
    SCOPED_TRACE(static_cast<int>(scheme));
    SrMesh sr(h, scheme);
    ResetCounter front{sr};
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int round = 0; round < 150; ++round) {
      // A selective state: a view from a random side, finer or coarser than the last one.
      Camera cam;
      cam.eye = (2.5f + u(rng)) * glm::normalize(glm::vec3(u(rng), u(rng), u(rng)) + glm::vec3(0.0f, 0.0f, 1e-3f));
      cam.target = glm::vec3(0.2f * u(rng), 0.2f * u(rng), 0.2f * u(rng));
      Query view;
      view.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                          Criterion::screen_error(cam, 600.0f, 0.5f + 4.0f * (u(rng) + 1.0f))});
      update(front, view);
      EXPECT_TRUE(is_fixpoint(sr, view)) << "round " << round;
      Query q;
      q.criterion = Criterion::object_error(0.0f);
      q.triangle_budget = base + 1 + rng() % 32;
      update(front, q);
      sr.validate();
      ASSERT_LE(sr.num_faces(), q.triangle_budget) << "round " << round << ", base " << base;
      EXPECT_TRUE(matches_oracle(sr)) << "round " << round;
    }
    if (scheme == RefinementScheme::kKimLee) kim_lee_fallbacks = front.resets;
    else EXPECT_EQ(front.resets, 0u) << "a baseline scheme stalled over the budget (not seen so far: its collapses are not postponed)";
  }
  EXPECT_GT(kim_lee_fallbacks, 0u) << "no Kim-Lee state where collapsing stalls over the budget: the test no longer reaches the case";
}

TEST(SrQuery, FeaturePointsAndSilhouette) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_icosphere(4));
  SrMesh sr(h);
  const glm::vec3 p{0.0f, 0.0f, 1.0f};
  Query q;
  q.criterion = Criterion::away_from_points({p}, 0.05f);
  extract(sr, q);
  EXPECT_TRUE(is_fixpoint(sr, q));
  // Near the point the mesh is at full resolution: the nearest leaf is active.
  Index nearest = 0;
  for (Index l = 0; l < h.num_leaves(); ++l)
    if (glm::length(h.position(l) - p) < glm::length(h.position(nearest) - p)) nearest = l;
  EXPECT_TRUE(sr.is_active(nearest));
  q.criterion = Criterion::away_from_silhouette({0.0f, -4.0f, 0.0f});
  extract(sr, q);
  EXPECT_TRUE(is_fixpoint(sr, q));
  EXPECT_TRUE(matches_oracle(sr));
}

// A fixed TriMesh as a front that never changes (searched with FrontMode::kKeep): the reference for the
// spatial queries on an SrMesh, which must answer as they do on sr.to_mesh()'s faces.
struct FixedMeshFront {
  const TriMesh* m;
  ElementBound element_bound(Index) const noexcept { return {}; }
  bool is_refined(Index) const noexcept { return false; }
  bool is_coarsenable(Index) const noexcept { return false; }
  std::size_t num_faces() const noexcept { return m->num_faces(); }
  std::uint64_t tie_key(Index e) const noexcept { return e; }
  void reset() {}
  template <class Sink> void refine(Index, Sink&&) {}
  void coarsen_one(Index) {}
  template <class Fn> void for_each_refine_candidate(Fn&&) const {}
  template <class Fn> void for_each_child_candidate(Index, Fn&&) const {}
  template <class Fn> void for_each_coarsen_candidate(Fn&&) const {}
  template <class Fn> void for_each_parent_candidate(Index, Fn&&) const {}
  template <class Fn> void for_each_face_geometry(Fn&& fn) const {
    for (std::size_t f = 0; f < m->num_faces(); ++f)
      fn(static_cast<Index>(f), m->positions[m->corner(f, 0)], m->positions[m->corner(f, 1)], m->positions[m->corner(f, 2)]);
  }
};
static_assert(SpatialFront<FixedMeshFront>);

// to_mesh() lists the faces in for_each_face order: face i of the mesh is the i-th active original face.
std::vector<Index> active_face_ids(const SrMesh& sr) {
  std::vector<Index> ids;
  sr.for_each_face([&](Index f, Index, Index, Index) { ids.push_back(f); });
  return ids;
}

void expect_same_hit(const std::optional<FaceHit>& got, const std::optional<FaceHit>& want, const std::vector<Index>& ids) {
  ASSERT_EQ(got.has_value(), want.has_value());
  if (!got) return;
  EXPECT_EQ(got->key, ids[want->key]);  // SrMesh keys faces by original face id
  EXPECT_EQ(got->t, want->t);
  EXPECT_EQ(got->point, want->point);
  EXPECT_EQ(got->a, want->a);
  EXPECT_EQ(got->b, want->b);
  EXPECT_EQ(got->c, want->c);
}

// README lists SrMesh among the fronts of the spatial queries: pick and locate_point answer the query on
// the SrMesh (global and local scope, incremental), and agree bit for bit with the same search on the mesh
// the SrMesh then holds; faces_within and intersect_region return the same faces.
TEST(SrQuery, SpatialQueriesOnTheSrMeshAgreeWithItsMesh) {
  const VertexHierarchy grid = build_vertex_hierarchy(testing::make_grid(24, 24, 0.3f));
  const VertexHierarchy ball = build_vertex_hierarchy(testing::make_icosphere(3));
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0.05f, 0.95f), angle(0.0f, 6.2831853f);
  for (const QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
    SpatialOptions opt;
    opt.scope = scope;
    SpatialOptions keep;
    keep.mode = FrontMode::kKeep;
    SrMesh on_grid(grid), on_ball(ball);
    for (int i = 0; i < 12; ++i) {
      Query q;
      q.criterion = Criterion::object_error(i % 2 == 0 ? 0.002f : 0.02f);
      // Point location on the height field.
      const glm::vec2 xy(u(rng), u(rng));
      const std::optional<FaceHit> at = locate_point(on_grid, q, xy, opt);
      on_grid.validate();
      const TriMesh gm = on_grid.to_mesh();
      FixedMeshFront gref{&gm};
      expect_same_hit(at, locate_point(gref, q, xy, keep), active_face_ids(on_grid));
      ASSERT_TRUE(at.has_value());
      EXPECT_TRUE(on_grid.face_active(at->key));
      // A ray from outside the ball towards a point near its centre.
      const float a = angle(rng);
      Ray ray;
      ray.origin = {3.0f * std::cos(a), 3.0f * std::sin(a), 0.5f * u(rng)};
      ray.direction = glm::vec3(0.1f * u(rng), 0.0f, 0.0f) - ray.origin;
      const std::optional<FaceHit> hit = pick(on_ball, q, ray, opt);
      const TriMesh bm = on_ball.to_mesh();
      FixedMeshFront bref{&bm};
      const std::vector<Index> ids = active_face_ids(on_ball);
      expect_same_hit(hit, pick(bref, q, ray, keep), ids);
      ASSERT_TRUE(hit.has_value());
      // The faces near the hit point, and in a box around it, by key.
      const glm::vec3 p = hit->point;
      std::vector<Index> near, want_near;
      for (const FaceHit& f : faces_within(on_ball, q, p, 0.3f, keep)) near.push_back(f.key);
      for (const FaceHit& f : faces_within(bref, q, p, 0.3f, keep)) want_near.push_back(ids[f.key]);
      EXPECT_EQ(near, want_near);
      EXPECT_GT(near.size(), 0u);
      const Box3 box{p - glm::vec3(0.2f), p + glm::vec3(0.2f)};
      std::vector<Index> inside, want_inside;
      for (const FaceHit& f : intersect_region(on_ball, q, box, keep)) inside.push_back(f.key);
      for (const FaceHit& f : intersect_region(bref, q, box, keep)) want_inside.push_back(ids[f.key]);
      EXPECT_EQ(inside, want_inside);
    }
  }
}

}  // namespace
}  // namespace varmesh
