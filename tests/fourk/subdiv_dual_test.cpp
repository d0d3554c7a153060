// Tests of fourk/subdiv_dual.hpp: Zwart-Powell (mid-edge) and Doo-Sabin steps on polygon meshes.
//
// Oracles: the dyadic masks of the regular schemes on a periodic grid (ZP: two steps = 1/4 [0 1 1 0;
// 1 2 2 1; 1 2 2 1; 0 1 1 0]; DS: one step = (1/16) [1 3 3 1] (x) [1 3 3 1]), the 4-8 average
// (v + F + m1 + m2) / 4 at quad corners, the classic Doo-Sabin weights written out per corner (O(k^2)), the
// counts of the header, Euler characteristics, the convex hull property, the border curves (ZP: the input
// polyline refined linearly; DS: Chaikin's corner cutting), and PolyMesh::validate() on every result and
// on corrupted inputs (a step throws exactly when validate() does).
#include "fourk/subdiv_dual.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <new>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include "fourk/topology_oracle.hpp"
#include "multitri/errors.hpp"

#include "alloc_guard.hpp"  // replaces operator new for this executable

namespace varmesh {
namespace {

constexpr DualScheme kSchemes[] = {DualScheme::kZwartPowell, DualScheme::kDooSabin};
constexpr double kPi = std::numbers::pi;

// Fixtures

// Periodic nu x nv quad grid (a torus); vertex (i, j) = i * nv + j, face (i, j) = (i,j), (i+1,j), (i+1,j+1),
// (i,j+1). Positions from `pos(i, j)`.
template <class Pos>
PolyMesh periodic_grid(int nu, int nv, Pos pos) {
  PolyMesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) m.positions.push_back(pos(i, j));
  auto id = [&](int i, int j) { return static_cast<Index>(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const Index q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
      m.add_face(q);
    }
  return m;
}

// Open nu x nv quad grid (a disk): vertices (i, j, random z), i <= nu, j <= nv.
PolyMesh open_grid(int nu, int nv, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> z(-0.5, 0.5);
  PolyMesh m;
  for (int i = 0; i <= nu; ++i)
    for (int j = 0; j <= nv; ++j) m.positions.emplace_back(i, j, z(rng));
  auto id = [&](int i, int j) { return static_cast<Index>(i * (nv + 1) + j); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const Index q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
      m.add_face(q);
    }
  return m;
}

// Closed mesh of mixed faces: an n-gon bottom, n side quads, a fan of n triangles to an apex of valence n
// (vertices of valence 3, 4 and n). Positions jittered.
PolyMesh capped_prism(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.1, 0.1);
  PolyMesh m;
  for (int ring = 0; ring < 2; ++ring)
    for (int i = 0; i < n; ++i) {
      const double a = 2 * kPi * i / n;
      m.positions.emplace_back(std::cos(a) + jitter(rng), std::sin(a) + jitter(rng), ring + jitter(rng));
    }
  m.positions.emplace_back(jitter(rng), jitter(rng), 1.6);
  const auto un = static_cast<Index>(n);
  auto b = [&](int i) { return static_cast<Index>(i % n); };
  auto t = [&](int i) { return un + static_cast<Index>(i % n); };
  std::vector<Index> bottom;
  for (int i = n - 1; i >= 0; --i) bottom.push_back(b(i));
  m.add_face(bottom);
  for (int i = 0; i < n; ++i) {
    const Index q[4] = {b(i), b(i + 1), t(i + 1), t(i)};
    m.add_face(q);
    const Index tri[3] = {t(i), t(i + 1), 2 * un};
    m.add_face(tri);
  }
  return m;
}

PolyMesh jittered(PolyMesh m, unsigned seed, double amount) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-amount, amount);
  for (glm::dvec3& p : m.positions) p += glm::dvec3(d(rng), d(rng), d(rng));
  return m;
}

// Open mesh with interior vertices of 2 edges: two faces glued along the path a - v1 - ... - vm - b,
// f = (a, v1, ..., vm, b, c) and g = (b, vm, ..., v1, a, d).
PolyMesh glued_pair(int m) {
  PolyMesh p;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> z(-0.2, 0.2);
  const auto um = static_cast<Index>(m);
  // a = 0, v_i = i (1..m), b = m + 1, c = m + 2, d = m + 3.
  for (Index i = 0; i <= um + 1; ++i) p.positions.emplace_back(i, 0, z(rng));
  p.positions.emplace_back((m + 1) / 2.0, 1, z(rng));
  p.positions.emplace_back((m + 1) / 2.0, -1, z(rng));
  std::vector<Index> f, g;
  for (Index i = 0; i <= um + 1; ++i) f.push_back(i);
  f.push_back(um + 2);
  for (Index i = um + 2; i-- > 0;) g.push_back(i);  // b, vm, ..., v1, a
  g.push_back(um + 3);
  p.add_face(f);
  p.add_face(g);
  return p;
}

// A closed pillow (two k-gons glued along their whole border) beside a cube: every pillow vertex is an
// interior vertex with 2 edges.
PolyMesh pillow_and_cube(int k) {
  PolyMesh m = make_quad_cube();
  const auto base = static_cast<Index>(m.positions.size());
  std::vector<Index> f, g;
  for (int i = 0; i < k; ++i) {
    const double a = 2 * kPi * i / k;
    m.positions.emplace_back(4 + std::cos(a), std::sin(a), 0.1 * i);
    f.push_back(base + static_cast<Index>(i));
  }
  g.assign(f.rbegin(), f.rend());
  m.add_face(f);
  m.add_face(g);
  return m;
}

// Helpers

struct Box {
  glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
};
Box bounds(const PolyMesh& m) {
  Box b;
  for (const glm::dvec3& p : m.positions) {
    b.lo = glm::min(b.lo, p);
    b.hi = glm::max(b.hi, p);
  }
  return b;
}

long euler(const PolyMesh& m) {
  return static_cast<long>(m.num_vertices()) - static_cast<long>(count_edges(m).edges) +
         static_cast<long>(m.num_faces());
}

std::size_t num_used_vertices(const PolyMesh& m) { return std::set<Index>(m.corners.begin(), m.corners.end()).size(); }

