// Findings of a review of the README and the command line, as a user meets them: demo on a real height field
// (--spacing, --z-scale, drawable proportions), environment variables that name nothing, pm build's targets
// that are not reached, build's size guard, query and pm query on the other kind of hierarchy, and messages
// that read badly (subdiv's refused step count, build's printout and --help, info's node error).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "apps/cli_support.hpp"
#include "mesh_fixtures.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/shapes.hpp"
#include "pm/hierarchy_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::contains;
using testing::count_lines;
using testing::EnvGuard;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh(args, dir); }

// A headerless float32 height field of n x n samples: a cone `peak` high (heights in "metres" on a grid of
// unit spacing: a needle when peak is much more than n).
fs::path write_cone_raw(const fs::path& dir, int n, float peak) {
  const fs::path path = dir / "cone.raw";
  std::vector<float> z(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  const float c = 0.5f * float(n - 1);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float r = std::hypot(float(x) - c, float(y) - c) / c;
      z[static_cast<std::size_t>(y * n + x)] = peak * std::max(0.0f, 1.0f - r) + 0.05f * peak * float((x * 7 + y * 3) % 5) / 5.0f;
    }
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(z.data()), static_cast<std::streamsize>(z.size() * sizeof(float)));
  return path;
}

// The extent in x of a mesh file's vertices.
float x_extent(const fs::path& mesh) {
  const TriMesh m = read_mesh(mesh.string());
  float lo = m.positions.front().x, hi = lo;
  for (const glm::vec3& p : m.positions) {
    lo = std::min(lo, p.x);
    hi = std::max(hi, p.x);
  }
  return hi - lo;
}

