// `varmesh compare` takes the cow and the bunny from Debian libcgal-demo's sample archive when the data
// folder lacks them. The archive here is one this test writes with GNU tar (so the test runs anywhere),
// pointed to by $VARMESH_PACKAGED_MESHES; a last test reads the installed package when it is there.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "apps/cli_support.hpp"
#include "mesh_fixtures.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/shapes.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::contains;
using testing::EnvGuard;
using testing::torus_grid;

// An archive laid out like libcgal-demo's data.tar.gz, with a torus as the cow and an icosphere as the
// bunny (vertex counts no generated stand-in of `compare` has).
fs::path write_archive(const fs::path& dir, const TriMesh& cow, const TriMesh& bunny) {
  const fs::path tree = dir / "tree";
  fs::create_directories(tree / "data" / "meshes");
  write_mesh((tree / "data" / "meshes" / "cow.off").string(), cow);
  write_mesh((tree / "data" / "meshes" / "bunny00.off").string(), bunny);
  const fs::path archive = dir / "data.tar.gz";
  const std::string cmd = "tar -czf '" + archive.string() + "' -C '" + tree.string() + "' data";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return archive;
}

CmdResult compare(const std::string& args, const fs::path& dir) {
  return testing::run_varmesh("compare --quick --quiet --panel 64 --cases cow,bunny,dragon " + args, dir);
}

TEST(PackagedModels, CompareTakesCowAndBunnyFromTheArchive) {
  const fs::path dir = testing::scratch_dir("packaged_models");
  const TriMesh cow = torus_grid(24, 12);
  const TriMesh bunny = make_icosphere(3);
  const fs::path archive = write_archive(dir, cow, bunny);
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const EnvGuard env("VARMESH_PACKAGED_MESHES", archive.string());
  const fs::path out = dir / "out";
  const CmdResult r = compare("--out " + out.string() + " --data " + empty.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "cow.off (libcgal-demo); original " + std::to_string(cow.num_vertices()) + " V " +
                                  std::to_string(cow.num_faces()) + " F"))
      << r.out;
  EXPECT_TRUE(contains(r.out, "bunny00.off (libcgal-demo); original " + std::to_string(bunny.num_vertices()) + " V " +
                                  std::to_string(bunny.num_faces()) + " F"))
      << r.out;
  EXPECT_TRUE(contains(r.out, "generated bumpy icosphere")) << "the dragon has no packaged model\n" << r.out;
  for (const char* name : {"cow", "bunny", "dragon"})
    EXPECT_TRUE(fs::is_regular_file(out / (std::string(name) + "_schemes.png"))) << name;
}

// VARMESH_PACKAGED_MESHES=none: no archive, the generated stand-ins (a path to no file is an error:
// cli_review_test.cpp).
TEST(PackagedModels, WithoutTheArchiveTheStandInsAreGenerated) {
  const fs::path dir = testing::scratch_dir("packaged_models_absent");
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const EnvGuard env("VARMESH_PACKAGED_MESHES", "none");
  const CmdResult r = compare("--out " + (dir / "out").string() + " --data " + empty.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "generated torus")) << r.out;
  EXPECT_FALSE(contains(r.out, "libcgal-demo")) << r.out;
}

TEST(PackagedModels, ACorruptArchiveIsAnErrorNamingItAndWritesNothing) {
  const fs::path dir = testing::scratch_dir("packaged_models_corrupt");
  const fs::path archive = write_archive(dir, torus_grid(16, 8), make_icosphere(2));
  // Overwrite the archive with its first half: the gzip stream ends early.
  {
    std::string bytes = testing::slurp(archive);
    bytes.resize(bytes.size() / 2);
    std::ofstream(archive, std::ios::binary | std::ios::trunc) << bytes;
  }
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const EnvGuard env("VARMESH_PACKAGED_MESHES", archive.string());
  const fs::path out = dir / "out";
  const CmdResult r = compare("--out " + out.string() + " --data " + empty.string(), dir);
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_TRUE(contains(r.err, archive.string())) << r.err;
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << "a failed run left files in " << out;
}

TEST(PackagedModels, TheInstalledCgalDemoCowIsTheDataFoldersCow) {
  const std::string installed = "/usr/share/doc/libcgal-dev/data.tar.gz";
  if (!fs::exists(installed)) GTEST_SKIP() << installed << " missing (Debian package libcgal-demo is not installed)";
  VARMESH_REQUIRE_SHARED(data_cow, "meshes/cow_cgal_2904v.off");
  const fs::path dir = testing::scratch_dir("packaged_models_installed");
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const EnvGuard env("VARMESH_PACKAGED_MESHES", installed);
  const CmdResult r = testing::run_varmesh(
      "compare --quick --quiet --panel 64 --cases cow --out " + (dir / "out").string() + " --data " + empty.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const TriMesh cow = read_mesh(data_cow);  // MANIFEST: the same file as the package's data/meshes/cow.off
  EXPECT_TRUE(contains(r.out, "cow.off (libcgal-demo); original " + std::to_string(cow.num_vertices()) + " V " +
                                  std::to_string(cow.num_faces()) + " F"))
      << r.out;
}

}  // namespace
}  // namespace varmesh
