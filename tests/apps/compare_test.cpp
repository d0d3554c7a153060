// `varmesh compare` as a user runs it: the quick run writes its table and pictures and exits 0, the printed
// #V and #F follow the paper's ordering (ours <= Hoppe-97 <= Xia-Varshney) in every case, missing data falls
// back to generated inputs, and bad options fail with exit code 1 and a one-line error.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "multitri/image.hpp"
#include "apps/cli_support.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

using testing::CmdResult;
using testing::slurp;

CmdResult run(const std::string& args, const fs::path& dir) { return testing::run_varmesh("compare " + args, dir); }

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

// #V and #F of one scheme in one case.
struct Counts {
  long vertices = -1, faces = -1;
};

std::string trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(' '), b = s.find_last_not_of(' ');
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// The table `varmesh compare` prints (print_table in apps/compare.cpp): a label of 16 columns, then one
// " |" cell per case. The "model" row names the cases ("<case> <type>"), the "scheme" row the three columns
// of each case (XV96, H97, ours, in any order), and the "#V" and "#F" rows hold the counts. Returns case ->
// scheme -> counts; a malformed table is a test failure.
std::map<std::string, std::map<std::string, Counts>> parse_counts(const std::string& out) {
  std::map<std::string, std::vector<std::vector<std::string>>> rows;  // label -> cells -> words
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.find(" |") == std::string::npos) continue;
    std::vector<std::string> parts;
    std::size_t from = 0;
    for (std::size_t bar; (bar = line.find(" |", from)) != std::string::npos; from = bar + 2) parts.push_back(line.substr(from, bar - from));
    parts.push_back(line.substr(from));
    std::vector<std::vector<std::string>> cells;
    for (std::size_t k = 1; k < parts.size(); ++k) {
      std::istringstream words(parts[k]);
      std::vector<std::string> w;
      for (std::string x; words >> x;) w.push_back(x);
      cells.push_back(w);
    }
    rows[trim(parts[0])] = cells;
  }
  std::map<std::string, std::map<std::string, Counts>> table;
  for (const char* label : {"model", "scheme", "#V", "#F"})
    if (rows.count(label) == 0) {
      ADD_FAILURE() << "no row '" << label << "' in\n" << out;
      return table;
    }
  const auto &models = rows["model"], &schemes = rows["scheme"], &vs = rows["#V"], &fs = rows["#F"];
  if (schemes.size() != models.size() || vs.size() != models.size() || fs.size() != models.size()) {
    ADD_FAILURE() << "rows of different lengths in\n" << out;
    return table;
  }
  auto number = [&](const std::string& s) {
    long v = -1;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size()) ADD_FAILURE() << "not a count: '" << s << "'";
    return v;
  };
  for (std::size_t c = 0; c < models.size(); ++c) {
    if (models[c].empty() || schemes[c].size() != 3 || vs[c].size() != 3 || fs[c].size() != 3) {
      ADD_FAILURE() << "case column " << c << " is not three cells in\n" << out;
      continue;
    }
    for (std::size_t k = 0; k < 3; ++k) table[models[c][0]][schemes[c][k]] = {number(vs[c][k]), number(fs[c][k])};
  }
  return table;
}

// Kim-Lee 2001, Table 2: ours <= Hoppe-97 <= Xia-Varshney in #V and in #F, for each of `cases` (exactly the
// cases of the table), read from the printed numbers; the run's own verdict line must agree.
void expect_ordering(const std::string& out, const std::vector<std::string>& cases) {
  const auto table = parse_counts(out);
  std::vector<std::string> found;
  for (const auto& [name, runs] : table) found.push_back(name);
  std::vector<std::string> want = cases;
  std::sort(want.begin(), want.end());
  EXPECT_EQ(found, want) << out;
  for (const auto& [name, runs] : table) {
    SCOPED_TRACE(name);
    ASSERT_EQ(runs.size(), 3u) << out;
    ASSERT_TRUE(runs.count("ours") && runs.count("H97") && runs.count("XV96")) << out;
    const Counts &ours = runs.at("ours"), &h97 = runs.at("H97"), &xv96 = runs.at("XV96");
    EXPECT_GT(ours.vertices, 0);
    EXPECT_GT(ours.faces, 0);
    EXPECT_LE(ours.vertices, h97.vertices) << "#V: ours > Hoppe-97";
    EXPECT_LE(h97.vertices, xv96.vertices) << "#V: Hoppe-97 > Xia-Varshney";
    EXPECT_LE(ours.faces, h97.faces) << "#F: ours > Hoppe-97";
    EXPECT_LE(h97.faces, xv96.faces) << "#F: Hoppe-97 > Xia-Varshney";
    EXPECT_NE(out.find(name + ": kim-lee <= hoppe97 <= xia-varshney in #V and #F: holds\n"), std::string::npos) << out;
  }
}

