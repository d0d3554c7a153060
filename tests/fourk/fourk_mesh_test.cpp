// Tests of fourk/fourk_mesh.hpp: the 4-k structure of Velho-Gomes 2000, section 7.1 (Face / Hedge in index
// form, pre-image, image, successor, predecessor, modification type), its split and swap operations, its
// invariants (validate() after every operation) and its export as a Multi-Triangulation.
#include "fourk/fourk_mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mesh_fixtures.hpp"

#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/shapes.hpp"

namespace varmesh {
namespace {

using Tri = std::array<VertexId, 3>;

// Smallest corner first, cyclic order kept: one key per oriented triangle.
Tri canonical(Tri t) {
  while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
  return t;
}

std::multiset<Tri> triangles(const TriMesh& m) {
  std::multiset<Tri> s;
  for (std::size_t f = 0; f < m.num_faces(); ++f) s.insert(canonical({m.corner(f, 0), m.corner(f, 1), m.corner(f, 2)}));
  return s;
}

// Each directed edge used once (conforming, consistently oriented); returns the number of border edges.
std::size_t expect_conforming(const TriMesh& m) {
  std::map<std::pair<Index, Index>, int> directed;
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int uses = ++directed[{m.corner(f, k), m.corner(f, (k + 1) % 3)}];
      EXPECT_EQ(uses, 1) << "directed edge used twice, face " << f;
    }
  std::size_t border = 0;
  for (const auto& [e, n] : directed)
    if (!directed.count({e.second, e.first})) ++border;
  return border;
}

// Euler characteristic V - E + F over the referenced vertices.
long euler(const TriMesh& m) {
  std::set<Index> vs;
  std::set<std::pair<Index, Index>> es;
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Index a = m.corner(f, k), b = m.corner(f, (k + 1) % 3);
      vs.insert(a);
      es.insert({std::min(a, b), std::max(a, b)});
    }
  return long(vs.size()) - long(es.size()) + long(m.num_faces());
}

// The unit square as two triangles sharing the diagonal 0-2: (0, 1, 2) and (0, 2, 3).
TriMesh square() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TriMesh torus(int nu, int nv) { return testing::torus_grid(nu, nv); }

TriMesh tetrahedron() {
  TriMesh m;
  m.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  m.indices = {0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2};
  return m;
}

TEST(FourKMesh, BaseMeshHasMatesAndValidates) {
  const FourKMesh fk(square());
  fk.validate();
  EXPECT_EQ(fk.num_faces(), 2u);
  EXPECT_EQ(fk.num_half_edges(), 6u);
  EXPECT_EQ(fk.num_base_faces(), 2u);
  EXPECT_EQ(fk.num_current_faces(), 2u);
  EXPECT_EQ(fk.num_modifications(), 0u);
  // Face 0 = (0, 1, 2): edge[2] = 2->0 is mated with face 1's edge[0] = 0->2.
  EXPECT_EQ(fk.face(0), (Tri{0, 1, 2}));
  EXPECT_EQ(fk.mate(2), 3u);
  EXPECT_EQ(fk.mate(3), 2u);
  EXPECT_EQ(fk.mate(0), kInvalid);
  EXPECT_EQ(FourKMesh::fbase(5), 1u);
  EXPECT_EQ(FourKMesh::next(5), 3u);
  EXPECT_EQ(FourKMesh::prev(3), 5u);
  EXPECT_EQ(fk.target(2), 0u);
  EXPECT_EQ(fk.successor(0), kInvalid);    // current: belongs to the drain
  EXPECT_EQ(fk.predecessor(0), kInvalid);  // base face: created by the source
  EXPECT_FALSE(fk.is_modification(0));
  EXPECT_THROW(fk.pre_image(0), InvalidInput);
  EXPECT_THROW(fk.modification_type(3), InvalidInput);
  EXPECT_GT(fk.memory_bytes(), 0u);
}

