// Hostile input and failing outputs, as found by fuzzing the varmesh command: every case exits 1 with one
// line of error that names the file, line or option at fault, and leaves no output behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/terrain_gen.hpp"
#include "apps/cli_support.hpp"
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

}  // namespace
}  // namespace varmesh
