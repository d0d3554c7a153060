// MtBuilder's checks of the Multi-Triangulation definition, and the renumbering it does.
#include <gtest/gtest.h>

#include <cmath>
#include <ranges>
#include <string>
#include <utility>
#include <vector>

#include "multitri/errors.hpp"
#include "multitri/mt.hpp"

namespace varmesh {
namespace {

// A unit square split by its diagonal (base), one split node on the diagonal, one swap node on an edge of
// the split image is impossible (different edges), so: square, split of the diagonal.
struct Square {
  MtBuilder b;
  VertexId v0, v1, v2, v3, m;
  FaceId t0, t1, c[4];
  Square() {
    v0 = b.add_vertex({0, 0, 0});
    v1 = b.add_vertex({1, 0, 0});
    v2 = b.add_vertex({1, 1, 0});
    v3 = b.add_vertex({0, 1, 0});
    m = b.add_vertex({0.5f, 0.5f, 0.25f});
    t0 = b.add_face(v0, v1, v2);
    t1 = b.add_face(v0, v2, v3);
    c[0] = b.add_face(m, v0, v1);
    c[1] = b.add_face(m, v1, v2);
    c[2] = b.add_face(m, v2, v3);
    c[3] = b.add_face(m, v3, v0);
    const FaceId base[] = {t0, t1};
    b.set_base(base);
  }
};

std::string message_of(MtBuilder&& b) {
  try {
    std::move(b).build();
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(Mt, SplitNodeBuildsAndValidates) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.25f);
  const Mt mt = std::move(s.b).build();
  mt.validate();
  EXPECT_EQ(mt.num_nodes(), 2u);
  EXPECT_EQ(mt.num_faces(), 6u);
  EXPECT_EQ(mt.kind(1), NodeKind::kSplit);
  EXPECT_EQ(mt.image_size(0), 2u);
  EXPECT_EQ(mt.image_size(1), 4u);
  ASSERT_EQ(mt.parents(1).size(), 1u);
  EXPECT_EQ(mt.parents(1).front(), 0u);
  EXPECT_FLOAT_EQ(mt.bound(1).error, 0.25f);
  // The bounding sphere contains every vertex the node touches.
  for (VertexId v = 0; v < mt.num_vertices(); ++v)
    EXPECT_LE(glm::length(mt.position(v) - mt.bound(1).center), mt.bound(1).radius);
}

TEST(Mt, FacesThatNoNodeCreatesAreRefused) {
  Square s;
  const FaceId a = s.b.add_face(s.v0, s.v1, s.v3), b2 = s.b.add_face(s.v1, s.v2, s.v3);
  const FaceId removed[] = {s.t0, s.t1}, created[] = {a, b2};
  s.b.add_node(NodeKind::kSwap, removed, created, 0.0f);
  // c[] faces were added but are created by nobody: the builder must say so.
  EXPECT_NE(message_of(std::move(s.b)).find("created by no node"), std::string::npos);
}

TEST(Mt, SwapAloneBuilds) {
  MtBuilder b;
  const VertexId v0 = b.add_vertex({0, 0, 0}), v1 = b.add_vertex({1, 0, 0}), v2 = b.add_vertex({1, 1, 0}),
                 v3 = b.add_vertex({0, 1, 0});
  const FaceId t0 = b.add_face(v0, v1, v2), t1 = b.add_face(v0, v2, v3);
  const FaceId s0 = b.add_face(v0, v1, v3), s1 = b.add_face(v1, v2, v3);
  const FaceId base[] = {t0, t1}, removed[] = {t0, t1}, created[] = {s0, s1};
  b.set_base(base);
  b.add_node(NodeKind::kSwap, removed, created, 0.0f);
  const Mt mt = std::move(b).build();
  mt.validate();
  EXPECT_EQ(mt.kind(1), NodeKind::kSwap);
}

TEST(Mt, RejectsFaceRemovedTwice) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.0f);
  const FaceId again[] = {s.t0};
  const FaceId extra = s.b.add_face(s.v0, s.v1, s.m);
  const FaceId created[] = {extra};
  s.b.add_node(NodeKind::kGeneric, again, created, 0.0f);
  const std::string msg = message_of(std::move(s.b));
  EXPECT_NE(msg.find("node 2"), std::string::npos) << msg;
  EXPECT_NE(msg.find("already removed"), std::string::npos) << msg;
}

