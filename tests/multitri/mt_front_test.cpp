// MtFront: the state of one extraction on an immutable Mt. Random walks checked against a model of the
// applied set after every move, round trips (refine all / coarsen all), forced moves and illegal moves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "mt_grid_fixture.hpp"

namespace varmesh {
namespace {

using testing::applied_set;
using testing::GridMtOptions;
using testing::make_grid_mt;
using testing::projected_area;

// Independent checks of a front against the applied set alone: faces = created by an applied node and
// not removed by one; every directed edge once; the projection tiles the domain.
void expect_front_matches(const MtFront& f, const std::vector<char>& applied, double domain_area) {
  const Mt& mt = f.mt();
  std::vector<FaceId> expected;
  for (FaceId face = 0; face < mt.num_faces(); ++face)
    if (applied[mt.creator(face)] && (mt.destroyer(face) == kInvalid || !applied[mt.destroyer(face)]))
      expected.push_back(face);
  std::vector<FaceId> got(f.faces().begin(), f.faces().end());
  std::sort(got.begin(), got.end());
  ASSERT_EQ(got, expected);
  std::vector<std::uint64_t> edges;
  for (FaceId face : got) {
    const auto v = mt.face(face);
    for (int k = 0; k < 3; ++k) edges.push_back((std::uint64_t(v[k]) << 32) | v[(k + 1) % 3]);
  }
  std::sort(edges.begin(), edges.end());
  ASSERT_TRUE(std::adjacent_find(edges.begin(), edges.end()) == edges.end()) << "directed edge repeated";
  ASSERT_NEAR(projected_area(f), domain_area, 1e-6 * domain_area);
  ASSERT_EQ(applied_set(f), applied);
  ASSERT_EQ(f.num_applied(), static_cast<std::size_t>(std::count(applied.begin(), applied.end(), 1)));
}

// Model of refine(n): n and its unapplied ancestors; of coarsen(n): n and its applied descendants.
std::vector<NodeId> missing_ancestors(const Mt& mt, const std::vector<char>& applied, NodeId n) {
  std::vector<NodeId> out, stack{n};
  std::vector<char> seen(mt.num_nodes(), 0);
  while (!stack.empty()) {
    const NodeId t = stack.back();
    stack.pop_back();
    if (applied[t] || seen[t]) continue;
    seen[t] = 1;
    out.push_back(t);
    for (NodeId p : mt.parents(t)) stack.push_back(p);
  }
  std::sort(out.begin(), out.end());
  return out;
}
std::vector<NodeId> applied_descendants(const Mt& mt, const std::vector<char>& applied, NodeId n) {
  std::vector<NodeId> out, stack{n};
  std::vector<char> seen(mt.num_nodes(), 0);
  while (!stack.empty()) {
    const NodeId t = stack.back();
    stack.pop_back();
    if (!applied[t] || seen[t]) continue;
    seen[t] = 1;
    out.push_back(t);
    for (NodeId c : mt.children(t)) stack.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string thrown_message(const std::function<void()>& fn, std::uint64_t* element) {
  try {
    fn();
  } catch (const InvalidInput& e) {
    *element = e.element();
    return e.what();
  }
  return "";
}

// One random walk of `steps` moves; full validation every `check_every` moves, model comparison always.
void random_walk(const testing::GridMt& g, std::uint32_t seed, int steps, int check_every) {
  const Mt& mt = g.mt;
  MtFront f(mt);
  std::vector<char> model = applied_set(f);
  std::mt19937 rng(seed);
  const auto nn = static_cast<NodeId>(mt.num_nodes());
  std::uniform_int_distribution<NodeId> any_node(0, nn - 1);
  int applies = 0, undos = 0, refines = 0, coarsens = 0, illegal = 0;
  std::size_t max_faces = 0;
  for (int step = 0; step < steps; ++step) {
    const unsigned op = rng() % 8;
    // Bias towards refining so that the walk reaches deep fronts, and towards legal single moves.
    if (op <= 1) {
      const NodeId n = any_node(rng);
      const auto expected = missing_ancestors(mt, model, n);
      std::vector<NodeId> sunk;
      f.refine(n, [&](NodeId r) {
        // Sink order: every parent of r was applied before r.
        for (NodeId p : mt.parents(r)) ASSERT_TRUE(f.is_applied(p)) << "refine applied " << r << " before " << p;
        sunk.push_back(r);
      });
      std::sort(sunk.begin(), sunk.end());
      ASSERT_EQ(sunk, expected) << "refine(" << n << ") must apply exactly the missing ancestors";
      for (NodeId r : sunk) model[r] = 1;
      ++refines;
    } else if (op == 2) {
      const NodeId n = any_node(rng);
      const auto expected = n == 0 ? std::vector<NodeId>{} : applied_descendants(mt, model, n);
      std::vector<NodeId> sunk;
      f.coarsen(n, [&](NodeId r) {
        for (NodeId c : mt.children(r)) ASSERT_FALSE(f.is_applied(c)) << "coarsen undid " << r << " before " << c;
        sunk.push_back(r);
      });
      std::sort(sunk.begin(), sunk.end());
      ASSERT_EQ(sunk, expected) << "coarsen(" << n << ") must undo exactly the applied descendants";
      for (NodeId r : sunk) model[r] = 0;
      ++coarsens;
    } else if (op <= 5) {
      // A legal apply, or an illegal one now and then.
      std::vector<NodeId> legal;
      for (NodeId n = 0; n < nn; ++n)
        if (f.can_apply(n)) legal.push_back(n);
      if (legal.empty() || rng() % 8 == 0) {
        const NodeId n = any_node(rng);
        if (f.can_apply(n)) continue;
        std::uint64_t element = 0;
        const std::string msg = thrown_message([&] { f.apply(n); }, &element);
        ASSERT_FALSE(msg.empty()) << "apply(" << n << ") is illegal but did not throw";
        ASSERT_EQ(element, n);
        ASSERT_NE(msg.find("node " + std::to_string(n)), std::string::npos) << msg;
        ++illegal;
      } else {
        const NodeId n = legal[rng() % legal.size()];
        f.apply(n);
        model[n] = 1;
        ++applies;
      }
    } else {
      std::vector<NodeId> legal;
      for (NodeId n = 0; n < nn; ++n)
        if (f.can_undo(n)) legal.push_back(n);
      if (legal.empty() || rng() % 8 == 0) {
        const NodeId n = any_node(rng);
        if (f.can_undo(n)) continue;
        std::uint64_t element = 0;
        const std::string msg = thrown_message([&] { f.undo(n); }, &element);
        ASSERT_FALSE(msg.empty()) << "undo(" << n << ") is illegal but did not throw";
        ASSERT_EQ(element, n);
        ASSERT_NE(msg.find("node " + std::to_string(n)), std::string::npos) << msg;
        ++illegal;
      } else {
        const NodeId n = legal[rng() % legal.size()];
        f.undo(n);
        model[n] = 0;
        ++undos;
      }
    }
    // The legality tests agree with the model.
    const NodeId probe = any_node(rng);
    bool parents_applied = true;
    for (NodeId p : mt.parents(probe)) parents_applied = parents_applied && model[p];
    bool children_unapplied = true;
    for (NodeId c : mt.children(probe)) children_unapplied = children_unapplied && !model[c];
    ASSERT_EQ(f.can_apply(probe), !model[probe] && parents_applied) << "node " << probe;
    ASSERT_EQ(f.can_undo(probe), probe != 0 && model[probe] && children_unapplied) << "node " << probe;
    max_faces = std::max(max_faces, f.num_faces());
    if (step % check_every == 0 || step + 1 == steps) {
      ASSERT_NO_THROW(f.validate()) << "step " << step;
    }
    if (step % (check_every * 16) == 0 || step + 1 == steps) {
      expect_front_matches(f, model, g.domain_area);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  // The walk really moved in both directions and reached deep fronts.
  EXPECT_GT(applies, steps / 10);
  EXPECT_GT(undos, steps / 20);
  EXPECT_GT(refines, steps / 10);
  EXPECT_GT(coarsens, steps / 20);
  EXPECT_GT(illegal, 0);
  EXPECT_GT(max_faces, g.mt.image_size(0) * 4);
}

TEST(MtFront, RandomWalkSmallValidatedEveryStep) {
  GridMtOptions o;
  o.n = 2;
  o.levels = 5;
  o.swap_probability = 0.25;
  o.seed = 7;
  const auto g = make_grid_mt(o);
  ASSERT_NO_THROW(g.mt.validate());
  ASSERT_GT(g.num_swaps, 0u);
  random_walk(g, 11, 10000, 1);
}

TEST(MtFront, RandomWalkTerrainWithSwaps) {
  GridMtOptions o;
  o.n = 3;
  o.levels = 6;
  o.swap_probability = 0.15;
  o.height = testing::hills;
  o.seed = 3;
  const auto g = make_grid_mt(o);
  ASSERT_GT(g.num_swaps, 0u);
  random_walk(g, 5, 10000, 7);
}

TEST(MtFront, CoarsestFrontIsTheBaseMesh) {
  const auto g = make_grid_mt({});
  MtFront f(g.mt);
  f.validate();
  EXPECT_EQ(f.num_applied(), 1u);
  EXPECT_EQ(f.num_faces(), g.mt.image_size(0));
  for (FaceId face = g.mt.image_begin(0); face < g.mt.image_end(0); ++face) EXPECT_TRUE(f.has_face(face));
  EXPECT_NEAR(projected_area(f), g.domain_area, 1e-9);
}

TEST(MtFront, RefineAllThenCoarsenAllIsTheBaseMesh) {
  GridMtOptions o;
  o.n = 3;
  o.levels = 5;
  o.swap_probability = 0.3;
  o.height = testing::hills;
  const auto g = make_grid_mt(o);
  const Mt& mt = g.mt;
  MtFront f(mt);
  std::vector<FaceId> base_faces(f.faces().begin(), f.faces().end());
  std::sort(base_faces.begin(), base_faces.end());
  const TriMesh base_mesh = f.to_mesh();

  std::vector<NodeId> order(mt.num_nodes());
  for (NodeId n = 0; n < order.size(); ++n) order[n] = n;
  std::mt19937 rng(9);
  for (int round = 0; round < 3; ++round) {
    std::shuffle(order.begin(), order.end(), rng);
    for (NodeId n : order) f.refine(n);
    f.validate();
    EXPECT_EQ(f.num_applied(), mt.num_nodes());
    // The finest front is the drain: every face no node removes.
    std::vector<FaceId> drain;
    for (FaceId face = 0; face < mt.num_faces(); ++face)
      if (mt.destroyer(face) == kInvalid) drain.push_back(face);
    std::vector<FaceId> got(f.faces().begin(), f.faces().end());
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, drain);
    EXPECT_NEAR(projected_area(f), g.domain_area, 1e-6 * g.domain_area);

    std::shuffle(order.begin(), order.end(), rng);
    for (NodeId n : order) f.coarsen(n);
    f.validate();
    EXPECT_EQ(f.num_applied(), 1u);
    got.assign(f.faces().begin(), f.faces().end());
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, base_faces);
    const TriMesh again = f.to_mesh();
    EXPECT_EQ(again.indices, base_mesh.indices);
    EXPECT_EQ(again.positions, base_mesh.positions);
  }
  // Coarsening the source is a no-op; reset() from a deep front gives the base mesh too.
  f.coarsen(0);
  EXPECT_EQ(f.num_applied(), 1u);
  f.refine(static_cast<NodeId>(mt.num_nodes() - 1));
  EXPECT_GT(f.num_applied(), 2u);
  f.reset();
  f.validate();
  std::vector<FaceId> got(f.faces().begin(), f.faces().end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, base_faces);
}

TEST(MtFront, RefineAppliesExactlyTheMissingAncestors) {
  GridMtOptions o;
  o.n = 2;
  o.levels = 6;
  o.swap_probability = 0.2;
  const auto g = make_grid_mt(o);
  const Mt& mt = g.mt;
  std::mt19937 rng(4);
  for (int trial = 0; trial < 60; ++trial) {
    MtFront f(mt);
    // A random starting front.
    for (int k = 0; k < 5; ++k) f.refine(static_cast<NodeId>(rng() % mt.num_nodes()));
    const auto before = applied_set(f);
    const NodeId n = static_cast<NodeId>(rng() % mt.num_nodes());
    const auto expected = missing_ancestors(mt, before, n);
    std::vector<NodeId> sunk;
    f.refine(n, [&](NodeId r) { sunk.push_back(r); });
    EXPECT_EQ(sunk.size(), expected.size());
    std::sort(sunk.begin(), sunk.end());
    EXPECT_EQ(sunk, expected);
    // Nothing else moved.
    const auto after = applied_set(f);
    for (NodeId m = 0; m < mt.num_nodes(); ++m)
      EXPECT_EQ(after[m], before[m] || std::binary_search(expected.begin(), expected.end(), m)) << "node " << m;
    f.validate();

    // coarsen(n) undoes exactly the applied descendants of n (n included).
    const NodeId c = static_cast<NodeId>(1 + rng() % (mt.num_nodes() - 1));
    const auto before2 = applied_set(f);
    const auto expected2 = applied_descendants(mt, before2, c);
    std::vector<NodeId> undone;
    f.coarsen(c, [&](NodeId r) { undone.push_back(r); });
    std::sort(undone.begin(), undone.end());
    EXPECT_EQ(undone, expected2);
    const auto after2 = applied_set(f);
    for (NodeId m = 0; m < mt.num_nodes(); ++m)
      EXPECT_EQ(after2[m], before2[m] && !std::binary_search(expected2.begin(), expected2.end(), m)) << "node " << m;
    f.validate();
  }
}

TEST(MtFront, IllegalMovesThrowNamingTheNodeAndChangeNothing) {
  GridMtOptions o;
  o.n = 2;
  o.levels = 3;
  const auto g = make_grid_mt(o);
  const Mt& mt = g.mt;
  MtFront f(mt);
  // A node with a parent other than the source.
  NodeId deep = kInvalid;
  for (NodeId n = 1; n < mt.num_nodes() && deep == kInvalid; ++n)
    if (mt.parents(n).front() != 0) deep = n;
  ASSERT_NE(deep, kInvalid);
  const NodeId top = mt.parents(deep).front();
  auto expect_throw = [&](const std::function<void()>& fn, NodeId n, const std::string& reason) {
    const auto applied_before = applied_set(f);
    std::vector<FaceId> faces_before(f.faces().begin(), f.faces().end());
    std::sort(faces_before.begin(), faces_before.end());
    std::uint64_t element = 0;
    const std::string msg = thrown_message(fn, &element);
    EXPECT_EQ(element, n) << msg;
    EXPECT_NE(msg.find("node " + std::to_string(n)), std::string::npos) << msg;
    EXPECT_NE(msg.find(reason), std::string::npos) << msg;
    EXPECT_EQ(applied_set(f), applied_before);
    std::vector<FaceId> faces_after(f.faces().begin(), f.faces().end());
    std::sort(faces_after.begin(), faces_after.end());
    EXPECT_EQ(faces_after, faces_before);
    EXPECT_NO_THROW(f.validate());
  };
  expect_throw([&] { f.apply(deep); }, deep, "parent");
  expect_throw([&] { f.apply(0); }, 0, "already applied");
  expect_throw([&] { f.undo(0); }, 0, "source");
  expect_throw([&] { f.undo(top); }, top, "not applied");
  f.refine(deep);
  expect_throw([&] { f.apply(top); }, top, "already applied");
  expect_throw([&] { f.apply(deep); }, deep, "already applied");
  expect_throw([&] { f.undo(top); }, top, "applied child");
  f.undo(deep);
  f.coarsen(top);
  expect_throw([&] { f.undo(deep); }, deep, "not applied");
  expect_throw([&] { f.undo(top); }, top, "not applied");
  f.validate();
}

TEST(MtFront, NodeOutOfRangeThrowsNamingIt) {
  const auto g = make_grid_mt({});
  MtFront f(g.mt);
  const auto bad = static_cast<NodeId>(g.mt.num_nodes());
  for (const auto& move : std::vector<std::function<void()>>{[&] { f.apply(bad); }, [&] { f.undo(bad); },
                                                              [&] { f.refine(bad); }, [&] { f.coarsen(bad); },
                                                              [&] { f.refine(kInvalid); }}) {
    std::uint64_t element = 0;
    const std::string msg = thrown_message(move, &element);
    ASSERT_FALSE(msg.empty());
    EXPECT_TRUE(element == bad || element == kInvalid) << msg;
    EXPECT_NE(msg.find("not a node"), std::string::npos) << msg;
  }
  EXPECT_NO_THROW(f.validate());
  EXPECT_EQ(f.num_applied(), 1u);
}

TEST(MtFront, ToMeshKeepsProvenanceAndIsHistoryIndependent) {
  GridMtOptions o;
  o.n = 2;
  o.levels = 4;
  o.height = testing::hills;
  const auto g = make_grid_mt(o);
  const Mt& mt = g.mt;
  std::mt19937 rng(2);
  std::vector<NodeId> targets;
  for (int k = 0; k < 6; ++k) targets.push_back(static_cast<NodeId>(rng() % mt.num_nodes()));
  MtFront a(mt), b(mt);
  for (NodeId n : targets) a.refine(n);
  // b reaches the same state by another history: everything, then coarsen what a does not have.
  for (NodeId n = 0; n < mt.num_nodes(); ++n) b.refine(n);
  for (NodeId n = static_cast<NodeId>(mt.num_nodes()); n-- > 1;)
    if (!a.is_applied(n)) b.coarsen(n);
  ASSERT_EQ(applied_set(a), applied_set(b));
  std::vector<FaceId> fa, fb;
  std::vector<VertexId> va, vb;
  const TriMesh ma = a.to_mesh(&fa, &va), mb = b.to_mesh(&fb, &vb);
  EXPECT_EQ(ma.indices, mb.indices);
  EXPECT_EQ(ma.positions, mb.positions);
  EXPECT_EQ(fa, fb);
  ASSERT_NO_THROW(ma.validate());
  ASSERT_EQ(fa.size(), ma.num_faces());
  ASSERT_EQ(va.size(), ma.num_vertices());
  for (std::size_t k = 0; k < fa.size(); ++k) {
    const auto v = mt.face(fa[k]);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(va[ma.corner(k, c)], v[static_cast<std::size_t>(c)]);
      EXPECT_EQ(ma.positions[ma.corner(k, c)], mt.position(v[static_cast<std::size_t>(c)]));
    }
  }
}

TEST(MtFront, ManyFrontsShareOneMt) {
  const auto g = make_grid_mt({});
  MtFront a(g.mt), b(g.mt);
  a.refine(static_cast<NodeId>(g.mt.num_nodes() - 1));
  EXPECT_EQ(b.num_applied(), 1u);
  b.validate();
  a.validate();
  MtFront c = a;  // a copy is an independent state
  EXPECT_EQ(applied_set(c), applied_set(a));
  c.reset();
  EXPECT_EQ(c.num_applied(), 1u);
  EXPECT_GT(a.num_applied(), 1u);
  a.validate();
  c.validate();
}


// A front points at its Mt: binding one to a temporary would dangle, so it does not compile.
static_assert(std::is_constructible_v<MtFront, const Mt&>);
static_assert(std::is_constructible_v<MtFront, Mt&>);
static_assert(!std::is_constructible_v<MtFront, Mt&&>);
static_assert(!std::is_constructible_v<MtFront, const Mt&&>);
static_assert(!std::is_constructible_v<MtFront, Mt>);

TEST(MtFront, RefusesAnEmptyMt) {
  const Mt empty;
  try {
    MtFront f(empty);
    FAIL() << "an empty Mt was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
}

#if defined(VARMESH_ENABLE_ASSERTS) || !defined(NDEBUG)
TEST(MtFrontDeathTest, UncheckedAccessorsAssertTheirPrecondition) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const testing::GridMt g = make_grid_mt(GridMtOptions{});
  const MtFront f(g.mt);
  const auto nn = static_cast<NodeId>(g.mt.num_nodes());
  EXPECT_DEATH((void)f.is_applied(nn), "precondition violated");
  EXPECT_DEATH((void)f.can_apply(1000000), "precondition violated");
  EXPECT_DEATH((void)f.can_undo(nn), "precondition violated");
  EXPECT_DEATH((void)f.has_face(static_cast<FaceId>(g.mt.num_faces())), "precondition violated");
  EXPECT_DEATH((void)f.element_bound(nn), "precondition violated");
}
#endif

}  // namespace
}  // namespace varmesh
