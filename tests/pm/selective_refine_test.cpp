// Selective refinement to a predicate (pm/selective_refine.hpp) under the three schemes, on generated
// versions of the Kim-Lee 2001 experiments: every scheme reaches every required vertex, the meshes are
// valid and equal the meshes their active sets define (dual pieces), Kim-Lee forces nothing and splits only
// what is needed (plus degenerate-case pre-splits), and kim-lee <= hoppe97 <= xia-varshney in #V and #F.
#include "pm/selective_refine.hpp"

#include <algorithm>
#include <array>
#include <functional>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include <limits>

#include "multitri/camera.hpp"
#include "multitri/errors.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"
#include "pm/dual_pieces.hpp"
#include "pm/qem_analysis.hpp"
#include "pm_fixtures.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

using testing::differs_from_dual_pieces;

constexpr std::array<RefinementScheme, 3> kSchemes = {RefinementScheme::kKimLee, RefinementScheme::kHoppe97,
                                                      RefinementScheme::kXiaVarshney};

Image gray_image(std::size_t w, std::size_t h, const std::vector<std::uint8_t>& px) {
  Image img;
  img.width = w;
  img.height = h;
  img.channels = 1;
  img.pixels = px;
  return img;
}


struct Outcome {
  std::size_t vertices = 0, faces = 0;
  SelectiveRefineResult result;
};

// Runs all three schemes with one predicate and checks what must hold for each; returns the counts.
std::array<Outcome, 3> run_schemes(const VertexHierarchy& h, const std::vector<std::uint8_t>& needs) {
  std::array<Outcome, 3> out;
  for (std::size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(scheme_name(kSchemes[k]));
    SrMesh m(h, kSchemes[k]);
    out[k].result = refine_to_predicate(m, [&](Index v) { return needs[v] != 0; });
    EXPECT_NO_THROW(m.validate());
    EXPECT_EQ(differs_from_dual_pieces(m), "");
    EXPECT_TRUE(out[k].result.complete()) << out[k].result.unsatisfied << " nodes left";
    // Every needed inner node is split, whatever the scheme.
    std::size_t unsplit = 0;
    for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v)
      unsplit += needs[v] && m.state(static_cast<Index>(v)) != SrMesh::State::kRefined;
    EXPECT_EQ(unsplit, 0u);
    // The mesh is fresh, so its counters are this run's. Every split is requested, forced or a section 4.4
    // pre-split, counted once; every collapse is forced (none is requested); nothing is collapsed, so no
    // collapse is postponed and #DC is the pre-splits.
    const SrStats& st = m.stats();
    EXPECT_EQ(st.vsplits, out[k].result.requested_vsplits + st.forced_vsplits + st.presplits);
    EXPECT_EQ(st.ecols, st.forced_ecols);
    EXPECT_EQ(st.postponed_ecols, 0u);
    EXPECT_EQ(st.degenerate_cases, st.presplits);
    EXPECT_EQ(out[k].result.stats.degenerate_cases, st.degenerate_cases);
    EXPECT_EQ(out[k].result.stats.presplits, st.presplits);
    EXPECT_EQ(out[k].result.stats.postponed_ecols, st.postponed_ecols);
    if (kSchemes[k] == RefinementScheme::kKimLee) {
      EXPECT_EQ(out[k].result.stats.forced_vsplits, 0u);
      EXPECT_EQ(out[k].result.stats.forced_ecols, 0u);
      // Truly selective: nothing is split beyond the needed nodes except the section 4.4 pre-splits.
      std::size_t extra = 0;
      for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v)
        extra += !needs[v] && m.state(static_cast<Index>(v)) == SrMesh::State::kRefined;
      EXPECT_LE(extra, st.presplits);
      EXPECT_EQ(out[k].result.requested_vsplits + st.presplits, out[k].result.stats.vsplits);
    }
    out[k].vertices = m.num_active_vertices();
    out[k].faces = m.num_faces();
  }
  return out;
}

