// Eigen-analysis of extraordinary vertices (fourk/subdiv_analysis.hpp): the patch, the local matrix against
// the engine's fast path, the Fourier blocks against a dense solve, and the subdominant-eigenvalue condition
// for the 4-8 rule and for Catmull-Clark (against Stam's closed form) at valences 3 to 12.
#include "fourk/subdiv_analysis.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "multitri/errors.hpp"
#include "multitri/huge_pages.hpp"

namespace varmesh {
namespace {

constexpr int kMinValence = 3;
constexpr int kMaxValence = 12;

// Stam 1998, section 4 (and Halstead, Kass, DeRose 1993): Catmull-Clark's subdominant eigenvalue,
// (5 + cos(2 pi / n) + cos(pi / n) sqrt(2 (9 + cos(2 pi / n)))) / 16. It is the larger root of the 2x2
// mode-1 block of the 1-ring matrix, lambda^2 - (5 + c)/8 lambda + 1/16 = 0 with c = cos(2 pi / n).
double stam_subdominant(int n) {
  const double c = std::cos(2 * std::numbers::pi / n), h = std::cos(std::numbers::pi / n);
  return (5.0 + c + h * std::sqrt(2.0 * (9.0 + c))) / 16.0;
}

std::vector<std::complex<double>> all_fourier_eigenvalues(const SubdivSpectrum& s) {
  std::vector<std::complex<double>> all;
  for (const auto& mode : s.modes) all.insert(all.end(), mode.begin(), mode.end());
  return all;
}

// Every value of `a` with modulus above `floor` has its own partner in `b` within `tol`.
bool matched(const std::vector<std::complex<double>>& a, const std::vector<std::complex<double>>& b, double floor,
             double tol) {
  std::vector<bool> used(b.size(), false);
  for (const auto& x : a) {
    if (std::abs(x) <= floor) continue;
    bool found = false;
    for (std::size_t i = 0; i < b.size() && !found; ++i)
      if (!used[i] && std::abs(b[i] - x) <= tol) used[i] = found = true;
    if (!found) return false;
  }
  return true;
}

// The fine vertex at sector coordinate c after one quadrisection of extraordinary_patch(k, rings), from the
// numbering documented in subdiv.hpp (old vertex kept, face f -> V + f, edge e -> V + F + e) and the
// patch's face order: an oracle independent of the labelling inside subdiv_analysis.cpp.
Index fine_vertex(const SubdivTopology& t, int k, int rings, PatchCoord c) {
  const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
  if (c.is_centre()) return 0;
  if (c.i % 2 == 0 && c.j % 2 == 0) return extraordinary_patch_vertex(k, rings, {c.sector, c.i / 2, c.j / 2});
  if (c.i % 2 == 1 && c.j % 2 == 1)
    return nv + static_cast<Index>(c.sector * rings * rings + (c.i / 2) * rings + c.j / 2);
  const PatchCoord a{c.sector, c.i / 2, c.j / 2};
  const PatchCoord b = c.i % 2 ? PatchCoord{c.sector, c.i / 2 + 1, c.j / 2} : PatchCoord{c.sector, c.i / 2, c.j / 2 + 1};
  const Index va = extraordinary_patch_vertex(k, rings, a), vb = extraordinary_patch_vertex(k, rings, b);
  for (std::size_t e = 0; e < t.num_edges(); ++e) {
    const Index x = t.edge_verts[2 * e], y = t.edge_verts[2 * e + 1];
    if ((x == va && y == vb) || (x == vb && y == va)) return nv + nf + static_cast<Index>(e);
  }
  ADD_FAILURE() << "no edge between " << va << " and " << vb;
  return 0;
}

TEST(SubdivAnalysisPatch, ShapeValencesAndCoordinates) {
  for (int k = kMinValence; k <= kMaxValence; ++k)
    for (int rings = 1; rings <= 3; ++rings) {
      SCOPED_TRACE("valence " + std::to_string(k) + ", rings " + std::to_string(rings));
      const PolyMesh m = extraordinary_patch(k, rings);
      ASSERT_NO_THROW(m.validate());
      EXPECT_TRUE(m.all_quads());
      EXPECT_EQ(m.num_vertices(), 1u + static_cast<std::size_t>(k * rings * (rings + 1)));
      EXPECT_EQ(m.num_faces(), static_cast<std::size_t>(k * rings * rings));
      const SubdivTopology t = make_subdiv_topology(m);
      EXPECT_EQ(t.valence[0], k);
      EXPECT_EQ(t.vertex_border[0], 0);
      for (Index v = 0; v < m.num_vertices(); ++v) {
        const PatchCoord c = extraordinary_patch_coord(k, rings, v);
        EXPECT_EQ(extraordinary_patch_vertex(k, rings, c), v);
        if (v == 0) continue;
        EXPECT_GE(c.i, 1);
        EXPECT_EQ(t.vertex_border[v], c.ring() == rings ? 1 : 0) << "vertex " << v;
        if (c.ring() < rings) {
          EXPECT_EQ(t.valence[v], 4) << "vertex " << v;
        }
      }
      // (0, j) of sector s is (j, 0) of sector s + 1.
      for (int s = 0; s < k; ++s)
        EXPECT_EQ(extraordinary_patch_vertex(k, rings, {s, 0, rings}),
                  extraordinary_patch_vertex(k, rings, {(s + 1) % k, rings, 0}));
    }
}

TEST(SubdivAnalysisPatch, RejectsBadArguments) {
  EXPECT_THROW(extraordinary_patch(2, 2), InvalidInput);
  EXPECT_THROW(extraordinary_patch(5, 0), InvalidInput);
  EXPECT_THROW(extraordinary_patch(5, 1 << 20), InvalidInput);
  EXPECT_THROW(extraordinary_patch_vertex(5, 2, {5, 1, 1}), InvalidInput);
  EXPECT_THROW(extraordinary_patch_vertex(5, 2, {0, 3, 0}), InvalidInput);
  EXPECT_THROW(extraordinary_patch_vertex(5, 2, {0, 1, -1}), InvalidInput);
  EXPECT_THROW(extraordinary_patch_coord(5, 2, 31), InvalidInput);
  EXPECT_THROW(local_subdivision_matrix(SubdivScheme::kFourEight, 2), InvalidInput);
  EXPECT_THROW(local_subdivision_matrix(SubdivScheme::kFourEight, 5, 0), InvalidInput);
  EXPECT_THROW(local_subdivision_matrix(SubdivScheme::kFourEight, 5, 3, 2), InvalidInput);
  // The 4-8 rows reach two coarse rings: a neighbourhood limited to ring 1 cannot close.
  // (InvalidInput is a std::logic_error too, hence the explicit check.)
  bool not_closed = false;
  try {
    local_subdivision_matrix(SubdivScheme::kFourEight, 5, 1, 1);
  } catch (const InvalidInput&) {
  } catch (const std::logic_error&) {
    not_closed = true;
  }
  EXPECT_TRUE(not_closed);
  EXPECT_NO_THROW(local_subdivision_matrix(SubdivScheme::kCatmullClark, 5, 1, 1));
  // Valence 40000 (within the engine's 65535 edges) makes a dense 80001 x 80001 matrix, about 51 GB: its
  // allocation used to end in std::bad_alloc; now refused by name first.
  if (physical_memory_bytes() > 0.0 && physical_memory_bytes() < 48e9) {
    try {
      local_subdivision_matrix(SubdivScheme::kCatmullClark, 40000, 1, 1);
      ADD_FAILURE() << "no throw";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("GB of memory here (valence)"), std::string::npos) << e.what();
      EXPECT_EQ(e.element(), 40000u);
    }
  }
}

TEST(SubdivAnalysisMatrix, SmallestInvariantRingAndAffineRows) {
  for (int k = kMinValence; k <= kMaxValence; ++k) {
    SCOPED_TRACE("valence " + std::to_string(k));
    const LocalSubdivMatrix cc = local_subdivision_matrix(SubdivScheme::kCatmullClark, k);
    const LocalSubdivMatrix fe = local_subdivision_matrix(SubdivScheme::kFourEight, k);
    EXPECT_EQ(cc.ring, 1);
    EXPECT_EQ(cc.size(), 1u + 2u * k);
    EXPECT_EQ(fe.ring, 2);
    EXPECT_EQ(fe.size(), 1u + 6u * k);
    for (const LocalSubdivMatrix* s : {&cc, &fe})
      for (std::size_t p = 0; p < s->size(); ++p) {
        double sum = 0.0;
        for (std::size_t q = 0; q < s->size(); ++q) sum += s->at(p, q);
        EXPECT_NEAR(sum, 1.0, 1e-14) << "row " << p;
      }
  }
}

// S applied to the coarse ring equals what subdivide() (the position fast path, not the tables) puts at the
// same positions of the fine patch.
TEST(SubdivAnalysisMatrix, ReproducesSubdivide) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (SubdivScheme scheme : {SubdivScheme::kCatmullClark, SubdivScheme::kFourEight})
    for (int k : {3, 4, 5, 7, 12}) {
      SCOPED_TRACE(std::string(to_string(scheme)) + ", valence " + std::to_string(k));
      const LocalSubdivMatrix s = local_subdivision_matrix(scheme, k);
      const int rings = s.ring + 2;
      PolyMesh patch = extraordinary_patch(k, rings);
      for (auto& p : patch.positions) p = {u(rng), u(rng), u(rng)};
      const SubdivMesh fine = subdivide(patch, scheme, 2);
      const SubdivTopology t = make_subdiv_topology(patch);
      for (std::size_t p = 0; p < s.size(); ++p) {
        glm::dvec3 want(0.0);
        for (std::size_t q = 0; q < s.size(); ++q)
          want += s.at(p, q) * patch.positions[extraordinary_patch_vertex(k, rings, s.positions[q])];
        const glm::dvec3 got = fine.positions[fine_vertex(t, k, rings, s.positions[p])];
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-13) << "position " << p;
      }
    }
}

