// Point-to-mesh distances (multitri/mesh_distance.hpp) against a plain scan with the tests' own
// point-to-triangle oracle (projection onto the plane, else the nearest edge; written independently).
#include "multitri/mesh_distance.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "distance_oracle.hpp"
#include "multitri/errors.hpp"
#include "multitri/shapes.hpp"

namespace varmesh {
namespace {

glm::dvec3 corner(const TriMesh& m, std::size_t f, std::size_t k) { return glm::dvec3(m.positions[m.indices[3 * f + k]]); }

double brute_force(const TriMesh& m, const glm::dvec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    best = std::min(best, testing::point_triangle(p, corner(m, f, 0), corner(m, f, 1), corner(m, f, 2)));
  return best;
}

// A random soup with some degenerate triangles: repeated corners, collinear corners, slivers.
TriMesh random_soup(std::mt19937& rng, std::size_t faces) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  TriMesh m;
  for (std::size_t f = 0; f < faces; ++f) {
    const glm::vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
    glm::vec3 c(u(rng), u(rng), u(rng));
    switch (f % 7) {
      case 0: c = a; break;                   // repeated corner
      case 1: c = a + 0.5f * (b - a); break;  // collinear
      case 2: c = a + 0.5f * (b - a) + glm::vec3(1e-6f, 0.0f, 0.0f); break;  // sliver
      default: break;
    }
    const Index base = static_cast<Index>(m.positions.size());
    m.positions.insert(m.positions.end(), {a, b, c});
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
  }
  return m;
}

TEST(MeshDistance, BvhAgreesWithAScan) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (const std::size_t faces : {1u, 3u, 5u, 40u, 700u}) {
    const TriMesh soup = random_soup(rng, faces);
    const TriangleBvh bvh(soup);
    EXPECT_EQ(bvh.num_triangles(), faces);
    for (int i = 0; i < 300; ++i) {
      const glm::dvec3 p(u(rng), u(rng), u(rng));
      const double want = brute_force(soup, p);
      EXPECT_NEAR(std::sqrt(bvh.nearest_sq(p)), want, 1e-9 * (1.0 + want)) << faces << " faces, point " << i;
    }
  }
}

TEST(MeshDistance, PointTriangleCases) {
  const glm::dvec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({0.25, 0.25, 2.0}, a, b, c), 4.0);  // above the interior
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({-1.0, -1.0, 0.0}, a, b, c), 2.0);  // corner region
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({0.5, -3.0, 0.0}, a, b, c), 9.0);   // edge region
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({0.25, 0.25, 0.0}, a, b, c), 0.0);  // on it
  // Degenerate: a segment from (0,0,0) to (2,0,0) given as three collinear corners, and a point.
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({1.0, 3.0, 4.0}, a, {2, 0, 0}, {1, 0, 0}), 25.0);
  EXPECT_DOUBLE_EQ(point_triangle_distance_sq({3.0, 0.0, 0.0}, a, a, a), 9.0);
}

TEST(MeshDistance, VertexToSurface) {
  const TriMesh sphere = make_icosphere(3);
  SurfaceDistance self = vertex_to_surface_distance(sphere, sphere);
  EXPECT_EQ(self.points, sphere.num_vertices());
  EXPECT_EQ(self.max, 0.0);
  EXPECT_NEAR(self.diagonal, 2.0 * std::sqrt(3.0), 0.05);
  // A copy grown by 10 %: the vertices of the small one lie 0.1 inside the big one's vertices, and at least
  // 0.1 * cos(the largest face's angular radius) below its faces.
  TriMesh big = sphere;
  for (glm::vec3& p : big.positions) p *= 1.1f;
  const SurfaceDistance grown = vertex_to_surface_distance(sphere, big);
  EXPECT_LE(grown.max, 0.1 + 1e-6);
  EXPECT_GT(grown.rms, 0.09);
  EXPECT_LE(grown.rms, grown.max);
  // Unreferenced vertices are not measured; no faces at all gives infinity.
  TriMesh extra = sphere;
  extra.positions.push_back({100.0f, 0.0f, 0.0f});
  EXPECT_EQ(vertex_to_surface_distance(extra, sphere).points, sphere.num_vertices());
  EXPECT_EQ(vertex_to_surface_distance(extra, sphere).max, 0.0);
  EXPECT_TRUE(std::isinf(vertex_to_surface_distance(sphere, TriMesh{}).max));
}

TEST(MeshDistance, BadInputIsNamed) {
  TriMesh m = make_icosphere(0);
  m.indices[4] = 999;
  EXPECT_THROW(TriangleBvh{m}, InvalidInput);
  EXPECT_THROW(vertex_to_surface_distance(m, make_icosphere(0)), InvalidInput);
  for (const float bad : {std::nanf(""), HUGE_VALF}) {
    TriMesh odd = make_icosphere(0);
    odd.positions[m.indices[0]].y = bad;
    EXPECT_THROW(TriangleBvh{odd}, InvalidInput);
    EXPECT_THROW(vertex_to_surface_distance(odd, make_icosphere(0)), InvalidInput);
    EXPECT_THROW(vertex_to_surface_distance(make_icosphere(0), odd), InvalidInput);
  }
}

// Slivers: corners on a line up to double rounding. The closest-point regions lose their signs there (a
// review found answers off by 1000x); they are measured by their edges, which the oracle agrees with.
TEST(MeshDistance, SliversAreMeasuredByTheirEdges) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 20000; ++i) {
    const glm::dvec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), off(u(rng), u(rng), u(rng));
    const double t = 1.5 * u(rng);
    const glm::dvec3 c = a + t * (b - a) + 1e-15 * off;
    const glm::dvec3 p = a + u(rng) * (b - a) + 0.01 * glm::dvec3(u(rng), u(rng), u(rng));
    const double want = testing::point_triangle(p, a, b, c);
    EXPECT_NEAR(std::sqrt(point_triangle_distance_sq(p, a, b, c)), want, 1e-9) << "case " << i;
  }
}

}  // namespace
}  // namespace varmesh
