// Reference construction of the mesh an active vertex set defines (Kim-Lee 2001, sections 3.2 and 4.2),
// deliberately independent of SrMesh: it reads only the tree and the original faces.
#include "pm/dual_pieces.hpp"

#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

std::vector<Index> active_ancestors(const VertexHierarchy& h, std::span<const std::uint8_t> active) {
  if (active.size() != h.num_nodes()) throw InvalidInput("active_ancestors: one flag per node expected");
  std::vector<Index> anc(h.num_nodes(), kInvalid);
  for (std::size_t v = h.num_nodes(); v-- > 0;) {
    const Index p = h.parent(static_cast<Index>(v));
    const Index above = p == kInvalid ? kInvalid : anc[p];
    if (active[v]) {
      if (above != kInvalid)
        throw InvalidInput("active_ancestors: node " + std::to_string(v) + " and its ancestor " + std::to_string(above) + " are both active");
      anc[v] = static_cast<Index>(v);
    } else {
      anc[v] = above;
    }
  }
  anc.resize(h.num_leaves());
  for (std::size_t l = 0; l < anc.size(); ++l)
    if (anc[l] == kInvalid) throw InvalidInput("active_ancestors: leaf " + std::to_string(l) + " has no active ancestor");
  return anc;
}

std::vector<DualPieceFace> dual_piece_mesh(const VertexHierarchy& h, std::span<const Index> leaf_ancestor) {
  if (leaf_ancestor.size() != h.num_leaves())
    throw InvalidInput("dual_piece_mesh: " + std::to_string(leaf_ancestor.size()) + " ancestors for " +
                       std::to_string(h.num_leaves()) + " leaves");
  for (std::size_t l = 0; l < leaf_ancestor.size(); ++l) {
    const Index a = leaf_ancestor[l];
    // The section 4.3 keys answer "ancestor of l?" in O(1).
    if (a >= h.num_nodes() || !h.is_ancestor_or_self(a, static_cast<Index>(l)))
      throw InvalidInput("dual_piece_mesh: leaf " + std::to_string(l) + ": " + std::to_string(a) +
                         " is not the leaf or one of its ancestors");
  }
  std::vector<DualPieceFace> out;
  for (std::size_t f = 0; f < h.num_faces(); ++f) {
    const auto c = h.face(static_cast<Index>(f));
    const Index a = leaf_ancestor[c[0]], b = leaf_ancestor[c[1]], d = leaf_ancestor[c[2]];
    if (a != b && b != d && a != d) out.push_back({static_cast<Index>(f), {a, b, d}});
  }
  return out;
}

}  // namespace varmesh