// Directed border edges (a, b): a -> b in a face, no face holds b -> a.
std::vector<std::pair<Index, Index>> border_edges(const PolyMesh& m) {
  std::set<std::pair<Index, Index>> directed;
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    const auto fc = m.face(f);
    for (std::size_t i = 0; i < fc.size(); ++i) directed.emplace(fc[i], fc[(i + 1) % fc.size()]);
  }
  std::vector<std::pair<Index, Index>> out;
  for (const auto& [a, b] : directed)
    if (!directed.count({b, a})) out.emplace_back(a, b);
  return out;
}

// The border loop of a disk, as positions in order.
std::vector<glm::dvec3> border_loop(const PolyMesh& m) {
  const auto edges = border_edges(m);
  std::map<Index, Index> next;
  for (const auto& [a, b] : edges) next[a] = b;
  std::vector<glm::dvec3> loop;
  Index v = edges.front().first;
  do {
    loop.push_back(m.positions[v]);
    v = next.at(v);
  } while (v != edges.front().first && loop.size() <= edges.size());
  return loop;
}

// Every point of `got` matches one point of `want` (to `tol`), one to one.
void expect_same_point_sets(const std::vector<glm::dvec3>& got, const std::vector<glm::dvec3>& want, double tol) {
  ASSERT_EQ(got.size(), want.size());
  std::vector<char> used(want.size(), 0);
  for (const glm::dvec3& p : got) {
    std::size_t best = want.size();
    for (std::size_t i = 0; i < want.size(); ++i)
      if (!used[i] && glm::distance(p, want[i]) <= tol) {
        best = i;
        break;
      }
    ASSERT_LT(best, want.size()) << "point (" << p.x << ", " << p.y << ", " << p.z << ") not expected";
    used[best] = 1;
  }
}

std::vector<glm::dvec3> border_points(const PolyMesh& m) {
  std::set<Index> vs;
  for (const auto& [a, b] : border_edges(m)) vs.insert(a);
  std::vector<glm::dvec3> out;
  for (const Index v : vs) out.push_back(m.positions[v]);
  return out;
}

// Dyadic masks on a periodic lattice

using Mask = std::array<std::array<double, 4>, 4>;  // [a][b]: a along u, b along v
using Field = std::vector<std::vector<double>>;     // [i][j]

Mask zwart_powell_mask() {
  const double m[4][4] = {{0, 1, 1, 0}, {1, 2, 2, 1}, {1, 2, 2, 1}, {0, 1, 1, 0}};
  Mask out;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) out[a][b] = m[a][b] / 4.0;
  return out;
}

Mask biquadratic_mask() {
  const double w[4] = {1, 3, 3, 1};
  Mask out;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) out[a][b] = w[a] * w[b] / 16.0;
  return out;
}

int wrap(int x, int n) { return ((x % n) + n) % n; }

// fine[alpha] = sum_beta mask[alpha - 2 beta] coarse[beta], periodic.
Field apply_mask(const Field& coarse, const Mask& mask) {
  const int nu = static_cast<int>(coarse.size()), nv = static_cast<int>(coarse[0].size());
  Field fine(2 * nu, std::vector<double>(2 * nv, 0.0));
  for (int au = 0; au < 2 * nu; ++au)
    for (int av = 0; av < 2 * nv; ++av)
      for (int a = au % 2; a < 4; a += 2)
        for (int b = av % 2; b < 4; b += 2)
          fine[au][av] += mask[a][b] * coarse[wrap((au - a) / 2, nu)][wrap((av - b) / 2, nv)];
  return fine;
}

// Where the fine lattice sits. With fine[alpha] = sum_beta mask[alpha - 2 beta] coarse[beta], the fine
// point alpha is the centre of its stencil: at (2 alpha - 3) / 4 in units of the coarse lattice (for
// alpha = 2m + 1: weight 3/4 on m and 1/4 on m - 1 in the biquadratic mask, so m - 1/4). After L levels it
// sits at (2 alpha - c_L) / 2^(L+1), c_0 = 0, c_L = 2 c_(L-1) + 3: an odd multiple of 1/2^(L+1). For a dual
// step this is the corner (face f, vertex v) of the grid: the point (v + centroid(f)) / 2.
int lattice_offset(int levels) { return levels == 0 ? 0 : 2 * lattice_offset(levels - 1) + 3; }

// The fine index along one periodic direction of n coarse cells from the angle of a point of the unit
// circle channel (coarse vertex i sat at angle 2 pi i / n). Returns -1 when the angle is not near an odd
// multiple of the fine quantum.
int fine_index(double x, double y, int n, int levels) {
  const int quanta = n << (levels + 1);  // quanta per turn
  const double t = std::atan2(y, x) / (2 * kPi) * quanta;
  const long q = std::lround(t);
  if (std::abs(t - static_cast<double>(q)) > 0.25) return -1;
  const int qi = wrap(static_cast<int>(q), quanta);
  if (qi % 2 == 0) return -1;
  return wrap((qi + lattice_offset(levels)) / 2, n << levels);
}

// Runs `steps` steps twice on the same periodic grid: once with (cos, sin) of the u angle in x, y and a
// random field f in z, once with the v angle and a random field g. Output numbering depends only on the
// connectivity (header), so vertex k of both runs is the same point; its two angles identify its fine
// lattice index, and both z values must be the mask applied `levels` times to f and g.
void expect_dyadic_mask(DualScheme scheme, int steps, int levels, const Mask& mask) {
  const int nu = 12, nv = 10;
  std::mt19937 rng(1234 + static_cast<unsigned>(steps));
  std::uniform_real_distribution<double> val(-1.0, 1.0);
  Field f(nu, std::vector<double>(nv)), g = f;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      f[i][j] = val(rng);
      g[i][j] = val(rng);
    }
  const PolyMesh a = periodic_grid(nu, nv, [&](int i, int j) {
    return glm::dvec3(std::cos(2 * kPi * i / nu), std::sin(2 * kPi * i / nu), f[i][j]);
  });
  const PolyMesh b = periodic_grid(nu, nv, [&](int i, int j) {
    return glm::dvec3(std::cos(2 * kPi * j / nv), std::sin(2 * kPi * j / nv), g[i][j]);
  });
  const PolyMesh ra = subdivide_dual(a, scheme, steps), rb = subdivide_dual(b, scheme, steps);
  ASSERT_EQ(ra.corners, rb.corners) << "numbering must not depend on positions";
  ASSERT_EQ(ra.face_offsets, rb.face_offsets);
  ASSERT_EQ(ra.num_vertices(), rb.num_vertices());
  ASSERT_NO_THROW(ra.validate());
  Field ef = f, eg = g;
  for (int l = 0; l < levels; ++l) {
    ef = apply_mask(ef, mask);
    eg = apply_mask(eg, mask);
  }
  const int fu = nu << levels, fv = nv << levels;
  ASSERT_EQ(ra.num_vertices(), static_cast<std::size_t>(fu) * static_cast<std::size_t>(fv));
  std::vector<char> seen(static_cast<std::size_t>(fu * fv), 0);
  double worst = 0;
  for (std::size_t k = 0; k < ra.num_vertices(); ++k) {
    const int iu = fine_index(ra.positions[k].x, ra.positions[k].y, nu, levels);
    const int iv = fine_index(rb.positions[k].x, rb.positions[k].y, nv, levels);
    ASSERT_GE(iu, 0) << "vertex " << k << " is not on the fine lattice (u)";
    ASSERT_GE(iv, 0) << "vertex " << k << " is not on the fine lattice (v)";
    char& s = seen[static_cast<std::size_t>(iu * fv + iv)];
    ASSERT_EQ(s, 0) << "two vertices at fine index (" << iu << ", " << iv << ")";
    s = 1;
    worst = std::max(worst, std::abs(ra.positions[k].z - ef[iu][iv]));
    worst = std::max(worst, std::abs(rb.positions[k].z - eg[iu][iv]));
  }
  EXPECT_LE(worst, 1e-12) << to_string(scheme) << " after " << steps << " steps";
}

