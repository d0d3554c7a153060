// Variable-resolution spatial queries (Velho-Gomes 2000, section 9) on fractal terrains through the implicit
// Grid48Front and the explicit MtFront of the same hierarchy: point location at the asked resolution, ray
// picking against an independent brute force, region intersection against polygon clipping, local vs
// global scope, incremental vs from-scratch answers, neighbour search.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"
#include "multitri/spatial_query.hpp"
#include "multitri/terrain_gen.hpp"
#include "distance_oracle.hpp"

namespace varmesh {
namespace {

using Corners = std::array<std::tuple<float, float, float>, 3>;

// A face by its corner positions, independent of keys and corner order.
Corners canon(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  Corners k{std::tuple{a.x, a.y, a.z}, std::tuple{b.x, b.y, b.z}, std::tuple{c.x, c.y, c.z}};
  std::sort(k.begin(), k.end());
  return k;
}
Corners canon(const FaceHit& h) { return canon(h.a, h.b, h.c); }

std::multiset<Corners> canon_set(const std::vector<FaceHit>& hits) {
  std::multiset<Corners> s;
  for (const FaceHit& h : hits) s.insert(canon(h));
  return s;
}

struct Face {
  Index key;
  glm::vec3 a, b, c;
};

template <class F>
std::vector<Face> all_faces(const F& front) {
  std::vector<Face> out;
  front.for_each_face_geometry(
      [&](Index key, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) { out.push_back({key, a, b, c}); });
  return out;
}

double xy_area(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  return 0.5 * std::abs((double(b.x) - a.x) * (double(c.y) - a.y) - (double(c.x) - a.x) * (double(b.y) - a.y));
}

// Independent xy containment: the point is on the inner side of every edge (either orientation).
bool xy_contains(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, glm::vec2 p, double eps = 1e-6) {
  auto side = [&](const glm::vec3& u, const glm::vec3& v) {
    return (double(v.x) - u.x) * (double(p.y) - u.y) - (double(v.y) - u.y) * (double(p.x) - u.x);
  };
  const double s0 = side(a, b), s1 = side(b, c), s2 = side(c, a);
  return (s0 >= -eps && s1 >= -eps && s2 >= -eps) || (s0 <= eps && s1 <= eps && s2 <= eps);
}

// Independent ray/triangle test: plane intersection, then same-side tests in the face's plane.
std::optional<double> brute_ray(const Ray& ray, const glm::vec3& fa, const glm::vec3& fb, const glm::vec3& fc) {
  const glm::dvec3 o(ray.origin), d(ray.direction), a(fa), b(fb), c(fc);
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double denom = glm::dot(n, d);
  if (std::abs(denom) < 1e-12 * glm::length(n) * glm::length(d)) return std::nullopt;
  const double t = glm::dot(n, a - o) / denom;
  if (t < 0.0) return std::nullopt;
  const glm::dvec3 p = o + t * d;
  const double tol = -1e-9 * glm::dot(n, n);
  if (glm::dot(glm::cross(b - a, p - a), n) < tol || glm::dot(glm::cross(c - b, p - b), n) < tol ||
      glm::dot(glm::cross(a - c, p - c), n) < tol)
    return std::nullopt;
  return t;
}

// Independent region oracle: clip the triangle by half-spaces n.x + d >= 0 (Sutherland-Hodgman).
bool clip_nonempty(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                   const std::vector<std::pair<glm::dvec3, double>>& halfspaces) {
  std::vector<glm::dvec3> poly{glm::dvec3(a), glm::dvec3(b), glm::dvec3(c)};
  for (const auto& [n, d] : halfspaces) {
    std::vector<glm::dvec3> next;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const glm::dvec3& p = poly[i];
      const glm::dvec3& q = poly[(i + 1) % poly.size()];
      const double sp = glm::dot(n, p) + d, sq = glm::dot(n, q) + d;
      if (sp >= 0.0) next.push_back(p);
      if ((sp >= 0.0) != (sq >= 0.0)) next.push_back(p + (q - p) * (sp / (sp - sq)));
    }
    poly.swap(next);
    if (poly.empty()) return false;
  }
  return true;
}

std::vector<std::pair<glm::dvec3, double>> box_halfspaces(const Box3& box) {
  std::vector<std::pair<glm::dvec3, double>> h;
  for (int k = 0; k < 3; ++k) {
    glm::dvec3 n(0.0);
    n[k] = 1.0;
    h.push_back({n, -double(box.lo[k])});
    h.push_back({-n, double(box.hi[k])});
  }
  return h;
}

std::vector<std::pair<glm::dvec3, double>> frustum_halfspaces(const Frustum& f) {
  std::vector<std::pair<glm::dvec3, double>> h;
  for (const Plane& p : f.planes) h.push_back({glm::dvec3(p.n), double(p.d)});
  return h;
}

Query error_query(float e) {
  Query q;
  q.criterion = Criterion::object_error(e);
  return q;
}

class SpatialQueryTest : public ::testing::Test {
 protected:
  // 33 x 33 samples in one 32-cell tile: no padding, so both fronts list exactly the grid's triangles.
  SpatialQueryTest() : field_(make_fractal_terrain(33, 33, 11)), grid_(field_, {1.0, 32}), mt_(grid_.to_mt()) {}

