#pragma once
/// Generated shapes for examples, stand-ins for missing data files, and tests.
#include "multitri/tri_mesh.hpp"

namespace varmesh {

/// Unit icosphere: the icosahedron refined `levels` times 1-to-4, new vertices projected on the sphere.
/// 20 * 4^levels faces, counter-clockwise seen from outside. Throws InvalidInput if levels is not in [0, 10].
TriMesh make_icosphere(int levels);

}  // namespace varmesh