TEST(FourKMesh, InternalEdgeSplitFollowsFigure12) {
  FourKMesh fk(square());
  // Split the shared diagonal from face 0's side: edge 2 of face 0 (2->0); face 0 is shifted so that
  // it becomes edge[0], and face 1's edge[0] (0->2) is its mate.
  const VertexId m = fk.split(2, {0.5f, 0.5f, 0.0f}, 0.25f);
  fk.validate();
  EXPECT_EQ(m, 4u);
  EXPECT_EQ(fk.face(0), (Tri{2, 0, 1}));  // cyclic shift: split edge first
  EXPECT_EQ(fk.face(1), (Tri{0, 2, 3}));
  EXPECT_EQ(fk.num_current_faces(), 4u);
  ASSERT_EQ(fk.num_modifications(), 1u);
  const HalfEdgeId e = fk.modifications()[0];
  EXPECT_EQ(e, FourKMesh::split_edge(0));
  EXPECT_TRUE(fk.is_modification(e));
  EXPECT_TRUE(fk.is_modification(fk.mate(e)));
  EXPECT_EQ(fk.mate(e), FourKMesh::split_edge(1));
  EXPECT_EQ(fk.modification_type(e), NodeKind::kSplit);
  const FourKFaceSet pre = fk.pre_image(e);
  ASSERT_EQ(pre.size, 2u);
  EXPECT_EQ(pre.faces[0], 0u);
  EXPECT_EQ(pre.faces[1], 1u);
  const FourKFaceSet img = fk.image(e);
  ASSERT_EQ(img.size, 4u);
  // f = (a, b, c) = (2, 0, 1) -> (c, a, m), (b, c, m); g = (b, a, d) = (0, 2, 3) -> (d, b, m), (a, d, m).
  EXPECT_EQ(fk.face(img.faces[0]), (Tri{1, 2, 4}));
  EXPECT_EQ(fk.face(img.faces[1]), (Tri{0, 1, 4}));
  EXPECT_EQ(fk.face(img.faces[2]), (Tri{3, 0, 4}));
  EXPECT_EQ(fk.face(img.faces[3]), (Tri{2, 3, 4}));
  for (FaceId c : img) {
    EXPECT_EQ(fk.predecessor(c), FourKMesh::split_edge(fk.parent(c)));
    EXPECT_EQ(fk.successor(c), kInvalid);
    EXPECT_EQ(fk.point(FourKMesh::split_edge(c) + 2), m) << "the new vertex is every child's apex";
  }
  EXPECT_EQ(fk.successor(0), e);
  EXPECT_EQ(fk.successor(1), fk.mate(e));
  EXPECT_FLOAT_EQ(fk.error(0), 0.25f);
  // The paper's functions agree whichever half-edge names the modification.
  EXPECT_EQ(fk.image(fk.mate(e)).size, 4u);
  EXPECT_EQ(fk.pre_image(fk.mate(e)).faces[0], 1u);
  // The current mesh: four faces around the valence-4 vertex m, a square with 4 border edges.
  const TriMesh cur = fk.current_mesh();
  EXPECT_EQ(expect_conforming(cur), 4u);
  EXPECT_EQ(euler(cur), 1);

  FourKMtMap map;
  const Mt mt = fk.to_mt({}, &map);
  mt.validate();
  ASSERT_EQ(mt.num_nodes(), 2u);
  EXPECT_EQ(mt.kind(1), NodeKind::kSplit);
  EXPECT_EQ(map.node_edge[0], kInvalid);
  EXPECT_EQ(map.node_edge[1], e);
  EXPECT_FLOAT_EQ(mt.bound(1).error, 0.25f);
  for (FaceId f = 0; f < mt.num_faces(); ++f) EXPECT_EQ(mt.face(f), fk.face(map.face[f]));
}