TEST(Mt, RejectsFaceCreatedTwice) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.0f);
  const FaceId r2[] = {s.c[0]};
  const FaceId c2[] = {s.c[1]};
  s.b.add_node(NodeKind::kGeneric, r2, c2, 0.0f);
  const std::string msg = message_of(std::move(s.b));
  EXPECT_NE(msg.find("already created"), std::string::npos) << msg;
}

TEST(Mt, RejectsWrongSplitArity) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  const FaceId created[] = {s.c[0], s.c[1], s.c[2]};
  s.b.add_node(NodeKind::kSplit, removed, created, 0.0f);
  EXPECT_NE(message_of(std::move(s.b)).find("a split must replace"), std::string::npos);
}

TEST(Mt, RejectsBoundaryChange) {
  // Removing t0 only and creating two faces that cover the whole square changes the boundary.
  Square s;
  const FaceId removed[] = {s.t0};
  const FaceId created[] = {s.c[0], s.c[1]};
  s.b.add_node(NodeKind::kGeneric, removed, created, 0.0f);
  const FaceId r2[] = {s.t1};
  const FaceId c2[] = {s.c[2], s.c[3]};
  s.b.add_node(NodeKind::kGeneric, r2, c2, 0.0f);
  const std::string msg = message_of(std::move(s.b));
  EXPECT_NE(msg.find("oriented boundary"), std::string::npos) << msg;
}

// A border edge may only come back subdivided. Any change of border edges passed before: two nodes could
// each rewrite an isolated triangle so that both new faces hold the directed edge 1 -> 6, and the front
// with both applied was not conforming (found by a review).
TEST(Mt, RejectsBorderChangesOtherThanSubdivision) {
  MtBuilder b;
  for (int i = 0; i < 8; ++i) b.add_vertex({float(i % 3), float(i / 3), float(i) * 0.1f});
  const FaceId t1 = b.add_face(0, 1, 2), t2 = b.add_face(3, 4, 5);
  const FaceId a = b.add_face(0, 1, 6), c = b.add_face(1, 6, 7);
  const FaceId base[] = {t1, t2};
  b.set_base(base);
  const FaceId ra[] = {t1}, ca[] = {a}, rb[] = {t2}, cb[] = {c};
  b.add_node(NodeKind::kGeneric, ra, ca, 0.5f);
  b.add_node(NodeKind::kGeneric, rb, cb, 0.5f);
  const std::string msg = message_of(std::move(b));
  EXPECT_NE(msg.find("other than by subdividing edge"), std::string::npos) << msg;
}

// A node's image may bring in only vertices of its own: an image whose centre is a vertex of another part of
// the base keeps the pre-image's boundary and every other rule, yet glues two patches at that vertex in
// every front that applies it (helper-52 found it in re-sealed .vrm files).
TEST(Mt, RejectsImagesThatBorrowAVertex) {
  for (const bool borrow_from_node : {false, true}) {
    MtBuilder b;
    for (int i = 0; i < 4; ++i) b.add_vertex({float(i == 1 || i == 2), float(i >= 2), 0.0f});  // square 0..3
    for (int i = 0; i < 3; ++i) b.add_vertex({5.0f + float(i == 1), float(i == 2), 0.0f});  // triangle 4..6
    b.add_vertex({5.5f, 0.3f, 0.0f});                                                   // 7: inside it
    const FaceId t0 = b.add_face(0, 1, 2), t1 = b.add_face(0, 2, 3), far = b.add_face(4, 5, 6);
    const FaceId base[] = {t0, t1, far};
    b.set_base(base);
    if (borrow_from_node) {  // vertex 7 first comes in with a split of the far triangle
      const FaceId r[] = {far}, c[] = {b.add_face(4, 5, 7), b.add_face(5, 6, 7), b.add_face(6, 4, 7)};
      b.add_node(NodeKind::kGeneric, r, c, 0.1f);
    }
    const Index centre = borrow_from_node ? 7 : 5;
    const FaceId r[] = {t0, t1};
    const FaceId c[] = {b.add_face(0, 1, centre), b.add_face(1, 2, centre), b.add_face(2, 3, centre), b.add_face(3, 0, centre)};
    b.add_node(NodeKind::kSplit, r, c, 0.1f);
    const std::string msg = message_of(std::move(b));
    EXPECT_NE(msg.find("brings in vertex " + std::to_string(centre)), std::string::npos) << msg;
    EXPECT_NE(msg.find(borrow_from_node ? "node 1 brings in" : "the base mesh uses"), std::string::npos) << msg;
  }
}

