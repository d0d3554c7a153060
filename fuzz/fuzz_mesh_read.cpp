// Mesh readers (multitri/mesh_io.hpp) on arbitrary bytes. Input: byte 0 chooses the format (low two bits:
// .obj, .off, .ply) and whether provenance is asked for (bit 2); the rest is the file. An accepted mesh must
// pass TriMesh::validate() and its provenance must describe it; only IoError may escape the reader.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/tri_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace varmesh;
  if (size < 1) return 0;
  static const char* const kNames[] = {"fuzz.obj", "fuzz.off", "fuzz.ply", "fuzz.PLY"};
  const std::string name = kNames[data[0] & 3];
  const std::string_view file(reinterpret_cast<const char*>(data + 1), size - 1);
  ReadInfo info;
  info.want_sources = (data[0] & 4) != 0;
  TriMesh mesh;
  try {
    mesh = read_mesh_data(name, file, &info);
  } catch (const IoError&) {
    return 0;
  } catch (const std::exception& e) {
    fuzz::finding("the reader threw something other than IoError:", e.what());
  }
  // Accepted: the documented guarantees.
  try {
    mesh.validate();
  } catch (const std::exception& e) {
    fuzz::finding("an accepted mesh fails TriMesh::validate():", e.what());
  }
  VARMESH_FUZZ_CHECK(mesh.num_faces() > 0);
  if (info.want_sources) {
    VARMESH_FUZZ_CHECK(info.triangle_face.size() == mesh.num_faces());
    VARMESH_FUZZ_CHECK(std::is_sorted(info.triangle_face.begin(), info.triangle_face.end()));
    VARMESH_FUZZ_CHECK(info.face_corners.size() == info.face_lines.size());
    VARMESH_FUZZ_CHECK(info.vertex_lines.size() == mesh.num_vertices());
    // A polygon of k corners gives k - 2 triangles, in file order.
    std::vector<std::size_t> triangles(info.face_corners.size(), 0);
    for (Index f : info.triangle_face) {
      VARMESH_FUZZ_CHECK(f < info.face_corners.size());
      ++triangles[f];
    }
    for (std::size_t f = 0; f < triangles.size(); ++f) {
      if (info.face_corners[f] != 0) VARMESH_FUZZ_CHECK(triangles[f] + 2 == info.face_corners[f]);
    }
  } else {
    VARMESH_FUZZ_CHECK(info.triangle_face.empty() && info.face_corners.empty());
  }
  return 0;
}
