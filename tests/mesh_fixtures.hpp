#pragma once
// Small generated meshes shared by several test suites (tests that must run without ../shared/data).
#include <cmath>

#include "multitri/tri_mesh.hpp"

namespace varmesh::testing {

/// A closed torus (major radius 2, minor 0.7) sampled on an nu x nv grid, each quad cut along the
/// diagonal from its corner (i, j) to (i+1, j+1): 2 nu nv consistently oriented faces, genus 1.
inline TriMesh torus_grid(int nu, int nv) {
  TriMesh m;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const float u = 6.2831853f * float(i) / float(nu), v = 6.2831853f * float(j) / float(nv);
      const float ring = 2.0f + 0.7f * std::cos(v);
      m.positions.push_back({std::cos(u) * ring, std::sin(u) * ring, 0.7f * std::sin(v)});
    }
  auto id = [&](int i, int j) { return static_cast<Index>(((j + nv) % nv) * nu + (i + nu) % nu); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  return m;
}

}  // namespace varmesh::testing
