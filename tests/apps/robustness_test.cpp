// Hostile input and failing outputs, as found by fuzzing the varmesh command: every case exits 1 with one
// line of error that names the file, line or option at fault, and leaves no output behind.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/terrain_gen.hpp"
#include "apps/cli_support.hpp"
#include "multitri/mt_file_edit.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::contains;
using testing::count_lines;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh(args, dir); }

// A height field small enough for a fast run, saved as float32 (17 x 17 samples).
fs::path write_small_terrain(const fs::path& dir) {
  const fs::path path = dir / "t.f32";
  write_heightfield_raw(path.string(), make_fractal_terrain(17, 17, 7, 20.0f));
  return path;
}

// A relative index of -2^63 used to be negated (signed overflow, undefined behaviour).
TEST(Robustness, ObjRelativeIndexOfInt64MinNamesTheLine) {
  const auto dir = testing::scratch_dir("robust_obj_int64_min");
  const fs::path obj = dir / "m.obj";
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9223372036854775808\n";
  const std::string out = (dir / "out.png").string();
  const CmdResult r = run("render " + obj.string() + " -o " + out, dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, obj.string() + ":4:")) << r.err;
  EXPECT_TRUE(contains(r.err, "relative vertex index -9223372036854775808")) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// A folder opens as a stream and reports a size near 2^63: reading one used to end in std::bad_alloc.
TEST(Robustness, AFolderGivenAsInputIsNamed) {
  const auto dir = testing::scratch_dir("robust_folder_input");
  fs::create_directories(dir / "h.vrm");
  fs::create_directories(dir / "m.obj");
  const std::string out = (dir / "out.obj").string();
  for (const std::string& args : {"query " + (dir / "h.vrm").string() + " --error 0 -o " + out,
                                  "subdiv " + (dir / "m.obj").string() + " --levels 1 -o " + out}) {
    const CmdResult r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "it is a folder, not a file")) << r.err;
    EXPECT_FALSE(contains(r.err, "bad_alloc")) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  const CmdResult r = run("info " + (dir / "m.obj").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, (dir / "m.obj").string() + ": cannot read: it is a folder")) << r.err;
}

// terrain wrote its mesh before rendering and writing --png: a failed picture left the mesh behind.
TEST(Robustness, TerrainPngFailureLeavesNoMesh) {
  const auto dir = testing::scratch_dir("robust_terrain_png");
  const fs::path field = write_small_terrain(dir);
  const std::string out = (dir / "out.obj").string();
  const std::string base = "terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + out;
  CmdResult r = run(base + " --png " + (dir / "missing" / "t.png").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, (dir / "missing" / "t.png").string())) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // A --png that is not a .png is refused before anything runs, as query and subdiv do.
  r = run(base + " --png " + (dir / "t.jpg").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "--png must end in .png")) << r.err;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "t.jpg"));
  // The working run writes both.
  r = run(base + " --png " + (dir / "t.png").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_TRUE(fs::exists(dir / "t.png"));
}

// query rendered --png first but wrote it after the mesh: a PNG that could not be written left the mesh.
TEST(Robustness, QueryPngFailureLeavesNoMesh) {
  const auto dir = testing::scratch_dir("robust_query_png");
  const fs::path field = write_small_terrain(dir);
  const std::string vrm = (dir / "h.vrm").string();
  CmdResult r = run("build " + field.string() + " --raw-size 17,17 --method adaptive --quiet -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string out = (dir / "out.obj").string();
  r = run("query " + vrm + " --error 0.5 -o " + out + " --png " + (dir / "missing" / "q.png").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, (dir / "missing" / "q.png").string())) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// build --pictures wrote its PNGs before the hierarchy: an unwritable -o left the pictures behind.
TEST(Robustness, BuildFailureLeavesNoPictures) {
  const auto dir = testing::scratch_dir("robust_build_pictures");
  const fs::path field = write_small_terrain(dir);
  const fs::path pictures = dir / "pics";
  const std::string build = "build " + field.string() + " --raw-size 17,17 --method adaptive --quiet --pictures ";
  const std::string bad_vrm = (dir / "missing" / "h.vrm").string();
  CmdResult r = run(build + pictures.string() + " -o " + bad_vrm, dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, bad_vrm)) << r.err;
  EXPECT_FALSE(fs::exists(pictures));
  // Pictures that cannot be written take the hierarchy with them.
  std::ofstream(dir / "file") << "x";
  const std::string vrm = (dir / "h.vrm").string();
  r = run(build + (dir / "file" / "pics").string() + " -o " + vrm, dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, (dir / "file" / "pics").string())) << r.err;
  EXPECT_FALSE(fs::exists(vrm));
  // The working run writes both.
  r = run(build + pictures.string() + " -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(vrm));
  EXPECT_TRUE(fs::exists(pictures / "adaptive_surface.png"));
  // A later run that fails at the pictures leaves the earlier run's hierarchy and pictures as they were (it
  // used to delete the user's .vrm and the pictures it had overwritten), and no staged file.
  const std::string old_vrm = testing::slurp(vrm), old_png = testing::slurp(pictures / "adaptive_surface.png");
  fs::create_directory(pictures / "adaptive_domain.png.tmp");
  fs::remove(pictures / "adaptive_domain.png");
  fs::rename(pictures / "adaptive_domain.png.tmp", pictures / "adaptive_domain.png");  // a folder where a PNG goes
  r = run("build " + field.string() + " --raw-size 17,17 --method adaptive --tolerance 0.5 --quiet --pictures " +
              pictures.string() + " -o " + vrm, dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, (pictures / "adaptive_domain.png").string())) << r.err;
  EXPECT_EQ(testing::slurp(vrm), old_vrm);
  EXPECT_EQ(testing::slurp(pictures / "adaptive_surface.png"), old_png);
  for (const fs::path& d : {dir, pictures})
    for (const auto& e : fs::directory_iterator(d))
      EXPECT_FALSE(contains(e.path().filename().string(), "partial")) << e.path();
}

// --error nan passed every "is it given" test (NaN >= 0 and NaN < 0 are both false): query silently
// extracted the finest mesh and terrain failed with "any_of: no parts".
TEST(Robustness, NanErrorIsRejectedByName) {
  const auto dir = testing::scratch_dir("robust_nan_error");
  const fs::path field = write_small_terrain(dir);
  const std::string vrm = (dir / "h.vrm").string();
  CmdResult r = run("build " + field.string() + " --raw-size 17,17 --method adaptive --quiet -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string out = (dir / "out.obj").string();
  for (const std::string& args : {"query " + vrm + " --error nan -o " + out,
                                  "terrain " + field.string() + " --raw-size 17,17 --error nan -o " + out,
                                  "subdiv cube --levels 1 --adaptive --error nan -o " + out}) {
    r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "--error must be")) << args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  r = run("demo --quiet --size 17 --error nan --out " + (dir / "demo").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "--error must be")) << r.err;
  EXPECT_FALSE(fs::exists(dir / "demo"));
}

// CLI11 parses "-1" into a std::size_t as SIZE_MAX: --budget -1 silently meant "no budget".
TEST(Robustness, NegativeBudgetIsRejectedByName) {
  const auto dir = testing::scratch_dir("robust_negative_budget");
  const fs::path field = write_small_terrain(dir);
  const std::string vrm = (dir / "h.vrm").string();
  CmdResult r = run("build " + field.string() + " --raw-size 17,17 --method adaptive --quiet -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string out = (dir / "out.obj").string();
  for (const std::string& args : {"query " + vrm + " --budget -1 -o " + out,
                                  "terrain " + field.string() + " --raw-size 17,17 --error 1 --budget -1 -o " + out}) {
    r = run(args, dir);
    EXPECT_NE(r.status, 0) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "--budget")) << args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
}