// A kind outside the enumeration built, and the Mt then failed its own file format.
TEST(Mt, RejectsUnknownNodeKind) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  EXPECT_THROW(s.b.add_node(static_cast<NodeKind>(7), removed, s.c, 0.0f), InvalidInput);
}

// Coordinates near float's limit: the packed bounds' frame step (hi - lo) / 65535 overflowed and decoded
// every centre as NaN.
TEST(Mt, BoundsOfHugeCoordinatesStayFinite) {
  MtBuilder b;
  const float big = 3.0e38f;
  b.add_vertex({-big, -big, 0});
  b.add_vertex({big, -big, 0});
  b.add_vertex({0, big, 0});
  b.add_vertex({0, -big, 0.5f});
  const FaceId t = b.add_face(0, 1, 2);
  const FaceId base[] = {t};
  b.set_base(base);
  const FaceId c0 = b.add_face(0, 3, 2), c1 = b.add_face(3, 1, 2);
  const FaceId removed[] = {t}, created[] = {c0, c1};
  b.add_node(NodeKind::kSplit, removed, created, 1.0f);
  const Mt mt = std::move(b).build();
  for (NodeId n = 0; n < mt.num_nodes(); ++n) {
    const ElementBound e = mt.bound(n);
    EXPECT_TRUE(std::isfinite(e.center.x) && std::isfinite(e.center.y) && std::isfinite(e.center.z)) << "node " << n;
    EXPECT_FALSE(std::isnan(e.radius)) << "node " << n;
    // The faces lie near the plane z = 0, facing +z: a NaN normal (the float cross product overflowed) made
    // a NaN cone, packed through undefined float-to-integer casts (helper-55).
    if (!e.cone.is_full()) {
      EXPECT_TRUE(std::isfinite(e.cone.axis.x) && std::isfinite(e.cone.axis.y) && std::isfinite(e.cone.axis.z)) << "node " << n;
      EXPECT_GT(e.cone.axis.z, 0.9f) << "node " << n;
    }
  }
}

TEST(Mt, RejectsRedundantFace) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.0f);
  // A face with the same vertices as c[0] created by a swap of c[0], c[1]: redundant.
  const FaceId dup = s.b.add_face(s.v0, s.v1, s.m);
  const FaceId other = s.b.add_face(s.m, s.v1, s.v2);
  const FaceId r2[] = {s.c[0], s.c[1]}, c2[] = {dup, other};
  s.b.add_node(NodeKind::kSwap, r2, c2, 0.0f);
  const FaceId first = s.c[0];
  const std::string msg = message_of(std::move(s.b));
  EXPECT_NE(msg.find("redundant"), std::string::npos) << msg;
  // Both faces are named, the later one first.
  EXPECT_NE(msg.find("creates face " + std::to_string(dup) + " with the same vertices as face " + std::to_string(first)),
            std::string::npos)
      << msg;
}

// The same check on a larger structure, the repeat in another winding and far from the first face: a fan of
// splits around one vertex, then a node that re-creates an early face reversed.
TEST(Mt, RejectsRedundantFaceInALargeStructure) {
  MtBuilder b;
  constexpr int kRim = 64;
  const VertexId centre = b.add_vertex({0, 0, 0});
  std::vector<VertexId> rim;
  for (int i = 0; i < kRim; ++i) {
    const float a = 6.2831853f * static_cast<float>(i) / kRim;
    rim.push_back(b.add_vertex({std::cos(a), std::sin(a), 0.0f}));
  }
  std::vector<FaceId> base;
  for (int i = 0; i < kRim; ++i) base.push_back(b.add_face(centre, rim[static_cast<std::size_t>(i)], rim[static_cast<std::size_t>((i + 1) % kRim)]));
  b.set_base(base);
  // Generic node: replace faces 0 and 1 (centre, r0, r1), (centre, r1, r2) by (r0, r1, r2), (centre, r0, r2)...
  const FaceId g0 = b.add_face(rim[0], rim[1], rim[2]), g1 = b.add_face(centre, rim[0], rim[2]);
  const FaceId rem[] = {base[0], base[1]}, cre[] = {g0, g1};
  b.add_node(NodeKind::kGeneric, rem, cre, 0.0f);
  // ...and a later node that brings back face 5's vertex triple in the other winding.
  const FaceId again = b.add_face(rim[6], rim[5], centre), other = b.add_face(centre, rim[5], rim[7]);
  const FaceId rem2[] = {base[5], base[6]}, cre2[] = {again, other};
  b.add_node(NodeKind::kGeneric, rem2, cre2, 0.0f);
  const FaceId first = base[5];
  const std::string msg = message_of(std::move(b));
  EXPECT_NE(msg.find("creates face " + std::to_string(again) + " with the same vertices as face " + std::to_string(first)),
            std::string::npos)
      << msg;
}