  glm::vec2 random_xy(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 32.0f);
    return {u(rng), u(rng)};
  }

  HeightField field_;
  Grid48 grid_;
  Mt mt_;
};

using SpatialQueryLocate = SpatialQueryTest;
using SpatialQueryPick = SpatialQueryTest;
using SpatialQueryRegion = SpatialQueryTest;
using SpatialQueryScope = SpatialQueryTest;
using SpatialQueryNeighbors = SpatialQueryTest;
using SpatialQueryFronts = SpatialQueryTest;

TEST_F(SpatialQueryLocate, ReturnedFaceContainsThePointInXy) {
  std::mt19937 rng(1);
  for (float e : {0.0f, 1.0f, 5.0f, 30.0f})
    for (QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
      Grid48Front front(grid_);
      for (int i = 0; i < 50; ++i) {
        const glm::vec2 p = random_xy(rng);
        const auto hit = locate_point(front, error_query(e), p, {scope});
        ASSERT_TRUE(hit.has_value()) << "no face over (" << p.x << "," << p.y << ")";
        EXPECT_TRUE(xy_contains(hit->a, hit->b, hit->c, p)) << "threshold " << e;
        EXPECT_EQ(hit->point.x, p.x);
        EXPECT_EQ(hit->point.y, p.y);
        // The reported height lies within the face's height range.
        EXPECT_GE(hit->point.z, std::min({hit->a.z, hit->b.z, hit->c.z}) - 1e-3f);
        EXPECT_LE(hit->point.z, std::max({hit->a.z, hit->b.z, hit->c.z}) + 1e-3f);
      }
      front.validate();
    }
}

TEST_F(SpatialQueryLocate, ZeroErrorGivesTheFinestTriangleInBothScopes) {
  std::mt19937 rng(2);
  for (QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
    Grid48Front front(grid_);
    for (int i = 0; i < 100; ++i) {
      const glm::vec2 p = random_xy(rng);
      const auto hit = locate_point(front, error_query(0.0f), p, {scope});
      ASSERT_TRUE(hit.has_value());
      EXPECT_EQ(xy_area(hit->a, hit->b, hit->c), 0.5) << "scope " << int(scope) << " at (" << p.x << "," << p.y << ")";
    }
  }
}

TEST_F(SpatialQueryLocate, OutsideTheGridFindsNothing) {
  Grid48Front front(grid_);
  EXPECT_FALSE(locate_point(front, error_query(1.0f), {-1.0f, 5.0f}).has_value());
  EXPECT_FALSE(locate_point(front, error_query(1.0f), {5.0f, 32.5f}).has_value());
  // Exactly on a grid vertex and on an edge: still one face, and it contains the point.
  for (glm::vec2 p : {glm::vec2(16.0f, 16.0f), glm::vec2(0.0f, 0.0f), glm::vec2(3.5f, 3.5f), glm::vec2(32.0f, 7.0f)}) {
    const auto hit = locate_point(front, error_query(0.0f), p);
    ASSERT_TRUE(hit.has_value()) << p.x << "," << p.y;
    EXPECT_TRUE(xy_contains(hit->a, hit->b, hit->c, p));
  }
}