// demo wrote its meshes and then rendered: a terrain whose extent overflows float failed in the renderer and
// left a half-written folder.
TEST(Robustness, DemoFailureLeavesNoFolder) {
  const auto dir = testing::scratch_dir("robust_demo_partial");
  // A 16-bit PGM whose z_range comment maps the samples onto +-3.4e38: finite heights, infinite extent.
  std::string pgm = "P5\n# varmesh z_range -3.4e38 3.4e38\n4 4\n65535\n";
  for (int i = 0; i < 16; ++i) pgm += (i % 2) ? std::string("\xff\xff", 2) : std::string("\x00\x00", 2);
  std::ofstream(dir / "huge.pgm", std::ios::binary) << pgm;
  const fs::path out = dir / "demo";
  const CmdResult r = run("demo --quiet --heightfield " + (dir / "huge.pgm").string() + " --out " + out.string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// compare made its --out folder first and wrote each case's pictures as it went: a case that failed (here
// an --image that is not an image) left the folder behind, with the earlier cases' files.
TEST(Robustness, CompareFailureLeavesNoFolder) {
  const auto dir = testing::scratch_dir("robust_compare_partial");
  std::ofstream(dir / "bad.png") << "not a png";
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const fs::path out = dir / "out";
  const CmdResult r = run("compare --quick --quiet --size 16 --panel 64 --cases terrain,image --image " +
                              (dir / "bad.png").string() + " --data " + empty.string() + " --out " + out.string(),
                          dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, (dir / "bad.png").string())) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// --pixels 0 reached the screen-space criterion, whose message names neither the command nor the option.
TEST(Robustness, NonPositivePixelsAreRejectedByName) {
  const auto dir = testing::scratch_dir("robust_pixels");
  const fs::path field = write_small_terrain(dir);
  const std::string out = (dir / "out.obj").string();
  for (const std::string& args : {"terrain " + field.string() + " --raw-size 17,17 --camera 8,-20,30,8,8,0,60 --pixels 0 -o " + out,
                                  "demo --quiet --size 17 --pixels 0 --out " + (dir / "demo").string()}) {
    const CmdResult r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "--pixels")) << args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "demo"));
}

// --pixels and --viewport only tune the camera's screen-space error: without --camera they were accepted
// and silently ignored, so `terrain --error 1 --pixels 2` looked like it had asked for a screen criterion.
TEST(Robustness, ScreenOptionsWithoutCameraAreRefused) {
  const auto dir = testing::scratch_dir("robust_pixels_no_camera");
  const fs::path field = write_small_terrain(dir);
  const std::string out = (dir / "out.obj").string();
  for (const std::string opt : {"--pixels 2", "--viewport 720"}) {
    const CmdResult r = run("terrain " + field.string() + " --raw-size 17,17 --error 1 " + opt + " -o " + out, dir);
    EXPECT_EQ(r.status, 1) << opt << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << opt << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, opt.substr(0, opt.find(' ')))) << r.err;
    EXPECT_TRUE(contains(r.err, "--camera")) << r.err;
    // The same option with a camera is accepted.
    const CmdResult ok =
        run("terrain " + field.string() + " --raw-size 17,17 --camera 8,-20,30,8,8,0,60 " + opt + " -o " + out, dir);
    EXPECT_EQ(ok.status, 0) << opt << "\n" << ok.err;
    fs::remove(out);
  }
  EXPECT_FALSE(fs::exists(out));
}

// Coordinates near float's limit are finite, but every length computed from them overflows: the commands
// failed deep inside ("frame_sphere: radius inf", "FourKMesh::set_error ... must be finite") without naming
// the file or the cause.
TEST(Robustness, CoordinatesBeyondFloatsReachAreNamed) {
  const auto dir = testing::scratch_dir("robust_huge_coordinates");
  const fs::path obj = dir / "huge.obj";
  std::ofstream(obj) << "v -3e38 0 0\nv 3e38 0 0\nv 0 3e38 0\nv 0 0 3e38\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
  const std::string out = (dir / "out").string();
  for (const std::string& args : {"render " + obj.string() + " -o " + out + ".png",
                                  "build " + obj.string() + " --method semiregular -o " + out + ".vrm",
                                  "subdiv " + obj.string() + " --levels 1 -o " + out + ".obj"}) {
    const CmdResult r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, obj.string() + ": the coordinates span more than about 1.8e19")) << args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out + ".png"));
  EXPECT_FALSE(fs::exists(out + ".vrm"));
  EXPECT_FALSE(fs::exists(out + ".obj"));
}