// The fraction of the picture's width spanned by pixels that are not the white background.
double drawn_width_fraction(const fs::path& png) {
  const Image img = read_png(png.string());
  std::size_t lo = img.width, hi = 0;
  for (std::size_t y = 0; y < img.height; ++y)
    for (std::size_t x = 0; x < img.width; ++x) {
      const std::uint8_t* p = &img.pixels[(y * img.width + x) * static_cast<std::size_t>(img.channels)];
      if (p[0] < 240 || p[1] < 240 || p[2] < 240) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
  return hi < lo ? 0.0 : double(hi - lo + 1) / double(img.width);
}

// Finding 6: heights in metres on samples 1 apart drew a needle (Fuji: 3737 m over 511 samples). Without
// --spacing and --z-scale such a field is laid out with a round spacing and a note says so; the pictures
// show a landscape, not a spike.
TEST(CliReview, DemoLaysOutANeedleHeightFieldAndSaysSo) {
  const fs::path dir = testing::scratch_dir("review_demo_needle");
  const fs::path raw = write_cone_raw(dir, 65, 500.0f);
  const fs::path out = dir / "out";
  const CmdResult r = run("demo --quiet --heightfield " + raw.string() + " --raw-size 65,65 --out " + out.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  // 500 / (0.2 x 64) = 39 rounds up to 50: the relief is 500 / 3200 of the width.
  EXPECT_TRUE(contains(r.out, "terrain 65 x 65 samples 50 apart, height range 5")) << r.out;
  EXPECT_TRUE(contains(r.out, "note: no --spacing: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "the samples are placed 50 apart here")) << r.out;
  EXPECT_NEAR(x_extent(out / "uniform.obj"), 64.0f * 50.0f, 1e-3f);
  // The overview frames a flat-ish landscape: it spans a good part of the picture's width (the needle
  // spanned about a tenth).
  EXPECT_GT(drawn_width_fraction(out / "uniform.png"), 0.4) << "uniform.png is a needle";
  EXPECT_GT(drawn_width_fraction(out / "view_camera.png"), 0.6);
}

// --spacing and --z-scale as terrain has them: the same meaning (x = column * spacing; heights times the
// factor) and the same checks, before any work; either one turns the automatic layout off.
TEST(CliReview, DemoTakesSpacingAndZScaleAsTerrainDoes) {
  const fs::path dir = testing::scratch_dir("review_demo_spacing");
  const fs::path raw = write_cone_raw(dir, 65, 500.0f);
  const std::string field = "demo --quiet --heightfield " + raw.string() + " --raw-size 65,65 ";
  CmdResult r = run(field + "--spacing 2 --out " + (dir / "s2").string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "terrain 65 x 65 samples 2 apart")) << r.out;
  EXPECT_FALSE(contains(r.out, "note:")) << r.out;
  EXPECT_NEAR(x_extent(dir / "s2" / "uniform.obj"), 128.0f, 1e-4f);
  // The terrain command's mesh of the same field and spacing spans the same box.
  r = run("terrain " + raw.string() + " --raw-size 65,65 --spacing 2 --error 1 -o " + (dir / "t.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NEAR(x_extent(dir / "t.obj"), 128.0f, 1e-4f);

  // --z-scale alone: heights scaled, spacing 1 as asked (no layout note).
  r = run(field + "--z-scale 0.01 --out " + (dir / "z").string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "terrain 65 x 65 samples, height range 5.")) << r.out;
  EXPECT_FALSE(contains(r.out, "note:")) << r.out;
  EXPECT_NEAR(x_extent(dir / "z" / "uniform.obj"), 64.0f, 1e-4f);

  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {field + "--spacing 0", "demo: --spacing must be finite and > 0"},
      {field + "--spacing -3", "demo: --spacing must be finite and > 0"},
      {field + "--spacing nan", "demo: --spacing must be finite and > 0"},
      {field + "--z-scale inf", "demo: --z-scale must be a finite number"},
      {field + "--spacing 1e30", "--spacing 1e+30: the terrain's bounding box is"},
      {field + "--z-scale 1e37", "--z-scale 1e+37 makes heights of"},
      {"demo --quiet --spacing 2", "--spacing requires --heightfield"},
      {"demo --quiet --z-scale 2", "--z-scale requires --heightfield"},
  };
  for (const Case& c : cases) {
    const fs::path out = dir / "bad";
    r = run(c.args + " --out " + out.string(), dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.out << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.message)) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
}

// The generated terrain keeps its layout (spacing 1, no note): the default demo did not change.
TEST(CliReview, DemoOnTheGeneratedTerrainIsUnchanged) {
  const fs::path dir = testing::scratch_dir("review_demo_default");
  const CmdResult r = run("demo --quiet --size 65 --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "terrain 65 x 65 samples, height range")) << r.out;
  EXPECT_FALSE(contains(r.out, "note:")) << r.out;
  EXPECT_NEAR(x_extent(dir / "out" / "uniform.obj"), 64.0f, 1e-4f);
  EXPECT_GT(drawn_width_fraction(dir / "out" / "uniform.png"), 0.4);
}

// A small compare run (one case, generated stand-in) with `env` set; the packaged archive is turned off
// unless the test sets it.
CmdResult compare_cow(const fs::path& dir, const std::string& extra = "") {
  return run("compare --quick --quiet --panel 64 --cases cow --out " + (dir / "out").string() + " " + extra, dir);
}

// Finding 8: a variable that is set and names nothing was ignored (VARMESH_DATA=/nonexistent used the
// packaged meshes, VARMESH_PACKAGED_MESHES=/nonexistent.tar.gz the generated ones) while --data nothere is
// an error. Now both are errors naming the variable and the path, before anything is written.
TEST(CliReview, CompareRefusesEnvironmentVariablesThatNameNothing) {
  const fs::path dir = testing::scratch_dir("review_compare_env");
  const fs::path missing = dir / "nonexistent";
  {
    const EnvGuard data("VARMESH_DATA", missing.string());
    const CmdResult r = compare_cow(dir);
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, "VARMESH_DATA: '" + missing.string() + "' is not a folder")) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  for (const fs::path& bad : {dir / "nonexistent.tar.gz", empty}) {
    const EnvGuard packaged("VARMESH_PACKAGED_MESHES", bad.string());
    const CmdResult r = compare_cow(dir, "--data " + empty.string());
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, "VARMESH_PACKAGED_MESHES: '" + bad.string() + "'")) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
  // "none" asks for the generated stand-ins; an existing VARMESH_DATA folder is the data folder.
  const EnvGuard none("VARMESH_PACKAGED_MESHES", "none");
  const EnvGuard data("VARMESH_DATA", empty.string());
  const CmdResult r = compare_cow(dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "generated torus")) << r.out;
  EXPECT_FALSE(contains(r.err, "not found")) << r.err;
  const CmdResult help = run("compare --help", dir);
  EXPECT_TRUE(contains(help.out, "VARMESH_PACKAGED_MESHES")) << help.out;
  EXPECT_TRUE(contains(help.out, "none: no packaged meshes")) << help.out;
}

// `n` icosahedra side by side, as one mesh of separate pieces.
TriMesh separate_icosahedra(int n) {
  const TriMesh one = make_icosphere(0);
  TriMesh all;
  for (int k = 0; k < n; ++k) {
    const Index base = static_cast<Index>(all.positions.size());
    for (const glm::vec3& p : one.positions) all.positions.push_back(p + glm::vec3(3.0f * float(k), 0.0f, 0.0f));
    for (Index i : one.indices) all.indices.push_back(base + i);
  }
  return all;
}

// Finding 9: a target that the analysis cannot reach ended with exit 0 and no word. Now a note names the
// target, what was reached and why (the checks that refused the collapses; the pieces that keep 4
// vertices each).
TEST(CliReview, PmBuildSaysWhenATargetIsNotReached) {
  const fs::path dir = testing::scratch_dir("review_pm_target");
  const fs::path mesh = dir / "pieces.obj";
  write_mesh(mesh.string(), separate_icosahedra(5));  // 60 vertices in 5 pieces: at best 20 vertices, 20 faces
  const fs::path vmh = dir / "p.vmh";
  CmdResult r = run("pm build " + mesh.string() + " --quiet --vertices 10 -o " + vmh.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const VertexHierarchy h = read_vertex_hierarchy(vmh.string());
  EXPECT_EQ(h.num_roots(), 20u);
  EXPECT_TRUE(contains(r.out, "note: --vertices 10 not reached: the base mesh has 20 vertices; no collapse left passes the checks"))
      << r.out;
  EXPECT_TRUE(contains(r.out, "the base mesh is 5 separate pieces")) << r.out;
  EXPECT_TRUE(contains(r.out, "no piece goes below 4 vertices")) << r.out;
  r = run("pm build " + mesh.string() + " --quiet --faces 12 -o " + vmh.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "note: --faces 12 not reached: the base mesh has 20 faces")) << r.out;
  // A --max-error that stops the analysis short of the target is named among the reasons.
  r = run("pm build " + mesh.string() + " --quiet --faces 24 --max-error 0 -o " + vmh.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "note: --faces 24 not reached")) << r.out;
  EXPECT_TRUE(contains(r.out, "were over --max-error")) << r.out;
  // A target reached: no note.
  write_mesh((dir / "torus.obj").string(), testing::torus_grid(16, 8));
  r = run("pm build " + (dir / "torus.obj").string() + " --quiet --vertices 20 -o " + vmh.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(contains(r.out, "note:")) << r.out;
}

// Finding 12: build had no size guard (the cow at --levels 12: 23.8M faces, a minute). The finest face count
// (base faces x 2^levels) is checked against --max-triangles (default 2^22) before the build.
TEST(CliReview, BuildRefusesAFinestMeshOverMaxTriangles) {
  const fs::path dir = testing::scratch_dir("review_build_size");
  const fs::path mesh = dir / "ico.off";
  write_mesh(mesh.string(), testing::icosahedron_mesh());  // 20 faces
  const fs::path vrm = dir / "ico.vrm";
  // 20 x 2^18 = 5.2M faces: over the default.
  CmdResult r = run("build " + mesh.string() + " --levels 18 --quiet -o " + vrm.string(), dir);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, "build: --levels 18 on the 20 faces of '" + mesh.string() +
                                  "' would make 5.243e+06 faces in the finest mesh (20 x 2^18), more than "
                                  "--max-triangles 4194304"))
      << r.err;
  EXPECT_TRUE(contains(r.err, "lower --levels (at most 17 here)")) << r.err;
  EXPECT_FALSE(fs::exists(vrm));
  r = run("build " + mesh.string() + " --levels 3 --max-triangles 100 --quiet -o " + vrm.string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "(20 x 2^3), more than --max-triangles 100")) << r.err;
  EXPECT_TRUE(contains(r.err, "(at most 2 here)")) << r.err;
  EXPECT_FALSE(fs::exists(vrm));
  // The default of 4 levels says so.
  r = run("build " + mesh.string() + " --max-triangles 100 --quiet -o " + vrm.string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "build: the default --levels 4 on the 20 faces")) << r.err;
  for (const char* bad : {"0", "2147483649"}) {
    r = run("build " + mesh.string() + " --levels 2 --max-triangles " + bad + " -o " + vrm.string(), dir);
    EXPECT_EQ(r.status, 1) << bad;
    EXPECT_TRUE(contains(r.err, "--max-triangles must be in 1 .. 2^31")) << r.err;
  }
  r = run("build torus --method adaptive --max-triangles 100 -o " + vrm.string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "build: --max-triangles is for --method semiregular")) << r.err;
  r = run("build " + mesh.string() + " --levels 2 --max-triangles 80 --quiet -o " + vrm.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "(20 coarsest, 80 finest)")) << r.out;
}

