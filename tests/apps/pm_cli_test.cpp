// `varmesh pm build` and `varmesh pm query`: the files they write are what the library reads back, a full
// refinement restores the input, budgets and the schemes' ordering hold, and bad input is named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "multitri/mesh_distance.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt_io.hpp"
#include "multitri/mt_metrics.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/pm_fixtures.hpp"
#include "apps/cli_support.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::contains;
using testing::count_lines;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh(args, dir); }

// A bumpy torus written as OBJ, and its hierarchy built by the command.
struct Built {
  fs::path dir, mesh, vmh;
  TriMesh input;
};

Built build_torus(const char* name, const std::string& extra = "") {
  Built b;
  b.dir = testing::scratch_dir(name);
  b.mesh = b.dir / "torus.obj";
  b.vmh = b.dir / "torus.vmh";
  b.input = testing::make_torus(24, 12);
  write_mesh(b.mesh.string(), b.input);
  const CmdResult r = run("pm build " + b.mesh.string() + " -o " + b.vmh.string() + " --quiet " + extra, b.dir);
  EXPECT_EQ(r.status, 0) << r.err;
  return b;
}

TEST(PmCli, BuildWritesTheHierarchyTheLibraryReads) {
  for (const std::string cost : {"quadric", "quadric-plain", "lindstrom-turk"}) {
    SCOPED_TRACE(cost);
    const Built b = build_torus(("pm_cli_build_" + cost).c_str(), "--cost " + cost);
    const VertexHierarchy h = read_vertex_hierarchy(b.vmh.string());
    h.validate();
    EXPECT_EQ(h.num_leaves(), b.input.num_vertices());
    EXPECT_EQ(h.num_faces(), b.input.num_faces());
    EXPECT_GT(h.num_collapses(), b.input.num_vertices() / 2);
  }
  // A face target stops the analysis there, with or without the Lindstrom-Turk finish; --lt-finish 0 gives
  // the library's quadrics-to-the-end hierarchy.
  for (const std::string finish : {"", " --lt-finish 0", " --lt-finish 2.5"}) {
    SCOPED_TRACE(finish);
    const Built b = build_torus("pm_cli_build_target", "--faces 100" + finish);
    const VertexHierarchy h = read_vertex_hierarchy(b.vmh.string());
    EXPECT_LE(h.base_faces().size(), 100u);
    EXPECT_GT(h.base_faces().size(), 90u);
    QemOptions o;
    o.target_faces = 100;
    o.lt_finish = finish.empty() ? 4.0 : std::stod(finish.substr(finish.rfind(' ') + 1));
    const VertexHierarchy lib = build_vertex_hierarchy(read_mesh(b.mesh.string()), o);
    ASSERT_EQ(h.num_collapses(), lib.num_collapses());
    for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v) {
      EXPECT_EQ(h.record(v).vt, lib.record(v).vt) << "node " << v;
      EXPECT_EQ(h.record(v).vu, lib.record(v).vu) << "node " << v;
    }
  }
}

