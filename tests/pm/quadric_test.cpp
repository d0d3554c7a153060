#include "pm/quadric.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

struct Rng {
  std::mt19937 gen{20240601u};
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(gen); }
  glm::dvec3 vec(double lo, double hi) { return {uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)}; }
  glm::dvec3 unit() {
    for (;;) {
      const glm::dvec3 v = vec(-1, 1);
      if (const double l = glm::length(v); l > 0.1 && l < 1) return v / l;
    }
  }
};

glm::dvec3 apply_a(const Quadric& q, const glm::dvec3& v) {
  return {q.a00 * v.x + q.a01 * v.y + q.a02 * v.z, q.a01 * v.x + q.a11 * v.y + q.a12 * v.z,
          q.a02 * v.x + q.a12 * v.y + q.a22 * v.z};
}

// Orthonormal frame (t, i, n) from a unit normal n.
void frame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& i) {
  t = glm::normalize(glm::cross(n, std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
  i = glm::cross(n, t);
}

TEST(QuadricTest, PlaneEvaluatesToWeightedSquaredDistance) {
  Rng rng;
  for (int trial = 0; trial < 50; ++trial) {
    const glm::dvec3 n = rng.vec(-3, 3);
    const double d = rng.uniform(-10, 10), w = rng.uniform(0.1, 5);
    const Quadric q = Quadric::from_plane(n, d, w);
    for (int k = 0; k < 20; ++k) {
      const glm::dvec3 p = rng.vec(-20, 20);
      const double dist = (glm::dot(n, p) + d) / glm::length(n);
      EXPECT_NEAR(q.evaluate(p), w * dist * dist, 1e-10 * (1 + w * dist * dist));
    }
  }
}

TEST(QuadricTest, TriangleIsAreaWeightedAndSumsAndScales) {
  Rng rng;
  for (int trial = 0; trial < 30; ++trial) {
    const glm::dvec3 a = rng.vec(-5, 5), b = rng.vec(-5, 5), c = rng.vec(-5, 5);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double area = 0.5 * glm::length(cr);
    const Quadric q = Quadric::from_triangle(a, b, c);
    const Quadric r = Quadric::from_plane(rng.unit(), rng.uniform(-1, 1), 2.0);
    for (int k = 0; k < 10; ++k) {
      const glm::dvec3 p = rng.vec(-10, 10);
      const double dist = glm::dot(glm::normalize(cr), p - a);
      EXPECT_NEAR(q.evaluate(p), area * dist * dist, 1e-9 * (1 + area * dist * dist));
      EXPECT_NEAR((q + r).evaluate(p), q.evaluate(p) + r.evaluate(p), 1e-9 * (1 + q.evaluate(p) + r.evaluate(p)));
      EXPECT_NEAR(q.scaled(3.5).evaluate(p), 3.5 * q.evaluate(p), 1e-9 * (1 + q.evaluate(p)));
    }
  }
  // Degenerate triangles (repeated or collinear corners) carry no plane.
  const glm::dvec3 p(1, 2, 3), e(0.5, -1, 2);
  for (const Quadric& z : {Quadric::from_triangle(p, p, p + e), Quadric::from_triangle(p, p + e, p + 2.0 * e)})
    EXPECT_EQ(z.evaluate(glm::dvec3(7, -4, 9)), 0.0);
}

TEST(QuadricTest, TetrahedronCornerIsTheExactOptimum) {
  Rng rng;
  const glm::dvec3 regular[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  for (int trial = 0; trial < 40; ++trial) {
    const double scale = std::pow(10.0, rng.uniform(-2, 3));
    const glm::dvec3 shift = rng.vec(-100, 100);
    glm::dvec3 v[4];
    for (int k = 0; k < 4; ++k) v[k] = shift + scale * (regular[k] + rng.vec(-0.3, 0.3));
    const Quadric q = Quadric::from_triangle(v[0], v[1], v[2]) + Quadric::from_triangle(v[0], v[2], v[3]) +
                      Quadric::from_triangle(v[0], v[3], v[1]);
    const glm::dvec3 candidates[] = {v[1], 0.5 * (v[0] + v[1])};
    const QuadricOptimum o = q.optimal(candidates);
    EXPECT_TRUE(o.solved);
    EXPECT_LT(glm::length(o.point - v[0]), 1e-9 * (scale + glm::length(shift)));
    // p^T A p + 2 b.p + c cancels terms of size trace(A) |p|^2: the rounding floor of any evaluation.
    const double floor = 1e-14 * (q.a00 + q.a11 + q.a22) * std::pow(scale + glm::length(v[0]), 2);
    EXPECT_LT(o.error, floor);
    EXPECT_GE(o.error, 0.0);
    EXPECT_LT(q.evaluate(v[0]), floor);
    EXPECT_TRUE(q.optimal_on_segment(v[1], v[2]).solved);
  }
}

TEST(QuadricTest, FlatRegionIsRankOneAndFallsBackToACandidate) {
  Rng rng;
  for (int trial = 0; trial < 20; ++trial) {
    const glm::dvec3 n = rng.unit(), o = rng.vec(-10, 10);
    glm::dvec3 t, i;
    frame(n, t, i);
    // A fan of 7 coplanar triangles with random radii around o.
    Quadric q;
    std::vector<glm::dvec3> ring;
    for (int k = 0; k < 7; ++k) {
      const double a = 2 * std::numbers::pi * k / 7;
      ring.push_back(o + rng.uniform(0.5, 2) * (std::cos(a) * t + std::sin(a) * i));
    }
    for (int k = 0; k < 7; ++k) q += Quadric::from_triangle(o, ring[k], ring[(k + 1) % 7]);
    // A = trace(A) n n^T: the tangent directions are in the kernel, n is the only image direction.
    const double trace = q.a00 + q.a11 + q.a22;
    EXPECT_GT(trace, 0.0);
    EXPECT_LT(glm::length(apply_a(q, t)), 1e-12 * trace);
    EXPECT_LT(glm::length(apply_a(q, i)), 1e-12 * trace);
    EXPECT_NEAR(glm::dot(n, apply_a(q, n)), trace, 1e-12 * trace);

    const glm::dvec3 above = o + 0.3 * n + 0.2 * t;
    const glm::dvec3 candidates[] = {above, ring[2], ring[4] - 0.1 * n};
    const QuadricOptimum best = q.optimal(candidates);
    EXPECT_FALSE(best.solved);
    EXPECT_EQ(best.point, ring[2]);  // the only candidate on the plane
    EXPECT_LT(best.error, 1e-12 * trace);
    EXPECT_GT(q.evaluate(above), 0.05 * trace);

    // On a segment crossing the plane the fallback is the crossing point.
    const glm::dvec3 below = o - 0.6 * n - 0.4 * i;
    const QuadricOptimum cross = q.optimal_on_segment(above, below);
    EXPECT_FALSE(cross.solved);
    EXPECT_NEAR(glm::dot(cross.point - o, n), 0.0, 1e-9);
    EXPECT_LT(glm::length(glm::cross(cross.point - above, below - above)), 1e-9);
    EXPECT_LT(cross.error, 1e-12 * trace);
  }
}

TEST(QuadricTest, BorderConstraintKeepsOptimumOnBorderLine) {
  Rng rng;
  constexpr int kArc = 8;
  for (int trial = 0; trial < 20; ++trial) {
    // Planar half-disk: centre c on the border line c + s t, the disk on the side +i, normal n.
    const glm::dvec3 n = rng.unit(), c = rng.vec(-10, 10);
    glm::dvec3 t, i;
    frame(n, t, i);
    const double r = rng.uniform(0.5, 3);
    std::vector<glm::dvec3> arc;
    for (int k = 0; k <= kArc; ++k) {
      const double a = std::numbers::pi * k / kArc;
      arc.push_back(c + r * (std::cos(a) * t + std::sin(a) * i));
    }
    Quadric faces_c, faces_a0;
    for (int k = 0; k < kArc; ++k) faces_c += Quadric::from_triangle(c, arc[k], arc[k + 1]);
    faces_a0 = Quadric::from_triangle(c, arc[0], arc[1]);
    // Border edges at c: (c, arc[0]) in face (c, arc[0], arc[1]) and (arc[kArc], c) in (c, arc[kArc-1], arc[kArc]).
    const double penalty = kDefaultBorderPenalty;
    const Quadric border0 = Quadric::from_border_edge(c, arc[0], arc[1], penalty);
    const Quadric border1 = Quadric::from_border_edge(arc[kArc], c, arc[kArc - 1], penalty);
    const Quadric chord = Quadric::from_border_edge(arc[0], arc[1], c, penalty);
    const Quadric qc = faces_c + border0 + border1;

    // The constraint is penalty * |edge|^2 * (distance to the border line)^2 per border edge.
    const double h = 0.1 * r;
    EXPECT_NEAR(qc.evaluate(c + h * i), 2 * penalty * r * r * h * h, 1e-9 * penalty * r * r * h * h);
    EXPECT_NEAR(qc.evaluate(c + 5.0 * t), 0.0, 1e-9 * penalty * r * r);

    // Unconstrained, an interior arc vertex costs nothing; constrained, the vertex stays on the line.
    const glm::dvec3 candidates[] = {arc[3], 0.5 * (c + arc[3]), c};
    EXPECT_LT(faces_c.evaluate(arc[3]), 1e-12 * r * r);
    EXPECT_FALSE(faces_c.optimal(candidates).solved);
    const QuadricOptimum kept = qc.optimal(candidates);
    EXPECT_FALSE(kept.solved);  // rank 2: free along the border line
    EXPECT_EQ(kept.point, c);
    EXPECT_GT(qc.evaluate(arc[3]), penalty * r * r * r * r);
    const QuadricOptimum on_segment = qc.optimal_on_segment(arc[3], c);
    EXPECT_LT(glm::length(on_segment.point - c), 1e-9 * r);

    // Collapse of border edge (c, arc[0]): both ends' quadrics; the optimum stays on the border line.
    const Quadric collapse = qc + faces_a0 + border0 + chord;
    const glm::dvec3 ends[] = {c, arc[0], 0.5 * (c + arc[0])};
    const QuadricOptimum o = collapse.optimal(ends);
    EXPECT_NEAR(glm::dot(o.point - c, i), 0.0, 1e-9 * r);
    EXPECT_NEAR(glm::dot(o.point - c, n), 0.0, 1e-9 * r);
    EXPECT_LT(o.error, 1e-9 * penalty * r * r * r * r);
  }
}

TEST(QuadricTest, RejectsBadInput) {
  EXPECT_THROW(Quadric::from_plane(glm::dvec3(0.0), 1.0), InvalidInput);
  EXPECT_THROW(Quadric::from_plane(glm::dvec3(1, 0, 0), std::nan("")), InvalidInput);
  EXPECT_THROW(Quadric::from_plane(glm::dvec3(1, 0, 0), 0.0, -1.0), InvalidInput);
  EXPECT_THROW(Quadric::from_border_edge(glm::dvec3(0), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), -2.0),
               InvalidInput);
  const Quadric q = Quadric::from_plane(glm::dvec3(0, 0, 1), 0.0);
  EXPECT_THROW(q.optimal({}), InvalidInput);
  EXPECT_THROW(AttributeQuadric{}.optimal({}), InvalidInput);
  // A zero quadric has no system to solve: the fallback picks the first candidate.
  const glm::dvec3 two[] = {glm::dvec3(1, 2, 3), glm::dvec3(4, 5, 6)};
  EXPECT_EQ(Quadric{}.optimal(two).point, two[0]);
  EXPECT_FALSE(Quadric{}.optimal(two).solved);
}

// Colour as an affine function of position: color(x) = m * x + k.
struct Ramp {
  glm::dvec3 m0, m1, m2, k;
  glm::dvec3 operator()(const glm::dvec3& x) const { return x.x * m0 + x.y * m1 + x.z * m2 + k; }
};

TEST(QuadricAttributeTest, LinearColourRampHasZeroErrorOnItsPlane) {
  Rng rng;
  for (int trial = 0; trial < 30; ++trial) {
    const Ramp ramp{rng.vec(-0.3, 0.3), rng.vec(-0.3, 0.3), rng.vec(-0.3, 0.3), rng.vec(0, 1)};
    const glm::dvec3 a = rng.vec(-3, 3), b = rng.vec(-3, 3), c = rng.vec(-3, 3);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double area = 0.5 * glm::length(cr);
    if (area < 0.5) continue;
    const glm::dvec3 nrm = glm::normalize(cr);
    const AttributeQuadric q =
        AttributeQuadric::from_triangle({a, ramp(a)}, {b, ramp(b)}, {c, ramp(c)});
    for (int k = 0; k < 10; ++k) {
      // Any point of the plane, inside the triangle or not, with its interpolated colour.
      const glm::dvec3 p = a + rng.uniform(-2, 3) * (b - a) + rng.uniform(-2, 3) * (c - a);
      EXPECT_NEAR(q.evaluate({p, ramp(p)}), 0.0, 1e-10 * area * (1 + glm::dot(p, p)));
      // Off the plane along the normal, keeping the colour: area * height^2 (the offset is orthogonal
      // to the triangle's plane in R^6).
      const double h = rng.uniform(-1, 1);
      EXPECT_NEAR(q.evaluate({p + h * nrm, ramp(p)}), area * h * h, 1e-9 * area * (1 + glm::dot(p, p)));
      // A wrong colour costs something.
      EXPECT_GT(q.evaluate({p, ramp(p) + glm::dvec3(0.2, 0, 0)}), 1e-4 * area);
    }
    // One triangle's A has rank 4: no unique optimum.
    const AttributePoint cand[] = {{a, ramp(a)}};
    EXPECT_FALSE(q.optimal(cand).solved);
  }
}

TEST(QuadricAttributeTest, FanOptimumReproducesSharedVertex) {
  Rng rng;
  constexpr int kSides = 5;
  for (int trial = 0; trial < 30; ++trial) {
    // A pyramid apex with arbitrary (not affine) colours at every vertex.
    const glm::dvec3 apex = rng.vec(-5, 5);
    const AttributePoint top{apex, rng.vec(0, 1)};
    std::vector<AttributePoint> ring;
    for (int k = 0; k < kSides; ++k) {
      const double a = 2 * std::numbers::pi * (k + rng.uniform(-0.2, 0.2)) / kSides;
      ring.push_back({apex + glm::dvec3(std::cos(a), std::sin(a), -rng.uniform(0.5, 1.5)), rng.vec(0, 1)});
    }
    AttributeQuadric q;
    for (int k = 0; k < kSides; ++k) q += AttributeQuadric::from_triangle(top, ring[k], ring[(k + 1) % kSides]);
    // entry(i, j) is the A of Q(x) = x.A.x + 2 b.x + c that evaluate() computes: the mixed second difference
    // Q(p + ei + ej) - Q(p + ei) - Q(p + ej) + Q(p) of a quadratic is exactly 2 A(i, j) (i == j included).
    auto shifted = [](AttributePoint x, int k, double by) {
      (k < 3 ? x.position : x.color)[k % 3] += by;
      return x;
    };
    const AttributePoint& p = ring[0];
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) {
        const AttributePoint pi = shifted(p, i, 1.0), pj = shifted(p, j, 1.0), pij = shifted(pi, j, 1.0);
        const double diff = q.evaluate(pij) - q.evaluate(pi) - q.evaluate(pj) + q.evaluate(p);
        EXPECT_NEAR(q.entry(i, j), 0.5 * diff, 1e-9 * (1.0 + q.evaluate(pij))) << i << ", " << j;
      }
    // Sums and scalings act on the entries.
    EXPECT_NEAR(q.scaled(2).evaluate(ring[0]), 2 * q.evaluate(ring[0]), 1e-12 * (1 + q.evaluate(ring[0])));

    const AttributeOptimum o = q.optimal(std::span<const AttributePoint>(ring));
    EXPECT_TRUE(o.solved);
    EXPECT_LT(glm::length(o.point.position - apex), 1e-9);
    EXPECT_LT(glm::length(o.point.color - top.color), 1e-9);
    EXPECT_LT(o.error, 1e-12);
    EXPECT_GE(o.error, 0.0);
    EXPECT_GT(q.evaluate(ring[0]), 1e-3);
    EXPECT_TRUE(q.optimal_on_segment(ring[0], ring[1]).solved);
  }
}

TEST(QuadricAttributeTest, SingularSegmentFallbackIsBestPointOfSegment) {
  // One flat triangle with constant colour: zero error on its plane with that colour, quadratic off it.
  const glm::dvec3 red(1, 0, 0);
  const AttributeQuadric q =
      AttributeQuadric::from_triangle({{0, 0, 0}, red}, {{1, 0, 0}, red}, {{0, 1, 0}, red});
  const AttributePoint p0{{0.2, 0.2, 1.0}, red}, p1{{0.4, 0.1, -3.0}, red};
  const AttributeOptimum o = q.optimal_on_segment(p0, p1);
  EXPECT_FALSE(o.solved);
  EXPECT_NEAR(o.point.position.z, 0.0, 1e-12);  // the segment crosses z = 0 at t = 1/4
  EXPECT_NEAR(o.point.position.x, 0.25, 1e-12);
  EXPECT_LT(o.error, 1e-20);
}

}  // namespace
}  // namespace varmesh