// Finding 22: query on a .vmh said "not a varmesh MT file (bad magic)"; pm query on a .vrm, "bad magic".
// Each now names what the file is and the command that reads it, and writes nothing.
TEST(CliReview, QueryAndPmQueryNameTheOtherKindOfHierarchy) {
  const fs::path dir = testing::scratch_dir("review_query_kind");
  const fs::path mesh = dir / "torus.obj";
  write_mesh(mesh.string(), testing::torus_grid(16, 8));
  const fs::path vmh = dir / "t.vmh", vrm = dir / "t.vrm", out = dir / "q.obj";
  ASSERT_EQ(run("pm build " + mesh.string() + " --quiet -o " + vmh.string(), dir).status, 0);
  ASSERT_EQ(run("build " + mesh.string() + " --levels 1 --quiet -o " + vrm.string(), dir).status, 0);
  CmdResult r = run("query " + vmh.string() + " --error 0.1 -o " + out.string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, vmh.string() + ": a progressive-mesh vertex hierarchy (.vmh, from varmesh pm build)")) << r.err;
  EXPECT_TRUE(contains(r.err, "use varmesh pm query")) << r.err;
  EXPECT_FALSE(contains(r.err, "bad magic")) << r.err;
  // The magic decides, not the extension.
  fs::copy_file(vmh, dir / "renamed.vrm");
  r = run("query " + (dir / "renamed.vrm").string() + " --error 0.1 -o " + out.string(), dir);
  EXPECT_TRUE(contains(r.err, "use varmesh pm query")) << r.err;
  r = run("pm query " + vrm.string() + " --error 0.1 -o " + out.string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, vrm.string() + ": a Multi-Triangulation (.vrm, from varmesh build)")) << r.err;
  EXPECT_TRUE(contains(r.err, "use varmesh query")) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // Each still reads its own kind.
  EXPECT_EQ(run("query " + vrm.string() + " --error 0.1 -o " + out.string(), dir).status, 0);
  EXPECT_EQ(run("pm query " + vmh.string() + " --error 0.1 -o " + out.string(), dir).status, 0);
}

