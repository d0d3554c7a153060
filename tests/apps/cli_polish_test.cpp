// Polish of the command line's words: counts whose noun agrees with them ("1 triangle", not "1 triangles"),
// render's refusal of an empty default view that blames the picture when the picture is what is too small,
// and subdiv's topology errors in the file's own terms (its face numbers, lines and vertex numbers) rather
// than those of the quads it rebuilt from the reader's triangles.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "apps/cli_support.hpp"
#include "apps/cli_util.hpp"
#include "apps/file_faces.hpp"
#include "fourk/poly_mesh.hpp"
#include "fourk/topology_oracle.hpp"
#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::contains;
using testing::count_lines;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh(args, dir); }

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

TEST(CountNoun, SingularForOneOnly) {
  using app::count_noun;
  EXPECT_EQ(count_noun(1, "triangle"), "1 triangle");
  EXPECT_EQ(count_noun(0, "triangle"), "0 triangles");
  EXPECT_EQ(count_noun(2, "triangle"), "2 triangles");
  EXPECT_EQ(count_noun(1, "vertex"), "1 vertex");
  EXPECT_EQ(count_noun(3, "vertex"), "3 vertices");
  EXPECT_EQ(count_noun(2, "non-manifold vertex"), "2 non-manifold vertices");
  EXPECT_EQ(count_noun(4, "leaf"), "4 leaves");
  EXPECT_EQ(count_noun(2, "vertex copy"), "2 vertex copies");
  EXPECT_EQ(count_noun(1, "vertex copy"), "1 vertex copy");
  EXPECT_EQ(count_noun(5, "binary step"), "5 binary steps");
  EXPECT_EQ(count_noun(1, "binary step"), "1 binary step");
  EXPECT_EQ(count_noun(2, "array"), "2 arrays");  // a vowel before the y: a plain s
  EXPECT_EQ(count_noun(2, "pass"), "2 passes");
  EXPECT_EQ(count_noun(2, "box"), "2 boxes");
  EXPECT_EQ(count_noun(2, "patch"), "2 patches");
  EXPECT_EQ(count_noun(UINT64_MAX, "node"), "18446744073709551615 nodes");
  // Every count but 1 takes the plural, and the count is written as it is.
  for (std::uint64_t n : {0ull, 2ull, 11ull, 21ull, 101ull, 1000001ull}) {
    EXPECT_EQ(app::noun_for(n, "collapse"), "collapses") << n;
    EXPECT_EQ(count_noun(n, "collapse"), std::to_string(n) + " collapses");
  }
}

// A triangle on its own (counts of 1 all through) and a square of two.
const char* const kTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const char* const kSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