// A mesh whose vertices all sit at one point has no extent for the picture camera to fit: it used to fail
// with "camera eye equals target" (subdiv --png) or a zero near plane.
TEST(Robustness, PointSizedMeshGetsAPicture) {
  const auto dir = testing::scratch_dir("robust_point_mesh");
  const fs::path obj = dir / "pt.obj";
  std::ofstream(obj) << "v 1000 1000 1000\nv 1000 1000 1000\nv 1000 1000 1000\nv 1000 1000 1000\nf 1 2 3\nf 1 3 4\n";
  const std::string out = (dir / "o.obj").string(), png = (dir / "o.png").string();
  const CmdResult r = run("subdiv " + obj.string() + " --levels 1 -o " + out + " --png " + png, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_TRUE(fs::exists(png));
}

// Found by a second review (each failed before its fix).

// A failed --png used to remove the mesh it had just renamed over the user's existing file: the old file
// was lost. Now the mesh is staged and moved into place only after the picture is written.
TEST(Robustness, AFailedPictureKeepsTheUsersExistingMesh) {
  const auto dir = testing::scratch_dir("robust_keep_existing");
  const fs::path field = write_small_terrain(dir);
  const fs::path keep = dir / "keep.obj";
  std::ofstream(keep) << "precious\n";
  fs::create_directories(dir / "folder.png");  // a folder where the picture should go
  for (const std::string& png : {(dir / "missing" / "x.png").string(), (dir / "folder.png").string()}) {
    const CmdResult r = run("terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + keep.string() + " --png " + png, dir);
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    std::ifstream in(keep);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "precious") << png;
  }
  for (const auto& e : fs::directory_iterator(dir))  // no staging file left behind
    EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
}

// A mesh path naming a folder was found only at the final rename, after the picture had been written: the
// run failed but left a new picture behind. It is refused before anything is written now.
TEST(Robustness, AMeshPathThatIsAFolderWritesNoPicture) {
  const auto dir = testing::scratch_dir("robust_mesh_folder");
  const fs::path field = write_small_terrain(dir);
  fs::create_directories(dir / "m.obj");
  const std::string png = (dir / "m.png").string();
  const CmdResult r = run("terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + (dir / "m.obj").string() + " --png " + png, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, (dir / "m.obj").string() + ": is a folder")) << r.err;
  EXPECT_FALSE(fs::exists(png));
  EXPECT_TRUE(fs::is_directory(dir / "m.obj"));
  for (const auto& e : fs::directory_iterator(dir))  // no staging file left behind
    EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
}

// A failed compare took back the files it had overwritten (an earlier run's pictures), deleted a dangling
// symbolic link given as --out, and left the parents it had created.
TEST(Robustness, AFailedCompareLeavesTheOutputFolderAsItWas) {
  const auto dir = testing::scratch_dir("robust_compare_rollback");
  const fs::path out = dir / "out";
  fs::create_directories(dir / "nodata");  // an empty data folder: the cases are generated
  CmdResult r = run("compare --quick --quiet --panel 64 --cases cow --data " + (dir / "nodata").string() + " --out " + out.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto size_before = fs::file_size(out / "cow_schemes.png");
  std::ofstream(dir / "bad.png") << "not a png";
  r = run("compare --quick --quiet --panel 128 --cases cow,image --image " + (dir / "bad.png").string() + " --data " +
              (dir / "nodata").string() + " --out " + out.string(),
          dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(fs::exists(out / "cow_schemes.png"));
  EXPECT_EQ(fs::file_size(out / "cow_schemes.png"), size_before);  // the earlier run's picture, untouched
  EXPECT_TRUE(fs::exists(out / "table.md"));
  for (const auto& e : fs::directory_iterator(out)) EXPECT_NE(e.path().filename().string().rfind(".varmesh-partial", 0), 0u) << e.path();
  // A dangling link as --out is the user's: refused, not deleted.
  fs::create_symlink(dir / "nowhere", dir / "dangling");
  r = run("compare --quick --quiet --cases cow --out " + (dir / "dangling").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir / "dangling")));
  // Folders this run made are taken back, parents included.
  r = run("compare --quick --quiet --cases image --image " + (dir / "bad.png").string() + " --out " + (dir / "new_a" / "new_b").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_FALSE(fs::exists(dir / "new_a"));
}

// Messages that named neither the file nor the option.
TEST(Robustness, TerrainErrorsNameTheirFileOrOption) {
  const auto dir = testing::scratch_dir("robust_terrain_names");
  const fs::path thin = dir / "thin.pgm";
  std::ofstream(thin, std::ios::binary) << "P5\n1 5\n255\n" << std::string(5, '\x10');
  const fs::path field = write_small_terrain(dir);
  const std::string out = (dir / "out.obj").string();
  const struct {
    std::string args, names;
  } cases[] = {
      {"terrain " + thin.string() + " --error 1 -o " + out, thin.string()},
      {"demo --quiet --heightfield " + thin.string() + " --out " + (dir / "d").string(), thin.string()},
      {"terrain " + field.string() + " --raw-size 17,17 --error 1 --spacing inf -o " + out, "--spacing"},
      {"terrain " + field.string() + " --raw-size 17,17 --error 1 --z-scale nan -o " + out, "--z-scale"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.names)) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
}

// The view-dependent terrain used a fixed far plane (1e7): the same scene in other units gave another mesh.
// And demo could not take a headerless height field (no --raw-size).
TEST(Robustness, TerrainViewsDoNotDependOnUnitsAndDemoTakesRawFields) {
  const auto dir = testing::scratch_dir("robust_terrain_units");
  const fs::path field = dir / "t.f32";
  write_heightfield_raw(field.string(), make_fractal_terrain(65, 65, 5, 20.0f));
  auto faces = [&](const std::string& args) {
    const fs::path out = dir / "o.obj";
    const CmdResult r = run("terrain " + field.string() + " --raw-size 65,65 " + args + " -o " + out.string(), dir);
    EXPECT_EQ(r.status, 0) << args << "\n" << r.err;
    return r.status == 0 ? read_mesh(out.string()).num_faces() : 0;
  };
  const std::size_t unit = faces("--camera 32,-40,40,32,32,0,50");
  EXPECT_GT(unit, 100u);
  EXPECT_EQ(faces("--spacing 1e5 --z-scale 1e5 --camera 3.2e6,-4e6,4e6,3.2e6,3.2e6,0,50"), unit);
  const CmdResult r = run("demo --quiet --heightfield " + field.string() + " --raw-size 65,65 --out " + (dir / "d").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "d" / "view.obj"));
}

// demo wrote its six files one after another: a failure on the fourth left the first three behind.
TEST(Robustness, AFailedDemoWritesNothing) {
  const auto dir = testing::scratch_dir("robust_demo_all_or_nothing");
  const fs::path out = dir / "out";
  fs::create_directories(out / "view_camera.png");  // a folder where a picture should go
  const CmdResult r = run("demo --quiet --size 17 --out " + out.string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(out)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "view_camera.png") << e.path();
  }
  EXPECT_EQ(entries, 1u);
}

// render --eye/--target measured the near and far planes from the target, so a target away from the mesh
// clipped it all (a white picture); a top view with the default +z up was refused; an unreferenced vertex
// far away framed an empty picture.
TEST(Robustness, RenderSeesTheMeshFromAnyCamera) {
  const auto dir = testing::scratch_dir("robust_render_cameras");
  std::ofstream(dir / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir / "unref.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1000 1000 1000\nf 1 2 3\n";
  const fs::path png = dir / "r.png";
  auto covered = [&](const std::string& args) {
    const CmdResult r = run(args + " -o " + png.string() + " --width 64 --height 48", dir);
    EXPECT_EQ(r.status, 0) << args << "\n" << r.err;
    if (r.status != 0) return std::size_t{0};
    const Image im = read_png(png.string());
    std::size_t n = 0;
    for (std::size_t i = 0; i < im.pixels.size(); i += 3)
      n += im.pixels[i] != 255 || im.pixels[i + 1] != 255 || im.pixels[i + 2] != 255;
    return n;
  };
  const std::string tri = "render " + (dir / "tri.obj").string();
  EXPECT_GT(covered(tri + " --eye 0.3,-3,1 --target 0.3,-2.9,0.97"), 50u);  // target well in front of the mesh
  EXPECT_GT(covered(tri + " --eye 0.3,0.3,5 --target 0.3,0.3,0"), 50u);      // straight down
  EXPECT_GT(covered("render " + (dir / "unref.obj").string()), 50u);
}

// Found by a third review, a fuzzing pass (each failed before its fix).

// What run_limited() holds one run of varmesh to, as a full disk, a small machine or an input that never
// comes would.
enum class Limit {
  kFileBlocks,  // files of at most N blocks of 512 bytes (ulimit -f); SIGXFSZ is ignored, so a write past
                // the limit fails with EFBIG as on a full disk
  kMemoryKb,    // N kB of address space (ulimit -v)
  kSeconds,     // N seconds under timeout(1): a command that waits forever ends with status 124 instead
};

// Runs `varmesh <args>` under `limit` of `amount`, stdout and stderr captured in files of `dir`. The limit is
// set in the shell that std::system starts for this one command, so the test process keeps its own.
CmdResult run_limited(Limit limit, int amount, const std::string& args, const fs::path& dir) {
  const std::string n = std::to_string(amount);
  std::string cmd;
  switch (limit) {
    case Limit::kFileBlocks: cmd = "trap '' XFSZ; ulimit -f " + n + "; "; break;
    case Limit::kMemoryKb: cmd = "ulimit -v " + n + "; "; break;
    case Limit::kSeconds: cmd = "timeout " + n + " "; break;
  }
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  cmd += std::string(VARMESH_EXE) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, testing::slurp(out), testing::slurp(err)};
}

// Every entry of `dir` whose name says it is a staging file or folder.
std::vector<std::string> staging_leftovers(const fs::path& dir) {
  std::vector<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (contains(name, "partial") || name.rfind(".tmp.", 0) == 0) found.push_back(e.path().string());
  }
  return found;
}

