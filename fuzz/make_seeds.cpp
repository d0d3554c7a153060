// Writes seed corpora for the harnesses into <folder>/<harness>/: tiny meshes in every format the readers
// take, hierarchy and MT files of them as the library encodes them, height fields. The meshes are the test
// fixtures' (tests/mesh_fixtures.hpp) and multitri's shapes, so no data file enters the repository.
// Usage: fuzz_make_seeds <folder>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fourk/bisection.hpp"
#include "fourk/fourk_mesh.hpp"
#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "mesh_fixtures.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_io.hpp"
#include "multitri/shapes.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"

namespace fs = std::filesystem;
using namespace varmesh;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put(const fs::path& p, const std::string& prefix, const std::string& body) {
  std::ofstream(p, std::ios::binary) << prefix << body;
}

// A 3 x 3 grid of quads cut into triangles: a mesh with a border, coloured.
TriMesh grid_mesh() {
  TriMesh m;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      m.positions.push_back({static_cast<float>(x), static_cast<float>(y), 0.1f * static_cast<float>(x * y % 3)});
      m.colors.push_back({static_cast<float>(x) / 3.0f, static_cast<float>(y) / 3.0f, 0.5f});
    }
  for (Index y = 0; y < 3; ++y)
    for (Index x = 0; x < 3; ++x) {
      const Index a = 4 * y + x;
      m.indices.insert(m.indices.end(), {a, a + 1, a + 5, a, a + 5, a + 4});
    }
  return m;
}

// Two triangles sharing one vertex only (a bow-tie): a non-manifold vertex.
TriMesh bow_tie() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  m.indices = {0, 1, 2, 0, 3, 4};
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <folder>\n", argv[0]);
    return 2;
  }
  const fs::path root = argv[1];
  for (const char* h : {"mesh_read", "hierarchy", "mt", "pipeline", "heightfield"}) fs::create_directories(root / h);
  const fs::path tmp = root / "tmp";
  fs::create_directories(tmp);

  TriMesh normals_mesh = testing::icosahedron_mesh();
  for (const glm::vec3& p : normals_mesh.positions) normals_mesh.normals.push_back(p);
  TriMesh uv_mesh = testing::tetrahedron_mesh();
  uv_mesh.texcoords = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  const std::vector<std::pair<std::string, TriMesh>> meshes = {
      {"tetra", testing::tetrahedron_mesh()}, {"ico", normals_mesh}, {"torus", testing::torus_grid(4, 3)},
      {"grid", grid_mesh()}, {"bowtie", bow_tie()}, {"uv", uv_mesh}};

  int n = 0;
  for (const auto& [name, mesh] : meshes) {
    // Mesh readers: byte 0 = format (0 obj, 1 off, 2 ply) | 4 (provenance).
    write_mesh((tmp / "m.obj").string(), mesh);
    const std::string obj = slurp(tmp / "m.obj");
    put(root / "mesh_read" / (name + ".obj"), std::string(1, '\x04'), obj);
    write_mesh((tmp / "m.off").string(), mesh);
    put(root / "mesh_read" / (name + ".off"), std::string(1, '\x01'), slurp(tmp / "m.off"));
    write_mesh((tmp / "m.ply").string(), mesh, {.binary = true});
    put(root / "mesh_read" / (name + "_bin.ply"), std::string(1, '\x06'), slurp(tmp / "m.ply"));
    write_mesh((tmp / "m.ply").string(), mesh, {.binary = false});
    put(root / "mesh_read" / (name + "_ascii.ply"), std::string(1, '\x02'), slurp(tmp / "m.ply"));
    // Pipelines: analysis options, subdivision choice, random seed, then the OBJ.
    for (int variant = 0; variant < 8; ++variant) {
      const std::string prefix = {static_cast<char>(variant), static_cast<char>(variant * 5), static_cast<char>(n++)};
      put(root / "pipeline" / (name + std::to_string(variant) + ".obj"), prefix, obj);
    }
    // Hierarchies: the default analysis, and with colours and locked copies where they apply.
    if (name == "bowtie") continue;
    for (int variant = 0; variant < 2; ++variant) {
      QemOptions o;
      o.use_colors = variant == 1;
      o.non_manifold = variant == 1 ? NonManifoldPolicy::kLock : NonManifoldPolicy::kSplit;
      const auto bytes = encode_vertex_hierarchy(build_vertex_hierarchy(mesh, o));
      put(root / "hierarchy" / (name + std::to_string(variant) + ".vmh"), "",
          std::string(bytes.begin(), bytes.end()));
    }
  }
  TriMesh square;
  square.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.2f}, {0, 1, 0}};
  square.indices = {0, 1, 2, 0, 2, 3};
  put(root / "mt" / "square_bisection.vrm", "", encode_mt(build_bisection_mt(square, mark_longest_edges(square), 3)));
  put(root / "mt" / "cube_subdiv.vrm", "", encode_mt(build_subdivision_mt(make_quad_cube(), SubdivScheme::kCatmullClark, 1)));
  FourKMesh fk(testing::tetrahedron_mesh());
  fk.split(FourKMesh::edge(0, 0), {0.5f, 0.5f, 0.5f}, 0.25f);
  put(root / "mt" / "tetra_fourk.vrm", "", encode_mt(fk.to_mt()));

  HeightField field;
  field.width = 3;
  field.height = 2;
  field.z = {0.0f, 1.0f, 2.0f, 3.0f, 4.5f, -1.0f};
  write_heightfield_pgm16((tmp / "h.pgm").string(), field);
  put(root / "heightfield" / "field.pgm", std::string(3, '\0'), slurp(tmp / "h.pgm"));
  write_heightfield_raw((tmp / "h.raw").string(), field);
  put(root / "heightfield" / "field.raw", std::string{'\x02', '\x03', '\x02'}, slurp(tmp / "h.raw"));
  put(root / "heightfield" / "ascii.pgm", std::string(3, '\0'), "P2\n2 2\n255\n0 1\n2 255\n");
  for (int channels = 1; channels <= 4; ++channels) {
    Image image;
    image.width = 3;
    image.height = 2;
    image.channels = channels;
    image.bit_depth = channels == 1 ? 16 : 8;
    if (image.bit_depth == 16) image.pixels16.assign(6, 40000);
    else image.pixels.assign(6 * static_cast<std::size_t>(channels), 77);
    write_png((tmp / "h.png").string(), image);
    put(root / "heightfield" / ("image" + std::to_string(channels) + ".png"),
        std::string{static_cast<char>(channels == 3 ? 3 : 1), '\0', '\0'}, slurp(tmp / "h.png"));
  }
  fs::remove_all(tmp);
  return 0;
}
