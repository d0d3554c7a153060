// VertexHierarchy as a value: copies, moves, and the empty hierarchy a default construction or a move
// leaves behind.
#include "pm/vertex_hierarchy.hpp"

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/query.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"

namespace varmesh {
namespace {

static_assert(std::is_nothrow_default_constructible_v<VertexHierarchy>);
static_assert(std::is_nothrow_move_constructible_v<VertexHierarchy> && std::is_nothrow_move_assignable_v<VertexHierarchy>);

// Every observable of the empty hierarchy, and that what reads a hierarchy takes it.
void expect_empty(const VertexHierarchy& h) {
  EXPECT_EQ(h.num_leaves(), 0u);
  EXPECT_EQ(h.num_nodes(), 0u);
  EXPECT_EQ(h.num_collapses(), 0u);
  EXPECT_EQ(h.num_faces(), 0u);
  EXPECT_EQ(h.num_roots(), 0u);
  EXPECT_EQ(h.max_depth(), 0);
  EXPECT_FALSE(h.has_colors());
  EXPECT_TRUE(h.positions().empty());
  EXPECT_TRUE(h.face_corners().empty());
  EXPECT_TRUE(h.base_faces().empty());
  EXPECT_TRUE(h.leaf_to_input().empty());
  EXPECT_TRUE(h.face_to_input().empty());
  EXPECT_EQ(h.repair_report().input_vertices, 0u);
  EXPECT_EQ(h.repair_report().input_faces, 0u);
  EXPECT_EQ(h.memory_bytes(), 0u);
  EXPECT_FALSE(h.is_leaf(0));
  EXPECT_NO_THROW(h.validate());
  EXPECT_THROW(encode_vertex_hierarchy(h), InvalidInput);  // "never built"
  EXPECT_THROW(mesh_after_collapses(h, 1), InvalidInput);
  EXPECT_EQ(mesh_after_collapses(h, 0).num_faces(), 0u);
  SrMesh sr(h);
  Query q;
  extract(sr, q);
  EXPECT_EQ(sr.num_faces(), 0u);
  sr.validate();
}

TEST(VertexHierarchy, DefaultIsEmpty) { expect_empty(VertexHierarchy{}); }

// A moved-from hierarchy is the empty one (the implicit move left num_leaves() at the old count over
// emptied arrays: 96 leaves and no node), and the moved-to one is the original, byte for byte in its file.
TEST(VertexHierarchy, MovedFromIsEmptyAndMovedToIsTheOriginal) {
  const TriMesh m = make_torus(12, 8);
  const VertexHierarchy reference = build_vertex_hierarchy(m);
  const std::vector<std::uint8_t> bytes = encode_vertex_hierarchy(reference);

  VertexHierarchy a = reference;  // a copy
  EXPECT_EQ(encode_vertex_hierarchy(a), bytes);
  VertexHierarchy b(std::move(a));
  expect_empty(a);
  EXPECT_EQ(encode_vertex_hierarchy(b), bytes);
  b.validate();

  VertexHierarchy c = build_vertex_hierarchy(make_icosphere(2));
  c = std::move(b);  // over a hierarchy with arrays of its own
  expect_empty(b);
  EXPECT_EQ(encode_vertex_hierarchy(c), bytes);
  a = std::move(c);  // into a moved-from one
  expect_empty(c);
  EXPECT_EQ(encode_vertex_hierarchy(a), bytes);
  b = a;  // a copy into a moved-from one
  EXPECT_EQ(encode_vertex_hierarchy(b), bytes);

  SrMesh sr(a);
  sr.refine_all();
  sr.validate();
  EXPECT_EQ(sr.num_faces(), reference.num_faces());
}

}  // namespace
}  // namespace varmesh