TEST(ZwartPowell, TwoStepsAreTheQuadraticBoxSplineMask) {
  expect_dyadic_mask(DualScheme::kZwartPowell, 2, 1, zwart_powell_mask());
}

TEST(ZwartPowell, FourStepsAreTheMaskTwice) {
  expect_dyadic_mask(DualScheme::kZwartPowell, 4, 2, zwart_powell_mask());
}

TEST(DooSabin, StepIsTheBiquadraticMask) {
  expect_dyadic_mask(DualScheme::kDooSabin, 1, 1, biquadratic_mask());
  expect_dyadic_mask(DualScheme::kDooSabin, 2, 2, biquadratic_mask());
}

// The oracle itself must be able to fail: the other scheme's mask does not fit.
TEST(DualMasks, WrongMaskIsDetected) {
  EXPECT_NONFATAL_FAILURE(expect_dyadic_mask(DualScheme::kDooSabin, 1, 1, zwart_powell_mask()), "after 1 steps");
  EXPECT_NONFATAL_FAILURE(expect_dyadic_mask(DualScheme::kZwartPowell, 2, 1, biquadratic_mask()),
                          "after 2 steps");
}

// Rules

// Quads: c(f, v) = (v + F + m1 + m2) / 4, the three binary 4-8 steps of the header. Vertex s of the
// result is the corner point of corner slot s.
TEST(DooSabin, QuadCornerIsTheFourEightAverage) {
  for (const PolyMesh& in : {jittered(make_quad_cube(), 3, 0.3), jittered(make_quad_torus(7, 5), 4, 0.1)}) {
    const PolyMesh out = doo_sabin_step(in);
    ASSERT_NO_THROW(out.validate());
    for (std::size_t f = 0; f < in.num_faces(); ++f) {
      const auto fc = in.face(f);
      ASSERT_EQ(fc.size(), 4u);
      glm::dvec3 centroid(0.0);
      for (const Index v : fc) centroid += in.positions[v] / 4.0;
      ASSERT_EQ(out.face_size(f), 4u);
      for (std::size_t i = 0; i < 4; ++i) {
        const glm::dvec3 v = in.positions[fc[i]];
        const glm::dvec3 m1 = (v + in.positions[fc[(i + 1) % 4]]) / 2.0;
        const glm::dvec3 m2 = (v + in.positions[fc[(i + 3) % 4]]) / 2.0;
        const glm::dvec3 want = (v + centroid + m1 + m2) / 4.0;
        const Index s = in.face_offsets[f] + static_cast<Index>(i);
        EXPECT_EQ(out.face(f)[i], s);
        EXPECT_LE(glm::distance(out.positions[s], want), 1e-14) << "face " << f << " corner " << i;
      }
    }
  }
}

// Doo-Sabin as binary 4-8 steps (linear diagonal, linear edge, diagonal with the 4-corner average, then the
// dual) equals the classic step on closed quad meshes, face for face (faces compared as cyclic sequences of
// positions); elsewhere it is rejected (borders) or differs only in the corner weights (triangles).
TEST(DooSabin, FourEightStepsGiveTheClassicStepOnQuads) {
  for (const PolyMesh& in : {jittered(make_quad_cube(), 5, 0.3), jittered(make_quad_torus(6, 5), 6, 0.1)}) {
    const PolyMesh classic = doo_sabin_step(in);
    const PolyMesh by48 = doo_sabin_by_four_eight_steps(in);
    ASSERT_NO_THROW(by48.validate());
    ASSERT_EQ(by48.num_vertices(), classic.num_vertices());
    ASSERT_EQ(by48.num_faces(), classic.num_faces());
    // Map each by48 vertex to the classic vertex at the same place (all corner points are distinct).
    std::vector<Index> to_classic(by48.num_vertices(), kInvalid);
    for (std::size_t v = 0; v < by48.num_vertices(); ++v)
      for (std::size_t w = 0; w < classic.num_vertices(); ++w)
        if (glm::distance(by48.positions[v], classic.positions[w]) < 1e-12) to_classic[v] = static_cast<Index>(w);
    for (Index w : to_classic) ASSERT_NE(w, kInvalid);
    auto canonical = [](std::vector<Index> f) {
      std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
      return f;
    };
    std::multiset<std::vector<Index>> a, b;
    for (std::size_t f = 0; f < by48.num_faces(); ++f) {
      std::vector<Index> face;
      for (Index v : by48.face(f)) face.push_back(to_classic[v]);
      a.insert(canonical(face));
    }
    for (std::size_t f = 0; f < classic.num_faces(); ++f) {
      const auto fc = classic.face(f);
      b.insert(canonical(std::vector<Index>(fc.begin(), fc.end())));
    }
    EXPECT_EQ(a, b);
  }
  EXPECT_THROW(doo_sabin_by_four_eight_steps(open_grid(3, 3, 1)), InvalidInput);
}