TEST_F(SpatialQueryPick, VerticalRayAgreesWithLocatePoint) {
  std::mt19937 rng(3);
  for (float e : {0.0f, 2.0f, 10.0f}) {
    Grid48Front front(grid_);
    for (int i = 0; i < 60; ++i) {
      const glm::vec2 p = random_xy(rng);
      const auto located = locate_point(front, error_query(e), p);
      const auto picked = pick(front, error_query(e), Ray{{p.x, p.y, 500.0f}, {0.0f, 0.0f, -1.0f}});
      ASSERT_TRUE(located && picked);
      EXPECT_EQ(located->key, picked->key);
      EXPECT_EQ(canon(*located), canon(*picked));
      EXPECT_NEAR(picked->point.z, located->point.z, 1e-3f);
      EXPECT_NEAR(picked->t, 500.0f - located->point.z, 1e-3f);
    }
  }
}

TEST_F(SpatialQueryPick, RayFromARandomCameraMatchesBruteForce) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int hits = 0;
  for (int i = 0; i < 80; ++i) {
    const float e = float(i % 4) * 2.0f;
    Grid48Front front(grid_);
    const glm::vec3 eye(-20.0f + 72.0f * u(rng), -20.0f + 72.0f * u(rng), 120.0f + 100.0f * u(rng));
    const glm::vec3 target(2.0f + 28.0f * u(rng), 2.0f + 28.0f * u(rng), 40.0f * u(rng));
    const Ray ray{eye, target - eye};
    const auto picked = pick(front, error_query(e), ray);
    // Brute force over every current face.
    double best = 1e300, second = 1e300;
    Corners best_face{};
    for (const Face& f : all_faces(front)) {
      const auto t = brute_ray(ray, f.a, f.b, f.c);
      if (!t) continue;
      if (*t < best) {
        second = best;
        best = *t;
        best_face = canon(f.a, f.b, f.c);
      } else {
        second = std::min(second, *t);
      }
    }
    if (best == 1e300) {
      EXPECT_FALSE(picked.has_value());
      continue;
    }
    ASSERT_TRUE(picked.has_value()) << "brute force hits at t=" << best;
    ++hits;
    EXPECT_NEAR(picked->t, best, 1e-4 * best);
    if (second - best > 1e-3 * best) {
      EXPECT_EQ(canon(*picked), best_face);
    }
    const glm::vec3 p = ray.origin + picked->t * ray.direction;
    EXPECT_NEAR(glm::length(p - picked->point), 0.0f, 1e-2f);
  }
  EXPECT_GT(hits, 60);
}

TEST_F(SpatialQueryPick, LocalScopeFindsTheSameFinestFaceAsGlobal) {
  // Figure 22(e, f): the smallest triangle under the cursor, found without refining the whole mesh.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 30; ++i) {
    const glm::vec3 eye(40.0f * u(rng), -30.0f, 150.0f);
    const glm::vec3 target(4.0f + 24.0f * u(rng), 4.0f + 24.0f * u(rng), 30.0f);
    const Ray ray{eye, target - eye};
    Grid48Front global(grid_), local(grid_);
    QueryStats gs, ls;
    const auto g = pick(global, error_query(0.0f), ray, {QueryScope::kGlobal, FrontMode::kExtract, &gs});
    const auto l = pick(local, error_query(0.0f), ray, {QueryScope::kLocal, FrontMode::kExtract, &ls});
    ASSERT_EQ(g.has_value(), l.has_value());
    if (!g) continue;
    EXPECT_EQ(canon(*g), canon(*l));
    EXPECT_EQ(xy_area(l->a, l->b, l->c), 0.5);
    EXPECT_LT(ls.refined, gs.refined);
    EXPECT_LT(local.num_faces(), global.num_faces());
  }
}