// Generated inputs only (an empty data folder), all five cases, small panels: fast under sanitizers.
TEST(Compare, QuickRunOnGeneratedInputsWritesTableAndPictures) {
  const fs::path dir = testing::scratch_dir("compare_quick");
  const fs::path empty = dir / "no_data";
  fs::create_directories(empty);
  const fs::path out = dir / "out";
  const testing::EnvGuard no_package("VARMESH_PACKAGED_MESHES", "none");
  const CmdResult r = run("--quick --quiet --panel 96 --size 16 --out " + out.string() + " --data " + empty.string(), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  for (const char* name : {"image", "terrain", "bunny", "cow", "dragon"}) {
    SCOPED_TRACE(name);
    EXPECT_NE(r.out.find(std::string(name) + ": kim-lee <= hoppe97 <= xia-varshney in #V and #F: "), std::string::npos) << r.out;
    for (const char* kind : {"_schemes.png", "_dual_pieces.png"}) {
      const Image img = read_png((out / (std::string(name) + kind)).string());
      EXPECT_EQ(img.width, 3u * 96u);
      EXPECT_EQ(img.height, std::string(name) == "image" && std::string(kind) == "_schemes.png" ? 2u * 96u : 96u);
    }
  }
  EXPECT_EQ(read_png((out / "image_features.png").string()).width, 2u * 96u);
  EXPECT_EQ(count(r.out, "generated"), 5) << r.out;
  expect_ordering(r.out, {"image", "terrain", "bunny", "cow", "dragon"});
  // The table: every row of Table 2, one column per case and scheme.
  for (const char* row : {"#V", "#F", "#DC", "forced vsplits", "forced ecols", "time ms"})
    EXPECT_NE(r.out.find(std::string("\n") + row + " "), std::string::npos) << row;
  const std::string md = slurp(out / "table.md");
  EXPECT_EQ(count(md, "kim-lee <= hoppe97"), 5);
  EXPECT_EQ(count(md, "| image kim-lee |"), 1);
  const std::string csv = slurp(out / "table.csv");
  EXPECT_EQ(count(csv, "\n"), 1 + 5 * 3);
  // Kim-Lee forces nothing, and no scheme misses a required vertex on these inputs.
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  while (std::getline(lines, line)) {
    std::vector<std::string> f;
    std::string cell;
    bool quoted = false;
    for (char c : line) {
      if (c == '"') quoted = !quoted;
      else if (c == ',' && !quoted) {
        f.push_back(cell);
        cell.clear();
      } else cell += c;
    }
    f.push_back(cell);
    ASSERT_EQ(f.size(), 19u) << line;
    EXPECT_EQ(f[15], "0") << "missing vertices: " << line;
    if (f[8] == "kim-lee") {
      EXPECT_EQ(f[12], "0") << line;
      EXPECT_EQ(f[13], "0") << line;
    }
  }
  EXPECT_TRUE(fs::exists(out / "compare_notes.md"));
}

// The Lindstrom-Turk analysis and the plain quadric placement give other hierarchies; the schemes'
// invariants hold on them too (Kim-Lee forces nothing and misses nothing), and the run says which cost it
// used.
TEST(Compare, OtherCostsRunEveryCase) {
  for (const std::string cost : {"lindstrom-turk", "quadric-plain"}) {
    SCOPED_TRACE(cost);
    const fs::path dir = testing::scratch_dir("compare_" + cost);
    const fs::path empty = dir / "no_data";
    fs::create_directories(empty);
    const fs::path out = dir / "out";
    // Generated stand-ins only (the packaged 75k-face bunny would dominate the sanitizer run).
    const testing::EnvGuard no_package("VARMESH_PACKAGED_MESHES", "none");
    const CmdResult r = run("--quick --quiet --panel 64 --size 16 --cost " + cost + " --out " + out.string() +
                                " --data " + empty.string(),
                            dir);
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("(collapse cost: " + cost + ")"), std::string::npos) << r.out;
    EXPECT_NE(slurp(out / "table.md").find("Collapse cost of the analysis: " + cost), std::string::npos);
    for (const char* name : {"image", "terrain", "bunny", "cow", "dragon"})
      EXPECT_NE(r.out.find(std::string(name) + ": kim-lee <= hoppe97 <= xia-varshney in #V and #F: "), std::string::npos)
          << name << "\n" << r.out;
    EXPECT_EQ(r.out.find("INVALID"), std::string::npos) << r.out;
    expect_ordering(r.out, {"image", "terrain", "bunny", "cow", "dragon"});
    const std::string csv = slurp(out / "table.csv");
    std::istringstream lines(csv);
    std::string line;
    std::getline(lines, line);
    int kim_lee_rows = 0;
    while (std::getline(lines, line)) {
      if (line.find(",kim-lee,") == std::string::npos) continue;
      ++kim_lee_rows;
      // Columns 12, 13, 15: forced vsplits, forced ecols, missing (see the quick run above); no quoted cells
      // before column 15 in these rows.
      std::vector<std::string> f;
      std::stringstream cells(line);
      std::string cell;
      while (std::getline(cells, cell, ',')) f.push_back(cell);
      ASSERT_GE(f.size(), 16u) << line;
      EXPECT_EQ(f[12], "0") << line;
      EXPECT_EQ(f[13], "0") << line;
      EXPECT_EQ(f[15], "0") << line;
    }
    EXPECT_EQ(kim_lee_rows, 5) << csv;
  }
}