void expect_ordering(const std::array<Outcome, 3>& o) {
  // kSchemes order: kim-lee, hoppe97, xia-varshney.
  EXPECT_LE(o[0].vertices, o[1].vertices);
  EXPECT_LE(o[1].vertices, o[2].vertices);
  EXPECT_LE(o[0].faces, o[1].faces);
  EXPECT_LE(o[1].faces, o[2].faces);
  // And the baselines do force something on these inputs (otherwise the comparison shows nothing).
  EXPECT_GT(o[1].result.stats.forced_vsplits, 0u);
  EXPECT_GT(o[2].result.stats.forced_vsplits, 0u);
}

TEST(SelectiveRefine, SobelFindsAStepEdge) {
  // Left half black, right half white: the gradient sits on the two columns beside the step.
  std::vector<std::uint8_t> px(16 * 8, 0);
  for (std::size_t y = 0; y < 8; ++y)
    for (std::size_t x = 8; x < 16; ++x) px[y * 16 + x] = 255;
  const Image img = gray_image(16, 8, px);
  const auto mag = sobel_magnitude(img);
  for (std::size_t y = 0; y < 8; ++y)
    for (std::size_t x = 0; x < 16; ++x) {
      const float expected = (x == 7 || x == 8) ? 4.0f : 0.0f;
      EXPECT_NEAR(mag[y * 16 + x], expected, 1e-5f) << x << "," << y;
    }
  const auto feat = top_fraction_features(mag, 0.05);
  EXPECT_EQ(feat.size(), 16u);  // ceil(0.05 * 128) = 7th largest is 4, and all 16 ties are kept
  for (Index f : feat) EXPECT_TRUE(f % 16 == 7 || f % 16 == 8);
  EXPECT_TRUE(top_fraction_features(sobel_magnitude(gray_image(4, 4, std::vector<std::uint8_t>(16, 90))), 1.0).empty());
  EXPECT_THROW(top_fraction_features(mag, 0.0), InvalidInput);
  // A NaN magnitude left the threshold undefined (0 features for {1, NaN, 3, NaN, 2} at 0.5): refused.
  const std::vector<float> with_nan = {1.0f, std::numeric_limits<float>::quiet_NaN(), 3.0f, 2.0f};
  EXPECT_THROW(top_fraction_features(with_nan, 0.5), InvalidInput);
  EXPECT_THROW(top_fraction_features(mag, 1.5), InvalidInput);
  EXPECT_THROW(sobel_magnitude(Image{}), InvalidInput);
}

TEST(SelectiveRefine, GridMeshesAreUprightCounterClockwiseAndColoured) {
  std::vector<std::uint8_t> px(5 * 4);
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<std::uint8_t>(10 * i);
  const TriMesh m = image_grid_mesh(gray_image(5, 4, px));
  ASSERT_EQ(m.num_vertices(), 20u);
  ASSERT_EQ(m.num_faces(), 2u * 4u * 3u);
  ASSERT_NO_THROW(m.validate());
  // Pixel (x, y) at (x, 3 - y, 0), grey colour.
  EXPECT_EQ(m.positions[1 * 5 + 2], glm::vec3(2, 2, 0));
  EXPECT_NEAR(m.colors[7].x, 70.0f / 255.0f, 1e-6f);
  EXPECT_EQ(m.colors[7].x, m.colors[7].z);
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const glm::vec3 a = m.positions[m.corner(f, 0)], b = m.positions[m.corner(f, 1)], c = m.positions[m.corner(f, 2)];
    EXPECT_GT(glm::cross(b - a, c - a).z, 0.0f) << "face " << f;
  }
  HeightField field;
  field.width = 4;
  field.height = 3;
  field.z = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  const TriMesh t = heightfield_grid_mesh(field);
  ASSERT_EQ(t.num_faces(), 12u);
  for (std::size_t f = 0; f < t.num_faces(); ++f) {
    const glm::vec3 a = t.positions[t.corner(f, 0)], b = t.positions[t.corner(f, 1)], c = t.positions[t.corner(f, 2)];
    EXPECT_GT(glm::cross(b - a, c - a).z, 0.0f) << "face " << f;
  }
  EXPECT_THROW(image_grid_mesh(gray_image(1, 4, std::vector<std::uint8_t>(4, 0))), InvalidInput);
}