// `build -o h.vrm --pictures h.vrm` made the folder h.vrm, wrote the pictures into it, then failed to move
// the hierarchy onto it: the pictures stayed. -o naming a folder and --view 0,0,0 were found only after
// the whole build.
TEST(Robustness, BuildRefusesClashingOutputsBeforeAnyWork) {
  const auto dir = testing::scratch_dir("robust_build_clash");
  std::ofstream(dir / "q.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const std::string build = "build " + (dir / "q.obj").string() + " --quiet ";
  const std::string vrm = (dir / "h.vrm").string();
  fs::create_directories(dir / "folder.vrm");
  const struct {
    std::string args, says;
  } cases[] = {
      {"-o " + vrm + " --pictures " + vrm, "--pictures"},
      {"-o " + vrm + " --pictures " + (dir / "h.vrm" / "pics").string(), "--pictures"},
      {"-o " + (dir / "folder.vrm").string(), (dir / "folder.vrm").string() + ": is a folder"},
      {"-o " + vrm + " --pictures " + (dir / "pics").string() + " --view 0,0,0", "--view: the direction is zero"},
      {"-o " + vrm + " --pictures " + (dir / "pics").string() + " --up 1,2", "--up"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run(build + c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c.args;  // refused before the build, which prints its sizes
    EXPECT_FALSE(fs::exists(vrm)) << c.args;
    EXPECT_FALSE(fs::exists(dir / "pics")) << c.args;
  }
  EXPECT_TRUE(fs::is_directory(dir / "folder.vrm"));
  EXPECT_TRUE(fs::is_empty(dir / "folder.vrm"));
  // The hierarchy inside its own pictures folder is fine.
  fs::create_directories(dir / "pics");
  const CmdResult r = run(build + "-o " + (dir / "pics" / "h.vrm").string() + " --pictures " + (dir / "pics").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "pics" / "h.vrm"));
  EXPECT_TRUE(fs::exists(dir / "pics" / "semiregular_level0.png"));
}

// An output could replace an input: `terrain dem.png -o dem.obj --png dem.png` overwrote the height field,
// `demo --heightfield d/uniform.png --out d` likewise, `subdiv a.obj -o a.obj` its mesh; through a symbolic
// link or a hard link the names need not even match.
TEST(Robustness, AnOutputNeverReplacesAnInput) {
  const auto dir = testing::scratch_dir("robust_output_is_input");
  Image dem;
  dem.width = dem.height = 17;
  dem.channels = 1;
  for (std::size_t i = 0; i < 17 * 17; ++i) dem.pixels.push_back(static_cast<std::uint8_t>((i * 37) % 251));
  write_png((dir / "dem.png").string(), dem);
  fs::create_directories(dir / "d");
  fs::copy_file(dir / "dem.png", dir / "d" / "uniform.png");
  fs::create_directories(dir / "pics");
  fs::copy_file(dir / "dem.png", dir / "pics" / "adaptive_surface.png");
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  CmdResult r = run("build " + (dir / "dem.png").string() + " --method adaptive --quiet -o " + (dir / "h.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("pm build " + (dir / "a.obj").string() + " --quiet -o " + (dir / "h.vmh").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  auto link = [&](const std::string& name, const std::string& to) {
    fs::create_symlink(to, dir / name);
    return (dir / name).string();
  };
  fs::create_hard_link(dir / "a.obj", dir / "hard.obj");
  const std::string a = (dir / "a.obj").string(), field = (dir / "dem.png").string();
  const std::string vrm = (dir / "h.vrm").string(), vmh = (dir / "h.vmh").string(), out = (dir / "out.obj").string();
  const struct {
    std::string args, input;
  } cases[] = {
      {"terrain " + field + " --error 5 -o " + (dir / "dem.obj").string() + " --png " + field, field},
      {"terrain " + field + " --error 5 -o " + link("dem_link.obj", "dem.png"), field},
      {"demo --quiet --heightfield " + (dir / "d" / "uniform.png").string() + " --out " + (dir / "d").string(),
       (dir / "d" / "uniform.png").string()},
      {"subdiv " + a + " --levels 1 -o " + a, a},
      {"subdiv " + a + " --levels 1 -o " + (dir / "hard.obj").string(), a},
      {"subdiv " + a + " --levels 1 -o " + out + " --png " + link("a_link.png", "a.obj"), a},
      {"subdiv " + a + " --levels 1 --figure " + dir.string(), a},  // no clash: a.obj is not a picture name
      {"render " + a + " -o " + link("render_link.png", "a.obj"), a},
      {"build " + a + " --quiet -o " + link("build_link.vrm", "a.obj"), a},
      {"build " + (dir / "pics" / "adaptive_surface.png").string() + " --method adaptive --quiet -o " +
           (dir / "h2.vrm").string() + " --pictures " + (dir / "pics").string(),
       (dir / "pics" / "adaptive_surface.png").string()},
      {"query " + vrm + " --error 1 -o " + out + " --png " + link("query_link.png", "h.vrm"), vrm},
      {"pm build " + a + " --quiet -o " + link("pm_link.vmh", "a.obj"), a},
      {"pm query " + vmh + " --error 1 -o " + link("pmq_link.obj", "h.vmh"), vmh},
      {"compare --quick --quiet --cases image --image " + (dir / "image_schemes.png").string() + " --out " + dir.string(), ""},
  };
  fs::copy_file(dir / "dem.png", dir / "image_schemes.png");
  for (const auto& c : cases) {
    const std::string before = c.input.empty() ? "" : testing::slurp(c.input);
    r = run(c.args, dir);
    if (contains(c.args, "--figure")) {
      EXPECT_EQ(r.status, 0) << c.args << "\n" << r.err;
      continue;
    }
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "is the same file as")) << c.args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c.args;
    if (!c.input.empty()) {
      EXPECT_EQ(testing::slurp(c.input), before) << c.args;
    }
  }
  EXPECT_FALSE(fs::exists(dir / "dem.obj"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "h2.vrm"));
  EXPECT_TRUE(staging_leftovers(dir).empty());
}

// We run as root: a symbolic link, a FIFO or a device node at an output path was replaced by a regular
// file. A link to a file (or a dangling one) is now written through and stays a link; anything that is not
// a regular file is refused before any work.
TEST(Robustness, LinksAreWrittenThroughAndSpecialFilesAreRefused) {
  const auto dir = testing::scratch_dir("robust_special_outputs");
  const fs::path field = write_small_terrain(dir);
  fs::create_directories(dir / "real");
  std::ofstream(dir / "real" / "old.obj") << "old\n";
  fs::create_symlink("real/old.obj", dir / "link.obj");
  fs::create_symlink("link.obj", dir / "chain.obj");
  fs::create_symlink("real/new.png", dir / "dangling.png");
  const std::string terrain = "terrain " + field.string() + " --raw-size 17,17 --error 1 ";
  CmdResult r = run(terrain + "-o " + (dir / "chain.obj").string() + " --png " + (dir / "dangling.png").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_symlink(dir / "chain.obj"));
  EXPECT_TRUE(fs::is_symlink(dir / "link.obj"));
  EXPECT_TRUE(fs::is_symlink(dir / "dangling.png"));
  EXPECT_GT(read_mesh((dir / "real" / "old.obj").string()).num_faces(), 0u);
  EXPECT_EQ(read_png((dir / "real" / "new.png").string()).width, 1024u);
  // Without --png the mesh goes through write_file_atomically, with the same policy.
  fs::remove(dir / "real" / "old.obj");
  r = run(terrain + "-o " + (dir / "link.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_symlink(dir / "link.obj"));
  EXPECT_TRUE(fs::is_regular_file(dir / "real" / "old.obj"));

  ASSERT_EQ(::mkfifo((dir / "fifo.obj").c_str(), 0644), 0);
  ASSERT_EQ(::mkfifo((dir / "fifo.png").c_str(), 0644), 0);
  fs::create_symlink("/dev/null", dir / "null.obj");
  const std::string ok = (dir / "ok.obj").string();
  for (const std::string& args : {terrain + "-o " + (dir / "fifo.obj").string(),
                                  terrain + "-o " + ok + " --png " + (dir / "fifo.png").string(),
                                  terrain + "-o " + (dir / "null.obj").string(),
                                  "subdiv cube --levels 1 -o " + (dir / "fifo.obj").string()}) {
    r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "named pipe (FIFO)") || contains(r.err, "character device")) << args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << args;  // before any work
    EXPECT_FALSE(fs::exists(ok)) << args;
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo.obj"));
  EXPECT_TRUE(fs::is_fifo(dir / "fifo.png"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));

  // Folder outputs: a FIFO among the demo's files stops it before any work; a link among them is written
  // through, and nothing of the staging is left.
  const fs::path demo = dir / "demo";
  fs::create_directories(demo);
  ASSERT_EQ(::mkfifo((demo / "view.obj").c_str(), 0644), 0);
  r = run("demo --quiet --size 17 --out " + demo.string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, (demo / "view.obj").string() + ": is a named pipe")) << r.err;
  EXPECT_EQ(r.out, "");
  fs::remove(demo / "view.obj");
  EXPECT_TRUE(fs::is_empty(demo));
  fs::create_symlink("../real/uniform.obj", demo / "uniform.obj");
  r = run("demo --quiet --size 17 --out " + demo.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_symlink(demo / "uniform.obj"));
  EXPECT_GT(read_mesh((dir / "real" / "uniform.obj").string()).num_faces(), 0u);
  EXPECT_TRUE(fs::is_regular_file(demo / "view.obj"));
  EXPECT_TRUE(staging_leftovers(dir).empty());
}

// Two outputs of one command that are one file (through symbolic links, dangling or not, or a hard link):
// the picture would have replaced the mesh. Refused before any work, naming both options; nothing written.
TEST(Robustness, TwoOutputsThatAreOneFileAreRefused) {
  const auto dir = testing::scratch_dir("robust_output_pairs");
  const fs::path field = write_small_terrain(dir);
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  CmdResult r = run("pm build " + (dir / "a.obj").string() + " --quiet -o " + (dir / "h.vmh").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  std::ofstream(dir / "kept.obj") << "kept\n";
  fs::create_symlink("kept.obj", dir / "kept_link.png");          // to an existing file
  fs::create_symlink("new.obj", dir / "new_link.png");            // both to one file that does not exist yet
  fs::create_symlink("new.obj", dir / "new_link.obj");
  fs::create_hard_link(dir / "kept.obj", dir / "kept_hard.png");  // a hard link cannot be told by its name
  const std::string terrain = "terrain " + field.string() + " --raw-size 17,17 --error 1 ";
  const std::string kept = (dir / "kept.obj").string(), a = (dir / "a.obj").string();
  const std::vector<std::string> cases = {
      terrain + "-o " + kept + " --png " + (dir / "kept_link.png").string(),
      terrain + "-o " + (dir / "new_link.obj").string() + " --png " + (dir / "new_link.png").string(),
      terrain + "-o " + kept + " --png " + (dir / "kept_hard.png").string(),
      "subdiv " + a + " --levels 1 -o " + kept + " --png " + (dir / "kept_link.png").string(),
      "pm query " + (dir / "h.vmh").string() + " --error 1 -o " + (dir / "new_link.obj").string() + " --png " +
          (dir / "new_link.png").string(),
  };
  for (const std::string& c : cases) {
    r = run(c, dir);
    EXPECT_EQ(r.status, 1) << c << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "-o '") && contains(r.err, "--png '") && contains(r.err, "are the same file"))
        << c << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c;
    EXPECT_EQ(testing::slurp(kept), "kept\n") << c;
    EXPECT_FALSE(fs::exists(dir / "new.obj")) << c;
  }
  EXPECT_TRUE(staging_leftovers(dir).empty());
  // Two different files through links are still fine.
  r = run(terrain + "-o " + (dir / "new_link.obj").string() + " --png " + (dir / "pic.png").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_GT(read_mesh((dir / "new.obj").string()).num_faces(), 0u);
}

// write_file_atomically, under every writer: the policy itself.
TEST(Robustness, WriteFileAtomicallyFollowsLinksAndRefusesSpecialFiles) {
  const auto dir = testing::scratch_dir("robust_write_atomically");
  fs::create_directories(dir / "sub");
  fs::create_symlink("sub/target.txt", dir / "rel.txt");                // relative, dangling
  fs::create_symlink((dir / "rel.txt").string(), dir / "abs.txt");       // absolute, to a link
  write_file_atomically((dir / "abs.txt").string(), "one");
  EXPECT_TRUE(fs::is_symlink(dir / "abs.txt"));
  EXPECT_TRUE(fs::is_symlink(dir / "rel.txt"));
  EXPECT_EQ(testing::slurp(dir / "sub" / "target.txt"), "one");
  write_file_atomically((dir / "rel.txt").string(), "two");
  EXPECT_EQ(testing::slurp(dir / "sub" / "target.txt"), "two");
  EXPECT_EQ(resolve_output_path((dir / "abs.txt").string()), dir / "sub" / "target.txt");

  fs::create_symlink("loop_b", dir / "loop_a");
  fs::create_symlink("loop_a", dir / "loop_b");
  fs::create_symlink("sub", dir / "folder_link");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0644), 0);
  const struct {
    std::string path, says;
  } refused[] = {{(dir / "loop_a").string(), "too many levels of symbolic links"},
                 {(dir / "sub").string(), "is a folder"},
                 {(dir / "folder_link").string(), "is a folder"},
                 {(dir / "fifo").string(), "is a named pipe (FIFO)"},
                 {"/dev/null", "is a character device"}};
  for (const auto& c : refused) {
    try {
      write_file_atomically(c.path, "x");
      ADD_FAILURE() << c.path << " was written";
    } catch (const IoError& e) {
      EXPECT_EQ(e.file(), c.path);
      EXPECT_TRUE(contains(e.reason(), c.says)) << e.what();
    }
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo"));
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir / "loop_a")));
  EXPECT_TRUE(staging_leftovers(dir).empty());
}