// Every polygon: the weights of Doo and Sabin (1978) written out per pair of corners.
TEST(DooSabin, ClassicWeightsOnEveryPolygon) {
  for (const int n : {3, 5, 6, 9}) {
    const PolyMesh in = capped_prism(n, static_cast<unsigned>(n));
    ASSERT_NO_THROW(in.validate());
    const PolyMesh out = doo_sabin_step(in);
    ASSERT_NO_THROW(out.validate());
    for (std::size_t f = 0; f < in.num_faces(); ++f) {
      const auto fc = in.face(f);
      const std::size_t k = fc.size();
      for (std::size_t i = 0; i < k; ++i) {
        glm::dvec3 want(0.0);
        for (std::size_t j = 0; j < k; ++j) {
          const double kd = static_cast<double>(k), d = static_cast<double>(i) - static_cast<double>(j);
          const double w = i == j ? (kd + 5.0) / (4.0 * kd) : (3.0 + 2.0 * std::cos(2 * kPi * d / kd)) / (4.0 * kd);
          want += w * in.positions[fc[j]];
        }
        EXPECT_LE(glm::distance(out.positions[in.face_offsets[f] + i], want), 1e-13)
            << "n = " << n << ", face " << f << " (" << k << " corners), corner " << i;
      }
    }
  }
}

// Face f of the result runs through the midpoints of f's edges c_i -> c_{i+1}; the face of an interior
// vertex v through the midpoints of v's edges, each once.
TEST(ZwartPowell, FacesRunThroughEdgeMidpoints) {
  for (const int n : {3, 5, 6}) {
    const PolyMesh in = capped_prism(n, 10 + static_cast<unsigned>(n));
    const PolyMesh out = zwart_powell_step(in);
    ASSERT_NO_THROW(out.validate());
    for (std::size_t f = 0; f < in.num_faces(); ++f) {
      const auto fc = in.face(f);
      ASSERT_EQ(out.face_size(f), fc.size());
      for (std::size_t i = 0; i < fc.size(); ++i) {
        const glm::dvec3 want = (in.positions[fc[i]] + in.positions[fc[(i + 1) % fc.size()]]) / 2.0;
        EXPECT_LE(glm::distance(out.positions[out.face(f)[i]], want), 1e-15);
      }
    }
    // Neighbours of each vertex, from the faces.
    std::vector<std::set<Index>> nbrs(in.num_vertices());
    for (std::size_t f = 0; f < in.num_faces(); ++f) {
      const auto fc = in.face(f);
      for (std::size_t i = 0; i < fc.size(); ++i) {
        nbrs[fc[i]].insert(fc[(i + 1) % fc.size()]);
        nbrs[fc[(i + 1) % fc.size()]].insert(fc[i]);
      }
    }
    ASSERT_EQ(out.num_faces(), in.num_faces() + in.num_vertices());
    for (std::size_t v = 0; v < in.num_vertices(); ++v) {
      const std::size_t of = in.num_faces() + v;
      ASSERT_EQ(out.face_size(of), nbrs[v].size()) << "vertex " << v;
      std::set<Index> met;
      for (const Index c : out.face(of)) {
        const glm::dvec3 other = 2.0 * out.positions[c] - in.positions[v];
        for (const Index w : nbrs[v])
          if (glm::distance(other, in.positions[w]) < 1e-12) met.insert(w);
      }
      EXPECT_EQ(met, nbrs[v]) << "vertex " << v;
    }
  }
}

// Steps are affine maps of the positions (weights sum to 1): step(A p + t) = A step(p) + t.
TEST(DualSteps, AffineInvariant) {
  const glm::dmat3 a(1.2, 0.3, -0.4, 0.1, 0.9, 0.5, -0.7, 0.2, 1.1);
  const glm::dvec3 t(3, -2, 5);
  const PolyMesh in = capped_prism(5, 99);
  PolyMesh moved = in;
  for (glm::dvec3& p : moved.positions) p = a * p + t;
  for (const DualScheme scheme : kSchemes) {
    const PolyMesh r = subdivide_dual(in, scheme, 2), rm = subdivide_dual(moved, scheme, 2);
    ASSERT_EQ(r.corners, rm.corners);
    for (std::size_t v = 0; v < r.num_vertices(); ++v)
      EXPECT_LE(glm::distance(a * r.positions[v] + t, rm.positions[v]), 1e-12) << to_string(scheme);
  }
}

// Counts, validity, Euler characteristic, hull

struct Case {
  std::string name;
  PolyMesh mesh;
};

std::vector<Case> fixtures() {
  return {{"cube", make_quad_cube()},
          {"torus", make_quad_torus(6, 4)},
          {"prism5", capped_prism(5, 1)},
          {"open_grid", open_grid(4, 3, 2)},
          {"strip", open_grid(1, 5, 3)},
          {"single_quad", open_grid(1, 1, 4)},
          {"glued_pair1", glued_pair(1)},
          {"glued_pair3", glued_pair(3)},
          {"pillow_and_cube", pillow_and_cube(5)}};
}

// The counts of the header, with E, E_b, V_b and the vertex kinds found here independently.
TEST(DualSteps, CountsPerStep) {
  for (const Case& c : fixtures()) {
    ASSERT_NO_THROW(c.mesh.validate()) << c.name;
    for (const DualScheme scheme : kSchemes) {
      PolyMesh cur = c.mesh;
      for (int s = 1; s <= 3; ++s) {
        const PolyEdgeCount ec = count_edges(cur);
        // Vertex kinds: border = on a border edge; 2-edge interior = 2 corners and not on the border.
        std::vector<std::size_t> corners_at(cur.num_vertices(), 0);
        for (const Index v : cur.corners) ++corners_at[v];
        std::set<Index> on_border;
        for (const auto& [a, b] : border_edges(cur)) {
          on_border.insert(a);
          on_border.insert(b);
        }
        std::size_t used = 0, two = 0;
        for (std::size_t v = 0; v < cur.num_vertices(); ++v) {
          if (corners_at[v] == 0) continue;
          ++used;
          if (corners_at[v] == 2 && !on_border.count(static_cast<Index>(v))) ++two;
        }
        const std::size_t vb = on_border.size(), faced = used - two;
        const PolyMesh next = dual_step(cur, scheme);
        ASSERT_NO_THROW(next.validate()) << c.name << " " << to_string(scheme) << " step " << s;
        if (scheme == DualScheme::kZwartPowell) {
          EXPECT_EQ(next.num_vertices(), ec.edges + vb) << c.name << " step " << s;
          EXPECT_EQ(next.num_faces(), cur.num_faces() + faced) << c.name << " step " << s;
        } else {
          EXPECT_EQ(next.num_vertices(), cur.corners.size() + 2 * ec.border_edges) << c.name << " step " << s;
          EXPECT_EQ(next.num_faces(), cur.num_faces() + faced + ec.edges) << c.name << " step " << s;
        }
        EXPECT_EQ(count_edges(next).border_edges, 2 * ec.border_edges) << c.name << " step " << s;
        EXPECT_EQ(num_used_vertices(next), next.num_vertices()) << c.name << " step " << s;
        // The size prediction for s steps from the base is exact.
        const DualMeshSize size = dual_mesh_size(c.mesh, scheme, s);
        EXPECT_EQ(size.vertices, next.num_vertices()) << c.name << " " << to_string(scheme) << " step " << s;
        EXPECT_EQ(size.faces, next.num_faces()) << c.name << " " << to_string(scheme) << " step " << s;
        EXPECT_EQ(size.corners, next.corners.size()) << c.name << " " << to_string(scheme) << " step " << s;
        cur = next;
      }
      // subdivide_dual = the steps one after the other.
      const PolyMesh direct = subdivide_dual(c.mesh, scheme, 3);
      EXPECT_EQ(direct.corners, cur.corners) << c.name;
      EXPECT_EQ(direct.positions, cur.positions) << c.name;
    }
  }
}