TEST(SelectiveRefine, DownsamplingAveragesBlocks) {
  std::vector<std::uint8_t> px(5 * 3, 0);
  px[0] = 200;
  px[1] = 100;
  px[5] = 100;
  px[6] = 0;
  px[4] = 50;  // lone column at the right edge: a partial block
  px[14] = 250;  // lone corner pixel
  const Image small = downsample_image(gray_image(5, 3, px), 2);
  ASSERT_EQ(small.width, 3u);
  ASSERT_EQ(small.height, 2u);
  EXPECT_EQ(small.pixels[0], 100);  // (200 + 100 + 100 + 0) / 4
  EXPECT_EQ(small.pixels[2], 25);   // (50 + 0) / 2
  EXPECT_EQ(small.pixels[5], 250);
  HeightField field;
  field.width = 4;
  field.height = 2;
  field.z = {0, 2, 4, 6, 8, 10, 12, 14};
  const HeightField half = downsample_heightfield(field, 2);
  ASSERT_EQ(half.width, 2u);
  ASSERT_EQ(half.height, 1u);
  EXPECT_FLOAT_EQ(half.z[0], 5.0f);
  EXPECT_FLOAT_EQ(half.z[1], 9.0f);
  EXPECT_FLOAT_EQ(half.spacing_x, 2.0f);
  EXPECT_THROW(downsample_image(gray_image(5, 3, px), 0), InvalidInput);
  // A factor beyond the picture averages it all into one pixel, however large (the rounded-up division
  // wrapped round near SIZE_MAX and gave an empty image).
  for (const std::size_t factor : {std::size_t{5}, std::size_t{1000}, std::numeric_limits<std::size_t>::max()}) {
    const Image one = downsample_image(gray_image(5, 3, px), factor);
    ASSERT_EQ(one.width, 1u) << factor;
    ASSERT_EQ(one.height, 1u) << factor;
    EXPECT_EQ(one.pixels[0], 47) << factor;  // (200 + 100 + 100 + 50 + 250) / 15 = 46.7
    const HeightField flat = downsample_heightfield(field, factor);
    ASSERT_EQ(flat.width, 1u) << factor;
    ASSERT_EQ(flat.height, 1u) << factor;
    EXPECT_FLOAT_EQ(flat.z[0], 7.0f) << factor;
  }
}

TEST(SelectiveRefine, FlagsReachEveryAncestorAndNothingElse) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_grid(12, 12));
  std::vector<std::uint8_t> leaves(h.num_leaves(), 0);
  leaves[17] = leaves[100] = 1;
  const auto flags = flag_ancestors(h, leaves);
  std::set<Index> expected;
  for (Index l : {Index{17}, Index{100}})
    for (Index v = l; v != kInvalid; v = h.parent(v)) expected.insert(v);
  for (std::size_t v = 0; v < h.num_nodes(); ++v) EXPECT_EQ(flags[v] != 0, expected.count(static_cast<Index>(v)) == 1) << v;
  EXPECT_THROW(flag_ancestors(h, std::vector<std::uint8_t>(3, 0)), InvalidInput);
  const std::vector<Index> inputs{5, 9};
  const auto lf = leaves_of_inputs(h, inputs);
  std::size_t n = 0;
  for (std::size_t l = 0; l < lf.size(); ++l)
    if (lf[l]) {
      ++n;
      EXPECT_TRUE(h.leaf_to_input()[l] == 5 || h.leaf_to_input()[l] == 9);
    }
  EXPECT_EQ(n, 2u);
  EXPECT_THROW(leaves_of_inputs(h, std::vector<Index>{1000000}), InvalidInput);
}

TEST(SelectiveRefine, TrivialPredicates) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_icosphere(2));
  for (RefinementScheme s : kSchemes) {
    SrMesh none(h, s);
    const auto r0 = refine_to_predicate(none, [](Index) { return false; });
    EXPECT_EQ(r0.stats.vsplits, 0u);
    EXPECT_EQ(none.num_active_vertices(), h.num_roots());
    SrMesh all(h, s);
    const auto r1 = refine_to_predicate(all, [](Index) { return true; });
    EXPECT_TRUE(r1.complete());
    EXPECT_EQ(all.num_active_vertices(), h.num_leaves());
    EXPECT_EQ(all.num_faces(), h.num_faces());
    EXPECT_NO_THROW(all.validate());
    EXPECT_THROW(refine_to_predicate(all, [](Index) { return true; }, 0), InvalidInput);
    // An empty std::function is a bad argument like the others (it used to escape as bad_function_call).
    SrMesh some(h, s);
    EXPECT_THROW(refine_to_predicate(some, std::function<bool(Index)>{}), InvalidInput);
    EXPECT_EQ(some.num_active_vertices(), h.num_roots());
  }
}