// A 4 x 4 grid of quads (an OBJ of polygons: subdiv keeps the quads).
fs::path write_quad_grid(const fs::path& dir) {
  const fs::path path = dir / "grid16.obj";
  std::ofstream out(path);
  for (int y = 0; y <= 4; ++y)
    for (int x = 0; x <= 4; ++x) out << "v " << x << ' ' << y << " 0\n";
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const int a = y * 5 + x + 1;
      out << "f " << a << ' ' << a + 1 << ' ' << a + 6 << ' ' << a + 5 << '\n';
    }
  return path;
}

// Finding 23: the library's refusal of a step count ended in "... memory here (steps) (element 18)". The
// command now says it in its own words. 16 quads at 13 levels make 2^31 triangles (within --max-triangles
// 2^31) and need about 100 GB: refused before any allocation on a machine with less.
TEST(CliReview, SubdivSaysARefusedStepCountInItsOwnWords) {
  if (physical_memory_bytes() >= 100e9) GTEST_SKIP() << "this machine has the memory for 2^31 triangles";
  const fs::path dir = testing::scratch_dir("review_subdiv_steps");
  const fs::path grid = write_quad_grid(dir);
  const fs::path out = dir / "out.obj";
  // The advice names the option the user typed.
  for (const char* count : {"--levels 13", "--steps 26"}) {
    const CmdResult r = run("subdiv " + grid.string() + " " + count + " --max-triangles 2147483648 -o " + out.string(), dir);
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, "varmesh: error: subdiv: 26 steps would ")) << r.err;
    const std::string option = std::string(count).substr(0, std::string(count).find(' '));
    EXPECT_TRUE(contains(r.err, ": lower " + option + "\n")) << r.err;
    EXPECT_FALSE(contains(r.err, "(element")) << r.err;
    EXPECT_FALSE(contains(r.err, "(steps)")) << r.err;
    EXPECT_FALSE(contains(r.err, grid.string())) << "the mesh is not at fault: " << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