// Closed meshes, the brief's forms: ZP V' = E, F' = F + V; DS V' = C, F' = F + V + E.
TEST(DualSteps, ClosedMeshCounts) {
  for (const PolyMesh& in : {make_quad_cube(), make_quad_torus(5, 7), capped_prism(6, 5)}) {
    const PolyEdgeCount ec = count_edges(in);
    ASSERT_EQ(ec.border_edges, 0u);
    const PolyMesh zp = zwart_powell_step(in), ds = doo_sabin_step(in);
    EXPECT_EQ(zp.num_vertices(), ec.edges);
    EXPECT_EQ(zp.num_faces(), in.num_faces() + in.num_vertices());
    EXPECT_EQ(zp.corners.size(), 2 * in.corners.size());
    EXPECT_EQ(ds.num_vertices(), in.corners.size());
    EXPECT_EQ(ds.num_faces(), in.num_faces() + in.num_vertices() + ec.edges);
    EXPECT_EQ(ds.corners.size(), 4 * in.corners.size());
  }
}

// A chain of m interior 2-edge vertices becomes a chain of m - 1 after a ZP step; a pillow stays a pillow.
TEST(ZwartPowell, InteriorTwoEdgeChainsShrink) {
  auto interior_two = [](const PolyMesh& m) {
    std::vector<std::size_t> at(m.num_vertices(), 0);
    for (const Index v : m.corners) ++at[v];
    std::set<Index> on_border;
    for (const auto& [a, b] : border_edges(m)) on_border.insert(a);
    std::size_t n = 0;
    for (std::size_t v = 0; v < m.num_vertices(); ++v) n += at[v] == 2 && !on_border.count(static_cast<Index>(v));
    return n;
  };
  PolyMesh chain = glued_pair(4), pillow = pillow_and_cube(6);
  for (std::size_t s = 0; s <= 5; ++s) {
    EXPECT_EQ(interior_two(chain), s < 4 ? 4 - s : 0) << "step " << s;
    EXPECT_EQ(interior_two(pillow), 6u) << "step " << s;
    chain = zwart_powell_step(chain);
    pillow = zwart_powell_step(pillow);
    ASSERT_NO_THROW(chain.validate());
    ASSERT_NO_THROW(pillow.validate());
  }
}

TEST(DualSteps, EulerCharacteristicIsPreserved) {
  for (const DualScheme scheme : kSchemes) {
    for (const PolyMesh& in : {make_quad_cube(), make_quad_torus(6, 5), capped_prism(7, 2), open_grid(3, 4, 5)}) {
      const long chi = euler(in);
      PolyMesh cur = in;
      for (int s = 1; s <= 4; ++s) {
        cur = dual_step(cur, scheme);
        ASSERT_NO_THROW(cur.validate());
        EXPECT_EQ(euler(cur), chi) << to_string(scheme) << " step " << s;
      }
    }
  }
  EXPECT_EQ(euler(make_quad_cube()), 2);
  EXPECT_EQ(euler(make_quad_torus(6, 5)), 0);
}

// Every new point is a convex combination of old ones, hence inside the input's bounding box.
TEST(DualSteps, ConvexHullProperty) {
  for (const DualScheme scheme : kSchemes)
    for (const Case& c : fixtures()) {
      const PolyMesh in = jittered(c.mesh, 11, 0.3);
      const Box b = bounds(in);
      const PolyMesh out = dual_step(in, scheme);
      for (const glm::dvec3& p : out.positions)
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(p[a], b.lo[a] - 1e-12) << c.name << " " << to_string(scheme);
          EXPECT_LE(p[a], b.hi[a] + 1e-12) << c.name << " " << to_string(scheme);
        }
    }
}

// The cube's surfaces converge: the bounding box moves less and less from one step to the next. The cube
// is turned first: both schemes keep each planar face's centroid and plane (a face's new face has the same
// centroid and lies in the same plane) and the limit touches the midpoints of the control polygon's edges,
// so the box of the axis-aligned cube never moves at all (checked too).
TEST(DualSteps, CubeConverges) {
  const glm::dvec3 axis = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
  const double angle = 0.7, c = std::cos(angle), s = std::sin(angle);
  auto turn = [&](glm::dvec3 p) {  // Rodrigues
    return c * p + s * glm::cross(axis, p) + (1 - c) * glm::dot(axis, p) * axis;
  };
  auto box_distance = [](const Box& a, const Box& b) {
    const glm::dvec3 dl = glm::abs(a.lo - b.lo), dh = glm::abs(a.hi - b.hi);
    return std::max({dl.x, dl.y, dl.z, dh.x, dh.y, dh.z});
  };
  for (const DualScheme scheme : kSchemes) {
    PolyMesh cur = make_quad_cube(), axis_aligned = cur;
    for (glm::dvec3& p : cur.positions) p = turn(p);
    const int kSteps = scheme == DualScheme::kZwartPowell ? 12 : 7;
    std::vector<double> moved;  // per step: the distance between the boxes before and after
    for (int step = 0; step < kSteps; ++step) {
      const Box before = bounds(cur);
      cur = dual_step(cur, scheme);
      const Box after = bounds(cur);
      moved.push_back(box_distance(before, after));
      for (int a = 0; a < 3; ++a) {  // nested boxes: the convex hull property
        EXPECT_GE(after.lo[a], before.lo[a] - 1e-12);
        EXPECT_LE(after.hi[a], before.hi[a] + 1e-12);
      }
      if (step < 4) {
        const Box b0 = bounds(axis_aligned);
        axis_aligned = dual_step(axis_aligned, scheme);
        EXPECT_LE(box_distance(b0, bounds(axis_aligned)), 1e-15) << to_string(scheme);
      }
    }
    std::string trace;
    for (const double m : moved) trace += " " + std::to_string(m);
    // After 4 steps the moves shrink: each below the one two steps before, and by 4 steps at least halved.
    for (std::size_t i = 6; i < moved.size(); ++i)
      EXPECT_LT(moved[i], moved[i - 2]) << to_string(scheme) << " step " << i << ":" << trace;
    EXPECT_LT(moved.back(), 0.5 * moved[moved.size() - 5]) << to_string(scheme) << ":" << trace;
    EXPECT_GT(moved[4], 0.0) << trace;
  }
}