TEST(FourKMesh, BorderSplitIsOneToTwo) {
  FourKMesh fk(square());
  const VertexId m = fk.split(0, {0.5f, 0.0f, 0.0f});  // edge 0->1 of face 0: on the border
  fk.validate();
  const HalfEdgeId e = fk.modifications()[0];
  EXPECT_EQ(fk.mate(e), kInvalid);
  EXPECT_EQ(fk.modification_type(e), NodeKind::kSplit);  // children[1] is set
  EXPECT_EQ(fk.pre_image(e).size, 1u);
  const FourKFaceSet img = fk.image(e);
  ASSERT_EQ(img.size, 2u);
  EXPECT_EQ(fk.face(img.faces[0]), (Tri{2, 0, m}));
  EXPECT_EQ(fk.face(img.faces[1]), (Tri{1, 2, m}));
  EXPECT_EQ(fk.num_current_faces(), 3u);
  const TriMesh cur = fk.current_mesh();
  EXPECT_EQ(expect_conforming(cur), 5u);
  const Mt mt = fk.to_mt();
  mt.validate();
  EXPECT_EQ(mt.num_nodes(), 2u);
  EXPECT_EQ(mt.image_size(1), 2u);
}

TEST(FourKMesh, InternalEdgeSwapFollowsFigure13) {
  FourKMesh fk(square());
  EXPECT_FALSE(fk.can_swap(0));  // border
  ASSERT_TRUE(fk.can_swap(3));
  fk.swap(3, 0.5f);  // face 1's edge[0] = 0->2: f = (0, 2, 3), g = (2, 0, 1)
  fk.validate();
  const HalfEdgeId e = fk.modifications()[0];
  EXPECT_EQ(e, FourKMesh::split_edge(1));
  EXPECT_EQ(fk.modification_type(e), NodeKind::kSwap);
  EXPECT_EQ(fk.modification_type(fk.mate(e)), NodeKind::kSwap);
  EXPECT_EQ(fk.child(0, 1), kInvalid);
  EXPECT_EQ(fk.child(1, 1), kInvalid);
  const FourKFaceSet img = fk.image(e);
  ASSERT_EQ(img.size, 2u);
  // a = 0, b = 2, c = 3, d = 1: (d, c, a) and (c, d, b); the new edge 1-3 is edge[0] of both.
  EXPECT_EQ(fk.face(img.faces[0]), (Tri{1, 3, 0}));
  EXPECT_EQ(fk.face(img.faces[1]), (Tri{3, 1, 2}));
  EXPECT_EQ(fk.mate(FourKMesh::split_edge(img.faces[0])), FourKMesh::split_edge(img.faces[1]));
  EXPECT_EQ(fk.num_current_faces(), 2u);
  EXPECT_EQ(expect_conforming(fk.current_mesh()), 4u);
  const Mt mt = fk.to_mt();
  mt.validate();
  ASSERT_EQ(mt.num_nodes(), 2u);
  EXPECT_EQ(mt.kind(1), NodeKind::kSwap);
  MtFront front(mt);
  front.apply(1);
  front.validate();
  EXPECT_EQ(triangles(front.to_mesh()).size(), 2u);
  front.undo(1);
  front.validate();

  // Swapping back recreates faces of the base: the structure records it, the Mt refuses it (redundancy).
  fk.swap(FourKMesh::split_edge(img.faces[0]));
  fk.validate();
  EXPECT_THROW(fk.to_mt(), InvalidInput);
}

TEST(FourKMesh, SwapRefusesExistingEdges) {
  FourKMesh fk(tetrahedron());
  fk.validate();
  for (HalfEdgeId h = 0; h < fk.num_half_edges(); ++h) {
    EXPECT_FALSE(fk.can_swap(h)) << "the opposite corners of a tetrahedron edge are always joined";
    EXPECT_THROW(fk.swap(h), InvalidInput);
  }
  fk.validate();
}