// An oriented surface uses each directed edge once. The base mesh and every image are checked for it: a
// node whose image held a directed edge twice kept the same oriented boundary, so it passed, and its front
// was no conforming mesh.
TEST(Mt, RejectsARepeatedDirectedEdge) {
  {
    MtBuilder b;
    const VertexId v0 = b.add_vertex({0, 0, 0}), v1 = b.add_vertex({1, 0, 0}), v2 = b.add_vertex({0, 1, 0}),
                   v3 = b.add_vertex({0, -1, 0});
    const FaceId base[] = {b.add_face(v0, v1, v2), b.add_face(v0, v1, v3)};  // v0 -> v1 twice
    b.set_base(base);
    const std::string msg = message_of(std::move(b));
    EXPECT_NE(msg.find("the base mesh uses the directed edge"), std::string::npos) << msg;
  }
  {
    // The four-face split of the square plus a closed tetrahedron on (m, v1, w, z): the tetrahedron's
    // edges pair among themselves, so the boundary is still the square's, but m -> v1 is used twice.
    Square s;
    const VertexId w = s.b.add_vertex({1, 0, 1}), z = s.b.add_vertex({0.5f, 0.5f, 1});
    std::vector<FaceId> created(s.c, s.c + 4);
    for (const auto& t : std::vector<std::array<VertexId, 3>>{{s.m, s.v1, w}, {s.m, w, z}, {s.m, z, s.v1}, {s.v1, z, w}})
      created.push_back(s.b.add_face(t[0], t[1], t[2]));
    const FaceId removed[] = {s.t0, s.t1};
    s.b.add_node(NodeKind::kGeneric, removed, created, 0.0f);
    const std::string msg = message_of(std::move(s.b));
    EXPECT_NE(msg.find("its image uses the directed edge"), std::string::npos) << msg;
  }
}

TEST(Mt, RejectsCycle) {
  // Two generic nodes that each remove a face the other creates.
  MtBuilder b;
  const VertexId v0 = b.add_vertex({0, 0, 0}), v1 = b.add_vertex({1, 0, 0}), v2 = b.add_vertex({0, 1, 0}),
                 v3 = b.add_vertex({1, 1, 0}), v4 = b.add_vertex({2, 0, 0});
  const FaceId base = b.add_face(v0, v1, v2);
  const FaceId f1 = b.add_face(v1, v3, v2), f2 = b.add_face(v1, v4, v3);
  const FaceId f3 = b.add_face(v0, v4, v2);
  const FaceId bases[] = {base};
  b.set_base(bases);
  const FaceId r1[] = {f1}, c1[] = {f2};
  const FaceId r2[] = {f2}, c2[] = {f1, f3};
  b.add_node(NodeKind::kGeneric, r1, c1, 0.0f);
  b.add_node(NodeKind::kGeneric, r2, c2, 0.0f);
  MtBuilder::Options o;
  o.check_geometry = false;
  std::string msg;
  try {
    std::move(b).build(o);
  } catch (const InvalidInput& e) {
    msg = e.what();
  }
  EXPECT_TRUE(msg.find("cycle") != std::string::npos || msg.find("no parent") != std::string::npos) << msg;
}

TEST(Mt, RenumbersParentsFirst) {
  // Nodes added children-first must come out parents-first, with the maps given back.
  Square s;
  // Second-level split of the edge v0-v1 of child c[0]... c[0] is a border face: a 1 -> 2 split.
  const VertexId e = s.b.add_vertex({0.5f, 0.0f, 0.0f});
  const FaceId g0 = s.b.add_face(e, s.m, s.v0), g1 = s.b.add_face(e, s.v1, s.m);
  const FaceId r2[] = {s.c[0]}, c2[] = {g0, g1};
  const NodeId child = s.b.add_node(NodeKind::kSplit, r2, c2, 0.0f);
  const FaceId removed[] = {s.t0, s.t1};
  const NodeId parent = s.b.add_node(NodeKind::kSplit, removed, s.c, 0.0f);
  std::vector<NodeId> node_map;
  const Mt mt = std::move(s.b).build({}, &node_map);
  mt.validate();
  ASSERT_EQ(node_map.size(), 3u);
  EXPECT_EQ(node_map[1], parent);
  EXPECT_EQ(node_map[2], child);
  EXPECT_EQ(mt.children(1).size(), 1u);
  // Saturation: the parent's sphere contains the child's.
  const auto& pb = mt.bound(1);
  const auto& cb = mt.bound(2);
  EXPECT_LE(glm::length(cb.center - pb.center) + cb.radius, pb.radius * 1.0001f);
}