// The image experiment (Table 2 "F.P.", Figure 9) on the generated test image.
TEST(SelectiveRefine, FeaturePointsAreRecoveredByEveryScheme) {
  const Image img = make_feature_test_image(24);  // small: colour quadrics are slow in sanitizer builds
  const std::vector<Index> features = top_fraction_features(sobel_magnitude(img), 0.1);
  ASSERT_GT(features.size(), 40u);
  QemOptions qo;
  qo.use_colors = true;
  const VertexHierarchy h = build_vertex_hierarchy(image_grid_mesh(img), qo);
  ASSERT_TRUE(h.has_colors());
  ASSERT_LT(h.num_roots(), 10u);
  const auto leaves = leaves_of_inputs(h, features);
  const auto needs = flag_ancestors(h, leaves);
  const auto outcome = run_schemes(h, needs);
  expect_ordering(outcome);
  for (RefinementScheme s : kSchemes) {
    SrMesh m(h, s);
    refine_to_predicate(m, [&](Index v) { return needs[v] != 0; });
    std::size_t missing = 0;
    for (std::size_t l = 0; l < leaves.size(); ++l) missing += leaves[l] && !m.is_active(static_cast<Index>(l));
    EXPECT_EQ(missing, 0u) << scheme_name(s);
  }
}

// The terrain experiment (Table 2 "V.F.", Figure 8) on a generated fractal terrain.
TEST(SelectiveRefine, TerrainFrustumIsRefinedByEveryScheme) {
  const HeightField field = make_fractal_terrain(32, 32, 7, 8.0f);
  const VertexHierarchy h = build_vertex_hierarchy(heightfield_grid_mesh(field));
  Camera cam;
  cam.eye = {4.0f, 2.0f, 14.0f};
  cam.target = {18.0f, 20.0f, 2.0f};
  cam.fov_y_deg = 35.0f;
  cam.aspect = 1.0f;
  cam.z_near = 0.1f;
  cam.z_far = 24.0f;
  const Frustum fr = cam.frustum();
  std::vector<std::uint8_t> needs(h.num_nodes(), 0);
  std::size_t n = 0;
  for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) {
    const ElementBound& b = h.bound(static_cast<Index>(v));
    needs[v] = fr.intersects_sphere(b.center, b.radius);
    n += needs[v];
  }
  ASSERT_GT(n, 100u);
  ASSERT_LT(n, h.num_collapses() * 3 / 4);  // a part of the terrain, not all of it
  expect_ordering(run_schemes(h, needs));
}

// The 3D experiment (Table 2 "V.F. & B.F.C.", Figure 10) on a generated closed surface.
TEST(SelectiveRefine, FrustumAndBackFaceCullingOnAClosedSurface) {
  const VertexHierarchy h = build_vertex_hierarchy(testing::make_icosphere(3));
  Camera cam;
  cam.eye = {0.4f, -2.2f, 0.9f};
  cam.target = {0.3f, 0.0f, 0.3f};
  cam.fov_y_deg = 20.0f;
  cam.aspect = 1.0f;
  cam.z_near = 0.01f;
  cam.z_far = 5.0f;
  const Criterion crit = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye)});
  std::vector<std::uint8_t> needs(h.num_nodes(), 0);
  std::size_t n = 0;
  for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) {
    needs[v] = !crit.is_fine(h.bound(static_cast<Index>(v)));
    n += needs[v];
  }
  ASSERT_GT(n, 50u);
  ASSERT_LT(n, h.num_collapses() * 3 / 4);
  expect_ordering(run_schemes(h, needs));
}

}  // namespace
}  // namespace varmesh
