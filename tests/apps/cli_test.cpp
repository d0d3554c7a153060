// The varmesh command as a user runs it: exit codes, one-line errors, no partial outputs, and results that
// meet what was asked.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sys/wait.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fourk/adaptive.hpp"
#include "fourk/grid48.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_distance.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_io.hpp"
#include "multitri/terrain_gen.hpp"
#include "apps/cli_support.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::count_lines;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh(args, dir); }

TEST(Cli, HelpOnEverySubcommand) {
  const auto dir = testing::scratch_dir("cli_help");
  for (const char* sub : {"", "info", "terrain", "render", "demo", "build", "query", "compare"}) {
    const CmdResult r = run(std::string(sub) + " --help", dir);
    EXPECT_EQ(r.status, 0) << sub;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub;
  }
}

// Errors of the command line itself keep the promise of the commands' errors: status 1 and one line (they
// used to exit with CLI11's codes 104-109 and a second "Run with --help" line).
TEST(Cli, CommandLineErrorsAreOneLineAndStatusOne) {
  const auto dir = testing::scratch_dir("cli_unknown");
  for (const char* args : {"terrain --no-such-option x", "subdiv cube --levels abc -o x.obj", "subdiv -o x.obj",
                           "subdiv cube --steps 99999999999 -o x.obj", "no-such-command", ""}) {
    const CmdResult r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("varmesh: error:"), std::string::npos) << args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(dir / "x.obj")) << args;
  }
}