// A target the input meets already: no collapse, and a note that says why (it read as a failure: "0
// collapses" and nothing else). A target below the input gives no such note.
TEST(PmCli, ATargetTheInputMeetsIsANote) {
  const Built b = build_torus("pm_cli_target_met");
  const std::size_t nv = b.input.num_vertices(), nf = b.input.num_faces();
  for (const std::string& target : {"--faces " + std::to_string(nf + 1000), "--faces " + std::to_string(nf),
                                   "--vertices " + std::to_string(nv)}) {
    SCOPED_TRACE(target);
    const CmdResult r = run("pm build " + b.mesh.string() + " -o " + b.vmh.string() + " --quiet " + target, b.dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const bool by_faces = target.rfind("--faces", 0) == 0;
    EXPECT_TRUE(contains(r.out, "note: " + target + " is at or above the input's " +
                                    (by_faces ? std::to_string(nf) + " faces" : std::to_string(nv) + " vertices")))
        << r.out;
    EXPECT_EQ(read_vertex_hierarchy(b.vmh.string()).num_collapses(), 0u);
  }
  const CmdResult r = run("pm build " + b.mesh.string() + " -o " + b.vmh.string() + " --quiet --faces " + std::to_string(nf - 10), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(contains(r.out, "at or above")) << r.out;
  EXPECT_GT(read_vertex_hierarchy(b.vmh.string()).num_collapses(), 0u);
}

// Hierarchy outputs take their extension in any case, as mesh outputs do (".VMH" and ".Vrm" were refused
// as "must end in .vmh"); `info` tells a hierarchy by its magic either way.
TEST(PmCli, HierarchyExtensionsInAnyCase) {
  const Built b = build_torus("pm_cli_ext_case");
  const fs::path upper = b.dir / "T.VMH", vrm = b.dir / "t.Vrm";
  CmdResult r = run("pm build " + b.mesh.string() + " -o " + upper.string() + " --quiet", b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(testing::slurp(upper), testing::slurp(b.vmh)) << "the same hierarchy under either name";
  r = run("info " + upper.string(), b.dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "collapses")) << r.out;
  r = run("build " + b.mesh.string() + " --levels 1 --quiet -o " + vrm.string(), b.dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(vrm));
  r = run("pm build " + b.mesh.string() + " -o " + (b.dir / "t.vmhx").string() + " --quiet", b.dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "must end in .vmh")) << r.err;
}

// --threads runs the library's parallel analysis: the same hierarchy as QemOptions::threads gives, not the
// serial one (a torus of 65,536 faces: two parts of at least 16,384).
// Run without --quiet: the progress line, rewritten in place with carriage returns, is for a terminal only;
// here stderr is a file, as in a log, and gets none of it (the first report comes at 4,096 collapses).
TEST(PmCli, ThreadsGiveTheLibrarysParallelHierarchy) {
  const fs::path dir = testing::scratch_dir("pm_cli_threads");
  const fs::path mesh = dir / "torus.obj", vmh = dir / "torus.vmh";
  write_mesh(mesh.string(), testing::make_torus(256, 128));
  const CmdResult r = run("pm build " + mesh.string() + " -o " + vmh.string() + " --faces 600 --threads 2", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(contains(r.err, "\r")) << r.err;
  EXPECT_FALSE(contains(r.err, "collapses,")) << r.err;
  const VertexHierarchy h = read_vertex_hierarchy(vmh.string());
  ASSERT_GT(h.num_collapses(), 4096u);
  QemOptions o;
  o.target_faces = 600;
  const TriMesh input = read_mesh(mesh.string());
  const VertexHierarchy serial = build_vertex_hierarchy(input, o);
  o.threads = 2;
  const VertexHierarchy lib = build_vertex_hierarchy(input, o);
  EXPECT_LE(h.base_faces().size(), 600u);
  ASSERT_EQ(h.num_collapses(), lib.num_collapses());
  bool differs_from_serial = h.num_collapses() != serial.num_collapses();
  for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v) {
    EXPECT_EQ(h.record(v).vt, lib.record(v).vt) << "node " << v;
    EXPECT_EQ(h.record(v).vu, lib.record(v).vu) << "node " << v;
    if (!differs_from_serial) differs_from_serial = h.record(v).vt != serial.record(v).vt || h.record(v).vu != serial.record(v).vu;
  }
  EXPECT_TRUE(differs_from_serial);
}

// --measure reports the library's vertex-to-surface distance: for pm build from the input's vertices to the
// base mesh, for pm query from the original vertices to the extracted mesh (0 at full resolution).
TEST(PmCli, MeasureReportsTheDistanceToTheOriginal) {
  const Built b = build_torus("pm_cli_measure");
  const CmdResult built = run("pm build " + b.mesh.string() + " -o " + b.vmh.string() + " --faces 100 --measure --quiet", b.dir);
  ASSERT_EQ(built.status, 0) << built.err;
  const VertexHierarchy h = read_vertex_hierarchy(b.vmh.string());
  const SurfaceDistance want = vertex_to_surface_distance(read_mesh(b.mesh.string()), mesh_after_collapses(h, h.num_collapses()));
  const auto [rms, max] = testing::measured_distance(built.out, "base mesh");
  EXPECT_GT(want.rms, 0.0);
  EXPECT_NEAR(rms, want.rms, 1e-5 * want.rms) << built.out;
  EXPECT_NEAR(max, want.max, 1e-5 * want.max) << built.out;
  const fs::path out = b.dir / "q.obj";
  CmdResult q = run("pm query " + b.vmh.string() + " --error 0 --measure -o " + out.string(), b.dir);
  ASSERT_EQ(q.status, 0) << q.err;
  EXPECT_EQ(testing::measured_distance(q.out, "result").second, 0.0) << q.out;
  q = run("pm query " + b.vmh.string() + " --budget 150 --measure -o " + out.string(), b.dir);
  ASSERT_EQ(q.status, 0) << q.err;
  const SurfaceDistance coarse = vertex_to_surface_distance(read_mesh(b.mesh.string()), read_mesh(out.string()));
  EXPECT_NEAR(testing::measured_distance(q.out, "result").first, coarse.rms, 1e-5 * coarse.rms) << q.out;
  // Without the flag, no measurement line.
  q = run("pm query " + b.vmh.string() + " --budget 150 -o " + out.string(), b.dir);
  EXPECT_TRUE(std::isnan(testing::measured_distance(q.out, "result").first)) << q.out;
}

TEST(PmCli, QueryRefinesUnderEachScheme) {
  const Built b = build_torus("pm_cli_query");
  // Error 0: every node with an error is split, which on a curved torus is all of them: the input returns.
  const fs::path full = b.dir / "full.obj";
  CmdResult r = run("pm query " + b.vmh.string() + " --error 0 -o " + full.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const TriMesh m = read_mesh(full.string());
  EXPECT_EQ(m.num_faces(), b.input.num_faces());
  EXPECT_EQ(m.num_vertices(), b.input.num_vertices());
  // A budget caps the triangles.
  const fs::path small = b.dir / "small.obj";
  r = run("pm query " + b.vmh.string() + " --budget 150 -o " + small.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_LE(read_mesh(small.string()).num_faces(), 150u);
  EXPECT_TRUE(contains(r.out, "budget reached")) << r.out;
  EXPECT_FALSE(contains(r.err, "below the base mesh")) << r.err;
  // A budget below the base mesh: the base mesh, and a note that says so with its size.
  const std::size_t base_faces = read_vertex_hierarchy(b.vmh.string()).base_faces().size();
  ASSERT_GT(base_faces, 1u);
  r = run("pm query " + b.vmh.string() + " --budget 1 -o " + small.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_mesh(small.string()).num_faces(), base_faces);
  EXPECT_TRUE(contains(r.err, "--budget 1 is below the base mesh's " + std::to_string(base_faces) + " triangles")) << r.err;
  // Under a view, Kim-Lee refines no more than Hoppe-97, which refines no more than Xia-Varshney (Table 2).
  std::vector<std::size_t> vertices;
  for (const std::string scheme : {"kim-lee", "hoppe97", "xia-varshney"}) {
    const fs::path out = b.dir / (scheme + ".obj");
    r = run("pm query " + b.vmh.string() + " --scheme " + scheme + " --camera 3,-2,2,0.8,0,0,30 -o " + out.string(), b.dir);
    ASSERT_EQ(r.status, 0) << scheme << "\n" << r.err;
    EXPECT_TRUE(contains(r.out, scheme + ":")) << r.out;
    vertices.push_back(read_mesh(out.string()).num_vertices());
  }
  EXPECT_LE(vertices[0], vertices[1]);
  EXPECT_LE(vertices[1], vertices[2]);
  EXPECT_LT(vertices[0], b.input.num_vertices()) << "the view should leave part of the torus coarse";
  // --png renders the result beside the mesh.
  const fs::path png = b.dir / "q.png";
  r = run("pm query " + b.vmh.string() + " --error 0.01 -o " + (b.dir / "q.obj").string() + " --png " + png.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(png));
}

TEST(PmCli, BadInputIsNamed) {
  const Built b = build_torus("pm_cli_bad");
  const std::string out = (b.dir / "out.obj").string();
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vrm").string(), "-o must end in .vmh"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --cost fast", "--cost: unknown 'fast'"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --colors", "has no vertex colours"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --max-error nan", "--max-error must be"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --max-error -2", "--max-error: must be >= 0"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --faces 50 --lt-finish 0.5", "--lt-finish must be 0 or a number > 1, not 0.5"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --lt-finish 1", "--lt-finish must be"},
      // Combinations the analysis would ignore (helper-53).
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --faces 100 --vertices 200", "--faces excludes --vertices"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --max-error 0.1 --lt-finish 3", "--lt-finish needs --faces or --vertices"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --faces 100 --cost lindstrom-turk --lt-finish 3", "--lt-finish is for --cost quadric"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --faces 100 --colors --lt-finish 3", "--lt-finish does not apply with --colors"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --colors --cost lindstrom-turk", "--cost lindstrom-turk would be ignored"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --threads 2 --cost lindstrom-turk", "--threads is for --cost quadric"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --threads 0 --colors", "--threads does not apply with --colors"},
      {"pm build " + b.mesh.string() + " -o " + (b.dir / "h.vmh").string() + " --threads -1", "--threads: must be an integer >= 0"},
      {"pm query " + b.vmh.string() + " -o " + out, "give --error E, --camera ... or --budget N"},
      {"pm query " + b.vmh.string() + " --error 1 --scheme fast -o " + out, "--scheme: unknown 'fast'"},
      {"pm query " + b.vmh.string() + " --error nan -o " + out, "--error must be"},
      {"pm query " + b.vmh.string() + " --error inf -o " + out, "--error: must be a finite number"},
      {"pm query " + b.vmh.string() + " --camera 0,0,3,0,0,0,40 --viewport inf -o " + out, "--viewport: must be a finite number"},
      {"pm query " + b.vmh.string() + " --camera 0,0,3,0,0,0,40 --pixels 1e39 -o " + out, "--pixels: must be a finite number"},  // inf as a float
      {"pm query " + b.mesh.string() + " --error 1 -o " + out, b.mesh.string()},
  };
  for (const Case& c : cases) {
    const CmdResult r = run(c.args, b.dir);
    EXPECT_EQ(r.status, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, c.message)) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(b.dir / "h.vmh"));
  EXPECT_FALSE(fs::exists(b.dir / "h.vrm"));
  // A truncated hierarchy file is refused by name, and leaves no output.
  {
    std::ifstream in(b.vmh, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(b.dir / "cut.vmh", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const CmdResult r = run("pm query " + (b.dir / "cut.vmh").string() + " --error 1 -o " + out, b.dir);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, (b.dir / "cut.vmh").string())) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// The camera's far plane was an absolute 1e7: a model in large units (the bunny scaled by 1e9) came back as
// its base mesh. The same view of the same model at another scale refines the same vertices.
TEST(PmCli, CameraQueriesDoNotDependOnScale) {
  const auto dir = testing::scratch_dir("pm_cli_scale");
  std::vector<std::size_t> vertices;
  for (const float scale : {1e-5f, 1.0f, 1e9f}) {
    TriMesh m = testing::make_torus(24, 12);
    for (glm::vec3& p : m.positions) p *= scale;
    const fs::path mesh = dir / "torus.obj", vmh = dir / "torus.vmh";
    write_mesh(mesh.string(), m);
    CmdResult r = run("pm build " + mesh.string() + " -o " + vmh.string() + " --quiet", dir);
    ASSERT_EQ(r.status, 0) << r.err;
    char camera[160];
    std::snprintf(camera, sizeof camera, "%g,%g,%g,0,0,0,40", 0.4 * scale, -2.5 * scale, 1.2 * scale);
    r = run("pm query " + vmh.string() + " --camera " + camera + " -o " + (dir / "q.obj").string(), dir);
    ASSERT_EQ(r.status, 0) << r.err;
    std::size_t v = 0;
    ASSERT_EQ(std::sscanf(r.out.c_str(), "kim-lee: %zu vertices", &v), 1) << r.out;
    vertices.push_back(v);
  }
  // Float rounding of the scaled positions moves a few nodes across the thresholds; the base mesh (what the
  // far plane left at 1e9) has a tenth of these vertices.
  EXPECT_GT(vertices[1], 200u);
  for (std::size_t v : vertices) EXPECT_NEAR(double(v), double(vertices[1]), 0.03 * double(vertices[1]));
}

// `varmesh info` on hierarchy files: told by their magic (whatever the extension), summarised with the counts
// the library reads from the same file, and refused by name when the loader refuses them.
TEST(PmCli, InfoSummarisesHierarchyFiles) {
  const Built b = build_torus("pm_cli_info", "--faces 100");
  const VertexHierarchy h = read_vertex_hierarchy(b.vmh.string());
  CmdResult r = run("info " + b.vmh.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "progressive-mesh vertex hierarchy (.vmh, format 1")) << r.out;
  std::size_t leaves = 0, faces = 0, collapses = 0, nodes = 0, base_v = 0, base_f = 0;
  const std::size_t at = r.out.find(" leaves, ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::size_t line = r.out.rfind('\n', at) + 1;
  ASSERT_EQ(std::sscanf(r.out.c_str() + line, "%zu leaves, %zu faces, %zu collapses (%zu nodes) down to a base mesh of %zu vertices, %zu faces",
                        &leaves, &faces, &collapses, &nodes, &base_v, &base_f), 6)
      << r.out;
  EXPECT_EQ(leaves, h.num_leaves());
  EXPECT_EQ(faces, b.input.num_faces());
  EXPECT_EQ(collapses, h.num_collapses());
  EXPECT_EQ(nodes, h.num_leaves() + h.num_collapses());
  EXPECT_EQ(base_v, h.num_roots());
  EXPECT_EQ(base_f, h.base_faces().size());
  float worst = 0.0f;
  for (Index root : h.roots()) worst = std::max(worst, h.bound(root).error);
  const std::size_t eb = r.out.find("(largest root): ");
  ASSERT_NE(eb, std::string::npos) << r.out;
  EXPECT_NEAR(std::stod(r.out.substr(eb + 16)), worst, 1e-5 * worst + 1e-12) << r.out;
  // The magic decides, not the extension.
  fs::copy_file(b.vmh, b.dir / "hier.obj");
  r = run("info " + (b.dir / "hier.obj").string(), b.dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "progressive-mesh vertex hierarchy")) << r.out;

  // A .vrm from `varmesh build`: the node and face counts of the library's metrics.
  const fs::path vrm = b.dir / "torus.vrm";
  r = run("build " + b.mesh.string() + " -o " + vrm.string() + " --levels 2 --quiet", b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const Mt mt = read_mt(vrm.string());
  const MtMetrics m = compute_metrics(mt);
  r = run("info " + vrm.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  std::size_t split = 0, swap = 0, generic = 0;
  const std::size_t kinds = r.out.find("nodes: ");
  ASSERT_NE(kinds, std::string::npos) << r.out;
  ASSERT_EQ(std::sscanf(r.out.c_str() + kinds, "nodes: %zu split, %zu swap, %zu generic", &split, &swap, &generic), 3) << r.out;
  EXPECT_EQ(split + swap + generic, mt.num_nodes() - 1);
  EXPECT_GT(split, 0u);
  EXPECT_TRUE(contains(r.out, "hierarchy: " + std::to_string(m.nodes) + " nodes, " + std::to_string(m.faces) + " faces (" +
                                  std::to_string(m.coarsest_faces) + " coarsest, " + std::to_string(m.finest_faces) + " finest)"))
      << r.out;

  // Refused by name: truncated, missing, empty.
  {
    std::ifstream in(b.vmh, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(b.dir / "cut.vmh", std::ios::binary) << bytes.substr(0, bytes.size() - 7);
    std::ofstream(b.dir / "empty.vrm", std::ios::binary).flush();
  }
  for (const fs::path& bad : {b.dir / "cut.vmh", b.dir / "missing.vrm", b.dir / "empty.vrm"}) {
    r = run("info " + bad.string(), b.dir);
    EXPECT_EQ(r.status, 1) << bad;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, bad.string())) << r.err;
    EXPECT_FALSE(contains(r.err, "unknown mesh format")) << r.err;
  }
}

// The mesh formats go by extension in any case, as read_mesh and write_mesh take them: pm build used to refuse
// an INPUT that render accepts (BUNNY.OBJ), and pm query an -o that write_mesh would write.
TEST(PmCli, MeshExtensionsInAnyCase) {
  const Built b = build_torus("pm_cli_upper_case");
  const fs::path upper = b.dir / "TORUS.OBJ";
  fs::copy_file(b.mesh, upper);
  const fs::path vmh = b.dir / "upper.vmh";
  CmdResult r = run("pm build " + upper.string() + " -o " + vmh.string() + " --quiet", b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_vertex_hierarchy(vmh.string()).num_leaves(), b.input.num_vertices());
  const fs::path out = b.dir / "OUT.PLY", png = b.dir / "OUT.PNG";
  r = run("pm query " + vmh.string() + " --budget 200 -o " + out.string() + " --png " + png.string(), b.dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_LE(read_mesh(out.string()).num_faces(), 200u);
  EXPECT_TRUE(fs::exists(png));
  // Not a mesh or not a picture: named with the command and the option, before any work.
  const fs::path bad = b.dir / "out.stl";
  r = run("pm query " + vmh.string() + " --budget 200 -o " + bad.string(), b.dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "pm query: -o must end in .obj, .ply or .off, not '" + bad.string() + "'")) << r.err;
  r = run("pm query " + vmh.string() + " --budget 200 -o " + (b.dir / "x.obj").string() + " --png " +
              (b.dir / "x.jpg").string(), b.dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.err, "pm query: --png must end in .png")) << r.err;
  EXPECT_FALSE(fs::exists(bad));
  EXPECT_FALSE(fs::exists(b.dir / "x.obj"));
}

}  // namespace
}  // namespace varmesh