TEST_F(SpatialQueryRegion, BoxMatchesClippingOracleInBothScopes) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int hit_boxes = 0;
  for (int i = 0; i < 40; ++i) {
    Box3 box;
    const glm::vec3 lo(-2.0f + 30.0f * u(rng), -2.0f + 30.0f * u(rng), 100.0f * u(rng) - 10.0f);
    box.add(lo);
    box.add(lo + glm::vec3(0.1f + 10.0f * u(rng), 0.1f + 10.0f * u(rng), 0.1f + 30.0f * u(rng)));
    const Query q = error_query(float(i % 5));
    for (QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
      Grid48Front front(grid_);
      const auto found = intersect_region(front, q, box, {scope});
      std::multiset<Corners> expected;
      for (const Face& f : all_faces(front))
        if (clip_nonempty(f.a, f.b, f.c, box_halfspaces(box))) expected.insert(canon(f.a, f.b, f.c));
      EXPECT_EQ(canon_set(found), expected) << "box " << i << " scope " << int(scope);
      hit_boxes += !expected.empty();
    }
  }
  EXPECT_GT(hit_boxes, 40) << "most boxes should meet the terrain";
}

TEST_F(SpatialQueryRegion, FrustumIsConservativeAndMissesNothing) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 20; ++i) {
    Camera cam;
    cam.eye = {-10.0f + 50.0f * u(rng), -30.0f, 80.0f + 60.0f * u(rng)};
    cam.target = {5.0f + 20.0f * u(rng), 5.0f + 20.0f * u(rng), 30.0f};
    cam.fov_y_deg = 15.0f + 20.0f * u(rng);
    cam.z_near = 1.0f;
    cam.z_far = 300.0f;
    const Frustum fr = cam.frustum();
    for (QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
      Grid48Front front(grid_);
      const auto found = intersect_region(front, error_query(1.0f), fr, {scope});
      const auto got = canon_set(found);
      std::multiset<Corners> conservative;
      for (const Face& f : all_faces(front)) {
        const Corners k = canon(f.a, f.b, f.c);
        if (clip_nonempty(f.a, f.b, f.c, frustum_halfspaces(fr))) {
          EXPECT_EQ(got.count(k), 1u) << "missed a face";
        }
        bool culled = false;
        for (const Plane& p : fr.planes)
          culled = culled || (p.signed_distance(f.a) < 0 && p.signed_distance(f.b) < 0 && p.signed_distance(f.c) < 0);
        if (!culled) conservative.insert(k);
      }
      EXPECT_EQ(got, conservative);
    }
  }
}

TEST(SpatialQueryLocality, LocalRefinesLessAndReturnsOnlyRegionFaces) {
  // A 128-cell tile with moderate relief (node spheres are then not much larger than their diamonds).
  const HeightField field = make_fractal_terrain(129, 129, 12, 30.0f);
  const Grid48 grid(field, {1.0, 128});
  Box3 box;
  box.add({40.3f, 52.2f, -1.0f});
  box.add({54.7f, 65.1f, 40.0f});
  for (float e : {0.0f, 0.2f, 1.0f}) {
    const Query q = error_query(e);
    Grid48Front global(grid), local(grid);
    QueryStats gs, ls;
    const auto g = intersect_region(global, q, box, {QueryScope::kGlobal, FrontMode::kExtract, &gs});
    const auto l = intersect_region(local, q, box, {QueryScope::kLocal, FrontMode::kExtract, &ls});
    local.validate();
    EXPECT_LT(ls.refined, gs.refined / 4) << "threshold " << e;
    EXPECT_LT(local.num_faces(), global.num_faces() / 4) << "threshold " << e;
    ASSERT_FALSE(l.empty());
    for (const FaceHit& h : l) EXPECT_TRUE(clip_nonempty(h.a, h.b, h.c, box_halfspaces(box)));
    // At zero error the faces meeting the region are the finest ones in both scopes.
    if (e == 0.0f) {
      EXPECT_EQ(canon_set(l), canon_set(g));
    }
    // Away from the region the local mesh stays coarse; the global one is refined there.
    const auto far_local = locate_point(local, q, {3.0f, 125.0f}, {QueryScope::kLocal, FrontMode::kKeep});
    const auto far_global = locate_point(global, q, {3.0f, 125.0f}, {QueryScope::kGlobal, FrontMode::kKeep});
    ASSERT_TRUE(far_local && far_global);
    EXPECT_GE(xy_area(far_local->a, far_local->b, far_local->c), 64.0);
    EXPECT_LE(xy_area(far_global->a, far_global->b, far_global->c), 16.0);
  }
}