// Borders

std::vector<glm::dvec3> chaikin(const std::vector<glm::dvec3>& loop) {
  std::vector<glm::dvec3> out;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const glm::dvec3 a = loop[i], b = loop[(i + 1) % loop.size()];
    out.push_back(0.75 * a + 0.25 * b);
    out.push_back(0.25 * a + 0.75 * b);
  }
  return out;
}

std::vector<glm::dvec3> linear_refine(const std::vector<glm::dvec3>& loop) {
  std::vector<glm::dvec3> out;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    out.push_back(loop[i]);
    out.push_back(0.5 * (loop[i] + loop[(i + 1) % loop.size()]));
  }
  return out;
}

// DS: the border of the result is Chaikin's polygon of the input border, step after step.
TEST(DooSabin, BorderIsChaikinPolygon) {
  for (const PolyMesh& in : {open_grid(3, 2, 8), open_grid(1, 4, 9), glued_pair(2)}) {
    std::vector<glm::dvec3> want = border_loop(in);
    PolyMesh cur = in;
    for (int s = 1; s <= 3; ++s) {
      cur = doo_sabin_step(cur);
      ASSERT_NO_THROW(cur.validate());
      want = chaikin(want);
      expect_same_point_sets(border_points(cur), want, 1e-12);
      EXPECT_EQ(border_loop(cur).size(), want.size()) << "the border stays one loop";
    }
  }
}

// ZP: the border of the result is the input border polyline with its midpoints inserted: it never moves.
TEST(ZwartPowell, BorderIsTheInputPolylineRefined) {
  for (const PolyMesh& in : {open_grid(3, 2, 8), open_grid(1, 4, 9), glued_pair(2)}) {
    std::vector<glm::dvec3> want = border_loop(in);
    PolyMesh cur = in;
    for (int s = 1; s <= 3; ++s) {
      cur = zwart_powell_step(cur);
      ASSERT_NO_THROW(cur.validate());
      want = linear_refine(want);
      expect_same_point_sets(border_points(cur), want, 1e-12);
      EXPECT_EQ(border_loop(cur).size(), want.size()) << "the border stays one loop";
    }
  }
}

// A single polygon: ZP gives the polygon of its midpoints plus one triangle per corner; DS its corner
// points plus a triangle per corner and a quad per edge. Both cover the same disk with the same border.
TEST(DualSteps, SinglePolygon) {
  for (const int k : {3, 4, 7}) {
    PolyMesh in;
    std::vector<Index> f;
    for (int i = 0; i < k; ++i) {
      in.positions.emplace_back(std::cos(2 * kPi * i / k), std::sin(2 * kPi * i / k), 0.0);
      f.push_back(static_cast<Index>(i));
    }
    in.add_face(f);
    const PolyMesh zp = zwart_powell_step(in), ds = doo_sabin_step(in);
    ASSERT_NO_THROW(zp.validate());
    ASSERT_NO_THROW(ds.validate());
    EXPECT_EQ(zp.num_faces(), 1u + k);
    EXPECT_EQ(ds.num_faces(), 1u + 2u * k);
    for (std::size_t g = 1; g < zp.num_faces(); ++g) EXPECT_EQ(zp.face_size(g), 3u);
    for (std::size_t g = 1; g <= static_cast<std::size_t>(k); ++g) EXPECT_EQ(ds.face_size(g), 3u);
    EXPECT_EQ(euler(zp), 1);
    EXPECT_EQ(euler(ds), 1);
  }
}

// Bad input and absurd step counts

PolyMesh bow_tie() {
  PolyMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  const Index a[3] = {0, 1, 2}, b[3] = {0, 3, 4};
  m.add_face(a);
  m.add_face(b);
  return m;
}

void expect_all_throw(const PolyMesh& m, const std::string& what) {
  EXPECT_THROW(m.validate(), InvalidInput) << what;
  EXPECT_THROW(zwart_powell_step(m), InvalidInput) << what;
  EXPECT_THROW(doo_sabin_step(m), InvalidInput) << what;
  for (const DualScheme scheme : kSchemes) {
    EXPECT_THROW(subdivide_dual(m, scheme, 2), InvalidInput) << what;
    EXPECT_THROW(subdivide_dual(m, scheme, 0), InvalidInput) << what;
    EXPECT_THROW(dual_mesh_size(m, scheme, 1), InvalidInput) << what;
  }
}

