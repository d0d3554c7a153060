// `varmesh subdiv` as a user runs it: outputs that equal the library's results, adaptive fronts between the
// base and the uniform mesh, one-line errors with no output file, pictures.
#include "apps/subdiv_cmd.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "apps/cli_support.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::count_lines;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh("subdiv " + args, dir); }

// The file must hold `expected`: the same triangles, positions within `tolerance` (0: as the writers round
// them; inputs from hand-written files may differ from the library's by a float rounding).
void expect_same_mesh(const std::string& path, const TriMesh& expected, float tolerance = 0.0f) {
  const TriMesh got = read_mesh(path);
  EXPECT_NO_THROW(got.validate());
  ASSERT_EQ(got.num_vertices(), expected.num_vertices()) << path;
  ASSERT_EQ(got.num_faces(), expected.num_faces()) << path;
  EXPECT_EQ(got.indices, expected.indices) << path;
  float worst = 0.0f;
  for (std::size_t v = 0; v < got.num_vertices(); ++v)
    worst = std::max(worst, glm::length(got.positions[v] - expected.positions[v]));
  EXPECT_LE(worst, tolerance) << path;
}

TEST(SubdivCli, HelpNamesTheSchemesAndTheQuasi48StandIn) {
  const auto dir = testing::scratch_dir("subdiv_help");
  const CmdResult r = run("--help", dir);
  EXPECT_EQ(r.status, 0);
  for (const char* word : {"Usage", "zwart-powell", "catmull-clark", "doo-sabin", "quasi48", "stand-in", "--adaptive", "--figure"})
    EXPECT_NE(r.out.find(word), std::string::npos) << word;
}

TEST(SubdivCli, PrimalSchemesWriteTheLibrarysMesh) {
  const auto dir = testing::scratch_dir("subdiv_primal");
  const PolyMesh cube = make_quad_cube(), torus = make_quad_torus(16, 8);
  struct Case {
    const char* scheme;
    SubdivScheme lib;
    const char* input;
    const char* count;  // --levels N or --steps S
    int steps;
    const char* ext;
  };
  const Case cases[] = {
      {"48", SubdivScheme::kFourEight, "cube", "--levels 3", 6, ".obj"},
      {"48", SubdivScheme::kFourEight, "torus", "--steps 3", 3, ".ply"},
      {"catmull-clark", SubdivScheme::kCatmullClark, "cube", "--levels 2", 4, ".off"},
      {"catmull-clark", SubdivScheme::kCatmullClark, "torus", "--steps 1", 1, ".obj"},
      {"linear", SubdivScheme::kLinear, "cube", "--levels 1", 2, ".ply"},
      {"linear", SubdivScheme::kLinear, "torus", "--levels 0", 0, ".obj"},
  };
  for (const Case& c : cases) {
    const std::string out = (dir / (std::string(c.scheme) + "_" + c.input + c.ext)).string();
    const CmdResult r = run(std::string(c.input) + " --scheme " + c.scheme + " " + c.count + " -o " + out, dir);
    ASSERT_EQ(r.status, 0) << c.scheme << " " << c.input << "\n" << r.err;
    EXPECT_EQ(r.err, "");
    const PolyMesh& base = std::string(c.input) == "cube" ? cube : torus;
    const TriMesh expected = subdivide(base, c.lib, c.steps).to_tri_mesh();
    expect_same_mesh(out, expected);
    EXPECT_NE(r.out.find(std::to_string(expected.num_faces()) + " triangles"), std::string::npos) << r.out;
  }
}