template <class F>
void check_incremental_equals_scratch(const F& prototype) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  F moving = prototype;
  for (int i = 0; i < 25; ++i) {
    const QueryScope scope = i % 2 ? QueryScope::kLocal : QueryScope::kGlobal;
    const Query q = error_query(float(i % 6));
    const glm::vec3 c(32.0f * u(rng), 32.0f * u(rng), 50.0f * u(rng));
    const float r = 2.0f + 10.0f * u(rng);
    const auto inc = faces_within(moving, q, c, r, {scope, FrontMode::kUpdate});
    moving.validate();
    F fresh = prototype;
    const auto scratch = faces_within(fresh, q, c, r, {scope, FrontMode::kExtract});
    EXPECT_EQ(canon_set(inc), canon_set(scratch)) << "step " << i;
    EXPECT_EQ(moving.num_faces(), fresh.num_faces()) << "step " << i;
    for (const FaceHit& h : inc) {
      // The tests' own point-triangle distance (distance_oracle.hpp), not the library's closest point.
      const double d = testing::point_triangle(glm::dvec3(c), glm::dvec3(h.a), glm::dvec3(h.b), glm::dvec3(h.c));
      EXPECT_LE(d, double(r) + 1e-9 * (1.0 + r));
      EXPECT_NEAR(h.t, d, 1e-4);
    }
  }
}

TEST_F(SpatialQueryScope, IncrementalAnswersEqualFromScratch) {
  check_incremental_equals_scratch(Grid48Front(grid_));
  check_incremental_equals_scratch(MtFront(mt_));
}

TEST_F(SpatialQueryNeighbors, FacesWithinMatchesBruteForceDistance) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int nonempty = 0;
  for (int i = 0; i < 20; ++i) {
    Grid48Front front(grid_);
    const glm::vec2 xy = random_xy(rng);
    const auto at = locate_point(front, error_query(2.0f), xy);
    ASSERT_TRUE(at.has_value());
    const float r = 0.5f + 6.0f * u(rng);
    const glm::vec3 c = at->point + glm::vec3(0.0f, 0.0f, 3.0f * u(rng));
    const auto found = faces_within(front, error_query(2.0f), c, r, {QueryScope::kGlobal, FrontMode::kKeep});
    // Brute force over every current face with the tests' own point-triangle distance (distance_oracle.hpp:
    // projection onto the plane, else the nearest edge), written apart from the library's closest point.
    // Faces within rounding of the radius may go either way and are left out of the comparison.
    std::multiset<Corners> expected, borderline;
    for (const Face& f : all_faces(front)) {
      const glm::dvec3 dc(c), a(f.a), b(f.b), fc(f.c);
      const double exact = testing::point_triangle(dc, a, b, fc);
      double sampled = 1e300;
      for (int s = 0; s <= 20; ++s)
        for (int t = 0; t <= 20 - s; ++t) {
          const glm::dvec3 p = a + (s / 20.0) * (b - a) + (t / 20.0) * (fc - a);
          sampled = std::min(sampled, glm::length(p - dc));
        }
      EXPECT_LE(exact, sampled + 1e-9);  // the oracle is no farther than any sample of the face
      EXPECT_NEAR(glm::length(closest_point_on_triangle(dc, a, b, fc) - dc), exact, 1e-9 * (1.0 + exact));
      if (std::abs(exact - r) <= 1e-9 * (1.0 + r)) borderline.insert(canon(f.a, f.b, f.c));
      else if (exact < r) expected.insert(canon(f.a, f.b, f.c));
    }
    std::multiset<Corners> got;
    for (const Corners& k : canon_set(found))
      if (!borderline.count(k)) got.insert(k);
    EXPECT_EQ(got, expected);
    nonempty += expected.size() > 1;
    EXPECT_EQ(canon_set(found).count(canon(*at)), 1u) << "the face under the point is within any radius";
  }
  EXPECT_GT(nonempty, 15) << "the balls should reach beyond the face under their centre";
}

