// A program outside the varmesh tree: builds a 4-8 terrain hierarchy through the installed package and
// extracts a mesh. Exits non-zero if anything is off, so CI notices a broken install.
#include <cstdio>

#include <multitri/tri_mesh.hpp>

int main() {
  varmesh::TriMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2};
  mesh.validate();
  std::printf("consumer: %zu faces\n", mesh.num_faces());
  return mesh.num_faces() == 1 ? 0 : 1;
}