TEST(CliPlurals, RealCommandsSayOneInTheSingular) {
  const fs::path dir = testing::scratch_dir("polish_plurals");
  write_text(dir / "tri.obj", kTriangle);
  write_text(dir / "square.obj", kSquare);
  const std::string tri = (dir / "tri.obj").string(), out = (dir / "out.obj").string();

  CmdResult r = run("render " + tri + " -o " + (dir / "tri.png").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "rendered 1 triangle -> ")) << r.out;
  EXPECT_TRUE(fs::exists(dir / "tri.png"));
  r = run("render " + (dir / "square.obj").string() + " -o " + (dir / "square.png").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "rendered 2 triangles -> ")) << r.out;

  r = run("subdiv " + tri + " --steps 1 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "3 vertices, 1 triangle paired into 0 quads, 1 left")) << r.out;
  EXPECT_TRUE(contains(r.out, ", 1 binary step: 3 vertices, 1 face -> ")) << r.out;
  r = run("subdiv " + tri + " --steps 2 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, ", 2 binary steps: 3 vertices, 1 face -> ")) << r.out;
  r = run("subdiv " + tri + " --scheme doo-sabin --steps 1 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "Doo-Sabin, 1 step: ")) << r.out;
  // A flat triangle moves nowhere: the front keeps the one base triangle.
  r = run("subdiv " + tri + " --steps 1 --adaptive --error 0 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, ", 1 binary step, adaptive: ")) << r.out;
  EXPECT_TRUE(contains(r.out, " 1 triangle of ")) << r.out;
  EXPECT_EQ(read_mesh(out).num_faces(), 1u);
  // The limit check counts steps too.
  r = run("subdiv cube --steps 1 --max-triangles 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "48 with 1 step would make ")) << r.err;

  // An octahedron down to 5 vertices: one collapse, and one vsplit back.
  write_text(dir / "oct.obj",
             "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\nf 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\n"
             "f 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n");
  const std::string vmh = (dir / "oct.vmh").string();
  r = run("pm build " + (dir / "oct.obj").string() + " --vertices 5 --quiet -o " + vmh, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "\n1 collapse (rejected: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "0 unreferenced vertices, ")) << r.out;
  // Six vertices are within 4x the target of 5: the one collapse is the Lindstrom-Turk finish's.
  EXPECT_TRUE(contains(r.out, "\ncollapse 1 ordered and placed by Lindstrom-Turk costs")) << r.out;
  EXPECT_FALSE(contains(r.out, "collapses 1 to 1")) << r.out;
  r = run("pm build " + (dir / "oct.obj").string() + " --vertices 4 --quiet -o " + (dir / "oct4.vmh").string(), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "\ncollapses 1 to 2 ordered and placed by Lindstrom-Turk costs")) << r.out;
  r = run("info " + vmh, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "6 leaves, 8 faces, 1 collapse (7 nodes)")) << r.out;
  r = run("pm query " + vmh + " --error 0 -o " + out, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "(1 vsplit, 0 forced, 0 ecols, ")) << r.out;
}

// A picture too small for any face to cover a pixel's centre: the message names the picture's size and the
// option to raise, and nothing is written. A mesh whose faces are tiny against its bounding box keeps the
// message that blames the faces, at any picture size: a larger picture would not help it.
TEST(CliRender, EmptyTinyPictureBlamesThePictureNotTheMesh) {
  const fs::path dir = testing::scratch_dir("polish_render_tiny");
  write_text(dir / "tri.obj", kTriangle);
  const std::string tri = (dir / "tri.obj").string();
  const fs::path png = dir / "out.png";
  struct Case {
    std::string size, says;
  };
  for (const Case& c : {Case{"--height 1", "the picture, 1024 x 1 pixels, is too small"},
                        Case{"--width 1", "the picture, 1 x 768 pixels, is too small"}}) {
    const CmdResult r = run("render " + tri + " -o " + png.string() + " " + c.size, dir);
    EXPECT_EQ(r.status, 1) << c.size;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, c.says)) << r.err;
    EXPECT_TRUE(contains(r.err, "give a larger " + c.size.substr(0, c.size.find(' ')))) << r.err;
    EXPECT_TRUE(contains(r.err, "nothing was written")) << r.err;
    EXPECT_FALSE(contains(r.err, "vertex far from the others")) << r.err;
    EXPECT_FALSE(fs::exists(png)) << c.size;
  }
  // The same triangle in a picture large enough shows.
  CmdResult r = run("render " + tri + " -o " + png.string() + " --height 64", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(png));
  fs::remove(png);

  // Two triangles 1e-4 across, 100 apart.
  write_text(dir / "specks.obj", "v 0 0 0\nv 0.0001 0 0\nv 0 0.0001 0\nv 100 0 0\nv 100.0001 0 0\nv 100 0.0001 0\n"
                                 "f 1 2 3\nf 4 5 6\n");
  for (const std::string size : {"", " --height 1"}) {
    r = run("render " + (dir / "specks.obj").string() + " -o " + png.string() + size, dir);
    EXPECT_EQ(r.status, 1) << size;
    EXPECT_TRUE(contains(r.err, "the faces are far smaller than the box")) << r.err;
    EXPECT_FALSE(contains(r.err, "is too small to show the mesh")) << r.err;
    EXPECT_FALSE(fs::exists(png)) << size;
  }
}

