#pragma once
/// Turning a mesh as users have it into the manifold original mesh M^ that a vertex hierarchy partitions
/// (Kim-Lee section 3 needs every dual piece to be a disc or half-disc).
///
/// Steps, each counted in InputRepairReport:
/// 1. unreferenced vertices are dropped;
/// 2. degenerate faces (a repeated corner) are dropped;
/// 3. duplicate faces (same three corners as an earlier face, in any order) are dropped;
/// 4. faces are attached edge by edge; a face that would make an edge carry a third face, or use a directed
///    edge a second time (inconsistent orientation), gets fresh copies of that edge's two corners instead;
/// 5. a vertex whose faces form several fans (a non-manifold vertex: a bow-tie or a cone of sheets) is split
///    into one copy per fan.
/// Afterwards every edge has one or two faces with opposite directions and every vertex one fan: the mesh is
/// an oriented 2-manifold with border. Positions (and colours) of copies equal the original vertex's.
///
/// NonManifoldPolicy::kSplit lets the analysis collapse copies like any vertex (the sheets may then drift
/// apart at coarse levels); kLock marks every copy made in steps 4-5 as locked (never collapsed), so the
/// sheets stay stitched at every level of detail.
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/tri_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

enum class NonManifoldPolicy : std::uint8_t { kSplit, kLock };

struct ManifoldInput {
  std::vector<glm::vec3> positions;  ///< per leaf
  std::vector<glm::vec3> colors;     ///< per leaf, empty when the input had none
  std::vector<Index> faces;          ///< 3 leaves per face, oriented consistently with the input face
  std::vector<Index> leaf_to_input;  ///< leaf -> input vertex
  std::vector<Index> face_to_input;  ///< face -> input face
  std::vector<std::uint8_t> locked;  ///< per leaf: 1 = never collapse
  InputRepairReport report;
};

/// Applies steps 1-5 above. Throws InvalidInput when `policy` is not one of the enumeration's values, when
/// mesh.validate() fails (naming the element) or when no face is left (naming the file-independent reason:
/// "no non-degenerate face"). O(faces log faces).
ManifoldInput make_manifold_input(const TriMesh& mesh, NonManifoldPolicy policy = NonManifoldPolicy::kSplit);

}  // namespace varmesh