// terrain took --spacing, --z-scale or .raw samples near +-3e38 that put the coordinates beyond float's
// reach: it wrote meshes the tool refuses to read, or failed with internal words ("frame_sphere: radius
// inf", "height field sample (1, 1) is not finite"). build --method adaptive said "tolerance must be finite
// and > 0, got inf" when no tolerance was given.
TEST(Robustness, TerrainCoordinatesBeyondFloatsReachAreNamedUpFront) {
  const auto dir = testing::scratch_dir("robust_terrain_span");
  const fs::path field = write_small_terrain(dir);  // heights within 0..20
  HeightField huge;
  huge.width = huge.height = 4;
  for (int i = 0; i < 16; ++i) huge.z.push_back(i % 2 ? 3e38f : -3e38f);
  write_heightfield_raw((dir / "huge.raw").string(), huge);
  const std::string out = (dir / "out.obj").string();
  const std::string small = "terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + out;
  const std::string big = (dir / "huge.raw").string() + " --raw-size 4,4";
  const struct {
    std::string args, says;
  } cases[] = {
      {"terrain " + big + " --error 1 -o " + out, (dir / "huge.raw").string() + ": the heights span 6e+38"},
      {small + " --spacing 1e18", "--spacing 1e+18: the terrain's bounding box is 2.26274e+19 across"},
      {small + " --z-scale 1e37", "--z-scale 1e+37: the heights span"},
      {small + " --z-scale 3e38", "--z-scale 3e+38 makes heights of"},
      {small + " --spacing 7e17 --z-scale 9e17", "--spacing 7e+17 and --z-scale 9e+17"},
      {"build " + big + " --method adaptive --quiet -o " + (dir / "h.vrm").string(), (dir / "huge.raw").string()},
      {"demo --quiet --heightfield " + big + " --out " + (dir / "demo").string(), (dir / "huge.raw").string()},
  };
  for (const auto& c : cases) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "tolerance")) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "not finite")) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "h.vrm"));
  EXPECT_FALSE(fs::exists(dir / "demo"));
  // Just inside the limit (a diagonal of 1.1e19) the mesh is written, and the tool reads it back.
  CmdResult r = run(small + " --spacing 5e17", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("subdiv " + out + " --levels 1 -o " + (dir / "again.obj").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
}

// --raw-size was parsed as floats and cast (undefined for 1e20; 16777217 read as 16777216); a raw file
// without it, and --terrain-rgb on a PGM, were reported by an internal function's name.
TEST(Robustness, RawSizeIsTwoIntegersAndMissingOptionsAreNamed) {
  const auto dir = testing::scratch_dir("robust_raw_size");
  const fs::path field = write_small_terrain(dir);
  std::ofstream(dir / "x.pgm", std::ios::binary) << "P5\n2 2\n255\n" << std::string(4, '\x10');
  const std::string out = (dir / "out.obj").string();
  const std::string terrain = "terrain " + field.string() + " --error 1 -o " + out;
  const struct {
    std::string args, says;
  } cases[] = {
      {terrain + " --raw-size 1e20,17", "--raw-size: expected two positive integers W,H, not '1e20,17'"},
      {terrain + " --raw-size 17.5,17", "--raw-size: expected two positive integers"},
      {terrain + " --raw-size 0,17", "--raw-size: expected two positive integers"},
      {terrain + " --raw-size -17,17", "--raw-size: expected two positive integers"},
      {terrain + " --raw-size 17", "--raw-size: expected two positive integers"},
      {terrain + " --raw-size 18446744073709551617,1", "--raw-size: W and H must be at most 268435456"},
      {terrain + " --raw-size 16777217,1", "16777217x1 float32 samples need 67108868"},
      {terrain, "give its size with --raw-size W,H"},
      {"build " + field.string() + " --method adaptive --quiet -o " + (dir / "h.vrm").string(), "--raw-size W,H"},
      {"demo --quiet --heightfield " + field.string() + " --out " + (dir / "d").string(), "--raw-size W,H"},
      {"terrain " + (dir / "x.pgm").string() + " --terrain-rgb --error 1 -o " + out,
       "--terrain-rgb decodes PNG pictures only, not '" + (dir / "x.pgm").string() + "'"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "read_heightfield")) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
}

// Negative values of options checked by CLI11's NonNegativeNumber printed DBL_MAX in 309 digits; `demo
// --out ""` said "filesystem error: cannot make absolute path"; empty values passed for "not given"; options
// that mean nothing without another were ignored; `compare --image FOLDER` said "no such file".
TEST(Robustness, OptionValuesGetCleanMessages) {
  const auto dir = testing::scratch_dir("robust_option_values");
  const fs::path field = write_small_terrain(dir);
  fs::create_directories(dir / "folder");
  const std::string out = (dir / "out.obj").string(), vrm = (dir / "h.vrm").string(), vmh = (dir / "h.vmh").string();
  const std::string terrain = "terrain " + field.string() + " --raw-size 17,17 -o " + out;
  const struct {
    std::string args, says;
  } cases[] = {
      {terrain + " --error -1", "--error: must be >= 0, not -1"},
      {terrain + " --error 1 --budget -1", "--budget: must be an integer >= 0, not '-1'"},
      {"query " + vrm + " --budget -1 -o " + out, "--budget: must be an integer >= 0"},
      {"pm query " + vmh + " --budget -1 -o " + out, "--budget: must be an integer >= 0"},
      {"pm query " + vmh + " --budget 2.5 -o " + out, "--budget: must be an integer >= 0, not '2.5'"},
      {"pm build " + out + " --faces -5 -o " + vmh, "--faces: must be an integer >= 0, not '-5'"},
      {"pm build " + out + " --vertices -5 -o " + vmh, "--vertices: must be an integer >= 0"},
      {"demo --quiet --out ''", "--out: empty file name"},
      {terrain + " --error 1 --png ''", "--png: empty file name"},
      {"build cube.obj -o " + vrm + " --pictures ''", "--pictures: empty file name"},
      {terrain + " --camera '' --pixels 2", "--camera: empty value"},
      {"query " + vrm + " -o " + out + " --camera '' --pixels 2", "--camera: empty value"},
      {"demo --quiet --heightfield '' --out " + (dir / "d").string(), "--heightfield: empty file name"},
      {"compare --quiet --image '' --out " + (dir / "c").string(), "--image: empty file name"},
      {"subdiv cube --levels 1 --scheme '' -o " + out, "--scheme: empty value"},
      {"subdiv cube --levels 1 -o ''", "--output: empty file name"},
      {"demo --quiet --raw-size 17,17 --out " + (dir / "d").string(), "--raw-size requires --heightfield"},
      {"demo --quiet --heightfield " + field.string() + " --raw-size 17,17 --size 33 --out " + (dir / "d").string(),
       "--size excludes --heightfield"},
      {terrain + " --error 1 --pixels 2", "--pixels requires --camera"},
      {"query " + vrm + " -o " + out + " --error 1 --up 0,1,0", "--up requires --png"},
      {"compare --quiet --image " + (dir / "folder").string() + " --out " + (dir / "c").string(), "is a folder, not a picture file"},
      {"compare --quiet --cases cow --image " + field.string() + " --out " + (dir / "c").string(), "--image is for the image case"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_LT(r.err.size(), 200u) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "filesystem error")) << c.args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c.args;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "d"));
  EXPECT_FALSE(fs::exists(dir / "c"));
}

