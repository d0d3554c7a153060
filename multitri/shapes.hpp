#pragma once
/// Generated shapes for examples, stand-ins for missing data files, and tests.
#include "multitri/tri_mesh.hpp"

namespace varmesh {

/// Unit icosphere: the icosahedron refined `levels` times 1-to-4, new vertices projected on the sphere.
/// 20 * 4^levels faces, counter-clockwise seen from outside. Throws InvalidInput if levels is not in [0, 10].
TriMesh make_icosphere(int levels);

/// Torus around the z axis (genus 1, closed): n x m vertices on a (u, v) grid, each grid quad split by its
/// (i, j)-(i+1, j+1) diagonal, 2 n m faces, counter-clockwise seen from outside. The tube's radius is
/// minor_radius * (1 + bump * sin 3u) (bump 0: a plain torus). Throws InvalidInput if n or m is below 3,
/// n * m exceeds 2^24, a radius is not finite and positive, bump is not finite, or a position overflows.
TriMesh make_torus(int n, int m, float major_radius = 1.0f, float minor_radius = 0.35f, float bump = 0.0f);

}  // namespace varmesh
