#pragma once
/// The mesh an active vertex set defines, built from the original mesh alone (Kim-Lee sections 3.2, 4.2):
/// the reference that SrMesh is tested against, and the colouring of Figures 10c/11c.
///
/// Given a set of active nodes that partitions the leaves (every leaf has exactly one active ancestor),
/// the dual piece D(v) of an active v is the union of the fundamental dual pieces of its leaves; the mesh's
/// vertices are the active nodes and its faces are the original faces whose three corners have three
/// distinct active ancestors, relabelled by those ancestors.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

/// Active ancestor of every leaf, computed top-down from the active flags (one pass over the nodes, which
/// are numbered children before parents). Throws InvalidInput naming a leaf with no active ancestor or two.
std::vector<Index> active_ancestors(const VertexHierarchy& h, std::span<const std::uint8_t> active);

/// Faces (original face id, relabelled corners) of the mesh the active set defines.
struct DualPieceFace {
  Index original = kInvalid;
  std::array<Index, 3> corners{};
};
/// The faces, in increasing original face id, given each leaf's active ancestor (as active_ancestors()
/// returns: leaf_ancestor[l] is l or an ancestor of l). Throws InvalidInput when leaf_ancestor does not
/// have one entry per leaf or an entry is not an ancestor of its leaf (naming the leaf). O(leaves + faces).
std::vector<DualPieceFace> dual_piece_mesh(const VertexHierarchy& h, std::span<const Index> leaf_ancestor);

}  // namespace varmesh
