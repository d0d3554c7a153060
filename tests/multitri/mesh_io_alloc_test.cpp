// Mesh and Multi-Triangulation readers under the allocation guard: a header's counts, however large, never
// make the reader ask for more than the file could fill (tests/alloc_guard.hpp fails any single allocation
// above 1 MiB).
#include "alloc_guard.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "multitri/errors.hpp"
#include "fourk/bisection.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_io.hpp"
#include "mt_file_edit.hpp"
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

// The error decode_mt throws under the guard ("bad_alloc" if an allocation above the limit was tried).
std::string guarded_decode_error(const std::string& bytes) {
  g_guard_peak = 0;
  g_guard_armed = true;
  std::string error = "no error";
  try {
    decode_mt(bytes, "edit.vrm");
  } catch (const IoError& e) {
    error = e.what();
  } catch (const std::bad_alloc&) {
    error = "bad_alloc";
  }
  g_guard_armed = false;
  EXPECT_LE(g_guard_peak.load(), kGuardLimit) << "largest single allocation";
  return error;
}

// .vrm files whose counts claim billions of elements, behind valid checksums (edited and re-sealed, so that
// the counts are what the reader acts on): each is refused by name before anything is allocated from it.
TEST(MeshIoAlloc, VrmCountsAllocateNoMoreThanTheFileHolds) {
  TriMesh base;
  base.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  base.indices = {0, 1, 2, 0, 2, 3};
  const Mt mt = build_bisection_mt(base, mark_longest_edges(base), 2, BisectionOptions{});
  const std::string good = encode_mt(mt);
  const std::size_t base_size_at = testing::kVrmHeaderBytes + 12 * (mt.num_vertices() + mt.num_faces());
  const std::size_t node1_removed_at = base_size_at + 4 + 5;
  const struct {
    std::size_t at;
    int width;
    const char* reason;
  } cases[] = {
      {testing::kVrmCountsAt, 4, "vertices"},      // V
      {testing::kVrmCountsAt + 4, 4, "faces"},     // F
      {testing::kVrmCountsAt + 8, 4, "nodes"},     // N
      {base_size_at, 4, "node images use more faces than the file has"},
      {node1_removed_at, 4, "removed count 4294967295 needs"},
  };
  for (const auto& c : cases) {
    std::string b = good;
    testing::put_le(b, c.at, 0xFFFFFFFFu, c.width);
    testing::reseal_all(b);
    const std::string error = guarded_decode_error(b);
    EXPECT_NE(error.find(c.reason), std::string::npos) << "byte " << c.at << ": " << error;
    EXPECT_NE(error.find("edit.vrm"), std::string::npos) << error;
  }
  // A version-1 file has no header checksum: its counts meet the same limits.
  for (std::size_t at : {testing::kVrmCountsAt, testing::kVrmCountsAt + 4, testing::kVrmCountsAt + 8}) {
    std::string b = testing::as_version_1(good);
    testing::put_le(b, at, 0xFFFFFFFFu, 4);
    testing::reseal(b);
    const std::string error = guarded_decode_error(b);
    EXPECT_NE(error.find("edit.vrm"), std::string::npos) << "byte " << at << ": " << error;
    EXPECT_EQ(error.find("bad_alloc"), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace varmesh