TEST(FourKMesh, BadInputThrowsNamingTheElement) {
  TriMesh empty;
  EXPECT_THROW(FourKMesh{empty}, InvalidInput);
  TriMesh degenerate = square();
  degenerate.indices[4] = 0;  // face 1 = (0, 0, 3)
  try {
    FourKMesh fk(degenerate);
    FAIL() << "degenerate face accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 1u);
    EXPECT_NE(std::string(e.what()).find("face 1"), std::string::npos) << e.what();
  }
  TriMesh fin = square();  // a third face on edge 0-2: non-manifold
  fin.positions.push_back({0.5f, 0.5f, 1.0f});
  fin.indices.insert(fin.indices.end(), {0, 2, 4});
  try {
    FourKMesh fk(fin);
    FAIL() << "non-manifold edge accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 2u);
    EXPECT_NE(std::string(e.what()).find("non-manifold"), std::string::npos) << e.what();
  }
  TriMesh flipped = square();
  std::swap(flipped.indices[4], flipped.indices[5]);  // (0, 3, 2) uses 2->0 like face 0
  try {
    FourKMesh fk(flipped);
    FAIL() << "inconsistent orientation accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("orientation"), std::string::npos) << e.what();
  }
  TriMesh twice = square();
  twice.indices.insert(twice.indices.end(), {0, 3, 1});
  twice.indices.insert(twice.indices.end(), {2, 1, 0});  // same vertices as face 0, reversed
  EXPECT_THROW(FourKMesh{twice}, InvalidInput);
  TriMesh out_of_range = square();
  out_of_range.indices[5] = 9;
  EXPECT_THROW(FourKMesh{out_of_range}, InvalidInput);

  FourKMesh fk(square());
  EXPECT_THROW(fk.split(6, {0, 0, 0}), InvalidInput);  // out of range
  EXPECT_THROW(fk.split(0, {NAN, 0, 0}), InvalidInput);
  EXPECT_THROW(fk.split(0, {0, 0, 0}, -1.0f), InvalidInput);
  fk.split(0, {0.5f, 0.0f, 0.0f});
  EXPECT_THROW(fk.split(1, {0, 0, 0}), InvalidInput);  // face 0 is no longer current
  EXPECT_THROW(fk.swap(1), InvalidInput);
  EXPECT_THROW(fk.set_error(3, 1.0f), InvalidInput);  // face 1 is current: no modification
  EXPECT_THROW(fk.set_error(0, -2.0f), InvalidInput);
  fk.validate();
}

