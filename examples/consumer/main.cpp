// A program outside the varmesh tree: builds a 4-8 terrain hierarchy through the installed package,
// extracts a mesh within an error bound and checks it. Exits non-zero if anything is off, so CI notices a
// broken install.
#include <cstdio>

#include <fourk/grid48.hpp>
#include <multitri/query.hpp>
#include <multitri/terrain_gen.hpp>

int main() {
  const varmesh::HeightField field = varmesh::make_fractal_terrain(65, 65, 1, 20.0f);
  const varmesh::Grid48 hierarchy(field);
  varmesh::Grid48Front front(hierarchy);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.5f);
  varmesh::extract(front, q);
  const varmesh::TriMesh mesh = front.to_mesh();
  const double error = hierarchy.max_vertical_error(mesh);
  std::printf("consumer: %zu triangles, max vertical error %.3f (asked 0.5)\n", mesh.num_faces(), error);
  return mesh.num_faces() > 2 && error <= 0.5 ? 0 : 1;
}