TEST(DualSteps, BadInputThrows) {
  expect_all_throw(bow_tie(), "bow-tie (non-manifold vertex)");
  PolyMesh nan = make_quad_cube();
  nan.positions[5].y = std::numeric_limits<double>::quiet_NaN();
  expect_all_throw(nan, "NaN");
  PolyMesh inf = make_quad_cube();
  inf.positions[2].z = std::numeric_limits<double>::infinity();
  expect_all_throw(inf, "infinity");
  PolyMesh range = make_quad_cube();
  range.corners[7] = 8;
  expect_all_throw(range, "corner out of range");
  PolyMesh repeat = make_quad_cube();
  repeat.corners[1] = repeat.corners[3];
  expect_all_throw(repeat, "repeated corner");
  PolyMesh flipped = make_quad_cube();
  std::reverse(flipped.corners.begin() + 4, flipped.corners.begin() + 8);
  expect_all_throw(flipped, "inconsistent orientation");
  PolyMesh three = open_grid(1, 1, 1);  // quad 0-2-3-1; two more faces on edge 0-2
  three.positions.emplace_back(0, 0, 1);
  three.positions.emplace_back(0, 0, -1);
  const Index t1[3] = {2, 0, 4}, t2[3] = {0, 2, 5};
  three.add_face(t1);
  three.add_face(t2);
  expect_all_throw(three, "edge on three faces");
  PolyMesh small = make_quad_cube();
  small.add_face(std::vector<Index>{0, 1});
  expect_all_throw(small, "two-corner face");
  PolyMesh empty;
  expect_all_throw(empty, "no face");
  PolyMesh offsets = make_quad_cube();
  offsets.face_offsets.back() = 23;
  expect_all_throw(offsets, "offsets do not end with the corner count");
  // Offsets that run past the corners and come back. Not given to PolyMesh::validate, which reads past the
  // corners on this input (found by the sanitizer build while writing these tests).
  PolyMesh past;
  past.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  past.corners = {0, 1, 2};
  past.face_offsets = {0, 100, 3};
  EXPECT_THROW(zwart_powell_step(past), InvalidInput);
  EXPECT_THROW(doo_sabin_step(past), InvalidInput);
  for (const DualScheme scheme : kSchemes) {
    EXPECT_THROW(subdivide_dual(past, scheme, 0), InvalidInput);
    EXPECT_THROW(dual_mesh_size(past, scheme, 1), InvalidInput);
  }
  // Two fans at a vertex of a closed mesh: two cubes sharing vertex 0.
  PolyMesh two_cubes = make_quad_cube();
  const PolyMesh cube = make_quad_cube();
  for (std::size_t v = 1; v < 8; ++v) two_cubes.positions.push_back(cube.positions[v] + glm::dvec3(2.0, 2.0, 2.0));
  for (std::size_t f = 0; f < 6; ++f) {
    std::vector<Index> q;
    for (const Index v : cube.face(f)) q.push_back(v == 0 ? 0 : v + 7);
    two_cubes.add_face(q);
  }
  expect_all_throw(two_cubes, "two closed fans at a vertex");
}

// Random corruptions of valid meshes: a step throws InvalidInput exactly when validate() does, and never
// crashes (the sanitizer build runs this too).
TEST(DualSteps, StepsThrowExactlyWhenValidateDoes) {
  std::mt19937 rng(2024);
  const std::vector<Case> cases = fixtures();
  int rejected = 0, accepted = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    PolyMesh m = cases[rng() % cases.size()].mesh;
    switch (rng() % 5) {
      case 0:  // move one corner to another vertex
        m.corners[rng() % m.corners.size()] = static_cast<Index>(rng() % (m.num_vertices() + 1));
        break;
      case 1: {  // reverse one face
        const std::size_t f = rng() % m.num_faces();
        std::reverse(m.corners.begin() + m.face_offsets[f], m.corners.begin() + m.face_offsets[f + 1]);
        break;
      }
      case 2: {  // duplicate a face, maybe reversed
        const std::size_t f = rng() % m.num_faces();
        std::vector<Index> q(m.face(f).begin(), m.face(f).end());
        if (rng() % 2) std::reverse(q.begin(), q.end());
        m.add_face(q);
        break;
      }
      case 3: {  // glue two vertices
        const Index a = static_cast<Index>(rng() % m.num_vertices()), b = static_cast<Index>(rng() % m.num_vertices());
        for (Index& c : m.corners)
          if (c == b) c = a;
        break;
      }
      default: {  // drop a face (often still valid)
        const std::size_t f = rng() % m.num_faces();
        const Index b = m.face_offsets[f], e = m.face_offsets[f + 1];
        m.corners.erase(m.corners.begin() + b, m.corners.begin() + e);
        m.face_offsets.erase(m.face_offsets.begin() + static_cast<std::ptrdiff_t>(f) + 1);
        for (std::size_t g = f + 1; g < m.face_offsets.size(); ++g) m.face_offsets[g] -= e - b;
        break;
      }
    }
    bool valid = true;
    try {
      m.validate();
    } catch (const InvalidInput&) {
      valid = false;
    }
    for (const DualScheme scheme : kSchemes) {
      if (valid) {
        PolyMesh out;
        ASSERT_NO_THROW(out = dual_step(m, scheme)) << "trial " << trial;
        ASSERT_NO_THROW(out.validate()) << "trial " << trial;
      } else {
        ASSERT_THROW(dual_step(m, scheme), InvalidInput) << "trial " << trial;
      }
    }
    (valid ? accepted : rejected) += 1;
  }
  EXPECT_GT(accepted, 300);
  EXPECT_GT(rejected, 300);
}

// What PolyMesh::validate() throws on `m` ("" when it passes), without its "polygon mesh: ".
std::string validate_refusal(const PolyMesh& m, std::uint64_t* element) {
  try {
    m.validate();
    return "";
  } catch (const InvalidInput& e) {
    *element = e.element();
    const std::string what = e.what(), prefix = "polygon mesh: ";
    return what.starts_with(prefix) ? what.substr(prefix.size()) : what;
  }
}

