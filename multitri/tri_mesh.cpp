#include "multitri/tri_mesh.hpp"

#include <cmath>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"

namespace varmesh {

void Box3::add(const glm::vec3& p) noexcept {
  lo = glm::min(lo, p);
  hi = glm::max(hi, p);
}

float Box3::diagonal() const noexcept { return empty() ? 0.0f : glm::length(hi - lo); }

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The index part of validate(): what the helpers below need to stay in bounds.
void check_indices(const TriMesh& mesh, const char* who) {
  if (mesh.indices.size() % 3 != 0)
    throw InvalidInput(std::string(who) + ": index count " + std::to_string(mesh.indices.size()) +
                       " is not a multiple of 3");
  const std::size_t n = mesh.positions.size();
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= n)
      throw InvalidInput(std::string(who) + ": face " + std::to_string(i / 3) + " refers to vertex " +
                             std::to_string(mesh.indices[i]) + " of " + std::to_string(n),
                         i / 3);
}

}  // namespace

void TriMesh::validate() const {
  if (indices.size() % 3 != 0) throw InvalidInput("index count is not a multiple of 3");
  const auto n = positions.size();
  for (std::size_t i = 0; i < indices.size(); ++i)
    if (indices[i] >= n)
      throw InvalidInput("face " + std::to_string(i / 3) + " refers to vertex " + std::to_string(indices[i]) +
                             " of " + std::to_string(n),
                         i / 3);
  for (std::size_t v = 0; v < n; ++v)
    if (!finite(positions[v])) throw InvalidInput("vertex position is not finite", v);
  if (!normals.empty() && normals.size() != n) throw InvalidInput("normals.size() != positions.size()");
  if (!texcoords.empty() && texcoords.size() != n) throw InvalidInput("texcoords.size() != positions.size()");
  if (!colors.empty() && colors.size() != n) throw InvalidInput("colors.size() != positions.size()");
  for (std::size_t v = 0; v < normals.size(); ++v)
    if (!finite(normals[v])) throw InvalidInput("vertex normal is not finite", v);
  for (std::size_t v = 0; v < texcoords.size(); ++v)
    if (!std::isfinite(texcoords[v].x) || !std::isfinite(texcoords[v].y))
      throw InvalidInput("vertex texture coordinate is not finite", v);
  for (std::size_t v = 0; v < colors.size(); ++v)
    if (!finite(colors[v])) throw InvalidInput("vertex colour is not finite", v);
}

Box3 TriMesh::bounds() const noexcept {
  Box3 b;
  for (const auto& p : positions) b.add(p);
  return b;
}

std::vector<glm::vec3> compute_vertex_normals(const TriMesh& mesh) {
  check_indices(mesh, "compute_vertex_normals");
  std::vector<glm::vec3> n(mesh.positions.size(), glm::vec3(0.0f));
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    const Index a = mesh.corner(f, 0), b = mesh.corner(f, 1), c = mesh.corner(f, 2);
    // The cross product's length is twice the area: area weighting comes for free.
    const glm::vec3 fn = glm::cross(mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
    n[a] += fn;
    n[b] += fn;
    n[c] += fn;
  }
  for (auto& v : n) {
    const float len = glm::length(v);
    v = len > 0.0f ? v / len : glm::vec3(0.0f);
  }
  return n;
}

double surface_area(const TriMesh& mesh) {
  check_indices(mesh, "surface_area");
  double sum = 0.0;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    const glm::dvec3 a(mesh.positions[mesh.corner(f, 0)]);
    const glm::dvec3 b(mesh.positions[mesh.corner(f, 1)]);
    const glm::dvec3 c(mesh.positions[mesh.corner(f, 2)]);
    sum += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  return sum;
}

}  // namespace varmesh