template <class F>
void check_adjacency(const F& front) {
  const FaceAdjacency adj = face_adjacency(front);
  adj.validate();
  EXPECT_EQ(adj.num_nonmanifold_edges, 0u);
  std::map<Index, Face> by_key;
  for (const Face& f : all_faces(front)) by_key[f.key] = f;
  ASSERT_EQ(by_key.size(), adj.num_faces());
  std::size_t links = 0;
  for (const auto& [key, f] : by_key) {
    const std::vector<Index> nb = adj.neighbors(key);
    EXPECT_LE(nb.size(), 3u);
    for (Index k : nb) {
      ++links;
      const std::vector<Index> back = adj.neighbors(k);
      EXPECT_EQ(std::count(back.begin(), back.end(), key), 1) << "neighbour relation is not symmetric";
      const Corners x = canon(f.a, f.b, f.c), y = canon(by_key[k].a, by_key[k].b, by_key[k].c);
      int shared = 0;
      for (const auto& p : x) shared += int(std::count(y.begin(), y.end(), p));
      EXPECT_EQ(shared, 2) << "neighbours must share exactly one edge";
    }
  }
  // Every edge is either shared by two faces or on the border: 3F = 2 * interior edges + border edges.
  EXPECT_EQ(3 * adj.num_faces(), links + adj.num_border_edges);
  // The one-shot convenience agrees with the built adjacency.
  const Index some = by_key.begin()->first;
  EXPECT_EQ(neighbors(front, some), adj.neighbors(some));
}

TEST_F(SpatialQueryNeighbors, SymmetricAndShareExactlyOneEdge) {
  for (float e : {0.0f, 3.0f, 15.0f}) {
    Grid48Front gf(grid_);
    extract(gf, error_query(e));
    check_adjacency(gf);
    MtFront mf(mt_);
    extract(mf, error_query(e));
    check_adjacency(mf);
  }
  // The full-resolution 32 x 32 grid: 128 border edges; interior faces have 3 neighbours.
  Grid48Front full(grid_);
  extract(full, error_query(0.0f));
  const FaceAdjacency adj = face_adjacency(full);
  EXPECT_EQ(adj.num_faces(), 2048u);
  EXPECT_EQ(adj.num_border_edges, 128u);
  EXPECT_EQ(adj.num_vertices, 33u * 33u);
  const auto hit = locate_point(full, error_query(0.0f), {16.3f, 16.6f}, {QueryScope::kGlobal, FrontMode::kKeep});
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(adj.neighbors(hit->key).size(), 3u);
}