// Grids damaged at random (testing::damaged_grid), some also given a face of two corners, a corner out of
// range or a NaN after their topological damage: each entry point refuses a mesh exactly when
// PolyMesh::validate() does, with validate()'s element and words (its own name for "polygon mesh"), so on a
// mesh with several problems the one validate() names; and a manifold rule exactly when the brute-force
// oracle (topology_oracle.hpp) finds it broken, naming the oracle's element.
TEST(DualSteps, RefuseWhatValidateAndTheOracleRefuse) {
  std::mt19937 rng(1807);
  auto pick = [&rng](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  std::map<TopologyRule, int> seen;
  int accepted = 0, other_damage = 0;
  for (int round = 0; round < 1200; ++round) {
    const testing::DamagedGrid grid = testing::damaged_grid(rng);
    const std::size_t damage = pick(6);
    PolyMesh m;
    for (std::size_t f = 0; f < grid.faces.size(); ++f) {
      if (damage == 0 && f == grid.faces.size() / 2) m.add_face(std::vector<Index>{0, 1});  // a two-corner face
      m.add_face(grid.faces[f]);
    }
    for (Index v = 0; v < grid.num_vertices; ++v)
      m.positions.emplace_back(double(v % 5), double(v / 5), 0.25 * (v % 3));
    if (damage == 1) m.corners[pick(m.corners.size())] = grid.num_vertices + Index(pick(3));  // out of range
    if (damage == 2) m.positions[pick(m.positions.size())].y = std::numeric_limits<double>::quiet_NaN();
    const bool damaged_more = damage < 3;
    other_damage += damaged_more;
    std::uint64_t element = InvalidInput::kNoElement;
    const std::string refusal = validate_refusal(m, &element);
    const TopologyProblem oracle = testing::slow_topology_problem(grid.faces, kPolyMeshRules);
    if (!damaged_more) {
      ASSERT_EQ(!refusal.empty(), bool(oracle)) << "round " << round << ": " << refusal;
      if (oracle) {
        EXPECT_EQ(element, oracle.element()) << "round " << round;
        EXPECT_EQ("polygon mesh: " + refusal, testing::refusal("polygon mesh", oracle)) << "round " << round;
      }
      ++seen[oracle.rule];
    }
    accepted += refusal.empty();
    const std::pair<const char*, std::function<void()>> entries[] = {
        {"zwart_powell_step", [&] { (void)zwart_powell_step(m); }},
        {"doo_sabin_step", [&] { (void)doo_sabin_step(m); }},
        {"dual_mesh_size", [&] { (void)dual_mesh_size(m, DualScheme::kDooSabin, 2); }},
        {"subdivide_dual", [&] { (void)subdivide_dual(m, DualScheme::kZwartPowell, 2); }},
    };
    for (const auto& [who, run] : entries) {
      try {
        run();
        EXPECT_TRUE(refusal.empty()) << "round " << round << ": " << who << " took what validate() refuses: "
                                     << refusal;
      } catch (const InvalidInput& e) {
        ASSERT_FALSE(refusal.empty()) << "round " << round << ": " << e.what();
        EXPECT_EQ(e.element(), element) << "round " << round << ": " << e.what();
        EXPECT_EQ(std::string(e.what()), std::string(who) + ": " + refusal) << "round " << round;
      }
    }
    if (refusal.empty()) {
      for (const DualScheme scheme : kSchemes) ASSERT_NO_THROW(dual_step(m, scheme).validate()) << "round " << round;
    }
  }
  for (TopologyRule r : {TopologyRule::kNone, TopologyRule::kRepeatedCorner, TopologyRule::kNonManifoldEdge,
                         TopologyRule::kInconsistentOrientation, TopologyRule::kNonManifoldVertex})
    EXPECT_GT(seen[r], 30) << int(r);
  EXPECT_GT(other_damage, 300);
  EXPECT_GT(accepted, 100);
}

TEST(DualSteps, AbsurdStepsAreRefusedBeforeAllocating) {
  const PolyMesh cube = make_quad_cube();
  for (const DualScheme scheme : kSchemes) {
    for (const int steps : {-1, 40, 1000, std::numeric_limits<int>::max()}) {
      g_guard_peak = 0;
      g_guard_armed = true;
      bool threw = false;
      std::string message;
      try {
        (void)subdivide_dual(cube, scheme, steps);
      } catch (const InvalidInput& e) {
        threw = true;
        message = e.what();
      } catch (const std::bad_alloc&) {
        message = "bad_alloc";
      }
      g_guard_armed = false;
      EXPECT_TRUE(threw) << to_string(scheme) << " steps " << steps << ": " << message;
      EXPECT_NE(message.find("steps"), std::string::npos) << message;
      EXPECT_LE(g_guard_peak.load(), kGuardLimit);
    }
  }
  // The bound is the corner count: DS multiplies a closed mesh's 24 corners by 4 per step, ZP by 2.
  EXPECT_EQ(dual_mesh_size(cube, DualScheme::kDooSabin, 13).corners, 24ull << 26);
  EXPECT_THROW(subdivide_dual(cube, DualScheme::kDooSabin, 14), InvalidInput);
  EXPECT_EQ(dual_mesh_size(cube, DualScheme::kZwartPowell, 26).corners, 24ull << 26);
  EXPECT_THROW(subdivide_dual(cube, DualScheme::kZwartPowell, 27), InvalidInput);
  EXPECT_EQ(dual_mesh_size(cube, DualScheme::kDooSabin, 40).corners, std::numeric_limits<std::uint64_t>::max());
  EXPECT_THROW(dual_mesh_size(cube, DualScheme::kDooSabin, -1), InvalidInput);
}

TEST(DualSteps, ZeroStepsIsACopy) {
  const PolyMesh in = capped_prism(5, 3);
  for (const DualScheme scheme : kSchemes) {
    const PolyMesh out = subdivide_dual(in, scheme, 0);
    EXPECT_EQ(out.positions, in.positions);
    EXPECT_EQ(out.corners, in.corners);
    EXPECT_EQ(out.face_offsets, in.face_offsets);
  }
  EXPECT_STREQ(to_string(DualScheme::kZwartPowell), "zwart-powell");
  EXPECT_STREQ(to_string(DualScheme::kDooSabin), "doo-sabin");
}

// The steps check what PolyMesh::validate() checks, including coordinates beyond 1e300 in size: a cube
// scaled to 1.5e308 used to pass and come back with infinite midpoints and corner points.
TEST(DualSteps, HugeCoordinatesAreRefusedAsValidateDoes) {
  PolyMesh huge = make_quad_cube();
  for (auto& p : huge.positions) p *= 1.5e308;
  huge.positions[5].z = -1.5e308;
  EXPECT_THROW(huge.validate(), InvalidInput);
  for (const DualScheme scheme : kSchemes) {
    try {
      (void)dual_step(huge, scheme);
      ADD_FAILURE() << to_string(scheme) << ": no throw";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("vertex 0 has a coordinate beyond 1e300"), std::string::npos) << e.what();
    }
    EXPECT_THROW(subdivide_dual(huge, scheme, 1), InvalidInput);
    EXPECT_THROW(dual_mesh_size(huge, scheme, 1), InvalidInput);
  }
  // At the limit validate() accepts, the steps give finite points.
  PolyMesh edge = make_quad_cube();
  for (auto& p : edge.positions) p *= 1e300;
  ASSERT_NO_THROW(edge.validate());
  for (const DualScheme scheme : kSchemes)
    for (const glm::dvec3& p : subdivide_dual(edge, scheme, 2).positions)
      ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << to_string(scheme);
}

}  // namespace
}  // namespace varmesh
