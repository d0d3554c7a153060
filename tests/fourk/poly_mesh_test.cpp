// Polygon meshes: triangulate() refuses input its TriMesh could not hold.
#include "fourk/poly_mesh.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

TEST(PolyMesh, TriangulateGivesValidMeshes) {
  for (const PolyMesh& p : {make_quad_cube(), make_quad_torus(5, 4)}) {
    const TriMesh t = triangulate(p);
    EXPECT_NO_THROW(t.validate());
    EXPECT_EQ(t.num_faces(), 2 * p.num_faces());
    EXPECT_EQ(t.num_vertices(), p.num_vertices());
  }
  // A pentagon is a fan of three triangles; a face of two corners gives none.
  PolyMesh p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 1, 0}};
  const Index five[] = {0, 1, 2, 3, 4}, two[] = {0, 1};
  p.add_face(five);
  p.add_face(two);
  const TriMesh t = triangulate(p);
  EXPECT_EQ(t.num_faces(), 3u);
  EXPECT_NO_THROW(t.validate());
}

TEST(PolyMesh, TriangulateRefusesBadInputByName) {
  PolyMesh p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Index ok[] = {0, 1, 2}, oob[] = {0, 5, 9};
  p.add_face(ok);
  p.add_face(oob);
  try {
    triangulate(p);
    ADD_FAILURE() << "no throw for a corner out of range";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 1u);
  }
  PolyMesh offsets = make_quad_cube();
  offsets.face_offsets.back() += 4;  // runs past the corners
  EXPECT_THROW(triangulate(offsets), InvalidInput);
  offsets = make_quad_cube();
  std::swap(offsets.face_offsets[2], offsets.face_offsets[3]);  // decreasing
  EXPECT_THROW(triangulate(offsets), InvalidInput);
  PolyMesh huge = make_quad_cube();
  huge.positions[3].y = 1e300;  // valid in double, infinite in float
  try {
    triangulate(huge);
    ADD_FAILURE() << "no throw for a position beyond float";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 3u);
  }
}

}  // namespace
}  // namespace varmesh