TEST(Compare, SharedDataQuickRun) {
  VARMESH_REQUIRE_SHARED(cow, "meshes/cow_cgal_2904v.off");
  const fs::path dir = testing::scratch_dir("compare_shared");
  const fs::path out = dir / "out";
  const CmdResult r = run("--quick --quiet --panel 96 --size 16 --cases image,cow --out " + out.string() + " --data " +
                              testing::shared_data(""),
                          dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("cow_cgal_2904v.off"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("peppers_256_gray.png"), std::string::npos) << r.out;
  EXPECT_EQ(count(r.out, "generated"), 0) << r.out;
  expect_ordering(r.out, {"image", "cow"});
  EXPECT_TRUE(fs::exists(out / "cow_schemes.png"));
  EXPECT_FALSE(fs::exists(out / "terrain_schemes.png"));
}

// Every case of the quick run on the data folder's inputs (the image, the Fuji terrain, the bunny, the cow
// and the dirty dragon res4): the paper's ordering in each.
TEST(Compare, SharedDataQuickRunEveryCase) {
  VARMESH_REQUIRE_SHARED(cow, "meshes/cow_cgal_2904v.off");
  const fs::path dir = testing::scratch_dir("compare_shared_all");
  const fs::path out = dir / "out";
  const CmdResult r = run("--quick --quiet --panel 64 --size 16 --out " + out.string() + " --data " + testing::shared_data(""), dir);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(count(r.out, "generated"), 0) << r.out;
  for (const char* file : {"peppers_256_gray.png", "fuji_elevation_512_f32le.raw", "bunny_libigl_3485v.off", "cow_cgal_2904v.off",
                           "dragon_vrip_res4_5205v.ply"})
    EXPECT_NE(r.out.find(file), std::string::npos) << file << "\n" << r.out;
  expect_ordering(r.out, {"image", "terrain", "bunny", "cow", "dragon"});
}

TEST(Compare, BadOptionsFailWithOneLineAndExitCode1) {
  const fs::path dir = testing::scratch_dir("compare_bad");
  const std::string out = " --out " + (dir / "out").string();
  struct Case {
    std::string args, expect;
  };
  for (const Case& c : {Case{"--cases image,teapot", "unknown case 'teapot'"}, Case{"--cases ,", "lists no case"},
                        Case{"--features 0", "--features"}, Case{"--features 1.5", "--features"},
                        Case{"--features abc", "--features"}, Case{"--size 3", "--size"}, Case{"--size 12.5", "--size"},
                        Case{"--panel big", "--panel"}, Case{"--cost volume", "--cost: unknown 'volume'"},
                        Case{"--data " + (dir / "nowhere").string(), "nowhere"},
                        Case{"--image " + (dir / "missing.png").string(), "missing.png"}}) {
    SCOPED_TRACE(c.args);
    const CmdResult r = run(c.args + out, dir);
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(count(r.err, "\n"), 1) << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out" / "table.md"));
  }
  // An unreadable image file is an I/O error naming it.
  std::ofstream(dir / "bad.png") << "not a png";
  const CmdResult r = run("--cases image --image " + (dir / "bad.png").string() + out, dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("bad.png"), std::string::npos) << r.err;
}

// A wide picture keeps a short side of 2 or more when it is scaled down (1000 x 2 became 125 x 1, refused by
// the grid builder without naming the file); a picture too thin to start with is refused by name.
TEST(Compare, ThinPicturesAreScaledOrNamed) {
  const fs::path dir = testing::scratch_dir("compare_thin");
  auto picture = [&](std::size_t w, std::size_t h, const char* name) {
    Image img;
    img.width = w, img.height = h, img.channels = 1;
    img.pixels.resize(w * h);
    for (std::size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<std::uint8_t>((i * 37) % 256);
    write_png((dir / name).string(), img);
    return (dir / name).string();
  };
  const std::string wide = picture(1000, 2, "wide.png"), thin = picture(1, 100, "thin.png");
  CmdResult r = run("--cases image --quick --quiet --image " + wide + " --out " + (dir / "w").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "w" / "table.md"));
  r = run("--cases image --quick --quiet --image " + thin + " --out " + (dir / "t").string(), dir);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(count(r.err, "\n"), 1) << r.err;
  EXPECT_NE(r.err.find(thin + ": "), std::string::npos) << r.err;
}

// A model file of the data folder whose faces are all degenerate, or all on one point, failed with the words
// of the analysis or of the camera ("mesh has no non-degenerate face", "frame_sphere: radius 0.000000 is not a
// positive number") and named no file. Both now name it, and leave no output folder.
TEST(Compare, ModelsWithoutSizeOrFacesAreNamed) {
  const fs::path dir = testing::scratch_dir("compare_flat_models");
  const fs::path data = dir / "data", cow = data / "meshes" / "cow_cgal_2904v.off";
  fs::create_directories(data / "meshes");
  const struct {
    const char* off;
    const char* says;
  } cases[] = {
      {"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 0 1\n3 1 2 2\n", "mesh has no non-degenerate face"},
      {"OFF\n4 2 0\n1 1 1\n1 1 1\n1 1 1\n1 1 1\n3 0 1 2\n3 0 2 3\n", "the model has no size"},
      {"OFF\n4 2 0\n0 0 0\n1e-40 0 0\n0 1e-40 0\n0 0 1e-40\n3 0 1 2\n3 0 2 3\n", "the model has no size"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.off);
    std::ofstream(cow) << c.off;
    const CmdResult r = run("--quick --quiet --cases cow --data " + data.string() + " --out " + (dir / "out").string(), dir);
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(count(r.err, "\n"), 1) << r.err;
    EXPECT_NE(r.err.find(cow.string() + ": " + c.says), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
}

}  // namespace
}  // namespace varmesh