TEST(SubdivAnalysisSpectrum, FourierBlocksMatchDenseSolve) {
  for (SubdivScheme scheme : {SubdivScheme::kCatmullClark, SubdivScheme::kFourEight})
    for (int k = kMinValence; k <= kMaxValence; ++k) {
      SCOPED_TRACE(std::string(to_string(scheme)) + ", valence " + std::to_string(k));
      const LocalSubdivMatrix s = local_subdivision_matrix(scheme, k);
      const SubdivSpectrum spec = fourier_spectrum(s);
      const auto fourier = all_fourier_eigenvalues(spec);
      const auto dense = dense_eigenvalues(s);
      ASSERT_EQ(fourier.size(), s.size());
      ASSERT_EQ(dense.size(), s.size());
      // Power traces hold whatever the Jordan structure: tr(S^p) = sum of lambda^p.
      const std::size_t n = s.size();
      std::vector<double> power(s.entries), next(n * n);
      for (int p = 1; p <= 3; ++p) {
        double trace = 0.0;
        for (std::size_t i = 0; i < n; ++i) trace += power[i * n + i];
        std::complex<double> sum = 0.0;
        for (const auto& x : fourier) sum += std::pow(x, p);
        EXPECT_NEAR(sum.real(), trace, 1e-12) << "power " << p;
        EXPECT_NEAR(sum.imag(), 0.0, 1e-12) << "power " << p;
        for (std::size_t i = 0; i < n; ++i)
          for (std::size_t j = 0; j < n; ++j) {
            double acc = 0.0;
            for (std::size_t l = 0; l < n; ++l) acc += power[i * n + l] * s.entries[l * n + j];
            next[i * n + j] = acc;
          }
        power.swap(next);
      }
      // The leading eigenvalues (away from the defective cluster at 0) agree one for one.
      EXPECT_TRUE(matched(fourier, dense, 0.05, 1e-7));
      EXPECT_TRUE(matched(dense, fourier, 0.05, 1e-7));
    }
}