// A write that failed inside a staging folder named it ("dem/.varmesh-partial-23497-285899160/uniform.obj:
// write failed"): the user's final path is named now. Files are limited to 2 kB, as a full disk would.
TEST(Robustness, FailedWritesInStagedFoldersNameTheFinalPath) {
  const auto dir = testing::scratch_dir("robust_staged_names");
  const fs::path demo = dir / "demo", fig = dir / "fig";
  const struct {
    std::string args, names;
  } cases[] = {
      {"demo --quiet --size 17 --out " + demo.string(), (demo / "uniform.obj").string() + ": write failed: File too large"},
      {"subdiv cube --levels 1 --figure " + fig.string(), (fig / "cube_base.png").string() + ": write failed"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run_limited(Limit::kFileBlocks, 4, c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.names)) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "partial")) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(demo));
  EXPECT_FALSE(fs::exists(fig));
}

// A FIFO given as an input blocked the open until something wrote to it: with no writer, every command
// hung (info, query, pm query, terrain, render). A link to a device read as an empty file ("no faces").
// Both are refused by what they are, before they are opened; `timeout` turns a regression into a failure.
TEST(Robustness, SpecialFilesGivenAsInputsAreRefusedWithoutWaiting) {
  const auto dir = testing::scratch_dir("robust_special_inputs");
  for (const char* name : {"m.obj", "h.vrm", "h.vmh", "t.pgm"}) ASSERT_EQ(::mkfifo((dir / name).c_str(), 0644), 0);
  fs::create_symlink("/dev/zero", dir / "zero.obj");
  const std::string out = (dir / "out.obj").string();
  const struct {
    std::string args, says;
  } cases[] = {
      {"info " + (dir / "m.obj").string(), (dir / "m.obj").string() + ": cannot read: it is a named pipe (FIFO)"},
      {"info " + (dir / "h.vrm").string(), (dir / "h.vrm").string() + ": cannot read: it is a named pipe (FIFO)"},
      {"render " + (dir / "m.obj").string() + " -o " + (dir / "r.png").string(), "named pipe (FIFO), not a regular file"},
      {"query " + (dir / "h.vrm").string() + " --error 1 -o " + out, (dir / "h.vrm").string() + ": cannot read"},
      {"pm query " + (dir / "h.vmh").string() + " --error 1 -o " + out, (dir / "h.vmh").string() + ": cannot read"},
      {"terrain " + (dir / "t.pgm").string() + " --error 1 -o " + out, (dir / "t.pgm").string() + ": cannot read"},
      {"info " + (dir / "zero.obj").string(), (dir / "zero.obj").string() + ": cannot read: it is a character device"},
  };
  for (const auto& c : cases) {
    const CmdResult r = run_limited(Limit::kSeconds, 60, c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "r.png"));
  EXPECT_TRUE(fs::is_fifo(dir / "m.obj"));
}