// Random splits and swaps on a closed torus; invariants after every operation; the paper's relations
// between faces and modifications; the Mt of the result against the structure.
TEST(FourKMesh, RandomSplitsAndSwapsKeepInvariants) {
  std::mt19937 rng(7);
  const TriMesh base = torus(6, 5);
  FourKMesh fk(base);
  std::set<Tri> ever;  // every face ever created, unoriented, to avoid redundant swaps
  auto key = [](Tri t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  for (FaceId f = 0; f < fk.num_faces(); ++f) ever.insert(key(fk.face(f)));
  std::size_t swaps = 0, splits = 0, border_splits = 0;
  for (int step = 0; step < 300; ++step) {
    const std::vector<FaceId> cur = fk.current_faces();
    const FaceId f = cur[std::uniform_int_distribution<std::size_t>(0, cur.size() - 1)(rng)];
    const HalfEdgeId h = FourKMesh::edge(f, std::uniform_int_distribution<int>(0, 2)(rng));
    bool swapped = false;
    if (rng() % 3 == 0 && fk.can_swap(h)) {
      const VertexId a = fk.point(h), b = fk.target(h), c = fk.point(FourKMesh::prev(h)),
                     d = fk.point(FourKMesh::prev(fk.mate(h)));
      if (!ever.count(key({d, c, a})) && !ever.count(key({c, d, b}))) {
        fk.swap(h, 0.1f);
        ever.insert(key({d, c, a}));
        ever.insert(key({c, d, b}));
        ++swaps;
        swapped = true;
      }
    }
    if (!swapped) {
      const glm::vec3 p = (fk.position(fk.point(h)) + fk.position(fk.target(h))) * 0.5f;
      if (fk.mate(h) == kInvalid) ++border_splits;
      fk.split(h, p, 1.0f / float(step + 1));
      ++splits;
      for (FaceId c = static_cast<FaceId>(fk.num_faces() - (fk.mate(fk.modifications().back()) == kInvalid ? 2 : 4));
           c < fk.num_faces(); ++c)
        ever.insert(key(fk.face(c)));
    }
    fk.validate();
  }
  EXPECT_GT(swaps, 20u);
  EXPECT_GT(splits, 150u);
  EXPECT_EQ(border_splits, 0u);  // a torus has no border
  EXPECT_EQ(fk.num_modifications(), swaps + splits);
  EXPECT_EQ(fk.num_current_faces(), base.num_faces() + 2 * splits);
  const TriMesh fine = fk.current_mesh();
  EXPECT_EQ(expect_conforming(fine), 0u);
  EXPECT_EQ(euler(fine), 0);  // still a torus

  // successor / predecessor / pre-image / image agree (section 7.1).
  for (FaceId f = 0; f < fk.num_faces(); ++f) {
    const HalfEdgeId s = fk.successor(f);
    if (s != kInvalid) {
      const FourKFaceSet pre = fk.pre_image(s);
      EXPECT_NE(std::find(pre.begin(), pre.end(), f), pre.end());
    }
    const HalfEdgeId p = fk.predecessor(f);
    if (p != kInvalid) {
      const FourKFaceSet img = fk.image(p);
      EXPECT_NE(std::find(img.begin(), img.end(), f), img.end()) << "face " << f;
      EXPECT_EQ(fk.modification_type(p) == NodeKind::kSwap, img.size == 2 && fk.mate(p) != kInvalid);
    }
  }

  FourKMtMap map;
  const Mt mt = fk.to_mt({}, &map);
  mt.validate();
  ASSERT_EQ(mt.num_nodes(), fk.num_modifications() + 1);
  ASSERT_EQ(mt.num_faces(), fk.num_faces());
  std::size_t mt_swaps = 0;
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    const HalfEdgeId e = map.node_edge[n];
    EXPECT_EQ(mt.kind(n), fk.modification_type(e));
    mt_swaps += mt.kind(n) == NodeKind::kSwap;
    std::vector<FaceId> a, b;
    for (FaceId f : mt.pre_image(n)) a.push_back(map.face[f]);
    for (FaceId f : fk.pre_image(e)) b.push_back(f);
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b);
    std::vector<FaceId> c, d;
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) c.push_back(map.face[f]);
    for (FaceId f : fk.image(e)) d.push_back(f);
    std::sort(c.begin(), c.end());
    std::sort(d.begin(), d.end());
    EXPECT_EQ(c, d);
  }
  EXPECT_EQ(mt_swaps, swaps);

  // Refine all = the current mesh; coarsen all = the base; random walks stay conforming.
  MtFront front(mt);
  for (NodeId n = 1; n < mt.num_nodes(); ++n) front.apply(n);
  front.validate();
  std::vector<VertexId> vid;
  const TriMesh all = front.to_mesh(nullptr, &vid);
  std::multiset<Tri> got;
  for (std::size_t f = 0; f < all.num_faces(); ++f)
    got.insert(canonical({vid[all.corner(f, 0)], vid[all.corner(f, 1)], vid[all.corner(f, 2)]}));
  EXPECT_EQ(got, triangles(fine));
  for (NodeId n = static_cast<NodeId>(mt.num_nodes()); n-- > 1;) front.undo(n);
  front.validate();
  EXPECT_EQ(front.num_faces(), base.num_faces());
  for (int walk = 0; walk < 200; ++walk) {
    const auto n = static_cast<NodeId>(1 + rng() % (mt.num_nodes() - 1));
    if (rng() % 2) front.refine(n);
    else front.coarsen(n);
    if (walk % 20 == 0) {
      front.validate();
      const TriMesh m = front.to_mesh();
      EXPECT_EQ(expect_conforming(m), 0u);
      EXPECT_EQ(euler(m), 0);
    }
  }
}

