// TriMesh: validate() names the element that breaks an invariant; vertex normals; surface area; boxes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "multitri/tri_mesh.hpp"

namespace varmesh {
namespace {

TriMesh unit_square() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

// Outward-oriented (counter-clockwise seen from outside) regular-ish tetrahedron.
TriMesh tetrahedron() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return m;
}

// Runs validate() and returns the exception (message, element); empty message if nothing was thrown.
std::pair<std::string, std::uint64_t> validate_error(const TriMesh& m) {
  try {
    m.validate();
  } catch (const InvalidInput& e) {
    return {e.what(), e.element()};
  }
  return {"", 0};
}

TEST(TriMesh, ValidMeshesPass) {
  EXPECT_NO_THROW(unit_square().validate());
  EXPECT_NO_THROW(tetrahedron().validate());
  EXPECT_NO_THROW(TriMesh{}.validate());
  TriMesh with_attrs = unit_square();
  with_attrs.normals.assign(4, {0, 0, 1});
  with_attrs.texcoords.assign(4, {0.5f, 0.5f});
  with_attrs.colors.assign(4, {1, 0, 0});
  EXPECT_NO_THROW(with_attrs.validate());
  // Degenerate and duplicated faces are data, not errors.
  TriMesh odd = unit_square();
  odd.indices.insert(odd.indices.end(), {0, 0, 1, 0, 1, 2});
  EXPECT_NO_THROW(odd.validate());
}

TEST(TriMesh, ValidateCatchesOutOfRangeIndex) {
  TriMesh m = unit_square();
  m.indices[4] = 4;  // face 1, corner 1
  const auto [msg, element] = validate_error(m);
  ASSERT_FALSE(msg.empty());
  EXPECT_EQ(element, 1u);
  EXPECT_NE(msg.find("face 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("vertex 4"), std::string::npos) << msg;
  m.indices[4] = kInvalid;
  EXPECT_THROW(m.validate(), InvalidInput);
}

TEST(TriMesh, ValidateCatchesIndexCountNotMultipleOfThree) {
  TriMesh m = unit_square();
  m.indices.push_back(0);
  EXPECT_FALSE(validate_error(m).first.empty());
}

TEST(TriMesh, ValidateCatchesNonFinitePosition) {
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    TriMesh m = unit_square();
    m.positions[2].y = bad;
    const auto [msg, element] = validate_error(m);
    ASSERT_FALSE(msg.empty());
    EXPECT_EQ(element, 2u);
    EXPECT_NE(msg.find("vertex"), std::string::npos) << msg;
    EXPECT_NE(msg.find("2"), std::string::npos) << "the message should name the vertex: " << msg;
  }
}

TEST(TriMesh, ValidateCatchesAttributeSizeMismatch) {
  {
    TriMesh m = unit_square();
    m.normals.assign(3, {0, 0, 1});
    const auto [msg, element] = validate_error(m);
    EXPECT_NE(msg.find("normals"), std::string::npos) << msg;
  }
  {
    TriMesh m = unit_square();
    m.texcoords.assign(5, {0, 0});
    const auto [msg, element] = validate_error(m);
    EXPECT_NE(msg.find("texcoords"), std::string::npos) << msg;
  }
  {
    TriMesh m = unit_square();
    m.colors.assign(1, {0, 0, 0});
    const auto [msg, element] = validate_error(m);
    EXPECT_NE(msg.find("colors"), std::string::npos) << msg;
  }
}

TEST(TriMesh, ValidateCatchesNonFiniteAttributes) {
  // The header lists finite attributes as an invariant.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  {
    TriMesh m = unit_square();
    m.normals.assign(4, {0, 0, 1});
    m.normals[3].x = nan;
    const auto [msg, element] = validate_error(m);
    EXPECT_FALSE(msg.empty()) << "NaN normal accepted";
    if (!msg.empty()) { EXPECT_EQ(element, 3u) << msg; }
  }
  {
    TriMesh m = unit_square();
    m.texcoords.assign(4, {0, 0});
    m.texcoords[1].y = nan;
    EXPECT_FALSE(validate_error(m).first.empty()) << "NaN texcoord accepted";
  }
  {
    TriMesh m = unit_square();
    m.colors.assign(4, {0, 0, 0});
    m.colors[0].z = std::numeric_limits<float>::infinity();
    EXPECT_FALSE(validate_error(m).first.empty()) << "infinite colour accepted";
  }
}

TEST(TriMesh, VertexNormalsOfATetrahedronPointOutwards) {
  const TriMesh m = tetrahedron();
  const auto n = compute_vertex_normals(m);
  ASSERT_EQ(n.size(), 4u);
  glm::vec3 centroid(0.0f);
  for (const auto& p : m.positions) centroid += p * 0.25f;
  for (std::size_t v = 0; v < 4; ++v) {
    EXPECT_NEAR(glm::length(n[v]), 1.0f, 1e-5f);
    EXPECT_GT(glm::dot(n[v], m.positions[v] - centroid), 0.0f) << "vertex " << v;
  }
  // The vertex at the right-angle corner: the three axis faces have area 1/2, so the normal is -(1,1,1)/sqrt3.
  EXPECT_NEAR(n[0].x, -1.0f / std::sqrt(3.0f), 1e-5f);
  EXPECT_NEAR(n[0].y, -1.0f / std::sqrt(3.0f), 1e-5f);
  EXPECT_NEAR(n[0].z, -1.0f / std::sqrt(3.0f), 1e-5f);
  // Flipping the orientation flips every normal.
  TriMesh flipped = m;
  for (std::size_t f = 0; f < flipped.num_faces(); ++f) std::swap(flipped.indices[3 * f + 1], flipped.indices[3 * f + 2]);
  const auto nf = compute_vertex_normals(flipped);
  for (std::size_t v = 0; v < 4; ++v) EXPECT_NEAR(glm::dot(nf[v], n[v]), -1.0f, 1e-5f);
}

TEST(TriMesh, VertexNormalsAreAreaWeightedAndZeroWhenUndefined) {
  TriMesh m = unit_square();
  m.positions.push_back({5, 5, 5});  // isolated vertex
  const auto n = compute_vertex_normals(m);
  for (std::size_t v = 0; v < 4; ++v) EXPECT_NEAR(glm::distance(n[v], glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  EXPECT_EQ(n[4], glm::vec3(0.0f));
  // A big face dominates a small one at a shared vertex.
  TriMesh two;
  two.positions = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 1}, {1, 0, 0}};
  two.indices = {0, 1, 2, 0, 3, 4};  // big face up (+z), small face facing +y
  const auto w = compute_vertex_normals(two);
  EXPECT_GT(w[0].z, 0.99f);
}

TEST(TriMesh, SurfaceArea) {
  EXPECT_DOUBLE_EQ(surface_area(unit_square()), 1.0);
  EXPECT_NEAR(surface_area(tetrahedron()), 1.5 + std::sqrt(3.0) / 2.0, 1e-6);
  EXPECT_EQ(surface_area(TriMesh{}), 0.0);
  TriMesh scaled = unit_square();
  for (auto& p : scaled.positions) p *= 3.0f;
  EXPECT_NEAR(surface_area(scaled), 9.0, 1e-9);
}

TEST(TriMesh, BoundsOfAMesh) {
  const TriMesh m = tetrahedron();
  const Box3 b = m.bounds();
  EXPECT_FALSE(b.empty());
  EXPECT_EQ(b.lo, glm::vec3(0, 0, 0));
  EXPECT_EQ(b.hi, glm::vec3(1, 1, 1));
  EXPECT_NEAR(b.diagonal(), std::sqrt(3.0f), 1e-6f);
  EXPECT_TRUE(TriMesh{}.bounds().empty());
  EXPECT_EQ(TriMesh{}.bounds().diagonal(), 0.0f);
}


TEST(TriMesh, HelpersRefuseIndicesOutOfRange) {
  TriMesh m;
  m.positions = {{0, 0, 0}};
  m.indices = {0, 5, 9};
  for (int which = 0; which < 2; ++which) {
    try {
      if (which == 0)
        (void)surface_area(m);
      else
        (void)compute_vertex_normals(m);
      ADD_FAILURE() << "helper " << which << " accepted a missing vertex";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.element(), 0u);
      EXPECT_NE(std::string(e.what()).find("face 0"), std::string::npos) << e.what();
    }
  }
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0};
  EXPECT_THROW((void)surface_area(m), InvalidInput);
  EXPECT_THROW((void)compute_vertex_normals(m), InvalidInput);
  m.indices.pop_back();
  EXPECT_DOUBLE_EQ(surface_area(m), 0.5);
  EXPECT_EQ(compute_vertex_normals(m)[0], glm::vec3(0, 0, 1));
}

}  // namespace
}  // namespace varmesh