// Cameras that float cannot place failed with the words of an internal check ("camera: z_near 0.000000 and
// z_far 0.000000 must satisfy ...", "frustum: plane 5 is not finite"), or not at all; render --fov nan
// passed CLI11's range check and was named "camera fov_y_deg".
TEST(Robustness, CamerasBeyondFloatsReachAreNamedByTheirOption) {
  const auto dir = testing::scratch_dir("robust_camera_reach");
  const fs::path field = write_small_terrain(dir);
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const std::string a = (dir / "a.obj").string(), vmh = (dir / "h.vmh").string(), out = (dir / "out.obj").string();
  CmdResult r = run("pm build " + a + " --quiet -o " + vmh, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string terrain = "terrain " + field.string() + " --raw-size 17,17 -o " + out;
  const struct {
    std::string args, says;
  } cases[] = {
      {"pm query " + vmh + " -o " + out + " --camera 1e-30,0,0,0,0,0,40", "--camera: eye and target are too close together"},
      {"subdiv " + a + " --steps 1 --adaptive --camera 1e-30,0,0,0,0,0,40 -o " + out,
       "--camera: eye and target are too close together"},
      {terrain + " --camera 1e20,8,10,8,8,0,40", "--camera: the eye is too far from the terrain"},
      {terrain + " --camera 1e-40,1e-40,1e-40,0,0,0,40 --spacing 1e-40 --z-scale 1e-40",
       "--camera: the eye and the terrain are too close together"},
      {"render " + a + " -o " + (dir / "r.png").string() + " --fov nan", "--fov must be a number in [1, 170]"},
  };
  for (const auto& c : cases) {
    r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << c.args << "\n" << r.err;
    EXPECT_FALSE(contains(r.err, "z_near") || contains(r.err, "frustum") || contains(r.err, "fov_y_deg"))
        << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "r.png"));
  // Samples 1e-40 apart seen from afar: the near plane is kept within 1e12 of the far one (the frustum had
  // no far plane), and the extraction goes through.
  r = run(terrain + " --camera 10,10,100,10,10,0,40 --spacing 1e-40", dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_GT(read_mesh(out).num_faces(), 0u);
}

// The demo on a needle (heights up to 2e18 on 17 x 17 samples, beyond spread_samples' reach): its view
// camera looked straight down with +z up ("render: camera up is zero or parallel to the view direction",
// after all the work), and its top view crashed the renderer (clipped points with w <= 0).
TEST(Robustness, DemoDrawsANeedleHeightField) {
  const auto dir = testing::scratch_dir("robust_demo_needle");
  HeightField needle;
  needle.width = needle.height = 17;
  for (std::size_t i = 0; i < 17 * 17; ++i) needle.z.push_back(1e18f * float(i % 3));
  write_heightfield_raw((dir / "n.f32").string(), needle);
  const fs::path out = dir / "demo";
  const CmdResult r = run("demo --quiet --heightfield " + (dir / "n.f32").string() + " --raw-size 17,17 --out " + out.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* name : {"uniform.png", "view_camera.png", "uniform_topdown.png", "view_topdown.png"})
    EXPECT_GT(read_png((out / name).string()).width, 0u) << name;
  EXPECT_GT(read_mesh((out / "view.obj").string()).num_faces(), 0u);
}

// An output name of 250 bytes is valid (255 is the limit), but its temporary names, the name with a prefix
// and a suffix, were not: every writer failed with "cannot create a temporary file: File name too long".
TEST(Robustness, OutputNamesNearTheLengthLimitAreWritten) {
  const auto dir = testing::scratch_dir("robust_long_names");
  const fs::path field = write_small_terrain(dir);
  const std::string stem(246, 'n');  // 250 bytes with ".obj"
  const std::string mesh = (dir / (stem + ".obj")).string(), png = (dir / (stem + ".png")).string();
  CmdResult r = run("terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + mesh + " --png " + png, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_GT(read_mesh(mesh).num_faces(), 0u);
  EXPECT_GT(read_png(png).width, 0u);
  const std::string vmh = (dir / (stem + ".vmh")).string();
  r = run("pm build " + mesh + " --quiet -o " + vmh, dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(vmh));
  const std::string longest(255, 'x');
  write_file_atomically((dir / longest).string(), "contents");
  EXPECT_EQ(testing::slurp(dir / longest), "contents");
  EXPECT_TRUE(staging_leftovers(dir).empty());
  EXPECT_EQ(bounded_file_name(".", std::string(300, 'a'), ".partial-1.obj").size(), 255u);
  EXPECT_EQ(bounded_file_name(".tmp.", "short.obj", ".7"), ".tmp.short.obj.7");
}

// With no camera option, a mesh whose faces are sub-pixel in the default view (one stray vertex 1e15 away
// sets the framing) or have no area was refused as "the camera sees none of the mesh (eye ..., target ...)",
// blaming a camera the user had not given and naming no file.
TEST(Robustness, RenderNamesAMeshTheDefaultViewCannotShow) {
  const auto dir = testing::scratch_dir("robust_render_default_view");
  std::ofstream(dir / "stray.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e15 1e15 1e15\nv 1e15 1e15 1.0000001e15\n"
                                      "v 1e15 1.0000001e15 1e15\nf 1 2 3\nf 4 5 6\n";
  std::ofstream(dir / "point.obj") << "v 2 2 2\nv 2 2 2\nv 2 2 2\nf 1 2 3\n";
  for (const char* name : {"stray.obj", "point.obj"}) {
    const std::string mesh = (dir / name).string(), png = (dir / "p.png").string();
    const CmdResult r = run("render " + mesh + " -o " + png, dir);
    EXPECT_EQ(r.status, 1) << name << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, mesh + ": no face covers a pixel of the default view")) << r.err;
    EXPECT_FALSE(fs::exists(png));
  }
}

// A .vrm with a coordinate near 3.4e38 and valid checksums (edited, or damaged and re-sealed) was queried:
// the mesh written could not be read back by varmesh, and --png failed with "render: camera needs 0 <
// z_near < z_far < inf, got z_near inf". The file is now refused by name, as read_input_mesh refuses meshes.
TEST(Robustness, QueryRefusesAHierarchyBeyondFloatsReach) {
  const auto dir = testing::scratch_dir("robust_query_extent");
  std::ofstream(dir / "q.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const std::string vrm = (dir / "h.vrm").string(), out = (dir / "out.obj").string();
  CmdResult r = run("build " + (dir / "q.obj").string() + " --levels 1 --quiet -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  std::string bytes = testing::slurp(vrm);
  const float huge = 3.0e38f;
  std::uint32_t bits = 0;
  std::memcpy(&bits, &huge, sizeof bits);
  testing::put_le(bytes, testing::kVrmHeaderBytes + 4, bits, 4);  // vertex 0's y
  testing::reseal(bytes);
  std::ofstream(vrm, std::ios::binary) << bytes;
  for (const std::string& extra : {std::string(), " --png " + (dir / "q.png").string()}) {
    r = run("query " + vrm + " --error 0 -o " + out + extra, dir);
    EXPECT_EQ(r.status, 1) << extra << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, vrm + ": the coordinates span more than about 1.8e19")) << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(dir / "q.png"));
  }
}