TEST_F(SpatialQueryFronts, MtFrontAndGrid48FrontAgree) {
  // Both fronts carry the same errors, so globally defined queries give the same mesh and the same answers.
  // Their spheres differ (the Mt recomputes them), so locally defined queries may force different faces
  // away from the region; at zero error the faces in the region are the finest ones and must agree.
  std::mt19937 rng(10);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 30; ++i) {
    const bool local = i % 3 == 0;
    const QueryScope scope = local ? QueryScope::kLocal : QueryScope::kGlobal;
    const Query q = error_query(local ? 0.0f : float(i % 4) * 3.0f);
    Grid48Front gf(grid_);
    MtFront mf(mt_);
    const glm::vec2 p = random_xy(rng);
    const auto lg = locate_point(gf, q, p, {scope});
    const auto lm = locate_point(mf, q, p, {scope});
    ASSERT_TRUE(lg && lm);
    EXPECT_EQ(canon(*lg), canon(*lm));
    if (!local) {
      EXPECT_EQ(gf.num_faces(), mf.num_faces());
    }

    const glm::vec3 eye(40.0f * u(rng), -25.0f, 140.0f);
    const Ray ray{eye, glm::vec3(4.0f + 24.0f * u(rng), 4.0f + 24.0f * u(rng), 20.0f) - eye};
    const auto pg = pick(gf, q, ray, {scope});
    const auto pm = pick(mf, q, ray, {scope});
    ASSERT_EQ(pg.has_value(), pm.has_value());
    if (pg) {
      EXPECT_EQ(canon(*pg), canon(*pm));
      EXPECT_NEAR(pg->t, pm->t, 1e-5f * pg->t);
    }

    Box3 box;
    box.add({30.0f * u(rng), 30.0f * u(rng), 0.0f});
    box.add(box.lo + glm::vec3(1.0f + 6.0f * u(rng), 1.0f + 6.0f * u(rng), 60.0f));
    EXPECT_EQ(canon_set(intersect_region(gf, q, box, {scope})), canon_set(intersect_region(mf, q, box, {scope})));
    const glm::vec3 c(32.0f * u(rng), 32.0f * u(rng), 50.0f);
    EXPECT_EQ(canon_set(faces_within(gf, q, c, 8.0f, {scope})), canon_set(faces_within(mf, q, c, 8.0f, {scope})));
    if (local) continue;

    // The located face's neighbours, by corners.
    const auto hg = locate_point(gf, q, p, {scope, FrontMode::kKeep});
    const auto hm = locate_point(mf, q, p, {scope, FrontMode::kKeep});
    ASSERT_TRUE(hg && hm);
    std::set<Corners> ng, nm;
    const FaceAdjacency ag = face_adjacency(gf), am = face_adjacency(mf);
    for (Index k : ag.neighbors(hg->key)) {
      const Index f = ag.find(k);
      ng.insert(canon(ag.corners[3 * f], ag.corners[3 * f + 1], ag.corners[3 * f + 2]));
    }
    for (Index k : am.neighbors(hm->key)) {
      const Index f = am.find(k);
      nm.insert(canon(am.corners[3 * f], am.corners[3 * f + 1], am.corners[3 * f + 2]));
    }
    EXPECT_EQ(ng, nm);
  }
}

TEST_F(SpatialQueryFronts, KeepModeDoesNotMoveTheFront) {
  Grid48Front front(grid_);
  extract(front, error_query(4.0f));
  const std::size_t before = front.num_faces();
  QueryStats st;
  st.refined = 99;
  const auto hit = pick(front, error_query(0.0f), Ray{{16.0f, 16.0f, 300.0f}, {0.01f, 0.005f, -1.0f}},
                        {QueryScope::kGlobal, FrontMode::kKeep, &st});
  EXPECT_TRUE(hit.has_value());
  EXPECT_EQ(front.num_faces(), before);
  EXPECT_EQ(st.refined, 0u);
}

TEST_F(SpatialQueryFronts, BadInputThrowsInvalidInput) {
  Grid48Front front(grid_);
  const Query q = error_query(1.0f);
  const float nan = std::nanf("");
  EXPECT_THROW(pick(front, q, Ray{{0.0f, 0.0f, 10.0f}, {0.0f, 0.0f, 0.0f}}), InvalidInput);
  EXPECT_THROW(pick(front, q, Ray{{nan, 0.0f, 10.0f}, {0.0f, 0.0f, -1.0f}}), InvalidInput);
  EXPECT_THROW(locate_point(front, q, {nan, 1.0f}), InvalidInput);
  EXPECT_THROW(faces_within(front, q, {1.0f, 1.0f, 1.0f}, -1.0f), InvalidInput);
  EXPECT_THROW(faces_within(front, q, {1.0f, 1.0f, 1.0f}, nan), InvalidInput);
  Box3 bad;
  bad.add({0.0f, 0.0f, 0.0f});
  bad.hi.x = nan;
  EXPECT_THROW(intersect_region(front, q, bad), InvalidInput);
  EXPECT_TRUE(intersect_region(front, q, Box3{}).empty());  // empty box: nothing
  EXPECT_THROW(neighbors(front, 1u << 30), InvalidInput);
  EXPECT_THROW(FaceAdjacency::build({1, 1}, std::vector<glm::vec3>(6, glm::vec3(0.0f))), InvalidInput);
  EXPECT_THROW(FaceAdjacency::build({1}, std::vector<glm::vec3>(2, glm::vec3(0.0f))), InvalidInput);
}