// The requirement for the documented rule four_eight_weight(n) = 1/2.
TEST(SubdivAnalysisSpectrum, FourEightSubdominantIsRealDoubleFirstModeAndStrict) {
  for (int k = kMinValence; k <= kMaxValence; ++k) {
    SCOPED_TRACE("valence " + std::to_string(k));
    const SubdivSpectrum s = subdivision_spectrum(SubdivScheme::kFourEight, k);
    EXPECT_NEAR(s.dominant.real(), 1.0, 1e-12);
    EXPECT_NEAR(s.dominant.imag(), 0.0, 1e-12);
    EXPECT_EQ(s.dominant_mode, 0);
    EXPECT_EQ(s.dominant_multiplicity, 1);
    EXPECT_NEAR(s.subdominant.imag(), 0.0, 1e-12);
    EXPECT_GT(s.subdominant.real(), 0.0);
    EXPECT_EQ(s.subdominant_modes, (std::vector<int>{1, k - 1}));
    EXPECT_GT(s.gap(), 1e-9) << "subdominant " << s.subdominant << ", next " << s.next;
    // The mode-1 block's leading eigenvalue is the subdominant, and every other mode stays below it.
    EXPECT_NEAR(std::abs(s.modes[1][0] - s.subdominant), 0.0, 1e-12);
    for (int w = 0; w < k; ++w) {
      const std::size_t first = (w == 0 || w == 1 || w == k - 1) ? 1 : 0;
      for (std::size_t i = first; i < s.modes[w].size(); ++i)
        EXPECT_LT(std::abs(s.modes[w][i]), s.subdominant.real() - 1e-9) << "mode " << w << " eigenvalue " << i;
    }
    EXPECT_TRUE(s.meets_subdominant_condition());
  }
}