// Out of memory printed "std::bad_alloc" alone. Address space limited by ulimit -v, which the sanitizers'
// shadow memory cannot live with.
TEST(Robustness, OutOfMemoryIsSaid) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ulimit -v and AddressSanitizer do not mix";
#else
  const auto dir = testing::scratch_dir("robust_out_of_memory");
  const fs::path out = dir / "demo";
  const CmdResult r = run_limited(Limit::kMemoryKb, 80000, "demo --quiet --size 2049 --out " + out.string(), dir);
  const std::string& err = r.err;
  EXPECT_EQ(r.status, 1) << err;
  EXPECT_EQ(count_lines(err), 1) << err;
  // "out of memory while <step> (varmesh demo)" when the failure falls within one of the steps announced on
  // stderr (which one depends on the machine).
  EXPECT_TRUE(contains(err, "varmesh: error: out of memory")) << err;
  EXPECT_TRUE(contains(err, "(varmesh demo)")) << err;
  EXPECT_FALSE(fs::exists(out));
#endif
}

// A file-size limit (ulimit -f) killed the command with SIGXFSZ in the middle of a write: the staged
// ".tmp.<name>.<n>" file stayed beside the output. The command ignores the signal, so the write fails
// with EFBIG like any failed write: one line naming the file, the staged file removed, the old file kept.
// (The other runs under a file limit, run_limited, ignore the signal in the shell first.)
TEST(Robustness, AFileSizeLimitLeavesNoStagedFile) {
  const auto dir = testing::scratch_dir("robust_file_size_limit");
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const fs::path out = dir / "out" / "big.obj";
  fs::create_directories(out.parent_path());
  std::ofstream(out) << "keep\n";
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "sh -c \"ulimit -f 4; " + std::string(VARMESH_EXE) + " subdiv " + (dir / "a.obj").string() +
                          " --levels 4 -o " + out.string() + "\" >/dev/null 2>" + err.string();
  const int raw = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(raw)) << "killed by signal " << (WIFSIGNALED(raw) ? WTERMSIG(raw) : 0);
  const std::string text = testing::slurp(err);
  EXPECT_EQ(WEXITSTATUS(raw), 1) << text;
  EXPECT_EQ(count_lines(text), 1) << text;
  EXPECT_TRUE(contains(text, out.string())) << text;
  EXPECT_EQ(testing::slurp(out), "keep\n");
  EXPECT_EQ(staging_leftovers(out.parent_path()), std::vector<std::string>{});
}

// A --view or --up given with large components (3e19: its squared length overflows float) is a direction
// like any other; it was taken for zero by the camera framing, which said "frame_sphere: the centre is not
// finite or the view direction is zero", and build --pictures said so after the whole build.
TEST(Robustness, PictureDirectionsOfAnySizeFrameTheModel) {
  const auto dir = testing::scratch_dir("robust_picture_direction_size");
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
                                  "f 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nf 1 4 3\nf 1 3 2\n";
  const std::string a = (dir / "a.obj").string(), out = (dir / "out.obj").string(), png = (dir / "p.png").string();
  CmdResult r = run("pm build " + a + " --quiet -o " + (dir / "h.vmh").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::string> commands = {
      "render " + a + " -o " + png,
      "pm query " + (dir / "h.vmh").string() + " --error 0 -o " + out + " --png " + png,
      "subdiv " + a + " --levels 1 -o " + out + " --png " + png,
      "build " + a + " --quiet --levels 1 -o " + (dir / "h.vrm").string() + " --pictures " + (dir / "pics").string(),
  };
  const std::vector<std::string> axes_given = {" --view 3e19,0,0", " --view 1e30,1e30,1e30",
                                               " --view 1e-30,0,0 --up 0,1e-30,0", " --up 0,3e19,0 --view 0,0,1"};
  for (const std::string& axes : axes_given) {
    for (const std::string& command : commands) {
      fs::remove_all(dir / "pics");
      fs::remove(png);
      r = run(command + axes, dir);
      EXPECT_EQ(r.status, 0) << command + axes << "\n" << r.err;
      EXPECT_FALSE(contains(r.err, "frame_sphere")) << command + axes << "\n" << r.err;
      const std::string picture = fs::exists(dir / "pics") ? (dir / "pics" / "semiregular_level1.png").string() : png;
      ASSERT_TRUE(fs::exists(picture)) << command + axes;
      // The model is in the picture: some pixels differ from the white background.
      const Image im = read_png(picture);
      std::size_t drawn = 0;
      for (std::size_t i = 0; i + 2 < im.pixels.size(); i += im.channels) drawn += im.pixels[i] != 255 || im.pixels[i + 1] != 255;
      EXPECT_GT(drawn, 100u) << command + axes;
    }
  }
  // The same option refused when it is zero, before any work.
  r = run("render " + a + " -o " + png + " --view 0,0,0", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "--view: the direction is zero")) << r.err;
}

// --max-triangles -1 was wrapped to 2^64 - 1 by the parser: build said "must be in 1 .. 2^31, not
// 18446744073709551615", a number the user never typed, and subdiv named no value at all.
TEST(Robustness, MaxTrianglesNamesTheValueGiven) {
  const auto dir = testing::scratch_dir("robust_max_triangles_value");
  std::ofstream(dir / "a.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
  const std::string a = (dir / "a.obj").string();
  const std::string build = "build " + a + " -o " + (dir / "h.vrm").string() + " --quiet";
  const std::string subdiv = "subdiv " + a + " --levels 1 -o " + (dir / "s.obj").string();
  for (const std::string& command : {build, subdiv}) {
    for (const std::string value : {"-1", "99999999999999999999999", "1.5", "0", "4294967296"}) {
      const CmdResult r = run(command + " --max-triangles " + value, dir);
      EXPECT_EQ(r.status, 1) << command << " " << value << "\n" << r.err;
      EXPECT_EQ(count_lines(r.err), 1) << r.err;
      EXPECT_TRUE(contains(r.err, "--max-triangles")) << r.err;
      EXPECT_TRUE(contains(r.err, value)) << command << " " << value << "\n" << r.err;
      EXPECT_FALSE(contains(r.err, "18446744073709551615")) << r.err;
    }
  }
  EXPECT_FALSE(fs::exists(dir / "h.vrm"));
  EXPECT_FALSE(fs::exists(dir / "s.obj"));
}

// Runs varmesh with `args` (stdout to /dev/null) and stderr on a pipe whose reading end is already closed:
// its first progress line raises SIGPIPE, as a closed terminal or `| head` would. Returns the wait status.
int run_with_stderr_closed(const std::vector<std::string>& args) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  ::close(fds[0]);
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::signal(SIGPIPE, SIG_DFL);  // the test runner may ignore it, and exec keeps an ignored signal ignored
    ::dup2(fds[1], 2);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    std::vector<char*> argv{const_cast<char*>(VARMESH_EXE)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(VARMESH_EXE, argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

// A command ended by a signal while its staging folder exists (compare makes it first, then reports its
// progress on stderr) removes the staging folder and the folders it made for the output: the default
// action of SIGPIPE left .varmesh-partial-* behind.
TEST(Robustness, AnInterruptedCommandLeavesNoStagingFolder) {
  const auto dir = testing::scratch_dir("robust_interrupted");
  fs::create_directories(dir / "existing");
  for (const fs::path& out : {dir / "new" / "out", dir / "existing"}) {
    const int status = run_with_stderr_closed({"compare", "--quick", "--cases", "image", "--out", out.string()});
    ASSERT_TRUE(WIFSIGNALED(status)) << out << ": status " << status;
    EXPECT_EQ(WTERMSIG(status), SIGPIPE) << out;
    EXPECT_EQ(staging_leftovers(dir), std::vector<std::string>{}) << out;
  }
  EXPECT_FALSE(fs::exists(dir / "new")) << "the folders made for the output stay after an interruption";
  EXPECT_TRUE(fs::is_directory(dir / "existing")) << "the user's folder was removed";
}

}  // namespace
}  // namespace varmesh