TEST(SubdivCli, Quasi48RunsTheFourEightRulesOnPairedTriangles) {
  const auto dir = testing::scratch_dir("subdiv_quasi48");
  // Built-in quads: triangulated, then paired again.
  CmdResult r = run("cube --scheme quasi48 --levels 2 -o " + (dir / "q.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const PolyMesh paired = pair_triangles(triangulate(make_quad_cube()));
  expect_same_mesh((dir / "q.obj").string(), subdivide(paired, SubdivScheme::kFourEight, 4).to_tri_mesh());
  // A triangle file: quasi48 and 48 get the same paired mesh.
  write_mesh((dir / "t.off").string(), triangulate(make_quad_torus(6, 4)));
  r = run((dir / "t.off").string() + " --scheme quasi48 --steps 3 -o " + (dir / "a.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run((dir / "t.off").string() + " --scheme 48 --steps 3 -o " + (dir / "b.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_same_mesh((dir / "a.obj").string(), read_mesh((dir / "b.obj").string()));
}

TEST(SubdivCli, TriangleFileIsPairedIntoQuads) {
  const auto dir = testing::scratch_dir("subdiv_file");
  // A quad mesh as a file arrives as triangles (the readers triangulate polygons): pairing makes quads again.
  const std::string in = (dir / "torus.obj").string();
  write_mesh(in, triangulate(make_quad_torus(10, 6)));
  const CmdResult r = run(in + " --scheme catmull-clark --levels 2 -o " + (dir / "cc.ply").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("120 triangles paired into 60 quads, 0 left"), std::string::npos) << r.out;
  const PolyMesh paired = pair_triangles(read_mesh(in));
  EXPECT_TRUE(paired.all_quads());
  expect_same_mesh((dir / "cc.ply").string(), subdivide(paired, SubdivScheme::kCatmullClark, 4).to_tri_mesh());
}

// Writes `m` with its polygons (write_mesh writes triangles only); positions rounded to float, as read back.
PolyMesh write_polygon_file(const fs::path& path, PolyMesh m) {
  std::ofstream out(path);
  const bool off = path.extension() == ".off";
  if (off) out << "OFF\n" << m.num_vertices() << " " << m.num_faces() << " 0\n";
  for (glm::dvec3& p : m.positions) {
    p = glm::dvec3(glm::vec3(p));
    char line[128];
    std::snprintf(line, sizeof line, "%s%.9g %.9g %.9g\n", off ? "" : "v ", p.x, p.y, p.z);
    out << line;
  }
  for (std::size_t f = 0; f < m.num_faces(); ++f) {
    out << (off ? std::to_string(m.face_size(f)) : std::string("f"));
    for (Index c : m.face(f)) out << " " << (off ? c : c + 1);
    out << "\n";
  }
  return m;
}

TEST(SubdivCli, PolygonFileKeepsItsQuads) {
  const auto dir = testing::scratch_dir("subdiv_polygons");
  // The readers give triangles; subdiv rebuilds the file's quads from the fans, triangles stay.
  const PolyMesh torus = write_polygon_file(dir / "torus.obj", make_quad_torus(10, 6));
  CmdResult r = run((dir / "torus.obj").string() + " --scheme catmull-clark --levels 2 -o " + (dir / "cc.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("60 faces (60 quads)"), std::string::npos) << r.out;
  expect_same_mesh((dir / "cc.obj").string(), subdivide(torus, SubdivScheme::kCatmullClark, 4).to_tri_mesh(), 1e-6f);
  // A square pyramid: one quad and four triangles, the quad first (its fan is followed by a triangle that
  // starts at the same corner: it must stay a triangle).
  PolyMesh pyramid;
  pyramid.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {0, 0, 1.5}};
  for (std::vector<Index> f : std::vector<std::vector<Index>>{{0, 3, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}})
    pyramid.add_face(f);
  pyramid = write_polygon_file(dir / "pyramid.off", pyramid);
  r = run((dir / "pyramid.off").string() + " --scheme catmull-clark --steps 3 -o " + (dir / "p.ply").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("5 faces (1 quad, 4 triangles)"), std::string::npos) << r.out;
  expect_same_mesh((dir / "p.ply").string(), subdivide(pyramid, SubdivScheme::kCatmullClark, 3).to_tri_mesh(), 1e-6f);
  // quasi48 pairs the triangles instead.
  r = run((dir / "torus.obj").string() + " --scheme quasi48 --levels 1 -o " + (dir / "q.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_same_mesh((dir / "q.obj").string(),
                   subdivide(pair_triangles(triangulate(torus)), SubdivScheme::kFourEight, 2).to_tri_mesh(), 1e-6f);
}

TEST(SubdivCli, DualSchemesOnTheCube) {
  const auto dir = testing::scratch_dir("subdiv_dual");
  // Cube: V 8, F 6, E 12, C 24. Doo-Sabin: 24 corner points; faces 6 quads + 8 triangles + 12 quads = 44
  // triangles. Zwart-Powell: the cuboctahedron (12 vertices, 6 quads + 8 triangles = 20 triangles), then
  // 24 vertices and 6 quads + 8 triangles + 12 quads = 44 triangles.
  struct Case {
    const char* args;
    std::size_t vertices, triangles;
  };
  for (const Case& c : {Case{"--scheme doo-sabin --levels 1", 24, 44}, Case{"--scheme zwart-powell --steps 1", 12, 20},
                        Case{"--scheme zwart-powell --levels 1", 24, 44}}) {
    const std::string out = (dir / "d.obj").string();
    fs::remove(out);
    const CmdResult r = run(std::string("cube ") + c.args + " -o " + out, dir);
    ASSERT_EQ(r.status, 0) << c.args << "\n" << r.err;
    const TriMesh m = read_mesh(out);
    EXPECT_NO_THROW(m.validate());
    EXPECT_EQ(m.num_vertices(), c.vertices) << c.args;
    EXPECT_EQ(m.num_faces(), c.triangles) << c.args;
    EXPECT_NO_THROW(pair_triangles(m).validate()) << c.args;  // closed, manifold
  }
}

TEST(SubdivCli, AdaptiveFrontLiesBetweenTheBaseAndTheUniformMesh) {
  const auto dir = testing::scratch_dir("subdiv_adaptive");
  const PolyMesh torus = make_quad_torus(16, 8);
  const std::size_t uniform = subdivide(torus, SubdivScheme::kFourEight, 5).to_tri_mesh().num_faces();
  auto faces = [&](const std::string& criterion) {
    const std::string out = (dir / "a.obj").string();
    const CmdResult r = run("torus --scheme 48 --steps 5 --adaptive " + criterion + " -o " + out, dir);
    EXPECT_EQ(r.status, 0) << criterion << "\n" << r.err;
    const TriMesh m = read_mesh(out);
    EXPECT_NO_THROW(m.validate());
    return m.num_faces();
  };
  EXPECT_EQ(faces("--error 0"), uniform);
  const std::size_t coarse = faces("--error 0.01");
  EXPECT_LT(coarse, uniform);
  EXPECT_GT(coarse, 2 * torus.num_faces());
  EXPECT_EQ(faces("--error 1000"), 2 * torus.num_faces());  // nothing refined: the base quads as triangles
  const std::size_t view = faces("--camera 3,0,1,0,0,0,40 --pixels 2");
  EXPECT_LT(view, uniform);
  EXPECT_GT(view, 2 * torus.num_faces());
}

// The adaptive summary counts the nodes the front refined; when none needed it (the base met the criterion),
// it says so rather than "0 nodes refined".
TEST(SubdivCli, AdaptiveSummarySaysWhenNothingNeededRefining) {
  const auto dir = testing::scratch_dir("subdiv_adaptive_summary");
  const std::string out = (dir / "a.obj").string();
  CmdResult r = run("torus --scheme 48 --steps 3 --adaptive --error 1000 -o " + out, dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("(no node needed refining)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("0 nodes refined"), std::string::npos) << r.out;
  EXPECT_EQ(read_mesh(out).num_faces(), 2 * make_quad_torus(16, 8).num_faces());  // the base, as the words say
  r = run("torus --scheme 48 --steps 3 --adaptive --error 0 -o " + out, dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find("no node needed refining"), std::string::npos) << r.out;
  const std::size_t at = r.out.find(" nodes refined)");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::size_t from = r.out.rfind('(', at);
  EXPECT_GT(std::stoul(r.out.substr(from + 1, at - from - 1)), 0u) << r.out;
}

TEST(SubdivCli, BadInputFailsWithOneLineAndNoOutput) {
  const auto dir = testing::scratch_dir("subdiv_bad");
  // A bow-tie (two triangles sharing only a vertex: a non-manifold vertex) and three triangles on one edge.
  std::ofstream((dir / "bowtie.obj").string()) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -1 0 0\nv 0 -1 0\nf 1 2 3\nf 1 4 5\n";
  std::ofstream((dir / "fin.obj").string()) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n";
  std::ofstream((dir / "trunc.off").string()) << "OFF\n4 2 0\n0 0 0\n1 0 0\n";
  // Four faces on edge 1-3, and an unrelated quad (which makes the reader's polygon path rebuild quads from
  // the fans: merging (1 2 3) with (1 3 4) used to hide the edge from the manifold check).
  std::ofstream((dir / "nm_quad.obj").string()) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nv 5 0 0\nv 6 0 0\nv 6 1 0\n"
                                                   "v 5 1 0\nf 1 2 3\nf 1 3 4\nf 2 1 3\nf 3 1 5\nf 6 7 8 9\n";
  // Two triangles on one vertex triple (a closed pillow) and a quad: subdivided uniformly, but the adaptive
  // hierarchy cannot hold the triangle twice (it failed with the Mt builder's words, naming no file).
  std::ofstream((dir / "pillow.obj").string()) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 0 0\nv 6 0 0\nv 6 1 0\nv 5 1 0\n"
                                                  "f 1 2 3\nf 3 2 1\nf 4 5 6 7\n";
  const std::string out = (dir / "out.obj").string();
  struct Case {
    std::string args, says;
  };
  const Case cases[] = {
      {"cube --scheme loop --levels 1 -o " + out, "unknown --scheme"},
      {"cube --levels -1 -o " + out, "--levels must be >= 0"},
      {"cube --steps -3 -o " + out, "--steps must be >= 0"},
      {"cube --levels 20 -o " + out, "lower --levels)"},
      {"cube --levels 1000 -o " + out, "absurd"},
      {"cube --scheme catmull-clark --steps 2000000000 -o " + out, "lower --steps)"},
      {"cube --scheme doo-sabin --steps 20 -o " + out, "lower --steps)"},
      {"cube --steps 30 --adaptive --error 0.1 -o " + out, "(--max-triangles / 8 with --adaptive; lower --steps)"},
      {"cube --levels 3 --max-triangles 100 -o " + out, "limit"},
      {"cube --levels 10 --adaptive --error 0.1 -o " + out, "(--max-triangles / 8 with --adaptive; lower --levels)"},
      {"cube --levels 1 --steps 2 -o " + out, "not both"},
      {"cube -o " + out, "--levels"},
      {"cube --levels 1", "-o"},
      {"cube --levels 1 -o " + (dir / "out.txt").string(), "-o must end"},
      {"cube --levels 1 --png " + (dir / "p.jpg").string() + " -o " + out, "--png must end"},
      {(dir / "missing.obj").string() + " --levels 1 -o " + out, "missing.obj"},
      {(dir / "trunc.off").string() + " --levels 1 -o " + out, "trunc.off"},
      {(dir / "bowtie.obj").string() + " --levels 1 -o " + out, "bowtie.obj:1: the faces at vertex 1 form 2 fans"},
      {(dir / "fin.obj").string() + " --levels 1 -o " + out, "fin.obj"},
      {"sphere --levels 1 -o " + out, "cube | torus"},
      {"cube --levels 1 --adaptive -o " + out, "--error"},
      {"cube --levels 1 --error 0.1 -o " + out, "need --adaptive"},
      {"cube --levels 1 --adaptive --camera 1,2,3 -o " + out, "--camera"},
      {"cube --scheme doo-sabin --levels 1 --adaptive --error 0.1 -o " + out, "primal"},
      {"cube --levels 1 --max-triangles 0 -o " + out, "--max-triangles"},
      {"cube --levels 1 --figure " + (dir / "fig").string() + " -o " + out, "--figure"},
      {(dir / "nm_quad.obj").string() + " --levels 1 -o " + out, "non-manifold edge"},
      {(dir / "pillow.obj").string() + " --levels 1 --adaptive --error 0 -o " + out, "pillow: build_subdivision_mt: faces 0 and 1"},
      {"cube --levels 1 --view 1,1,1 -o " + out, "give --png or --figure"},
      {"cube --levels 1 --error -0.5 -o " + out, "--error: must be >= 0"},
      {"cube --levels 1 --adaptive --camera 3,3,3,0,0,0,40 --pixels -1 -o " + out, "--pixels: must be > 0"},
      {"cube --steps -2147483648 -o " + out, "--steps must be >= 0"},
      {"cube --levels 2 --steps -2147483648 -o " + out, "not both"},
  };
  for (const Case& c : cases) {
    const CmdResult r = run(c.args, dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_EQ(r.out, "") << c.args;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.args;
    EXPECT_FALSE(fs::exists(dir / "fig")) << c.args;
  }
  // Nothing else was left behind (temporary files included).
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name == "bowtie.obj" || name == "fin.obj" || name == "trunc.off" || name == "nm_quad.obj" ||
                name == "pillow.obj" || name == "stdout.txt" || name == "stderr.txt")
        << name;
  }
}

TEST(SubdivCli, PngShowsTheResult) {
  const auto dir = testing::scratch_dir("subdiv_png");
  const CmdResult r = run("cube --scheme catmull-clark --levels 2 --png " + (dir / "cc.png").string() + " -o " +
                              (dir / "cc.obj").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const Image img = read_png((dir / "cc.png").string());
  EXPECT_EQ(img.width, 1024u);
  EXPECT_EQ(img.height, 768u);
  std::size_t covered = 0;
  for (std::size_t i = 0; i < img.pixels.size(); i += 3) covered += img.pixels[i] != 255 || img.pixels[i + 2] != 255;
  EXPECT_GT(covered, img.width * img.height / 10);  // the surface fills a good part of the frame
  EXPECT_TRUE(fs::exists(dir / "cc.obj"));
}

TEST(SubdivCli, FigureDrawsEverySchemeWithOneCamera) {
  const auto dir = testing::scratch_dir("subdiv_figure");
  const fs::path fig = dir / "fig";
  const CmdResult r = run("cube --levels 2 --figure " + fig.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::string> labels = {"base",          "triangles", "linear",       "48",
                                           "catmull-clark", "quasi48",   "zwart-powell", "doo-sabin"};
  for (const std::string& label : labels) {
    const fs::path p = fig / ("cube_" + label + ".png");
    ASSERT_TRUE(fs::exists(p)) << p;
    const Image img = read_png(p.string());
    EXPECT_EQ(img.width, 640u);
    EXPECT_EQ(img.height, 480u);
  }
  const Image grid = read_png((fig / "cube_grid.png").string());
  EXPECT_EQ(grid.width, 4u * 640u + 3u * 4u);
  EXPECT_EQ(grid.height, 2u * 480u + 4u);
  // The table lists every scheme.
  for (const char* s : {"linear", "48", "catmull-clark", "zwart-powell", "doo-sabin", "quasi48"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

// --figure wrote its pictures straight into the folder: a picture that could not be written (here a folder
// in its place; a full disk likewise) left the others behind. They are staged now, the folder in the way is
// found before any work, and an earlier figure survives a failed run.
TEST(SubdivCli, FigureIsWrittenAllOrNothing) {
  const auto dir = testing::scratch_dir("subdiv_figure_staged");
  const fs::path fig = dir / "fig";
  fs::create_directories(fig / "cube_grid.png");
  CmdResult r = run("cube --levels 1 --figure " + fig.string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find((fig / "cube_grid.png").string() + ": is a folder"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(fig)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"cube_grid.png"});
  // A working run, then one that fails while writing (files limited to 4 kB, like a full disk): the first
  // run's pictures are untouched and nothing of the second is left.
  fs::remove(fig / "cube_grid.png");
  r = run("cube --levels 1 --figure " + fig.string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string base = testing::slurp(fig / "cube_base.png");
  const std::string cmd = "sh -c \"trap '' XFSZ; ulimit -f 8; " + std::string(VARMESH_EXE) + " subdiv cube --levels 2 --figure " +
                          fig.string() + "\" >/dev/null 2>" + (dir / "stderr.txt").string();
  const int raw = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(raw) && WEXITSTATUS(raw) == 1);
  const std::string err = testing::slurp(dir / "stderr.txt");
  EXPECT_NE(err.find(fig.string() + "/cube_"), std::string::npos) << err;
  EXPECT_EQ(err.find("partial"), std::string::npos) << err;
  EXPECT_EQ(testing::slurp(fig / "cube_base.png"), base);
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(fig)) {
    ++entries;
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  }
  EXPECT_EQ(entries, 9u);
  // A picture that would replace the input (here through a link) is refused.
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
  std::ofstream(dir / "m.obj") << quad;
  fs::create_directories(dir / "fig2");
  fs::create_symlink("../m.obj", dir / "fig2" / "m_base.png");
  r = run((dir / "m.obj").string() + " --levels 1 --figure " + (dir / "fig2").string(), dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("is the same file as the input"), std::string::npos) << r.err;
  EXPECT_EQ(testing::slurp(dir / "m.obj"), quad);
}

}  // namespace
}  // namespace varmesh
