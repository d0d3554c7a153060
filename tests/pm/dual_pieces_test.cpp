// The dual-piece reference (pm/dual_pieces.hpp) on its inputs: the active sets and ancestor arrays it
// accepts and those it refuses. Its use as the oracle of SrMesh is in sr_mesh_test.cpp.
#include "pm/dual_pieces.hpp"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"

namespace varmesh {
namespace {

TEST(DualPieces, BaseAndLeavesGiveTheBaseAndOriginalMeshes) {
  const VertexHierarchy h = build_vertex_hierarchy(make_torus(12, 8));
  std::vector<std::uint8_t> leaves(h.num_nodes(), 0), roots(h.num_nodes(), 0);
  for (Index l = 0; l < h.num_leaves(); ++l) leaves[l] = 1;
  for (Index r : h.roots()) roots[r] = 1;
  EXPECT_EQ(dual_piece_mesh(h, active_ancestors(h, leaves)).size(), h.num_faces());
  const std::vector<DualPieceFace> base = dual_piece_mesh(h, active_ancestors(h, roots));
  EXPECT_EQ(base.size(), h.base_faces().size());
  const SrMesh sr(h);
  for (const DualPieceFace& f : base) EXPECT_EQ(sr.face(f.original), f.corners) << f.original;
}

// dual_piece_mesh indexed its array by leaf without looking at its size: two entries for 96 leaves read
// past the end. Now the size and each entry (the leaf or one of its ancestors) are checked.
TEST(DualPieces, RefusesAncestorArraysThatDoNotFitTheHierarchy) {
  const VertexHierarchy h = build_vertex_hierarchy(make_torus(12, 8));
  std::vector<std::uint8_t> roots(h.num_nodes(), 0);
  for (Index r : h.roots()) roots[r] = 1;
  const std::vector<Index> good = active_ancestors(h, roots);
  EXPECT_THROW(dual_piece_mesh(h, std::vector<Index>(2, 0)), InvalidInput);
  EXPECT_THROW(dual_piece_mesh(h, std::vector<Index>(h.num_nodes(), 0)), InvalidInput);
  EXPECT_THROW(dual_piece_mesh(h, std::vector<Index>(h.num_leaves(), kInvalid)), InvalidInput);
  std::vector<Index> bad = good;
  bad[5] = static_cast<Index>(h.num_nodes());  // out of range
  EXPECT_THROW(dual_piece_mesh(h, bad), InvalidInput);
  bad = good;
  bad[5] = good[6] != good[5] ? good[6] : h.roots()[0] == good[5] ? h.roots()[1] : h.roots()[0];  // not its ancestor
  ASSERT_FALSE(h.is_ancestor_or_self(bad[5], 5));
  EXPECT_THROW(dual_piece_mesh(h, bad), InvalidInput);
  EXPECT_NO_THROW(dual_piece_mesh(h, good));
  EXPECT_THROW(active_ancestors(h, std::vector<std::uint8_t>(3, 1)), InvalidInput);
}

}  // namespace
}  // namespace varmesh