TEST(Cli, InfoReportsCountsAndMissingFileIsOneLine) {
  const auto dir = testing::scratch_dir("cli_info");
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {5, 5, 5}};
  m.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  write_mesh((dir / "tet.obj").string(), m);
  CmdResult r = run((dir / "tet.obj").string(), dir);  // no subcommand: an error
  EXPECT_NE(r.status, 0);
  r = run("info " + (dir / "tet.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("vertices"), std::string::npos);
  EXPECT_NE(r.out.find("1 unreferenced"), std::string::npos) << r.out;
  r = run("info " + (dir / "missing.obj").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("missing.obj"), std::string::npos);
}

TEST(Cli, TerrainMeetsTheErrorAndFailsCleanly) {
  const auto dir = testing::scratch_dir("cli_terrain");
  HeightField f = make_fractal_terrain(70, 45, 3, 500.0f);
  for (float& v : f.z) v = std::round(v);
  write_heightfield_raw((dir / "t.f32").string(), f);
  const std::string out = (dir / "t.ply").string();
  CmdResult r = run("terrain " + (dir / "t.f32").string() + " --raw-size 70,45 --error 3 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const TriMesh mesh = read_mesh(out);
  const Grid48 g(f);
  EXPECT_LE(g.max_vertical_error(mesh), 3.0);
  EXPECT_GT(mesh.num_faces(), 10u);
  // View-dependent with a budget.
  r = run("terrain " + (dir / "t.f32").string() + " --raw-size 70,45 --camera -10,-10,300,35,22,0,50 --budget 500 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_LE(read_mesh(out).num_faces(), 500u);  // clipped to the grid and still within the budget
  EXPECT_GT(read_mesh(out).num_faces(), 400u);
  // Bad inputs: a one-line error, exit 1, and no output file.
  const std::string bad_out = (dir / "bad.obj").string();
  std::ofstream((dir / "trunc.pgm").string()) << "P5\n10 10\n255\nabc";
  for (const std::string& args :
       {"terrain " + (dir / "trunc.pgm").string() + " --error 1 -o " + bad_out,
        "terrain " + (dir / "t.f32").string() + " --raw-size 70,44 --error 1 -o " + bad_out,
        "terrain " + (dir / "t.f32").string() + " --raw-size 70,45 --error 1 -o " + (dir / "x.txt").string(),
        "terrain " + (dir / "t.f32").string() + " --raw-size 70,45 --camera 1,2,3 -o " + bad_out,
        "terrain " + (dir / "t.f32").string() + " --raw-size 70,45 -o " + bad_out}) {
    r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(bad_out)) << args;
  }
}

TEST(Cli, RenderWritesAPngOfTheAskedSize) {
  const auto dir = testing::scratch_dir("cli_render");
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  write_mesh((dir / "tet.off").string(), m);
  const CmdResult r = run("render " + (dir / "tet.off").string() + " --width 120 --height 90 --wireframe -o " +
                        (dir / "tet.png").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const Image img = read_png((dir / "tet.png").string());
  EXPECT_EQ(img.width, 120u);
  EXPECT_EQ(img.height, 90u);
  const CmdResult bad = run("render " + (dir / "tet.off").string() + " --width 0 -o " + (dir / "z.png").string(), dir);
  EXPECT_NE(bad.status, 0);
  EXPECT_FALSE(fs::exists(dir / "z.png"));
}

TEST(Cli, DemoWritesItsFilesAndTheBoundHolds) {
  const auto dir = testing::scratch_dir("cli_demo");
  const CmdResult r = run("demo --quiet --size 129 --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("bound holds"), std::string::npos) << r.out;
  for (const char* f : {"uniform.obj", "view.obj", "uniform.png", "view_camera.png", "uniform_topdown.png", "view_topdown.png"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_GT(read_mesh((dir / "out" / "view.obj").string()).num_faces(), 100u);
}

// The library's adaptive parametric torus at the tolerance `build torus --method adaptive` documents as its
// default (0.0685, Velho-Gomes Figure 20(d)): its finest face count, which the command must reproduce.
std::size_t library_torus_faces() {
  AdaptiveOptions o;
  o.tolerance = 0.0685f;
  return build_adaptive_parametric(torus_parametric(), o).num_finest_faces;
}

TEST(Cli, BuildThenQueryAdaptiveTorus) {
  const auto dir = testing::scratch_dir("cli_build_query");
  CmdResult r = run("build torus --method adaptive -o " + (dir / "t.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("query " + (dir / "t.vrm").string() + " --error 0 -o " + (dir / "fine.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const TriMesh fine = read_mesh((dir / "fine.obj").string());
  EXPECT_EQ(fine.num_faces(), library_torus_faces());  // the finest front at the default tolerance
  r = run("query " + (dir / "t.vrm").string() + " --ramp -3,0,0,3,0,0,0.2,3 -o " + (dir / "ramp.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const TriMesh ramp = read_mesh((dir / "ramp.obj").string());
  EXPECT_LT(ramp.num_faces(), fine.num_faces());
  // Finer where the ramp asks for small triangles (x < 0) than where it allows large ones.
  std::size_t left = 0, right = 0;
  for (std::size_t f = 0; f < ramp.num_faces(); ++f) (ramp.positions[ramp.indices[3 * f]].x < 0 ? left : right)++;
  EXPECT_GT(left, right);
  // --measure: the distance from the finest mesh's vertices, as the library measures it (0 for the finest).
  r = run("query " + (dir / "t.vrm").string() + " --ramp -3,0,0,3,0,0,0.2,3 --measure -o " + (dir / "ramp.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const SurfaceDistance want = vertex_to_surface_distance(fine, read_mesh((dir / "ramp.obj").string()));
  EXPECT_GT(want.rms, 0.0);
  EXPECT_NEAR(testing::measured_distance(r.out, "result").first, want.rms, 1e-5 * want.rms) << r.out;
  EXPECT_NEAR(testing::measured_distance(r.out, "result").second, want.max, 1e-5 * want.max) << r.out;
  r = run("query " + (dir / "t.vrm").string() + " --error 0 --measure -o " + (dir / "fine.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(testing::measured_distance(r.out, "result").second, 0.0) << r.out;
}

// --budget alone asks for the finest mesh within the budget: it used to mean --error 0, which takes nodes of
// error 0 (simplify4k's exact collapses of a flat grid) for fine and stopped at the coarsest exact mesh.
TEST(Cli, BudgetAloneReachesTheFinestMesh) {
  const auto dir = testing::scratch_dir("cli_budget_flat");
  TriMesh grid;
  const int n = 9;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) grid.positions.push_back({float(i), float(j), 0.0f});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const Index a = Index(j * n + i), b = a + 1, c = a + Index(n) + 1, d = a + Index(n);
      grid.indices.insert(grid.indices.end(), {a, b, c, a, c, d});
    }
  write_mesh((dir / "grid.off").string(), grid);
  const std::string vrm = (dir / "g.vrm").string(), out = (dir / "q.obj").string();
  CmdResult r = run("build " + (dir / "grid.off").string() + " --method simplify4k -o " + vrm + " --quiet", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("query " + vrm + " --budget 1000 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_mesh(out).num_faces(), grid.num_faces()) << r.out;
  r = run("query " + vrm + " --budget 100 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_LE(read_mesh(out).num_faces(), 100u);
  EXPECT_GT(read_mesh(out).num_faces(), 90u) << r.out;
  EXPECT_FALSE(testing::contains(r.err, "below the base mesh")) << r.err;
  // Below the coarsest front: that front (the simplified grid's base), and a note naming its size.
  r = run("query " + vrm + " --budget 1 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t base = read_mesh(out).num_faces();
  const Mt mt = read_mt(vrm);
  EXPECT_EQ(base, mt.image_size(Mt::source()));
  EXPECT_TRUE(testing::contains(r.err, "--budget 1 is below the base mesh's " + std::to_string(base) + " triangles")) << r.err;
}

// A --ramp between points far apart: the float squared length overflowed, t became NaN and every node was
// refined. Halfway between +-1e20 the ramp asks for the middle size everywhere, like a constant ramp.
TEST(Cli, RampBetweenFarPoints) {
  const auto dir = testing::scratch_dir("cli_ramp_far");
  CmdResult r = run("build torus --method adaptive -o " + (dir / "t.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  auto faces = [&](const std::string& ramp) {
    const CmdResult q = run("query " + (dir / "t.vrm").string() + " --ramp " + ramp + " -o " + (dir / "r.obj").string(), dir);
    EXPECT_EQ(q.status, 0) << q.err;
    return read_mesh((dir / "r.obj").string()).num_faces();
  };
  const std::size_t far = faces("-1e20,0,0,1e20,0,0,0.5,1.5"), constant = faces("-1,0,0,1,0,0,1,1"), fine = faces("-1,0,0,1,0,0,1e-6,1e-6");
  EXPECT_LT(far, fine);
  EXPECT_EQ(far, constant);
}

TEST(Cli, QueryPictureCameraOptions) {
  const auto dir = testing::scratch_dir("cli_query_up");
  CmdResult r = run("build torus --method adaptive -o " + (dir / "t.vrm").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string base = "query " + (dir / "t.vrm").string() + " --error 0 -o " + (dir / "m.obj").string();
  r = run(base + " --png " + (dir / "up.png").string() + " --up 0,1,0 --view 0,0,1", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const Image img = read_png((dir / "up.png").string());
  EXPECT_EQ(img.width, 1024u);
  // A zero up axis or view direction, or a malformed one, fails and writes no file at all.
  for (const char* bad : {" --up 0,0,0", " --view 0,0,0", " --up 1,2"}) {
    const auto png = dir / "bad.png", obj = dir / "bad.obj";
    r = run("query " + (dir / "t.vrm").string() + " --error 0 -o " + obj.string() + " --png " + png.string() + bad, dir);
    EXPECT_EQ(r.status, 1) << bad;
    EXPECT_FALSE(std::filesystem::exists(png)) << bad;
    EXPECT_FALSE(std::filesystem::exists(obj)) << bad;
  }
}

TEST(Cli, BuildAndQueryFailCleanly) {
  const auto dir = testing::scratch_dir("cli_build_bad");
  CmdResult r = run("build torus --method nonsense -o " + (dir / "x.vrm").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("unknown --method"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "x.vrm"));
  r = run("build torus --method adaptive -o " + (dir / "x.obj").string(), dir);
  EXPECT_EQ(r.status, 1);
  {
    std::ofstream junk(dir / "junk.vrm", std::ios::binary);
    junk << "VMSHMT\r\nnot really";
  }
  r = run("query " + (dir / "junk.vrm").string() + " --error 1 -o " + (dir / "out.obj").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1);
  EXPECT_NE(r.err.find("junk.vrm"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "out.obj"));
}

// Options that do not apply, or values that used to mean "the default", are refused by name (helper-52's
// review: --tolerance -1 built with the default, --levels did nothing for adaptive, --raw-size, --up and
// --view were ignored); mesh errors name the file; --levels past the machine's memory is refused up front.
TEST(Cli, BuildRefusesOptionsThatDoNotApply) {
  const auto dir = testing::scratch_dir("cli_build_options");
  TriMesh tet;
  tet.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  tet.indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  const std::string mesh = (dir / "tet.off").string(), vrm = (dir / "o.vrm").string();
  write_mesh(mesh, tet);
  TriMesh bad = tet;  // a third face on the edge (0, 1): non-manifold
  bad.positions.push_back({0, 0, 5});
  bad.indices.insert(bad.indices.end(), {0, 1, 4});
  const std::string bad_mesh = (dir / "nm.off").string();
  write_mesh(bad_mesh, bad);
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"build " + mesh + " -o " + vrm + " --tolerance 5", "--tolerance is for --method adaptive"},
      {"build " + mesh + " -o " + vrm + " --method simplify4k --tolerance 3", "--tolerance is for --method adaptive"},
      {"build torus --method adaptive -o " + vrm + " --tolerance -1", "--tolerance: must be > 0"},
      {"build torus --method adaptive -o " + vrm + " --tolerance 0", "--tolerance: must be > 0"},
      {"build torus --method adaptive -o " + vrm + " --levels 3", "build --method adaptive: --tolerance 0.0685 is not met within 3 levels: raise --levels"},
      {"build implicit-torus --method adaptive -o " + vrm + " --levels 2 --tolerance 0.01", "--tolerance 0.01 is not met within 2 levels"},
      {"build torus --method adaptive -o " + vrm + " --raw-size 3,3", "--raw-size is for a .raw or .f32 height field"},
      {"build " + mesh + " -o " + vrm + " --raw-size 3,3", "--raw-size is for --method adaptive"},
      {"build " + mesh + " -o " + vrm + " --up 0,1,0", "--up requires --pictures"},
      {"build " + mesh + " -o " + vrm + " --view 0,1,0", "--view requires --pictures"},
      {"build " + mesh + " -o " + vrm + " --levels -1", "--levels"},
      {"build saddle --method adaptive -o " + vrm + " --levels 0", "--levels must be in 1..48"},
      {"build saddle --method adaptive -o " + vrm + " --levels 49", "--levels must be in 1..48"},
      {"build " + mesh + " -o " + vrm + " --levels 40", "would make 4.398e+12 faces in the finest mesh (4 x 2^40), more than --max-triangles 4194304"},
      {"build " + mesh + " -o " + vrm + " --levels 29 --max-triangles 2147483648", "would exceed 2^31 faces"},
      // The fifth face of the file (0, 1, 4), on its last line, is the edge's third; OFF numbers vertices from 0.
      {"build " + bad_mesh + " -o " + vrm, bad_mesh + ":12: the edge 0-1 belongs to 3 faces, faces 1, 2 and 5"},
      {"build " + bad_mesh + " --method simplify4k -o " + vrm, bad_mesh + ":12: the edge 0-1 belongs to 3 faces, faces 1, 2 and 5"},
      {"terrain " + mesh + " --raw-size 3,3 --error 1 -o " + (dir / "t.obj").string(), "--raw-size is for a .raw or .f32"},
  };
  // 4 x 2^28 faces stay below 2^31 (and --max-triangles 2^31) but need ~280 GB: refused by the library's memory check, naming the file.
  std::vector<Case> all = cases;
  if (physical_memory_bytes() < 250e9)
    all.push_back({"build " + mesh + " -o " + vrm + " --levels 28 --max-triangles 2147483648", mesh + ": build_semiregular: parameter levels = 28"});
  for (const Case& c : all) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(vrm)) << c.args;
  }
  // --levels reaches the adaptive builder: a deeper limit meets the tolerance, with the same result as the default.
  CmdResult r = run("build torus --method adaptive -o " + vrm + " --levels 12 --quiet", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("query " + vrm + " --error 0 -o " + (dir / "q.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_mesh((dir / "q.obj").string()).num_faces(), library_torus_faces());
  // --up without --png in a query.
  r = run("query " + vrm + " --error 0 -o " + (dir / "q2.obj").string() + " --up 0,1,0", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--up requires --png"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "q2.obj"));
}

}  // namespace
}  // namespace varmesh

namespace varmesh {
namespace {

// A box 1 x 4 x 0.5 (long along y), closed, outward faces.
TriMesh tall_box() {
  TriMesh m;
  const glm::vec3 lo(0.0f), hi(1.0f, 4.0f, 0.5f);
  for (int i = 0; i < 8; ++i) m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  m.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  return m;
}

// The rectangle of the picture's pixels that are not the white background.
struct Extent {
  std::size_t x0 = SIZE_MAX, y0 = SIZE_MAX, x1 = 0, y1 = 0, count = 0;
};
Extent drawn_extent(const Image& im) {
  Extent e;
  for (std::size_t y = 0; y < im.height; ++y)
    for (std::size_t x = 0; x < im.width; ++x) {
      const std::uint8_t* p = &im.pixels[(y * im.width + x) * 3];
      if (p[0] == 255 && p[1] == 255 && p[2] == 255) continue;
      e.x0 = std::min(e.x0, x), e.y0 = std::min(e.y0, y), e.x1 = std::max(e.x1, x), e.y1 = std::max(e.y1, y);
      ++e.count;
    }
  return e;
}

// render --up keeps the given axis up in the picture (a y-up model used to lie on its side), --view looks
// from the given side, --fov without --eye keeps the mesh framed, and --view with --eye is refused.
TEST(CliRender, UpViewAndFovFrameTheMesh) {
  const auto dir = testing::scratch_dir("cli_render_up");
  const std::string box = (dir / "box.obj").string();
  write_mesh(box, tall_box());
  auto picture = [&](const std::string& args) {
    const std::string out = (dir / "p.png").string();
    fs::remove(out);
    const CmdResult r = run("render " + box + " -o " + out + " --width 400 --height 400 " + args, dir);
    EXPECT_EQ(r.status, 0) << args << "\n" << r.err;
    return r.status == 0 ? drawn_extent(read_png(out)) : Extent{};
  };
  // Seen from +z with y up, the box's long side (y) is vertical; with x up, horizontal.
  const Extent y_up = picture("--up 0,1,0 --view 0,0,1");
  const Extent x_up = picture("--up 1,0,0 --view 0,0,1");
  ASSERT_GT(y_up.count, 0u);
  ASSERT_GT(x_up.count, 0u);
  EXPECT_GT(y_up.y1 - y_up.y0, 3 * (y_up.x1 - y_up.x0)) << "y up: the long side should be vertical";
  EXPECT_GT(x_up.x1 - x_up.x0, 3 * (x_up.y1 - x_up.y0)) << "x up: the long side should be horizontal";
  // --fov alone keeps the framing (the eye moves back or forth): the covered area stays about the same.
  const Extent wide = picture(""), narrow = picture("--fov 15");
  ASSERT_GT(wide.count, 0u);
  EXPECT_NEAR(double(narrow.count) / double(wide.count), 1.0, 0.15);
  const CmdResult r = run("render " + box + " -o " + (dir / "q.png").string() + " --view 1,0,0 --eye 5,5,5", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(testing::contains(r.err, "--view and --eye")) << r.err;
  EXPECT_FALSE(fs::exists(dir / "q.png"));
}

// A camera that sees none of the mesh used to write a white picture and report success.
TEST(CliRender, ACameraThatSeesNothingIsRefused) {
  const auto dir = testing::scratch_dir("cli_render_blank");
  const std::string box = (dir / "box.obj").string();
  write_mesh(box, tall_box());
  const CmdResult r = run("render " + box + " -o " + (dir / "p.png").string() + " --target 100,100,100", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(testing::contains(r.err, "sees none of the mesh")) << r.err;
  EXPECT_FALSE(fs::exists(dir / "p.png"));
}

// An output in a folder that does not exist is refused before the work (it was found when the result was
// written), naming the folder; nothing is printed on stdout.
TEST(CliOutputs, AMissingFolderIsRefusedBeforeTheWork) {
  const auto dir = testing::scratch_dir("cli_missing_folder");
  const std::string box = (dir / "box.obj").string();
  write_mesh(box, tall_box());
  const fs::path field = dir / "t.f32";
  write_heightfield_raw(field.string(), make_fractal_terrain(17, 17, 7, 20.0f));
  const std::string missing = (dir / "nothere").string();
  for (const std::string& args :
       {"pm build " + box + " -o " + missing + "/x.vmh", "build " + box + " --levels 1 -o " + missing + "/x.vrm",
        "render " + box + " -o " + missing + "/x.png", "subdiv " + box + " --levels 1 -o " + missing + "/x.obj",
        "terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + missing + "/x.obj",
        "terrain " + field.string() + " --raw-size 17,17 --error 1 -o " + (dir / "ok.obj").string() + " --png " + missing + "/x.png"}) {
    const CmdResult r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_TRUE(testing::contains(r.err, "folder '" + missing + "' does not exist")) << args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << args;
  }
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_FALSE(fs::exists(dir / "ok.obj"));
}

// build --method adaptive on a height field takes --spacing and --z-scale as terrain does (a DEM in metres
// with samples 30 m apart came out as needles): the finest front spans (W - 1) x spacing and the scaled
// heights. Elsewhere the options are refused by name.
TEST(CliBuild, AdaptiveHeightFieldTakesSpacingAndZScale) {
  const auto dir = testing::scratch_dir("cli_build_spacing");
  const fs::path field = dir / "t.f32";
  const HeightField f = make_fractal_terrain(33, 17, 7, 20.0f);
  write_heightfield_raw(field.string(), f);
  const auto [lo, hi] = std::minmax_element(f.z.begin(), f.z.end());
  const std::string vrm = (dir / "t.vrm").string(), fine = (dir / "fine.obj").string();
  CmdResult r = run("build " + field.string() + " --raw-size 33,17 --method adaptive --spacing 30 --z-scale 2 "
                    "--tolerance 0.5 --quiet -o " + vrm, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("query " + vrm + " --error 0 -o " + fine, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const TriMesh m = read_mesh(fine);
  glm::vec3 bmin(1e30f), bmax(-1e30f);
  for (const glm::vec3& p : m.positions) bmin = glm::min(bmin, p), bmax = glm::max(bmax, p);
  EXPECT_NEAR(bmax.x - bmin.x, 32 * 30.0f, 1e-3f);
  EXPECT_NEAR(bmax.y - bmin.y, 16 * 30.0f, 1e-3f);
  EXPECT_NEAR(bmax.z - bmin.z, 2.0f * (*hi - *lo), 1e-3f * (*hi - *lo));
  const std::string mesh = (dir / "m.obj").string();
  write_mesh(mesh, m);
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {"build torus --method adaptive --spacing 2 -o " + vrm, "not the built-in torus"},
           {"build " + mesh + " --levels 1 --z-scale 2 -o " + vrm, "are for --method adaptive on a height field"},
           {"build " + field.string() + " --raw-size 33,17 --method adaptive --spacing 0 -o " + vrm, "--spacing must be finite and > 0"}}) {
    r = run(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_TRUE(testing::contains(r.err, message)) << args << "\n" << r.err;
  }
}

// terrain --budget N alone (as query and pm query take it): the finest mesh the budget allows.
TEST(CliTerrain, BudgetAloneIsAQuery) {
  const auto dir = testing::scratch_dir("cli_terrain_budget");
  const fs::path field = dir / "t.f32";
  write_heightfield_raw(field.string(), make_fractal_terrain(65, 65, 7, 20.0f));
  const std::string out = (dir / "b.obj").string();
  for (const std::size_t budget : {50u, 500u, 2000u}) {
    const CmdResult r = run("terrain " + field.string() + " --raw-size 65,65 --budget " + std::to_string(budget) + " -o " + out, dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const std::size_t faces = read_mesh(out).num_faces();
    EXPECT_LE(faces, budget);
    EXPECT_GT(faces, budget / 2) << "the budget, not a criterion, should stop the refinement";
  }
  const CmdResult r = run("terrain " + field.string() + " --raw-size 65,65 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(testing::contains(r.err, "--budget N")) << r.err;
}

// A misspelt command is named, with the commands known at that level.
TEST(Cli, AnUnknownCommandIsNamed) {
  const auto dir = testing::scratch_dir("cli_unknown_command");
  CmdResult r = run("biuld x.obj -o y.vrm", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(testing::contains(r.err, "'biuld' is not a command of varmesh") && testing::contains(r.err, "build")) << r.err;
  r = run("pm qeury x.vmh", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(testing::contains(r.err, "'qeury' is not a command of varmesh pm (known: build, query")) << r.err;
  r = run("pm --help", dir);
  EXPECT_EQ(r.status, 0);
}

// A misspelt option is named, with the nearest option of that command when one is close (CLI11 said "The
// following arguments were not expected: 20 --eror", or that a required option was missing when the
// misspelt one was it). A negative number is a value, not an option.
TEST(Cli, AnUnknownOptionIsNamedWithTheNearestOne) {
  const auto dir = testing::scratch_dir("cli_unknown_option");
  struct Case {
    std::string args, expected;
  };
  for (const Case& c : {Case{"terrain x.pgm --eror 20 -o y.obj", "unknown option '--eror' for varmesh terrain (did you mean --error?)"},
                        Case{"pm query x.vmh --bugdet 5", "unknown option '--bugdet' for varmesh pm query (did you mean --budget?)"},
                        Case{"pm build x.obj --outptu y.vmh", "unknown option '--outptu' for varmesh pm build (did you mean --output?)"},
                        Case{"render --zzzzzz x.obj -o y.png", "unknown option '--zzzzzz' for varmesh render; see varmesh render --help"},
                        Case{"terrain x.pgm -q -o y.obj", "unknown option '-q' for varmesh terrain"}}) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(testing::contains(r.err, c.expected)) << c.args << ": " << r.err;
  }
  const CmdResult r = run("query x.vrm --budget -5 -o y.obj", dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_FALSE(testing::contains(r.err, "unknown option")) << r.err;
  EXPECT_TRUE(testing::contains(r.err, "--budget")) << r.err;
}

}  // namespace
}  // namespace varmesh

namespace varmesh {
namespace {

// --flip-rows puts the file's first row at the largest y: a peak in the first row lands at y = 0 without
// it and at y = (rows - 1) * spacing with it; the heights are the file's either way.
TEST(CliTerrain, FlipRowsPutsTheFirstRowAtTheLargestY) {
  const auto dir = testing::scratch_dir("cli_terrain_flip");
  HeightField f;
  f.width = 9;
  f.height = 5;
  f.z.assign(f.width * f.height, 0.0f);
  f.z[2] = 7.0f;  // row 0, column 2
  const fs::path field = dir / "t.f32";
  write_heightfield_raw(field.string(), f);
  for (const bool flip : {false, true}) {
    const std::string out = (dir / "m.obj").string();
    const CmdResult r = run("terrain " + field.string() + " --raw-size 9,5 --error 0 --spacing 2 -o " + out +
                                (flip ? " --flip-rows" : ""), dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const TriMesh m = read_mesh(out);
    glm::vec3 top(0.0f, 0.0f, -1.0f);
    for (const glm::vec3& p : m.positions)
      if (p.z > top.z) top = p;
    EXPECT_FLOAT_EQ(top.z, 7.0f);
    EXPECT_FLOAT_EQ(top.x, 4.0f);
    EXPECT_FLOAT_EQ(top.y, flip ? 8.0f : 0.0f) << (flip ? "--flip-rows" : "default");
  }
}

}  // namespace
}  // namespace varmesh