// Quads on one edge three times, after two triangles (which the rebuilt polygon mesh merges into one quad,
// so its face numbers run one behind the file's): the message names the file's faces, their lines and the
// OBJ's own vertex numbers.
TEST(CliSubdiv, NonManifoldPolygonFileIsNamedInTheFilesTerms) {
  const fs::path dir = testing::scratch_dir("polish_subdiv_nonmanifold");
  const std::string out = (dir / "out.obj").string();
  write_text(dir / "fin.obj",
             "# two triangles, then three quads on the edge 1-2\n"
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 -1 0\nv 1 -1 0\nv 0 0 1\nv 1 0 1\n"
             "f 1 2 6\n"       // line 10, face 1
             "f 1 6 5\n"       // line 11, face 2 (with face 1, one quad of the rebuilt mesh)
             "\n"
             "f 1 2 3 4\n"     // line 13, face 3
             "f 2 1 8 7\n");   // line 14, face 4: faces 1, 3 and 4 hold the edge 1-2
  CmdResult r = run("subdiv " + (dir / "fin.obj").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, "fin.obj:14: the edge 1-2 belongs to 3 faces, faces 1, 3 and 4 (lines 10, 13 and 14): a "
                              "non-manifold edge"))
      << r.err;
  EXPECT_FALSE(fs::exists(out));

  // Two quads that run their shared edge the same way, after a square of two triangles elsewhere; CRLF line
  // ends and a comment after a face.
  write_text(dir / "flip.obj", "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nv 2 0 0\r\nv 2 1 0\r\n"
                               "v 5 5 0\r\nv 6 5 0\r\nv 6 6 0\r\nv 5 6 0\r\nf 7 8 9\r\nf 7 9 10\r\n"
                               "f 1 2 3 4\r\nf 2 3 6 5 # flipped\r\n");
  r = run("subdiv " + (dir / "flip.obj").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "flip.obj:14: faces 3 and 4 (lines 13 and 14) both run the edge 2-3 from 2 to 3: their "
                              "orientations disagree"))
      << r.err;
  EXPECT_FALSE(fs::exists(out));

  // OFF numbers its vertices from 0, and counts its lines with the header's; a bow-tie of two quads.
  write_text(dir / "bowtie.off", "OFF\n# a bow-tie\n7 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 0 0\n-1 -1 0\n0 -1 0\n"
                                 "4 0 1 2 3\n4 0 4 5 6\n");
  r = run("subdiv " + (dir / "bowtie.off").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "bowtie.off:4: the faces at vertex 0 form 2 fans that share no edge there, e.g. faces 1 "
                              "and 2 (lines 11 and 12): a non-manifold vertex"))
      << r.err;
  EXPECT_FALSE(fs::exists(out));

  // A triangle file (paired into quads by the command): the same words.
  write_text(dir / "fin3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  r = run("subdiv " + (dir / "fin3.obj").string() + " --scheme quasi48 --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "fin3.obj:8: the edge 1-2 belongs to 3 faces, faces 1, 2 and 3 (lines 6, 7 and 8)")) << r.err;
  EXPECT_FALSE(fs::exists(out));

  // PLY counts vertices from 0 like OFF; an ascii body has lines (a face spread over two here), a binary one
  // only face numbers. Three quads on the edge 0-1.
  const std::string head = "ply\nformat %s 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n";
  const float xyz[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, -1, 0}, {1, -1, 0}, {0, 0, 1}, {1, 0, 1}};
  const std::vector<std::vector<std::int32_t>> quads = {{0, 1, 2, 3}, {1, 0, 4, 5}, {0, 1, 7, 6}};
  std::string ascii = head, binary = head;
  auto le32 = [&binary](std::uint32_t u) {
    for (int k = 0; k < 4; ++k) binary += static_cast<char>((u >> (8 * k)) & 0xffu);
  };
  ascii.replace(ascii.find("%s"), 2, "ascii");
  binary.replace(binary.find("%s"), 2, "binary_little_endian");
  for (const auto& p : xyz) {
    ascii += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
    for (float c : p) le32(std::bit_cast<std::uint32_t>(c));
  }
  ascii += "4 0 1 2 3\n4 1 0 4 5\n4\n0 1 7 6\n";  // faces on lines 18, 19 and 20
  for (const auto& q : quads) {
    binary += '\4';
    for (std::int32_t c : q) le32(static_cast<std::uint32_t>(c));
  }
  write_text(dir / "fin_ascii.ply", ascii);
  write_text(dir / "fin_binary.ply", binary);
  r = run("subdiv " + (dir / "fin_ascii.ply").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "fin_ascii.ply:20: the edge 0-1 belongs to 3 faces, faces 1, 2 and 3 (lines 18, 19 and "
                              "20): a non-manifold edge"))
      << r.err;
  r = run("subdiv " + (dir / "fin_binary.ply").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "fin_binary.ply: the edge 0-1 belongs to 3 faces, faces 1, 2 and 3: a non-manifold edge"))
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// `build` on a mesh that breaks the 4-k hierarchy's rules (FourKMesh's, which simplify4k checks too): the
// message names the file's faces from 1, their lines and the OBJ's vertex numbers, not the library's numbering
// of the reader's triangles (a quad first makes the two differ: the library's faces 2 and 3 are the file's 2
// and 3, but its face 0 is half of the file's face 1), and no hierarchy is written. A non-manifold vertex is
// no error for these methods: the bow-tie builds.
TEST(CliBuild, TopologyErrorsNameTheFilesFaces) {
  const fs::path dir = testing::scratch_dir("polish_build_topology");
  const std::string out = (dir / "out.vrm").string();
  const std::string square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n# faces\n";
  write_text(dir / "fin.obj", square + "f 1 2 3 4\nf 2 1 5\nf 1 2 6\n");  // faces on lines 8, 9 and 10
  write_text(dir / "flip.obj", square + "f 1 2 3 4\n\nf 2 3 5\n");        // lines 8 and 10
  write_text(dir / "pillow.obj", square + "f 1 2 3 4\nf 2 5 6\nf 6 5 2\n");
  write_text(dir / "bowtie.obj", square + "v -1 0 0\nv -1 -1 0\nf 1 2 3 4\nf 1 7 8\n");
  struct Case {
    std::string file, says;
  };
  const Case cases[] = {
      {"fin.obj", "fin.obj:10: the edge 1-2 belongs to 3 faces, faces 1, 2 and 3 (lines 8, 9 and 10): a non-manifold edge"},
      {"flip.obj", "flip.obj:10: faces 1 and 2 (lines 8 and 10) both run the edge 2-3 from 2 to 3: their orientations "
                   "disagree"},
      {"pillow.obj", "pillow.obj:10: faces 2 and 3 (lines 9 and 10) have the same vertices: a doubled face"},
  };
  for (const char* method : {"semiregular", "simplify4k"})
    for (const Case& c : cases) {
      const std::string args = "build --method " + std::string(method) + " " + (dir / c.file).string() + " -o " + out;
      const CmdResult r = run(args, dir);
      EXPECT_EQ(r.status, 1) << args;
      EXPECT_EQ(count_lines(r.err), 1) << r.err;
      EXPECT_TRUE(contains(r.err, c.says)) << args << "\n" << r.err;
      EXPECT_FALSE(contains(r.err, "FourKMesh")) << r.err;
      EXPECT_FALSE(fs::exists(out)) << args;
    }
  const CmdResult r = run("build --method semiregular " + (dir / "bowtie.obj").string() + " --levels 1 -o " + out, dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
}

// The reader's provenance read with the mesh.
std::pair<TriMesh, ReadInfo> read_with_sources(const std::string& name, const std::string& text) {
  ReadInfo info;
  info.want_sources = true;
  TriMesh m = read_mesh_data(name, text, &info);
  return {std::move(m), std::move(info)};
}

// file_faces from the readers' provenance on hand-made text: polygons of any size come back with their
// corners and lines, whatever the line ends; provenance that does not describe the mesh, or triangle strips,
// give nothing.
TEST(FileFaces, FromTheReadersProvenance) {
  const std::string obj = "\xEF\xBB\xBFv 0 0 0\rv 1 0 0\r\nv 2 1 0\nv 1 2 0\nv 0 2 0 # five\nv -1 1 0\n"
                          "f 1 2 3 4 5 6\r\n# a comment\n\nf -6 -4 -3\n";
  const auto [m, info] = read_with_sources("hex.obj", obj);
  const std::optional<app::FileFaces> ff = app::file_faces(m, info);
  ASSERT_TRUE(ff);
  EXPECT_EQ(ff->offsets, (std::vector<std::size_t>{0, 6, 9}));
  EXPECT_EQ(ff->corners, (std::vector<Index>{0, 1, 2, 3, 4, 5, 0, 2, 3}));
  EXPECT_EQ(ff->lines, (std::vector<std::size_t>{7, 10}));
  EXPECT_EQ(ff->vertex_lines, (std::vector<std::size_t>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(ff->first_vertex, 1u);

  const std::string off = "OFF 4\n\n 2 # counts on two lines\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n3 0 2 1\n";
  const auto [mo, info_o] = read_with_sources("q.off", off);
  const std::optional<app::FileFaces> fo = app::file_faces(mo, info_o);
  ASSERT_TRUE(fo);
  EXPECT_EQ(fo->corners, (std::vector<Index>{0, 1, 2, 3, 0, 2, 1}));
  EXPECT_EQ(fo->lines, (std::vector<std::size_t>{8, 9}));
  EXPECT_EQ(fo->vertex_lines, (std::vector<std::size_t>{4, 5, 6, 7}));
  EXPECT_EQ(fo->first_vertex, 0u);

  // Another file's mesh, or a read that asked for no provenance: nothing.
  EXPECT_FALSE(app::file_faces(mo, info));
  EXPECT_FALSE(app::file_faces(m, info_o));
  ReadInfo plain;
  EXPECT_FALSE(app::file_faces(read_mesh_data("hex.obj", obj, &plain), plain));

  // The same quad and triangle as a PLY: ascii lines, binary none.
  const std::string ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                          "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n\n3 0 2 1\n";
  const auto [mp, info_p] = read_with_sources("q.ply", ply);
  const std::optional<app::FileFaces> fp = app::file_faces(mp, info_p);
  ASSERT_TRUE(fp);
  EXPECT_EQ(fp->corners, fo->corners);
  EXPECT_EQ(fp->offsets, fo->offsets);
  EXPECT_EQ(fp->lines, (std::vector<std::size_t>{14, 16}));
  EXPECT_EQ(fp->vertex_lines, (std::vector<std::size_t>{10, 11, 12, 13}));
  EXPECT_EQ(fp->first_vertex, 0u);

  // Triangle strips are no polygons.
  const std::string strips = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                             "property float z\nelement tristrips 1\nproperty list uchar int vertex_indices\n"
                             "end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n4 0 1 2 3\n";
  const auto [ms, info_s] = read_with_sources("s.ply", strips);
  EXPECT_FALSE(app::file_faces(ms, info_s));
}

// A polygon file made by cutting and damaging a grid of quads and triangles (faces reversed, doubled,
// fins added across edges, faces removed, a corner repeated, the order shuffled), written as OBJ and OFF with
// comments, blank lines and mixed line ends. The provenance must give back the faces as written; the problem
// found in them must be the one a brute-force reading of the rules finds (tests/fourk/topology_oracle.hpp),
// there exactly when PolyMesh::validate() refuses the same faces, and its words must name the file's faces,
// vertices and line.
TEST(FileFaces, TopologyProblemAgreesWithPolyMeshValidate) {
  std::mt19937 rng(93);
  auto pick = [&rng](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  int problems = 0, clean = 0;
  for (int round = 0; round < 400; ++round) {
    const std::size_t w = 1 + pick(4), h = 1 + pick(3);
    std::vector<glm::dvec3> positions;
    for (std::size_t y = 0; y <= h; ++y)
      for (std::size_t x = 0; x <= w; ++x) positions.emplace_back(double(x), double(y), 0.0);
    std::vector<std::vector<Index>> faces;
    for (std::size_t y = 0; y < h; ++y)
      for (std::size_t x = 0; x < w; ++x) {
        const Index a = Index(y * (w + 1) + x), b = a + 1, c = b + Index(w + 1), d = a + Index(w + 1);
        if (pick(3) == 0) {
          faces.push_back({a, b, c});
          faces.push_back({a, c, d});
        } else {
          faces.push_back({a, b, c, d});
        }
      }
    const int damages = int(pick(3));
    for (int k = 0; k < damages; ++k) {
      std::vector<Index>& f = faces[pick(faces.size())];
      switch (pick(6)) {
        case 0: std::reverse(f.begin(), f.end()); break;
        case 1: faces.push_back(faces[pick(faces.size())]); break;
        case 2: {  // a fin: a new vertex and a triangle on an edge of f
          const std::size_t i = pick(f.size());
          positions.emplace_back(0.5, 0.5, 1.0 + double(k));
          const std::vector<Index> fin{f[(i + 1) % f.size()], f[i], Index(positions.size() - 1)};
          faces.push_back(fin);
          break;
        }
        case 3:
          if (faces.size() > 1) faces.erase(faces.begin() + std::ptrdiff_t(pick(faces.size())));
          break;
        case 4: {  // glue two vertices: bow-ties, and sometimes worse
          const Index from = Index(pick(positions.size())), to = Index(pick(positions.size()));
          for (std::vector<Index>& g : faces)
            std::replace(g.begin(), g.end(), from, to);
          break;
        }
        default: f[pick(f.size())] = f[pick(f.size())]; break;  // maybe a repeated corner
      }
    }
    std::shuffle(faces.begin(), faces.end(), rng);
    for (std::vector<Index>& f : faces) std::rotate(f.begin(), f.begin() + std::ptrdiff_t(pick(f.size())), f.end());

    PolyMesh p;
    p.positions = positions;
    for (const std::vector<Index>& f : faces) p.add_face(f);
    bool valid = true;
    try {
      p.validate();
    } catch (const InvalidInput&) {
      valid = false;
    }
    const TopologyProblem expected = testing::slow_topology_problem(faces, kPolyMeshRules);
    EXPECT_EQ(valid, !expected) << describe_topology_problem(expected);

    for (const bool as_obj : {true, false}) {
      const char* ends[] = {"\n", "\r\n", "\r"};
      std::string text;
      std::size_t line = 1;
      std::vector<std::size_t> face_lines, vertex_lines;
      auto put = [&](const std::string& s) {
        // An empty line's LF right after a lone CR would make the two one CRLF.
        const bool after_cr = !text.empty() && text.back() == '\r';
        text += s + (s.empty() && after_cr ? "\r" : ends[pick(3)]);
        ++line;
      };
      if (as_obj) {
        put("# round " + std::to_string(round));
        for (const glm::dvec3& q : positions) {
          vertex_lines.push_back(line);
          put("v " + std::to_string(q.x) + " " + std::to_string(q.y) + " " + std::to_string(q.z));
        }
        for (const std::vector<Index>& f : faces) {
          if (pick(4) == 0) put("");
          std::string s = "f";
          for (Index c : f) s += " " + std::to_string(c + 1);
          face_lines.push_back(line);
          put(s + (pick(4) == 0 ? " # a face" : ""));
        }
      } else {
        put("OFF");
        put(std::to_string(positions.size()) + " " + std::to_string(faces.size()) + " 0");
        for (const glm::dvec3& q : positions) {
          vertex_lines.push_back(line);
          put(std::to_string(q.x) + " " + std::to_string(q.y) + " " + std::to_string(q.z));
        }
        for (const std::vector<Index>& f : faces) {
          if (pick(4) == 0) put("# between faces");
          std::string s = std::to_string(f.size());
          for (Index c : f) s += " " + std::to_string(c);
          face_lines.push_back(line);
          put(s);
        }
      }
      const std::string name = as_obj ? "r.obj" : "r.off";
      const auto [m, info] = read_with_sources(name, text);
      const std::optional<app::FileFaces> ff = app::file_faces(m, info);
      ASSERT_TRUE(ff) << text;
      ASSERT_EQ(ff->num_faces(), faces.size());
      for (std::size_t f = 0; f < faces.size(); ++f) {
        EXPECT_EQ(std::vector<Index>(ff->corners.begin() + std::ptrdiff_t(ff->offsets[f]),
                                     ff->corners.begin() + std::ptrdiff_t(ff->offsets[f + 1])),
                  faces[f]);
        EXPECT_EQ(ff->lines[f], face_lines[f]);
      }
      // The data: the rule, faces and vertices the brute-force reading of the rules finds in the faces as
      // written (file order, so face f is the file's face f + 1).
      const TopologyProblem found = app::find_topology_problem(*ff);
      EXPECT_TRUE(testing::same_problem(found, expected)) << describe_topology_problem(found) << "\n" << text;
      // The words: the file's face numbers, lines and vertex numbers, and the line of the face that shows it.
      std::size_t at = 0;
      const std::string problem = app::topology_problem(*ff, &at);
      EXPECT_EQ(problem.empty(), valid) << problem << "\n" << text;
      if (expected) {
        const Index first_vertex = as_obj ? 1 : 0;
        std::string named = expected.faces.size() == 1 ? "face " : "faces ";
        for (std::size_t i = 0; i < expected.faces.size(); ++i)
          named += (i == 0 ? "" : i + 1 == expected.faces.size() ? " and " : ", ") + std::to_string(expected.faces[i] + 1);
        EXPECT_TRUE(contains(problem, named)) << named << " in " << problem;
        const Index v0 = expected.vertices[0] + first_vertex, v1 = expected.vertices[1] + first_vertex;
        std::size_t want_line = 0;
        switch (expected.rule) {
          case TopologyRule::kRepeatedCorner:
            EXPECT_TRUE(contains(problem, "lists vertex " + std::to_string(v0) + " twice")) << problem;
            want_line = face_lines[expected.faces[0]];
            break;
          case TopologyRule::kNonManifoldEdge:
            EXPECT_TRUE(contains(problem, "the edge " + std::to_string(std::min(v0, v1)) + "-" +
                                              std::to_string(std::max(v0, v1)) + " belongs to"))
                << problem;
            want_line = face_lines[expected.faces[2]];
            break;
          case TopologyRule::kInconsistentOrientation:
            EXPECT_TRUE(contains(problem, "from " + std::to_string(v0) + " to " + std::to_string(v1))) << problem;
            want_line = face_lines[expected.faces[1]];
            break;
          case TopologyRule::kNonManifoldVertex:
            EXPECT_TRUE(contains(problem, "the faces at vertex " + std::to_string(v0) + " form")) << problem;
            want_line = vertex_lines[expected.vertices[0]];
            break;
          default: ADD_FAILURE() << problem;
        }
        EXPECT_EQ(at, want_line) << problem;
      }
      (valid ? clean : problems) += 1;
    }
  }
  // Both kinds came up often enough to mean something.
  EXPECT_GT(problems, 100);
  EXPECT_GT(clean, 100);
}

}  // namespace
}  // namespace varmesh
