// The generated shapes: closed, oriented outwards, of the topology and size they promise. Checked by
// analyze_mesh (topology, an independent implementation) and by the signed volume and distances.
#include "multitri/shapes.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <tuple>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/terrain_gen.hpp"
#include "mesh_fixtures.hpp"

namespace varmesh {
namespace {

using testing::signed_volume;

TEST(Shapes, IcosphereIsAClosedOutwardSphere) {
  for (int levels : {0, 1, 3}) {
    const TriMesh m = make_icosphere(levels);
    const MeshReport r = analyze_mesh(m);
    EXPECT_EQ(r.faces, 20u << (2 * levels));
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.genus, 0);
    EXPECT_EQ(r.non_manifold_vertices, 0u);
    for (const glm::vec3& p : m.positions) EXPECT_NEAR(glm::length(p), 1.0f, 1e-6f);
    // Outwards: positive volume, below the unit ball's.
    EXPECT_GT(signed_volume(m), 0.0);
    EXPECT_LT(signed_volume(m), 4.0 / 3.0 * std::numbers::pi);
  }
  EXPECT_THROW(make_icosphere(-1), InvalidInput);
  EXPECT_THROW(make_icosphere(11), InvalidInput);
}

TEST(Shapes, TorusIsAClosedOutwardGenusOneSurface) {
  for (const auto& [n, m, bump] : {std::tuple{3, 3, 0.0f}, std::tuple{16, 10, 0.0f}, std::tuple{40, 24, 0.15f}}) {
    const float big = 1.0f, small = 0.35f;
    const TriMesh t = make_torus(n, m, big, small, bump);
    const MeshReport r = analyze_mesh(t);
    EXPECT_EQ(r.vertices, static_cast<std::size_t>(n * m));
    EXPECT_EQ(r.faces, static_cast<std::size_t>(2 * n * m));
    EXPECT_TRUE(r.closed);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(r.euler_characteristic, 0);
    EXPECT_EQ(r.genus, 1);
    EXPECT_EQ(r.degenerate_faces + r.zero_area_faces + r.duplicate_faces, 0u);
    // Every vertex on its tube: distance to the core circle within [small (1 - bump), small (1 + bump)].
    for (const glm::vec3& p : t.positions) {
      const double core = std::hypot(p.x, p.y) - big;
      const double d = std::hypot(core, static_cast<double>(p.z));
      EXPECT_GE(d, small * (1.0 - bump) - 1e-5);
      EXPECT_LE(d, small * (1.0 + bump) + 1e-5);
    }
    // Outwards, and no more than the solid torus of the largest tube radius holds.
    const double vol = signed_volume(t);
    const double rmax = small * (1.0 + bump);
    EXPECT_GT(vol, 0.0);
    EXPECT_LT(vol, 2.0 * std::numbers::pi * std::numbers::pi * big * rmax * rmax);
  }
  EXPECT_THROW(make_torus(2, 8), InvalidInput);
  EXPECT_THROW(make_torus(8, 2), InvalidInput);
  EXPECT_THROW(make_torus(1 << 13, 1 << 12), InvalidInput);
}


TEST(Shapes, TorusRefusesRadiiThatAreNotFiniteAndPositive) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::tuple<float, float, float> bad[] = {{nan, 0.3f, 0.0f}, {1.0f, inf, 0.0f}, {1.0f, 0.3f, nan},
                                                 {-1.0f, 0.3f, 0.0f}, {1.0f, 0.0f, 0.0f}, {3e38f, 3e38f, 0.0f}};
  for (const auto& [big, small, bump] : bad)
    EXPECT_THROW(make_torus(8, 8, big, small, bump), InvalidInput) << big << " " << small << " " << bump;
}

TEST(Shapes, FractalTerrainRefusesParametersThatGiveNonFiniteHeights) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, nan), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, inf), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, -1.0f), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, 100.0f, 8, nan), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, 100.0f, 8, inf), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, 100.0f, 20, 1e10f), InvalidInput);  // octave sum overflows
  EXPECT_THROW(make_fractal_terrain(1, 8, 1), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 32769, 1), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, 100.0f, 0), InvalidInput);
  EXPECT_THROW(make_fractal_terrain(8, 8, 1, 100.0f, 21), InvalidInput);
  const HeightField f = make_fractal_terrain(8, 8, 1, 100.0f, 20, -0.9f);
  f.validate();
  for (float z : f.z) {
    EXPECT_GE(z, 0.0f);
    EXPECT_LE(z, 100.0f);
  }
}

}  // namespace
}  // namespace varmesh