// The derived relations are plain forward ranges, written without std::ranges::view_interface (which
// clang 14 cannot instantiate with libstdc++ 12; the public_headers_compile_alone test compiles mt.hpp
// alone with the configured compiler).
static_assert(std::ranges::forward_range<Mt::ParentRange>);
static_assert(std::ranges::forward_range<Mt::ChildRange>);
// They point at their Mt: not available on a temporary one.
template <class M>
concept HasParents = requires(M&& mt) { std::forward<M>(mt).parents(NodeId{0}); };
template <class M>
concept HasChildren = requires(M&& mt) { std::forward<M>(mt).children(NodeId{0}); };
static_assert(HasParents<const Mt&> && HasChildren<const Mt&>);
static_assert(!HasParents<Mt> && !HasChildren<Mt>);

TEST(Mt, ParentAndChildRangesAnswerEmptyFrontAndSize) {
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.25f);
  const Mt mt = std::move(s.b).build();
  EXPECT_TRUE(mt.parents(0).empty());
  EXPECT_EQ(mt.parents(0).size(), 0u);
  EXPECT_FALSE(mt.children(0).empty());
  EXPECT_TRUE(static_cast<bool>(mt.children(0)));
  EXPECT_EQ(mt.children(0).size(), 1u);
  EXPECT_EQ(mt.children(0).front(), 1u);
  EXPECT_TRUE(mt.children(1).empty());
  EXPECT_FALSE(static_cast<bool>(mt.children(1)));
  const auto parents = mt.parents(1);
  const std::vector<NodeId> listed(parents.begin(), parents.end());
  EXPECT_EQ(listed, std::vector<NodeId>{0});
  EXPECT_EQ(std::ranges::distance(mt.children(0)), 1);
}

// The cone table is a constant expression: a static initialiser of any translation unit may decode bounds.
constinit const float kConeCosOfRightAngle = Mt::cone_cos(254);
static_assert(Mt::cone_cos(0) == 1.0f);
static_assert(Mt::cone_cos(Mt::kFullConeCode) == -1.0f);

TEST(Mt, ConeCosTableIsTheCosineOfEachCode) {
  const double unit = std::acos(-1.0) / 2.0 / 254.0;
  for (unsigned i = 0; i < 254; ++i)
    EXPECT_EQ(Mt::cone_cos(i), static_cast<float>(std::cos(i * unit))) << "code " << i;
  EXPECT_EQ(kConeCosOfRightAngle, 0.0f);  // 90 degrees exactly (std::cos of the double pi/2 gives 6e-17)
  for (unsigned i = 0; i + 1 < 255; ++i) EXPECT_GT(Mt::cone_cos(i), Mt::cone_cos(i + 1)) << "code " << i;
}

#if defined(VARMESH_ENABLE_ASSERTS) || !defined(NDEBUG)
TEST(MtDeathTest, UncheckedAccessorsAssertTheirPrecondition) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Square s;
  const FaceId removed[] = {s.t0, s.t1};
  s.b.add_node(NodeKind::kSplit, removed, s.c, 0.25f);
  const Mt mt = std::move(s.b).build();
  const auto nn = static_cast<NodeId>(mt.num_nodes());
  const auto nf = static_cast<FaceId>(mt.num_faces());
  EXPECT_DEATH((void)mt.bound(nn), "precondition violated");
  EXPECT_DEATH((void)mt.pre_image(nn), "precondition violated");
  EXPECT_DEATH((void)mt.children(nn), "precondition violated");
  EXPECT_DEATH((void)mt.face(nf), "precondition violated");
  EXPECT_DEATH((void)mt.destroyer(nf), "precondition violated");
  EXPECT_DEATH((void)mt.position(static_cast<VertexId>(mt.num_vertices())), "precondition violated");
  EXPECT_DEATH((void)mt.children(1).front(), "precondition violated");
}
#endif

}  // namespace
}  // namespace varmesh