// A disc with a border: border splits (1 -> 2) mixed with interior splits and swaps.
TEST(FourKMesh, BorderAndInteriorOperationsOnAnOpenMesh) {
  TriMesh m;
  m.positions.push_back({0, 0, 0});
  const int k = 6;
  for (int i = 0; i < k; ++i) m.positions.push_back({std::cos(1.047f * float(i)), std::sin(1.047f * float(i)), 0.0f});
  for (int i = 0; i < k; ++i) m.indices.insert(m.indices.end(), {0, Index(1 + i), Index(1 + (i + 1) % k)});
  FourKMesh fk(m);
  std::mt19937 rng(3);
  std::set<Tri> ever;
  auto key = [](Tri t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  for (FaceId f = 0; f < fk.num_faces(); ++f) ever.insert(key(fk.face(f)));
  std::size_t lone = 0, swaps = 0;
  for (int step = 0; step < 150; ++step) {
    std::vector<HalfEdgeId> border, all;
    for (FaceId f : fk.current_faces())
      for (int j = 0; j < 3; ++j) {
        all.push_back(FourKMesh::edge(f, j));
        if (fk.mate(FourKMesh::edge(f, j)) == kInvalid) border.push_back(FourKMesh::edge(f, j));
      }
    const HalfEdgeId h = step % 3 == 0 ? border[rng() % border.size()] : all[rng() % all.size()];
    if (step % 3 == 1 && fk.can_swap(h)) {
      const VertexId a = fk.point(h), b = fk.target(h), c = fk.point(FourKMesh::prev(h)),
                     d = fk.point(FourKMesh::prev(fk.mate(h)));
      if (!ever.count(key({d, c, a})) && !ever.count(key({c, d, b}))) {
        fk.swap(h, 1.0f);
        ever.insert(key({d, c, a}));
        ever.insert(key({c, d, b}));
        ++swaps;
        fk.validate();
        continue;
      }
    }
    lone += fk.mate(h) == kInvalid;
    fk.split(h, (fk.position(fk.point(h)) + fk.position(fk.target(h))) * 0.5f, 1.0f);
    for (FaceId c = static_cast<FaceId>(fk.num_faces() - (fk.mate(fk.modifications().back()) == kInvalid ? 2 : 4));
         c < fk.num_faces(); ++c)
      ever.insert(key(fk.face(c)));
    fk.validate();
  }
  EXPECT_GT(lone, 40u);
  EXPECT_GT(swaps, 5u);
  const TriMesh fine = fk.current_mesh();
  expect_conforming(fine);
  EXPECT_EQ(euler(fine), 1);
  const Mt mt = fk.to_mt();
  mt.validate();
  MtFront front(mt);
  for (NodeId n = 1; n < mt.num_nodes(); ++n) front.apply(n);
  front.validate();
  EXPECT_EQ(front.num_faces(), fine.num_faces());
}

#if defined(VARMESH_ENABLE_ASSERTS) || !defined(NDEBUG)
// The unchecked accessors check their documented preconditions in debug and sanitizer builds.
TEST(FourKMeshDeathTest, UncheckedAccessorsAssert) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const FourKMesh k(make_icosphere(0));
  const Index far = 1u << 30;
  EXPECT_DEATH(k.point(far), "precondition");
  EXPECT_DEATH(k.mate(far), "precondition");
  EXPECT_DEATH(k.face(far), "precondition");
  EXPECT_DEATH(k.is_current(far), "precondition");
  EXPECT_DEATH(k.position(far), "precondition");
}
#endif

}  // namespace
}  // namespace varmesh