TEST(SpatialQueryPredicates, SharedEdgeAndVertexAreNeverLost) {
  // Two triangles sharing the diagonal of the unit square, tilted so that coordinates round.
  const glm::vec3 a(0.1f, 0.1f, 0.3f), b(1.3f, 0.2f, 0.7f), c(1.1f, 1.7f, 0.2f), d(0.2f, 1.2f, 0.9f);
  for (int i = 0; i <= 100; ++i) {
    const float s = float(i) / 100.0f;
    const glm::vec3 on = a + s * (c - a);  // on the shared edge a-c
    const Ray down{on + glm::vec3(0.0f, 0.0f, 5.0f), {0.0f, 0.0f, -1.0f}};
    const bool h1 = intersect_ray_triangle(down, a, b, c).has_value();
    const bool h2 = intersect_ray_triangle(down, a, c, d).has_value();
    EXPECT_TRUE(h1 || h2) << "ray through the shared edge missed both faces at s=" << s;
    const bool l1 = locate_in_xy({on.x, on.y}, a, b, c).has_value();
    const bool l2 = locate_in_xy({on.x, on.y}, a, c, d).has_value();
    EXPECT_TRUE(l1 || l2) << "point on the shared edge lost at s=" << s;
  }
  // A vertical face has no xy-interior; a ray in a face's plane misses it.
  EXPECT_FALSE(locate_in_xy({0.5f, 0.0f}, {0, 0, 0}, {1, 0, 0}, {0, 0, 1}).has_value());
  EXPECT_FALSE(intersect_ray_triangle(Ray{{-1, 0.2f, 0}, {1, 0, 0}}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}).has_value());
  // SAT: a triangle crossing a box without any corner inside it, and one just beside it.
  Box3 box;
  box.add({0, 0, 0});
  box.add({1, 1, 1});
  EXPECT_TRUE(triangle_overlaps_box({-1, 0.5f, 0.5f}, {2, 0.5f, 0.5f}, {0.5f, 5, 0.5f}, box));
  EXPECT_FALSE(triangle_overlaps_box({1.2f, 0, 0}, {3, 0, 0}, {1.2f, 3, 3}, box));
  // The face's plane separates: the triangle cuts the box's bounding slabs but passes beyond a corner.
  EXPECT_FALSE(triangle_overlaps_box({3.1f, 0, 0}, {0, 3.1f, 0}, {0, 0, 3.1f}, box));
  EXPECT_TRUE(triangle_overlaps_box({2.5f, 0, 0}, {0, 2.5f, 0}, {0, 0, 2.5f}, box));
}


TEST(SpatialQuery, IntersectRegionRefusesANonFiniteFrustum) {
  const HeightField field = make_fractal_terrain(17, 17, 3);
  const Grid48 grid(field);
  Grid48Front front(grid);
  Frustum f = Camera{}.frustum();
  f.planes[0].d = std::numeric_limits<float>::quiet_NaN();
  for (const QueryScope scope : {QueryScope::kGlobal, QueryScope::kLocal}) {
    SpatialOptions o;
    o.scope = scope;
    EXPECT_THROW(intersect_region(front, Query{}, f, o), InvalidInput);
  }
  SpatialOptions keep;
  keep.mode = FrontMode::kKeep;
  EXPECT_THROW(intersect_region(front, Query{}, f, keep), InvalidInput);
}

}  // namespace
}  // namespace varmesh
