// Mesh readers under the allocation guard: a header's counts, however large, never make the reader ask for
// more than the file could fill (tests/alloc_guard.hpp fails any single allocation above 1 MiB).
#include "alloc_guard.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

// A binary PLY whose face element claims 300,000 faces and whose body holds that many bytes, enough for the
// size check (each list has at least its count byte) but only zero-length lists. The reader used to reserve
// indices for every claimed triangle (3.6 MB) before finding that face 0 has no corners.
TEST(MeshIoAlloc, PlyFaceCountReservesNoMoreThanTheFileHolds) {
  const auto dir = testing::scratch_dir("mesh_io_alloc");
  const std::filesystem::path path = dir / "claims.ply";
  {
    std::ofstream out(path, std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
           "property float z\nelement face 300000\nproperty list uchar int vertex_indices\nend_header\n";
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    out.write(reinterpret_cast<const char*>(v), sizeof v);
    const std::string zeros(300000, '\0');
    out.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
  }
  g_guard_peak = 0;
  g_guard_armed = true;
  std::string error;
  try {
    read_mesh(path.string());
  } catch (const IoError& e) {
    error = e.what();
  } catch (const std::bad_alloc&) {
    error = "bad_alloc";
  }
  g_guard_armed = false;
  EXPECT_NE(error.find("has 0 corners"), std::string::npos) << error;
  EXPECT_LE(g_guard_peak.load(), kGuardLimit) << "largest single allocation";
}

}  // namespace
}  // namespace varmesh