// At valence 4 one quadrisection of the C4 box spline halves linear functions and quarters quadratics.
TEST(SubdivAnalysisSpectrum, FourEightRegularVertexIsTheBoxSpline) {
  const SubdivSpectrum s = subdivision_spectrum(SubdivScheme::kFourEight, 4);
  EXPECT_NEAR(s.subdominant.real(), 0.5, 1e-12);
  EXPECT_NEAR(s.next.real(), 0.25, 1e-9);
  EXPECT_EQ(s.next_modes, (std::vector<int>{0, 2, 2}));  // x^2 + y^2; x^2 - y^2 and xy
}

TEST(SubdivAnalysisSpectrum, CatmullClarkMatchesStamClosedForm) {
  for (int k = kMinValence; k <= kMaxValence; ++k) {
    SCOPED_TRACE("valence " + std::to_string(k));
    const SubdivSpectrum s = subdivision_spectrum(SubdivScheme::kCatmullClark, k);
    EXPECT_NEAR(s.subdominant.real(), stam_subdominant(k), 1e-10);
    EXPECT_NEAR(s.subdominant.imag(), 0.0, 1e-12);
    EXPECT_TRUE(s.meets_subdominant_condition());
  }
  EXPECT_NEAR(stam_subdominant(4), 0.5, 1e-15);
  const SubdivSpectrum regular = subdivision_spectrum(SubdivScheme::kCatmullClark, 4);
  EXPECT_NEAR(regular.next.real(), 0.25, 1e-9);
}

// Enlarging the neighbourhood adds eigenvalues of the outer rings only: the leading ones stay.
TEST(SubdivAnalysisSpectrum, LargerNeighbourhoodKeepsLeadingEigenvalues) {
  for (SubdivScheme scheme : {SubdivScheme::kCatmullClark, SubdivScheme::kFourEight})
    for (int k : {3, 5, 8, 12}) {
      SCOPED_TRACE(std::string(to_string(scheme)) + ", valence " + std::to_string(k));
      const SubdivSpectrum base = subdivision_spectrum(scheme, k);
      const LocalSubdivMatrix big = local_subdivision_matrix(scheme, k, 4);
      EXPECT_EQ(big.ring, 4);
      const SubdivSpectrum s = fourier_spectrum(big);
      EXPECT_NEAR(std::abs(s.dominant - base.dominant), 0.0, 1e-12);
      EXPECT_NEAR(std::abs(s.subdominant - base.subdominant), 0.0, 1e-12);
      EXPECT_EQ(s.subdominant_modes, base.subdominant_modes);
      EXPECT_NEAR(std::abs(s.next - base.next), 0.0, 1e-9);
      EXPECT_TRUE(s.meets_subdominant_condition());
    }
}

// The condition can fail: linear subdivision halves the one-ring in every Fourier mode.
TEST(SubdivAnalysisSpectrum, LinearSchemeFailsTheCondition) {
  for (int k = kMinValence; k <= kMaxValence; ++k) {
    const SubdivSpectrum s = subdivision_spectrum(SubdivScheme::kLinear, k);
    EXPECT_NEAR(s.subdominant.real(), 0.5, 1e-12);
    EXPECT_EQ(static_cast<int>(s.subdominant_modes.size()), k) << "valence " << k;
    EXPECT_FALSE(s.meets_subdominant_condition()) << "valence " << k;
  }
}

TEST(SubdivAnalysisSpectrum, RejectsMalformedMatrices) {
  LocalSubdivMatrix s = local_subdivision_matrix(SubdivScheme::kFourEight, 5);
  LocalSubdivMatrix broken = s;
  broken.entries[broken.size() + 3] += 1e-6;  // row 1 only: breaks the rotation symmetry
  EXPECT_THROW(fourier_spectrum(broken), InvalidInput);
  broken = s;
  broken.entries.pop_back();
  EXPECT_THROW(fourier_spectrum(broken), InvalidInput);
  EXPECT_THROW(dense_eigenvalues(broken), InvalidInput);
  broken = s;
  broken.valence = 6;
  EXPECT_THROW(fourier_spectrum(broken), InvalidInput);
}

}  // namespace
}  // namespace varmesh