// Finding 23: build's printout said "(0 left over, split 1->2 on the border)" with nothing left over; the
// count is said only when there is one.
TEST(CliReview, BuildSaysLeftOverFacesOnlyWhenThereAreSome) {
  const fs::path dir = testing::scratch_dir("review_build_leftover");
  const fs::path ico = dir / "ico.off", odd = dir / "odd.obj";
  write_mesh(ico.string(), testing::icosahedron_mesh());  // 20 faces: all paired
  {
    std::ofstream out(odd);  // a fan of 3 triangles: one is left over
    out << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\nf 1 4 5\n";
  }
  CmdResult r = run("build " + ico.string() + " --levels 1 --quiet -o " + (dir / "a.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "semiregular: 20 base faces paired into 10 blocks, 1 level\n")) << r.out;
  EXPECT_FALSE(contains(r.out, "left over")) << r.out;
  r = run("build " + odd.string() + " --levels 1 --quiet -o " + (dir / "b.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "paired into 1 block (1 left over, split 1->2 on the border), 1 level")) << r.out;
}

// The line of `--help` output that starts with `option` (after the indentation).
std::string help_line(const std::string& help, const std::string& option) {
  std::istringstream lines(help);
  std::string line;
  while (std::getline(lines, line))
    if (line.find_first_not_of(' ') != std::string::npos && line.compare(line.find_first_not_of(' '), option.size() + 1, option + " ") == 0)
      return line;
  return {};
}

// Finding 23: `build --help` showed "--up TEXT Needs: --pictures with --pictures: ...": CLI11's Needs ran
// into the description. The options that need another show a value name; the description says what they need.
TEST(CliReview, HelpOfOptionsThatNeedAnotherReadsProperly) {
  const fs::path dir = testing::scratch_dir("review_help");
  struct Case {
    std::string command, option, expected;
  };
  const std::vector<Case> cases = {
      {"build", "--up", "--up X,Y,Z"},
      {"build", "--view", "--view X,Y,Z"},
      {"build", "--max-triangles", "--max-triangles N"},
      {"query", "--up", "--up X,Y,Z"},
      {"query", "--pixels", "--pixels PIXELS"},
      {"query", "--viewport", "--viewport PIXELS"},
      {"pm build", "--faces", "--faces N"},
      {"pm build", "--vertices", "--vertices N"},
      {"pm query", "--view", "--view X,Y,Z"},
      {"pm query", "--pixels", "--pixels PIXELS"},
      {"subdiv", "--pixels", "--pixels PIXELS"},
      {"subdiv", "--viewport", "--viewport PIXELS"},
      {"demo", "--raw-size", "--raw-size W,H"},
      {"demo", "--spacing", "--spacing D"},
      {"demo", "--z-scale", "--z-scale S"},
  };
  for (const Case& c : cases) {
    const CmdResult r = run(c.command + " --help", dir);
    ASSERT_EQ(r.status, 0) << c.command;
    const std::string line = help_line(r.out, c.option);
    ASSERT_FALSE(line.empty()) << c.command << " " << c.option << "\n" << r.out;
    EXPECT_TRUE(contains(line, c.expected + "  ")) << line;
    EXPECT_FALSE(contains(line, "Needs:")) << line;
    EXPECT_FALSE(contains(line, "Excludes:")) << line;
  }
  // The requirement itself still holds.
  const CmdResult r = run("build torus --method adaptive -o " + (dir / "x.vrm").string() + " --up 0,1,0", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "--up requires --pictures")) << r.err;
}

// Finding 19: info on a .vmh called the node error "an estimate of its distance to the input" and printed
// it as e-4 of the diagonal (the bunny's: "14876.23 e-4", 1.49 diagonals, 4.5 times the measured distance).
// It is now a percent of the diagonal, beside the absolute value, and said to be conservative.
TEST(CliReview, InfoGivesTheNodeErrorAsAPercentOfTheDiagonal) {
  const fs::path dir = testing::scratch_dir("review_info_error");
  const fs::path mesh = dir / "torus.obj", vmh = dir / "t.vmh";
  write_mesh(mesh.string(), testing::torus_grid(16, 8));
  ASSERT_EQ(run("pm build " + mesh.string() + " --quiet -o " + vmh.string(), dir).status, 0);
  const VertexHierarchy h = read_vertex_hierarchy(vmh.string());
  float worst = 0.0f;
  for (Index root : h.roots()) worst = std::max(worst, h.bound(root).error);
  Box3 box;
  for (std::size_t v = 0; v < h.num_leaves(); ++v) box.add(h.position(static_cast<Index>(v)));
  const double diagonal = glm::length(glm::dvec3(box.hi) - glm::dvec3(box.lo));
  const CmdResult r = run("info " + vmh.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t at = r.out.find("node error of the base mesh (largest root): ");
  ASSERT_NE(at, std::string::npos) << r.out;
  double value = 0.0, percent = 0.0, diag = 0.0;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "node error of the base mesh (largest root): %lf = %lf %% of the bounding-box diagonal %lf",
                        &value, &percent, &diag),
            3)
      << r.out;
  EXPECT_NEAR(value, worst, 1e-5 * worst);
  EXPECT_NEAR(diag, diagonal, 1e-5 * diagonal);
  EXPECT_NEAR(percent, 100.0 * double(worst) / diagonal, 1e-2 * percent);
  EXPECT_TRUE(contains(r.out, "a conservative estimate of the distance to the input")) << r.out;
  EXPECT_FALSE(contains(r.out, " e-4 ")) << r.out;
}

// Finding 6 on the data folder's DEMs (skipped without it): Fuji and Jacksboro get a spacing and pictures
// that span the frame.
TEST(CliReview, DemoOnTheDataFoldersTerrains) {
  VARMESH_REQUIRE_SHARED(fuji, "terrain/fuji_elevation_512_f32le.raw");
  VARMESH_REQUIRE_SHARED(jacksboro, "terrain/jacksboro_fault_dem_403x344.pgm");
  const fs::path dir = testing::scratch_dir("review_demo_dems");
  struct Case {
    std::string args, name, apart;
  };
  for (const Case& c : {Case{"--heightfield " + fuji + " --raw-size 512,512", "fuji", "512 x 512 samples 50 apart"},
                        Case{"--heightfield " + jacksboro, "jacksboro", "403 x 344 samples 20 apart"}}) {
    const fs::path out = dir / c.name;
    const CmdResult r = run("demo --quiet " + c.args + " --out " + out.string(), dir);
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_TRUE(contains(r.out, c.apart)) << r.out;
    EXPECT_TRUE(contains(r.out, "(bound holds)")) << r.out;
    EXPECT_GT(drawn_width_fraction(out / "uniform.png"), 0.5) << c.name;
    EXPECT_GT(drawn_width_fraction(out / "view_camera.png"), 0.9) << c.name;
  }
}

}  // namespace
}  // namespace varmesh
