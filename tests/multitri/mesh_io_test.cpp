#include "multitri/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <ostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary);
  out << contents;
  ASSERT_TRUE(out.good()) << path;
}

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

// A small mesh whose floats are awkward to print: thirds, tiny, huge, negative zero, a subnormal.
TriMesh awkward_mesh(bool normals, bool texcoords, bool colors) {
  TriMesh m;
  m.positions = {{0.1f, -0.0f, 1.0f / 3.0f},
                 {3.4028235e38f, 1e-40f, -7.25f},
                 {123456.79f, 2.0f / 3.0f, 1e-7f},
                 {-1.0f, 0.0f, 5e-30f},
                 {9.999999f, -2.5e-12f, 42.0f}};
  m.indices = {0, 1, 2, 0, 2, 3, 3, 2, 4, 4, 1, 0};
  for (std::size_t v = 0; v < m.positions.size(); ++v) {
    const float t = static_cast<float>(v);
    if (normals) m.normals.push_back({0.6f, -0.8f * t / 7.0f, 1.0f / (t + 3.0f)});
    if (texcoords) m.texcoords.push_back({t / 9.0f, 1.0f - t * 0.1f});
    // Multiples of 1/255 survive PLY's uchar colours exactly.
    if (colors) m.colors.push_back({(3.0f * t) / 255.0f, 255.0f / 255.0f, (200.0f - t) / 255.0f});
  }
  return m;
}

void expect_vec3_bits(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(bits(a[i][k]), bits(b[i][k])) << what << " " << i << "." << k;
}

void expect_identical(const TriMesh& expected, const TriMesh& got, bool with_texcoords = true) {
  expect_vec3_bits(expected.positions, got.positions, "position");
  EXPECT_EQ(expected.indices, got.indices);
  expect_vec3_bits(expected.normals, got.normals, "normal");
  expect_vec3_bits(expected.colors, got.colors, "colour");
  if (with_texcoords) {
    ASSERT_EQ(expected.texcoords.size(), got.texcoords.size());
    for (std::size_t i = 0; i < expected.texcoords.size(); ++i) {
      EXPECT_EQ(bits(expected.texcoords[i].x), bits(got.texcoords[i].x)) << i;
      EXPECT_EQ(bits(expected.texcoords[i].y), bits(got.texcoords[i].y)) << i;
    }
  } else {
    EXPECT_TRUE(got.texcoords.empty());
  }
}

TEST(MeshIoFormat, ChoosesByExtensionCaseInsensitively) {
  EXPECT_EQ(mesh_format_from_path("a/b.obj"), MeshFormat::kObj);
  EXPECT_EQ(mesh_format_from_path("B.OFF"), MeshFormat::kOff);
  EXPECT_EQ(mesh_format_from_path("x.y.PlY"), MeshFormat::kPly);
  EXPECT_THROW(mesh_format_from_path("mesh.stl"), IoError);
  EXPECT_THROW(mesh_format_from_path("obj"), IoError);
  EXPECT_THROW(read_mesh("missing_folder/mesh.txt"), IoError);
}

TEST(MeshIoFormat, MissingFileIsIoError) {
  const fs::path dir = testing::scratch_dir("mesh_io_missing");
  EXPECT_THROW(read_mesh((dir / "none.ply").string()), IoError);
}

// Round trips: every format and attribute combination, positions bit-exact.
struct RoundTripCase {
  const char* ext;
  bool binary;
  bool normals;
  bool texcoords;
  bool colors;
};

void PrintTo(const RoundTripCase& c, std::ostream* os) {
  *os << c.ext << (c.binary ? " binary" : " text") << " normals=" << c.normals << " texcoords=" << c.texcoords
      << " colors=" << c.colors;
}

std::string case_name(const ::testing::TestParamInfo<RoundTripCase>& info) {
  const RoundTripCase& c = info.param;
  std::string name = std::string(c.ext) + (c.binary ? "_binary" : "_text");
  if (c.normals) name += "_n";
  if (c.texcoords) name += "_t";
  if (c.colors) name += "_c";
  return name;
}

std::vector<RoundTripCase> round_trip_cases() {
  std::vector<RoundTripCase> cases;
  for (int mask = 0; mask < 8; ++mask) {
    const bool n = (mask & 1) != 0, t = (mask & 2) != 0, c = (mask & 4) != 0;
    cases.push_back({"obj", false, n, t, c});
    cases.push_back({"off", false, n, t, c});
    cases.push_back({"ply", true, n, t, c});
    cases.push_back({"ply", false, n, t, c});
  }
  return cases;
}

class MeshIoRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(MeshIoRoundTrip, WriteThenReadIsIdentical) {
  const RoundTripCase& c = GetParam();
  const fs::path dir = testing::scratch_dir("mesh_io_round_trip_" + case_name({c, 0}));
  const std::string path = (dir / (std::string("mesh.") + c.ext)).string();
  const TriMesh mesh = awkward_mesh(c.normals, c.texcoords, c.colors);
  WriteOptions options;
  options.binary = c.binary;
  write_mesh(path, mesh, options);
  ReadInfo info;
  info.polygons_triangulated = 99;  // the reader resets it
  const TriMesh back = read_mesh(path, &info);
  EXPECT_EQ(info.polygons_triangulated, 0u);
  EXPECT_EQ(info.attribute_conflicts, 0u);
  // OFF has no texture coordinates.
  expect_identical(mesh, back, std::string(c.ext) != "off");
  // Only the target is left in the folder: no temporary files.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);

  // Writing what was read gives the same bytes again.
  const std::string path2 = (dir / (std::string("again.") + c.ext)).string();
  write_mesh(path2, back, options);
  std::ifstream a(path, std::ios::binary), b(path2, std::ios::binary);
  const std::string sa((std::istreambuf_iterator<char>(a)), {}), sb((std::istreambuf_iterator<char>(b)), {});
  EXPECT_EQ(sa, sb);
}

INSTANTIATE_TEST_SUITE_P(MeshIo, MeshIoRoundTrip, ::testing::ValuesIn(round_trip_cases()), case_name);

TEST(MeshIoPly, BinaryFlagChoosesEncoding) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_flag");
  const TriMesh mesh = awkward_mesh(false, false, false);
  write_mesh((dir / "b.ply").string(), mesh);
  WriteOptions ascii;
  ascii.binary = false;
  write_mesh((dir / "a.ply").string(), mesh, ascii);
  std::ifstream b(dir / "b.ply", std::ios::binary), a(dir / "a.ply", std::ios::binary);
  const std::string sb((std::istreambuf_iterator<char>(b)), {}), sa((std::istreambuf_iterator<char>(a)), {});
  EXPECT_NE(sb.find("format binary_little_endian 1.0\n"), std::string::npos);
  EXPECT_NE(sa.find("format ascii 1.0\n"), std::string::npos);
}

// Builds binary PLY bodies in either byte order.
class Bytes {
 public:
  explicit Bytes(bool big_endian) : big_(big_endian) {}
  template <class T>
  Bytes& put(T v) {
    auto b = std::bit_cast<std::array<char, sizeof(T)>>(v);
    if (big_ != (std::endian::native == std::endian::big)) std::reverse(b.begin(), b.end());
    data_.append(b.data(), b.size());
    return *this;
  }
  const std::string& str() const { return data_; }

 private:
  bool big_;
  std::string data_;
};

// Every scalar type, both spellings, skipped vertex properties and lists, a skipped element before and
// after the faces, a quad, float colours, s t texcoords and vertex_index.
std::string all_types_ply(const char* format) {
  return std::string("ply\nformat ") + format +
         " 1.0\n"
         "comment every scalar type\n"
         "obj_info skipped\n"
         "element material 2\n"
         "property list uint8 float32 shininess\n"
         "property ushort id\n"
         "element vertex 4\n"
         "property double x\n"
         "property float32 y\n"
         "property short z\n"
         "property char tag\n"
         "property uchar flags\n"
         "property list int16 uint junk\n"
         "property uint16 u16\n"
         "property int32 i32\n"
         "property uint32 u32\n"
         "property int8 i8\n"
         "property float64 nx\n"
         "property float ny\n"
         "property int nz\n"
         "property float red\n"
         "property double green\n"
         "property float blue\n"
         "property float s\n"
         "property float t\n"
         "element face 2\n"
         "property uchar flags\n"
         "property list uint int16 vertex_index\n"
         "property list uchar double weights\n"
         "element edge 1\n"
         "property int vertex1\n"
         "property uint vertex2\n"
         "end_header\n";
}

struct AllTypesVertex {
  double x;
  float y;
  std::int16_t z;
  float nx, ny;
  std::int32_t nz;
  float r, g, b, s, t;
};

const AllTypesVertex kAllTypes[4] = {
    {0.5, -1.25f, 3, 0.0f, 0.0f, 1, 0.0f, 0.25f, 1.0f, 0.5f, 0.75f},
    {1e-3, 2.0f, -4, 1.0f, 0.0f, 0, 0.5f, 0.5f, 0.5f, 0.0f, 1.0f},
    {-2.0, 0.125f, 32767, 0.0f, 1.0f, 0, 1.0f, 0.0f, 0.0f, 1.0f, 0.0f},
    {1e10, -0.0f, -32768, 0.0f, 0.0f, -1, 0.125f, 1.0f, 0.0f, 0.25f, 0.25f},
};

std::string all_types_binary(bool big) {
  Bytes b(big);
  // material: list of shininess floats, id
  b.put<std::uint8_t>(2).put(1.0f).put(2.0f).put<std::uint16_t>(7);
  b.put<std::uint8_t>(0).put<std::uint16_t>(8);
  for (const AllTypesVertex& v : kAllTypes) {
    b.put(v.x).put(v.y).put(v.z).put<std::int8_t>(-5).put<std::uint8_t>(200);
    b.put<std::int16_t>(2).put<std::uint32_t>(0xdeadbeef).put<std::uint32_t>(1);  // junk list
    b.put<std::uint16_t>(65535).put<std::int32_t>(-70000).put<std::uint32_t>(4000000000u).put<std::int8_t>(-128);
    b.put(static_cast<double>(v.nx)).put(v.ny).put(v.nz);
    b.put(v.r).put(static_cast<double>(v.g)).put(v.b).put(v.s).put(v.t);
  }
  // face 0: flags, the quad 0 1 2 3, one weight; face 1: flags, the triangle 3 2 1, no weight
  b.put<std::uint8_t>(9).put<std::uint32_t>(4);
  for (std::int16_t i : std::initializer_list<std::int16_t>{0, 1, 2, 3}) b.put(i);
  b.put<std::uint8_t>(1).put(0.5);
  b.put<std::uint8_t>(9).put<std::uint32_t>(3);
  for (std::int16_t i : std::initializer_list<std::int16_t>{3, 2, 1}) b.put(i);
  b.put<std::uint8_t>(0);
  b.put<std::int32_t>(0).put<std::uint32_t>(1);  // edge
  return all_types_ply(big ? "binary_big_endian" : "binary_little_endian") + b.str();
}

std::string all_types_ascii() {
  std::string s = all_types_ply("ascii");
  s += "2 1 2 7\n0 8\n";
  s += "0.5 -1.25 3 -5 200 2 3735928559 1 65535 -70000 4000000000 -128 0 0 1 0 0.25 1 0.5 0.75\n";
  s += "1e-3 2 -4 -5 200 0 65535 -70000 4000000000 -128 1 0 0 0.5 0.5 0.5 0 1\n";
  s += "-2 0.125 32767 -5 200 0 65535 -70000 4000000000 -128 0 1 0 1 0 0 1 0\n";
  s += "1e10 -0 -32768 -5 200 1 9 65535 -70000 4000000000 -128 0 0 -1 0.125 1 0 0.25 0.25\n";
  s += "9 4 0 1 2 3 0\n";
  s += "1 3 3 2 1 1 0.5\n";
  s += "0 1\n";
  return s;
}

void expect_all_types_mesh(const TriMesh& m, const ReadInfo& info) {
  ASSERT_EQ(m.num_vertices(), 4u);
  ASSERT_EQ(m.normals.size(), 4u);
  ASSERT_EQ(m.colors.size(), 4u);
  ASSERT_EQ(m.texcoords.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const AllTypesVertex& v = kAllTypes[i];
    EXPECT_EQ(bits(m.positions[i].x), bits(static_cast<float>(v.x))) << i;
    EXPECT_EQ(bits(m.positions[i].y), bits(v.y)) << i;
    EXPECT_EQ(m.positions[i].z, static_cast<float>(v.z)) << i;
    EXPECT_EQ(m.normals[i], glm::vec3(v.nx, v.ny, static_cast<float>(v.nz))) << i;
    EXPECT_EQ(m.colors[i], glm::vec3(v.r, v.g, v.b)) << i;
    EXPECT_EQ(m.texcoords[i], glm::vec2(v.s, v.t)) << i;
  }
  EXPECT_EQ(m.indices, (std::vector<Index>{0, 1, 2, 0, 2, 3, 3, 2, 1}));
  EXPECT_EQ(info.polygons_triangulated, 1u);
}

TEST(MeshIoPly, AllScalarTypesBothEndiannessesAndAscii) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_types");
  const std::pair<const char*, std::string> files[] = {
      {"le.ply", all_types_binary(false)}, {"be.ply", all_types_binary(true)}, {"ascii.ply", all_types_ascii()}};
  for (const auto& [name, contents] : files) {
    SCOPED_TRACE(name);
    write_text(dir / name, contents);
    ReadInfo info;
    const TriMesh m = read_mesh((dir / name).string(), &info);
    expect_all_types_mesh(m, info);
  }
}

TEST(MeshIoPly, BigEndianRoundTripByHand) {
  // The writer only emits little endian; a big-endian copy of the same mesh must read identically.
  const fs::path dir = testing::scratch_dir("mesh_io_ply_be");
  const TriMesh mesh = awkward_mesh(true, true, true);
  Bytes b(true);
  for (std::size_t v = 0; v < mesh.num_vertices(); ++v) {
    b.put(mesh.positions[v].x).put(mesh.positions[v].y).put(mesh.positions[v].z);
    b.put(mesh.normals[v].x).put(mesh.normals[v].y).put(mesh.normals[v].z);
    for (int k = 0; k < 3; ++k) b.put(static_cast<std::uint8_t>(std::lround(mesh.colors[v][k] * 255.0f)));
    b.put(mesh.texcoords[v].x).put(mesh.texcoords[v].y);
  }
  for (std::size_t f = 0; f < mesh.num_faces(); ++f)
    b.put<std::uint8_t>(3).put(mesh.corner(f, 0)).put(mesh.corner(f, 1)).put(mesh.corner(f, 2));
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty float texture_u\nproperty float texture_v\nelement face 4\n"
      "property list uchar uint vertex_indices\nend_header\n";
  write_text(dir / "be.ply", header + b.str());
  expect_identical(mesh, read_mesh((dir / "be.ply").string()));
}

TEST(MeshIoPly, CrLfHeaderAndColourGroupsAreOptional) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_crlf");
  write_text(dir / "m.ply",
             "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\n"
             "property float z\r\nproperty ushort red\r\nproperty ushort green\r\nproperty ushort blue\r\n"
             "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
             "0 0 0 65535 0 0\r\n1 0 0 0 65535 0\r\n0 1 0 0 0 0\r\n3 0 1 2\r\n");
  const TriMesh m = read_mesh((dir / "m.ply").string());
  EXPECT_EQ(m.indices, (std::vector<Index>{0, 1, 2}));
  EXPECT_EQ(m.colors[0], glm::vec3(1.0f, 0.0f, 0.0f));
  EXPECT_EQ(m.colors[1], glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_FALSE(m.has_normals());
}

// After the last element: blank lines and trailing blanks are fine, anything else is an error at its line
// (it means the header's counts do not describe the body).
TEST(MeshIoPly, AsciiBodyEndsWithTheLastElement) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_trailing");
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2";
  write_text(dir / "blank.ply", header + body + "  \t\r\n\n   \n\r\n");
  EXPECT_EQ(read_mesh((dir / "blank.ply").string()).indices, (std::vector<Index>{0, 1, 2}));
  write_text(dir / "no_newline.ply", header + body);
  EXPECT_EQ(read_mesh((dir / "no_newline.ply").string()).indices, (std::vector<Index>{0, 1, 2}));
  struct Case {
    const char* tail;
    const char* where;
    const char* token;
  };
  const Case cases[] = {
      {" 7\n", ":13: ", "'7'"},          // one token too many on the last line
      {"\n\n\njunk\n", ":16: ", "'junk'"},  // after blank lines
      {"\ncomment x\n", ":14: ", "'comment'"},
  };
  for (const Case& c : cases) {
    const std::string path = (dir / "tail.ply").string();
    write_text(path, header + body + c.tail);
    try {
      read_mesh(path);
      ADD_FAILURE() << "accepted a body ending in " << c.tail;
    } catch (const IoError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path + c.where + "data after the last element declared in the header: " + c.token),
                std::string::npos)
          << what;
    }
  }
}

// Version 1.0 is the only one: any other version is named as unsupported, whatever the encoding.
TEST(MeshIoPly, FormatVersionOtherThanOneIsRefused) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_version");
  const std::string rest =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  write_text(dir / "one.ply", "ply\nformat ascii 1\n" + rest);
  EXPECT_EQ(read_mesh((dir / "one.ply").string()).num_faces(), 1u);
  for (const char* format : {"ascii 2.0", "ascii 1.1", "binary_little_endian 2.0", "binary_big_endian 0.9", "ascii one"}) {
    const std::string path = (dir / "v.ply").string();
    write_text(path, std::string("ply\nformat ") + format + "\n" + rest);
    try {
      read_mesh(path);
      ADD_FAILURE() << "accepted format " << format;
    } catch (const IoError& e) {
      const std::string what = e.what();
      const std::string version = std::string(format).substr(std::string(format).find(' ') + 1);
      EXPECT_NE(what.find(path + ":2: unsupported PLY format version '" + version + "' (only 1.0 is supported)"),
                std::string::npos)
          << what;
    }
  }
}

TEST(MeshIoPly, ElementWithoutPropertiesIsSkippedWhateverItsCount) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_empty_element");
  const std::string head = "ply\nformat ascii 1.0\nelement nothing 1000000000000\nelement vertex 3\n"
                           "property float x\nproperty float y\nproperty float z\nelement face 1\n"
                           "property list uchar int vertex_indices\nend_header\n";
  write_text(dir / "m.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(read_mesh((dir / "m.ply").string()).num_faces(), 1u);
}

// Hand-made strip: 0 1 2 3, restart, 4 5 6 6 7 8 (two degenerate joins).
TEST(MeshIoPly, TriStripsAlternateOrientationRestartAndDropDegenerates) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_strips");
  const std::vector<std::int32_t> strip = {0, 1, 2, 3, -1, 4, 5, 6, 6, 7, 8};
  const std::vector<Index> expected = {0, 1, 2, 2, 1, 3, 4, 5, 6, 7, 6, 8};
  std::string head = "ply\nformat %s 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
                     "element tristrips 1\nproperty list int int vertex_indices\nend_header\n";
  for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    SCOPED_TRACE(format);
    std::string text = head;
    text.replace(text.find("%s"), 2, format);
    const bool ascii = std::string(format) == "ascii";
    Bytes b(std::string(format) == "binary_big_endian");
    for (int v = 0; v < 9; ++v) {
      const float p[3] = {static_cast<float>(v % 3), static_cast<float>(v / 3), 0.0f};
      if (ascii) {
        text += std::to_string(v % 3) + " " + std::to_string(v / 3) + " 0\n";
      } else {
        b.put(p[0]).put(p[1]).put(p[2]);
      }
    }
    if (ascii) {
      text += std::to_string(strip.size());
      for (std::int32_t s : strip) text += " " + std::to_string(s);
      text += "\n";
    } else {
      b.put(static_cast<std::int32_t>(strip.size()));
      for (std::int32_t s : strip) b.put(s);
      text += b.str();
    }
    write_text(dir / "strip.ply", text);
    ReadInfo info;
    const TriMesh m = read_mesh((dir / "strip.ply").string(), &info);
    EXPECT_EQ(m.indices, expected);
    EXPECT_EQ(info.strip_degenerates_dropped, 2u);
  }
}

TEST(MeshIoPly, HugeCountFailsBeforeAllocating) {
  // 10^12 vertices of 12 bytes would need 12 TB; the check must come before any allocation.
  try {
    read_mesh(testing::test_data("bad/ply_huge_count_binary.ply"));
    FAIL() << "no exception";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("larger than the file can hold"), std::string::npos) << e.what();
  }
}

TEST(MeshIoObj, NegativeIndicesAreRelative) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_negative");
  write_text(dir / "m.obj",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
             "v 1 1 0\nf -3 -1 -2\nf 2 -1 3\n");
  const TriMesh m = read_mesh((dir / "m.obj").string());
  EXPECT_EQ(m.indices, (std::vector<Index>{0, 1, 2, 1, 3, 2, 1, 3, 2}));
}

TEST(MeshIoObj, PolygonsAreFanTriangulatedAndCounted) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_polygons");
  write_text(dir / "m.obj",
             "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\n"
             "f 1 2 3 4 5\nf 1 2 3\nf 5 4 3 2\n");
  ReadInfo info;
  const TriMesh m = read_mesh((dir / "m.obj").string(), &info);
  EXPECT_EQ(m.num_faces(), 3u + 1u + 2u);
  EXPECT_EQ(info.polygons_triangulated, 2u);
  EXPECT_EQ(m.indices, (std::vector<Index>{0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 1, 2, 4, 3, 2, 4, 2, 1}));
}

TEST(MeshIoObj, CornerFormsAttributesAndConflicts) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_corners");
  write_text(dir / "m.obj",
             "mtllib m.mtl\no thing\ng part\ns 1\nusemtl red\n"
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 5 5 5 # unreferenced, kept\n"
             "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5 0\nvt 1 0\n"
             "vn 0 0 1\nvn 0 0 -1\n"
             "f 1/1/1 2/2/1 3/3/1\n"
             "f 2/5 4/4 3/3\n"     // vt 5 equals vt 2: not a conflict
             "f 2//2 4//1 3//1\n"  // vertex 2 had vn 1: conflict
             "f 4/1 3 2\n"         // vertex 4 had vt 4: conflict
             "l 1 2\np 3\n");
  ReadInfo info;
  const TriMesh m = read_mesh((dir / "m.obj").string(), &info);
  ASSERT_EQ(m.num_vertices(), 5u);
  EXPECT_EQ(m.positions[4], glm::vec3(5.0f));
  EXPECT_EQ(m.num_faces(), 4u);
  ASSERT_TRUE(m.has_texcoords());
  ASSERT_TRUE(m.has_normals());
  EXPECT_EQ(m.texcoords[0], glm::vec2(0.0f, 0.0f));
  EXPECT_EQ(m.texcoords[1], glm::vec2(1.0f, 0.0f));
  EXPECT_EQ(m.texcoords[2], glm::vec2(0.0f, 1.0f));
  EXPECT_EQ(m.texcoords[3], glm::vec2(0.5f, 0.5f));
  EXPECT_EQ(m.texcoords[4], glm::vec2(0.0f, 0.0f));  // never given
  EXPECT_EQ(m.normals[1], glm::vec3(0.0f, 0.0f, 1.0f));
  EXPECT_EQ(m.normals[3], glm::vec3(0.0f, 0.0f, 1.0f));
  EXPECT_EQ(info.attribute_conflicts, 2u);
}

TEST(MeshIoObj, ColoursWeightsForwardReferencesAndCrLf) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_misc");
  write_text(dir / "c.obj", "v 0 0 0 1 0 0\r\nv 1 0 0 0 1 0\r\nv 0 1 0 0 0 0.5\r\nf 1 2 3\r\n");
  const TriMesh c = read_mesh((dir / "c.obj").string());
  ASSERT_TRUE(c.has_colors());
  EXPECT_EQ(c.colors[2], glm::vec3(0.0f, 0.0f, 0.5f));
  write_text(dir / "w.obj", "f 1 2 3\nv 0 0 0 1\nv +1 0 0 1\nv 0 1e-50 0 1\n");
  const TriMesh w = read_mesh((dir / "w.obj").string());
  EXPECT_FALSE(w.has_colors());
  EXPECT_EQ(w.positions[1], glm::vec3(1.0f, 0.0f, 0.0f));
  EXPECT_EQ(w.positions[2], glm::vec3(0.0f, 0.0f, 0.0f));  // underflow to zero is not an error
  EXPECT_EQ(w.indices, (std::vector<Index>{0, 1, 2}));
}

// Classic Mac OS line ends (a lone CR): read as lines, with the same result and line numbers as LF.
TEST(MeshIoObj, LoneCrLineEndsAreLineEnds) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_cr");
  const std::string lf =
      "# made on a Mac\nv 0 0 0\nv 1 0 0\n\nv 0 1 0\nv 1 1 0\nvt 0.5 0.25\nf 1/1 2/1 3/1\nf 2 4 3\n";
  std::string cr = lf;
  std::replace(cr.begin(), cr.end(), '\n', '\r');
  write_text(dir / "lf.obj", lf);
  write_text(dir / "cr.obj", cr);
  const TriMesh expected = read_mesh((dir / "lf.obj").string());
  ASSERT_EQ(expected.num_faces(), 2u);
  expect_identical(expected, read_mesh((dir / "cr.obj").string()));
  // An error names the line the CRs make (the 4th line is empty).
  std::string bad = "v 0 0 0\rv 1 0 0\r\rv 0 1 0\rf 1 2 3\rf 1 2 x\r";
  write_text(dir / "bad.obj", bad);
  try {
    read_mesh((dir / "bad.obj").string());
    FAIL() << "accepted a bad corner";
  } catch (const IoError& e) {
    EXPECT_EQ(e.line(), 6u) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad vertex index in face corner 'x'"), std::string::npos) << e.what();
  }
}

// Empty texcoord or normal slots mean "not given": "1//" is "1", "1/2/" is "1/2". Filled slots still
// have to be indices (the bad fixtures obj_corner_*).
TEST(MeshIoObj, EmptyCornerSlotsAreNotGiven) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_empty_slots");
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.25\nvn 0 0 1\n";
  write_text(dir / "plain.obj", v + "f 1 2 3\n");
  write_text(dir / "slashes.obj", v + "f 1// 2// 3//\n");
  write_text(dir / "one_slash.obj", v + "f 1/ 2/ 3/\n");
  const TriMesh plain = read_mesh((dir / "plain.obj").string());
  expect_identical(plain, read_mesh((dir / "slashes.obj").string()));
  expect_identical(plain, read_mesh((dir / "one_slash.obj").string()));
  EXPECT_FALSE(plain.has_texcoords());
  EXPECT_FALSE(plain.has_normals());
  write_text(dir / "vt.obj", v + "f 1/1/ 2/1/ 3/1\n");
  const TriMesh vt = read_mesh((dir / "vt.obj").string());
  ASSERT_TRUE(vt.has_texcoords());
  EXPECT_FALSE(vt.has_normals());
  EXPECT_EQ(vt.texcoords[1], glm::vec2(0.5f, 0.25f));
  write_text(dir / "vn.obj", v + "f 1//1 2// 3/1/1\n");
  const TriMesh vn = read_mesh((dir / "vn.obj").string());
  ASSERT_TRUE(vn.has_normals());
  EXPECT_EQ(vn.normals[0], glm::vec3(0.0f, 0.0f, 1.0f));
  EXPECT_EQ(vn.normals[1], glm::vec3(0.0f));  // its corner gave none
  EXPECT_EQ(vn.texcoords[2], glm::vec2(0.5f, 0.25f));
}

TEST(MeshIoText, Utf8ByteOrderMarkIsSkippedInObjAndOffOnly) {
  const fs::path dir = testing::scratch_dir("mesh_io_bom");
  const std::string bom = "\xEF\xBB\xBF";
  write_text(dir / "b.obj", bom + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const TriMesh obj = read_mesh((dir / "b.obj").string());
  EXPECT_EQ(obj.num_vertices(), 3u);  // the first v was hidden behind the mark before
  EXPECT_EQ(obj.positions[0], glm::vec3(0.0f));
  write_text(dir / "b.off", bom + "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(read_mesh((dir / "b.off").string()).num_faces(), 1u);
  // PLY's magic must be the file's first bytes.
  write_text(dir / "b.ply", bom + "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                              "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_THROW(read_mesh((dir / "b.ply").string()), IoError);
  // A mark anywhere else is not skipped.
  write_text(dir / "m.obj", "v 0 0 0\n" + bom + "v 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_THROW(read_mesh((dir / "m.obj").string()), IoError);
}

TEST(MeshIoOff, VariantsColoursNormalsAndComments) {
  const fs::path dir = testing::scratch_dir("mesh_io_off_variants");
  write_text(dir / "c.off",
             "# leading comment\nCOFF 4 2 5 # counts on the header line\n"
             "0 0 0 255 0 0 255\n1 0 0 0 51 0\n\n# a blank line and a comment\n0 1 0 0 0 255 128\n1 1 0 10 20 30 40\n"
             "4 0 1 3 2 255 0 0\n3 0 2 3\n");
  ReadInfo info;
  const TriMesh c = read_mesh((dir / "c.off").string(), &info);
  ASSERT_EQ(c.num_vertices(), 4u);
  EXPECT_EQ(c.indices, (std::vector<Index>{0, 1, 3, 0, 3, 2, 0, 2, 3}));
  EXPECT_EQ(info.polygons_triangulated, 1u);
  EXPECT_EQ(c.colors[0], glm::vec3(1.0f, 0.0f, 0.0f));
  EXPECT_EQ(c.colors[1], glm::vec3(0.0f, 51.0f / 255.0f, 0.0f));
  EXPECT_EQ(c.colors[3], glm::vec3(10.0f / 255.0f, 20.0f / 255.0f, 30.0f / 255.0f));

  write_text(dir / "cn.off",
             "CNOFF\n3 1 0\n0 0 0 0 0 1 0.5 0.25 1.0 1.0\n1 0 0 0 0 1 0 0 0.\n0 1 0 0 1 0 1e-1 0 0\n3 0 1 2\n");
  const TriMesh cn = read_mesh((dir / "cn.off").string());
  EXPECT_EQ(cn.normals[2], glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_EQ(cn.colors[0], glm::vec3(0.5f, 0.25f, 1.0f));
  EXPECT_EQ(cn.colors[2], glm::vec3(0.1f, 0.0f, 0.0f));

  write_text(dir / "st.off", "STOFF\n3 1\n0 0 0 0.5 1\n1 0 0 1 1\n0 1 0 0 0\n3 2 1 0\n");
  const TriMesh st = read_mesh((dir / "st.off").string());
  EXPECT_EQ(st.texcoords[0], glm::vec2(0.5f, 1.0f));
  EXPECT_EQ(st.indices, (std::vector<Index>{2, 1, 0}));
}

// Line ends as text from different systems spells them: the LF text `lf` with its k-th LF spelled
// kEnds[(k + start) % 6]. The order makes every kind follow every other kind somewhere. `lf` must have no
// empty line: a CR line end followed by an LF one would be one CRLF.
std::string mixed_line_ends(const std::string& lf, std::size_t start) {
  static const char* const kEnds[6] = {"\r", "\n", "\r\n", "\r", "\r\n", "\n"};
  std::string out;
  std::size_t k = start;
  for (char c : lf) {
    if (c == '\n') out += kEnds[k++ % 6];
    else out += c;
  }
  return out;
}

std::string lone_cr_line_ends(std::string lf) {
  std::replace(lf.begin(), lf.end(), '\n', '\r');
  return lf;
}

// The 1-based line of the first `needle` in the LF text `lf`.
std::size_t line_of(const std::string& lf, const std::string& needle) {
  const std::size_t at = lf.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return 1 + static_cast<std::size_t>(std::count(lf.begin(), lf.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// Writes `contents` to dir/name and returns the IoError that reading it must raise.
IoError read_failure(const fs::path& dir, const std::string& name, const std::string& contents) {
  write_text(dir / name, contents);
  try {
    read_mesh((dir / name).string());
  } catch (const IoError& e) {
    return e;
  }
  ADD_FAILURE() << name << " was accepted";
  return IoError(name, "accepted");
}

// LF, CR and CRLF mixed in one OBJ (pieces pasted together on different systems): each is one line end,
// for the statements and for the line numbers in errors.
TEST(MeshIoObj, MixedLineEndsAreEachOneLineEnd) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_mixed_ends");
  const std::string lf =
      "# pasted together\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.5 0.25\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n"
      "g second # a comment ends at its line end too\nf 2 4 3\n";
  write_text(dir / "lf.obj", lf);
  const TriMesh expected = read_mesh((dir / "lf.obj").string());
  ASSERT_EQ(expected.num_faces(), 2u);
  ASSERT_TRUE(expected.has_texcoords());
  const std::string bad = lf + "v 2 2 0\nf 1 2 x\nf 1 2 3\n";
  for (std::size_t start = 0; start < 6; ++start) {
    SCOPED_TRACE(start);
    write_text(dir / "mixed.obj", mixed_line_ends(lf, start));
    expect_identical(expected, read_mesh((dir / "mixed.obj").string()));
    const IoError e = read_failure(dir, "bad.obj", mixed_line_ends(bad, start));
    EXPECT_EQ(e.line(), line_of(bad, "f 1 2 x")) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad vertex index in face corner 'x'"), std::string::npos) << e.what();
  }
  // A CR before a CRLF (left by a second text-mode conversion) is a line end of its own: an empty line.
  const IoError e = read_failure(dir, "crcrlf.obj", "v 0 0 0\r\r\nv 1 0 0\r\r\nv 0 1 0\r\r\nf 1 2 x\r\r\n");
  EXPECT_EQ(e.line(), 7u) << e.what();
}

// A backslash at the end of a line (blanks and a CR may follow it) continues the statement on the next
// line, and stands for a blank there. Any statement may be continued, the keyword too; the statements the
// reader skips (g, o, usemtl, l) are skipped with the lines they continue onto. A comment ends at its own
// line end: a backslash in a comment continues nothing.
TEST(MeshIoObj, BackslashContinuesAStatement) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_continuation");
  const std::string plain =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.5 0.25\nvn 0 0 1\ng a b\nusemtl m x\nl 1 2\no obj name\n"
      "f 1/1/1 2/1/1 3/1/1\nf 2 4 3\n";
  write_text(dir / "plain.obj", plain);
  const TriMesh expected = read_mesh((dir / "plain.obj").string());
  ASSERT_EQ(expected.num_vertices(), 4u);
  ASSERT_EQ(expected.num_faces(), 2u);
  const std::string continued =
      "v 0 0 \\\n0\nv 1 \\\n 0 0\nv\\\n0 1 0\n# a comment ends here \\\nv 1 1 0\nvt 0.5\\\n 0.25\nvn 0 0 \\\n1\n"
      "g a \\\nb\nusemtl m \\\n x\nl 1 \\\n2\no obj \\\nname\nf 1/1/1 2/1/1 \\\n3/1/1\nf \\\n2 \\\n4\\\n3\n";
  write_text(dir / "continued.obj", continued);
  expect_identical(expected, read_mesh((dir / "continued.obj").string()));
  // CRLF line ends, blanks between the backslash and the line end, a lone CR (classic Mac OS).
  std::string crlf;
  for (char c : continued) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  write_text(dir / "crlf.obj", crlf);
  expect_identical(expected, read_mesh((dir / "crlf.obj").string()));
  std::string blanks;
  for (char c : continued) blanks += c == '\\' ? std::string("\\ \t\r") : std::string(1, c);
  write_text(dir / "blanks.obj", blanks);
  expect_identical(expected, read_mesh((dir / "blanks.obj").string()));
  write_text(dir / "cr.obj", lone_cr_line_ends(continued));
  expect_identical(expected, read_mesh((dir / "cr.obj").string()));
  // What a skipped statement continues onto is skipped with it: this v is part of the group's name.
  write_text(dir / "group.obj", plain + "g name \\\nv 9 9 9\n");
  EXPECT_EQ(read_mesh((dir / "group.obj").string()).num_vertices(), 4u);
  // A continued line that ends the statement: the next line is a statement of its own.
  write_text(dir / "empty_next.obj", plain + "f 1 2 3 \\\n\nf 3 2 4\n");
  EXPECT_EQ(read_mesh((dir / "empty_next.obj").string()).num_faces(), 4u);
}

// A backslash as the file's last byte (or followed by blanks only) continues onto nothing: the statement
// ends there.
TEST(MeshIoObj, BackslashAtTheEndOfTheFile) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_continuation_eof");
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  write_text(dir / "plain.obj", v + "f 1 2 3\n");
  const TriMesh expected = read_mesh((dir / "plain.obj").string());
  for (const char* end : {"f 1 2 3 \\", "f 1 2 3\\", "f 1 2 3 \\ \r", "f 1 2 \\\n3 \\"}) {
    SCOPED_TRACE(end);
    write_text(dir / "eof.obj", v + end);
    expect_identical(expected, read_mesh((dir / "eof.obj").string()));
  }
  const IoError e = read_failure(dir, "short.obj", v + "f 1 2 \\");
  EXPECT_EQ(e.line(), 4u) << e.what();
  EXPECT_NE(std::string(e.what()).find("face has 2 corners"), std::string::npos) << e.what();
}

// A backslash that is not the last thing on its line is an ordinary character, which no number or index
// accepts: an error, as before continuations were read.
TEST(MeshIoObj, BackslashInsideALineIsAnError) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_backslash_inside");
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Case {
    std::string text;
    const char* reason;
  };
  const Case cases[] = {
      {v + "f 1 \\ 2 3\n", "bad vertex index in face corner '\\'"},
      {v + "f 1 2\\3\n", "bad face corner '2\\3'"},
      {v + "f 1 2 3 \\ # a comment after the backslash\n", "bad vertex index in face corner '\\'"},
      {v + "f 1 2 3 \\x\n", "bad vertex index in face corner '\\x'"},
      {"v 0 0\\0\n" + v + "f 1 2 3\n", "bad number '0\\0' for vertex y"},
      {"v 0 0 \\\\\n0\n" + v + "f 1 2 3\n", "bad number '\\' for vertex z"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    const IoError e = read_failure(dir, "bad.obj", c.text);
    EXPECT_EQ(e.line(), line_of(c.text, "\\")) << e.what();
    EXPECT_NE(std::string(e.what()).find(c.reason), std::string::npos) << e.what();
  }
}

// Line numbers after continued lines count every physical line. An error about one token names the line
// that token is on; an error about the statement as a whole (too few numbers or corners, a colour that
// does not match the other vertices) names the line where the statement starts.
TEST(MeshIoObj, ErrorLinesAfterContinuedLines) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_continuation_lines");
  const std::string head = "v 0 0 \\\n0\nv 1 \\\n0 \\\n0\n# three\nv 0 1 0\nf 1 \\\n2 \\\n3\n";
  struct Case {
    std::string tail;
    std::string at;  // the line named is the first line holding this text
    const char* reason;
  };
  const Case cases[] = {
      {"f 1 2 x\n", "f 1 2 x", "bad vertex index in face corner 'x'"},
      {"f 1 \\\n2 \\\nx\n", "x\n", "bad vertex index in face corner 'x'"},
      {"v 0 \\\n1.5y 0\n", "1.5y", "bad number '1.5y' for vertex y"},
      {"vn 0 0 \\\n1 \\\n2\n", "2\n", "vn statement has more than 3 numbers"},
      {"f 1 \\\n2 \\\n-7\n", "-7", "relative vertex index -7 is out of range"},
      {"f 1 \\\n2 \\\n9\n", "9\n", "face refers to vertex 9 but the file has 3 v statements"},
      {"f 1 \\\n2\n", "f 1 \\\n2\n", "face has 2 corners"},
      {"v 0 \\\n1\n", "v 0 \\\n1\n", "missing vertex z"},
      {"v 0 1 \\\n0 1 \\\n0\n", "v 0 1 \\\n0 1", "v statement has 5 numbers"},
      {"v 2 2 \\\n0 0.5 \\\n0.5 0.5\n", "v 2 2", "v has a colour but earlier v statements do not"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.tail);
    const std::string text = head + c.tail;
    const IoError e = read_failure(dir, "bad.obj", text);
    EXPECT_EQ(e.line(), line_of(text, c.at)) << e.what();
    EXPECT_NE(std::string(e.what()).find(c.reason), std::string::npos) << e.what();
  }
}

// Continuations put at random token boundaries (the backslash after a blank or right after the token,
// blanks after it, LF or CRLF) change neither the mesh nor the line that a later error names.
TEST(MeshIoObj, RandomContinuationsChangeNothing) {
  const fs::path dir = testing::scratch_dir("mesh_io_obj_continuation_random");
  const std::string plain =
      "# random\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 1 1 0 0.5 0.5 0.5\nvt 0.5 0.25\nvt 0.25 0.5\n"
      "vn 0 0 1\ns off\ng part\nf 1/1/1 2/2/1 3/1/1\nusemtl red\nf -3 4 -2 # last\n";
  write_text(dir / "plain.obj", plain);
  const TriMesh expected = read_mesh((dir / "plain.obj").string());
  std::mt19937 rng(5);
  auto continue_randomly = [&](const std::string& source) {
    std::string out;
    bool in_comment = false;
    for (std::size_t i = 0; i < source.size(); ++i) {
      const char c = source[i];
      out += c;
      in_comment = c == '#' || (in_comment && c != '\n');
      const bool token_end = c != ' ' && c != '\n' && i + 1 < source.size() && source[i + 1] == ' ';
      if (!token_end || in_comment || rng() % 3 != 0) continue;
      out += rng() % 2 == 0 ? " \\" : "\\";
      for (auto b = rng() % 3; b > 0; --b) out += rng() % 2 == 0 ? ' ' : '\t';
      out += rng() % 2 == 0 ? "\r\n" : "\n";
    }
    return out;
  };
  std::size_t continued = 0;
  for (int trial = 0; trial < 100; ++trial) {
    SCOPED_TRACE(trial);
    const std::string good = continue_randomly(plain);
    continued += good.size() > plain.size() ? 1 : 0;
    write_text(dir / "good.obj", good);
    expect_identical(expected, read_mesh((dir / "good.obj").string()));
    const std::string bad = good + continue_randomly("f 1 2 3\nf 1 2 3 4 x 2\n");
    const IoError e = read_failure(dir, "bad.obj", bad);
    EXPECT_EQ(e.line(), line_of(bad, "x")) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad vertex index in face corner 'x'"), std::string::npos) << e.what();
  }
  EXPECT_GT(continued, 90u);
}

// OFF with lone CRs (classic Mac OS) or mixed line ends reads as with LF, header included, and errors name
// the line counted the same way.
TEST(MeshIoOff, LoneCrAndMixedLineEnds) {
  const fs::path dir = testing::scratch_dir("mesh_io_off_line_ends");
  const std::string lf = "COFF\n# four vertices\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n1 1 0 1 2 3\n"
                         "3 0 1 2\n3 1 3 2 # face colour follows\n";
  write_text(dir / "lf.off", lf);
  const TriMesh expected = read_mesh((dir / "lf.off").string());
  ASSERT_EQ(expected.num_faces(), 2u);
  ASSERT_TRUE(expected.has_colors());
  const std::string bad = lf.substr(0, lf.find("3 1 3 2")) + "3 1 3 9\n";
  std::vector<std::pair<std::string, std::string>> spellings = {{"cr", lone_cr_line_ends(lf)}};
  for (std::size_t start = 0; start < 6; ++start) spellings.emplace_back("mixed" + std::to_string(start), mixed_line_ends(lf, start));
  for (const auto& [name, text] : spellings) {
    SCOPED_TRACE(name);
    write_text(dir / (name + ".off"), text);
    expect_identical(expected, read_mesh((dir / (name + ".off")).string()));
  }
  const std::string bad_spellings[] = {lone_cr_line_ends(bad), mixed_line_ends(bad, 0), mixed_line_ends(bad, 3)};
  for (const std::string& text : bad_spellings) {
    const IoError e = read_failure(dir, "bad.off", text);
    EXPECT_EQ(e.line(), line_of(bad, "3 1 3 9")) << e.what();
    EXPECT_NE(std::string(e.what()).find("vertex index 9 out of range"), std::string::npos) << e.what();
  }
}

// An ascii PLY with lone CRs or mixed line ends, in the header and the body, reads as with LF; errors in
// either name the line counted the same way.
TEST(MeshIoPly, AsciiLoneCrAndMixedLineEnds) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_ascii_line_ends");
  const std::string lf = all_types_ascii();
  std::vector<std::pair<std::string, std::string>> spellings = {{"cr", lone_cr_line_ends(lf)}};
  for (std::size_t start = 0; start < 6; ++start) spellings.emplace_back("mixed" + std::to_string(start), mixed_line_ends(lf, start));
  std::string bad_header = lf, bad_body = lf;
  bad_header.replace(bad_header.find("property short z"), 16, "property shorty z");
  bad_body.replace(bad_body.find("1 3 3 2 1 1 0.5"), 15, "1 3 3 2 9 1 0.5");
  for (const auto& [name, text] : spellings) {
    SCOPED_TRACE(name);
    write_text(dir / (name + ".ply"), text);
    ReadInfo info;
    expect_all_types_mesh(read_mesh((dir / (name + ".ply")).string(), &info), info);
  }
  const std::string bad_spellings[] = {"cr", "mixed0", "mixed1", "mixed2"};
  for (const std::string& name : bad_spellings) {
    SCOPED_TRACE(name);
    auto spell = [&](const std::string& text) {
      return name == "cr" ? lone_cr_line_ends(text) : mixed_line_ends(text, static_cast<std::size_t>(name.back() - '0'));
    };
    IoError e = read_failure(dir, "bad.ply", spell(bad_header));
    EXPECT_EQ(e.line(), line_of(bad_header, "property shorty z")) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown property type 'shorty'"), std::string::npos) << e.what();
    e = read_failure(dir, "bad.ply", spell(bad_body));
    EXPECT_EQ(e.line(), line_of(bad_body, "1 3 3 2 9 1 0.5")) << e.what();
    EXPECT_NE(std::string(e.what()).find("face 1: vertex index 9 out of range"), std::string::npos) << e.what();
  }
}

// A binary PLY's header may use any line ends too, while its body is read byte for byte: CR and LF bytes
// in the values stay what they are.
TEST(MeshIoPly, BinaryHeaderLineEndsLeaveTheBodyAlone) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_binary_line_ends");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment bytes 10 and 13 in the body\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  // The body's first byte is `first` (the low byte of the first x); colours are CR and LF bytes.
  auto body = [](std::uint8_t first) {
    Bytes b(false);
    b.put<std::uint32_t>(0x3f800000u | first).put(0.0f).put(0.0f).put<std::uint8_t>(13).put<std::uint8_t>(10).put<std::uint8_t>(13);
    b.put(1.0f).put(0.0f).put(0.0f).put<std::uint8_t>(10).put<std::uint8_t>(13).put<std::uint8_t>(10);
    b.put(0.0f).put(1.0f).put(0.0f).put<std::uint8_t>(13).put<std::uint8_t>(13).put<std::uint8_t>(10);
    b.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
    return b.str();
  };
  for (const std::uint8_t first : {std::uint8_t{10}, std::uint8_t{13}}) {
    SCOPED_TRACE(static_cast<int>(first));
    write_text(dir / "lf.ply", header + body(first));
    const TriMesh expected = read_mesh((dir / "lf.ply").string());
    ASSERT_EQ(bits(expected.positions[0].x), 0x3f800000u | first);
    ASSERT_EQ(expected.colors[0], glm::vec3(13.0f, 10.0f, 13.0f) / 255.0f);
    ASSERT_EQ(expected.colors[2], glm::vec3(13.0f, 13.0f, 10.0f) / 255.0f);
    std::string crlf;
    for (char c : header) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    // A header with lone CRs only: its end_header line ends at the CR, also when the body's first byte
    // is an LF.
    const std::pair<std::string, std::string> files[] = {{"crlf.ply", crlf}, {"cr.ply", lone_cr_line_ends(header)}};
    for (const auto& [name, text] : files) {
      SCOPED_TRACE(name);
      write_text(dir / name, text + body(first));
      expect_identical(expected, read_mesh((dir / name).string()));
    }
  }
  // Mixed line ends with an LF somewhere: a lone CR after end_header ends the header when a CR byte
  // follows it...
  for (std::size_t start = 0; start < 6; ++start) {
    SCOPED_TRACE(start);
    write_text(dir / "lf.ply", header + body(13));
    write_text(dir / "mixed.ply", mixed_line_ends(header, start) + body(13));
    expect_identical(read_mesh((dir / "lf.ply").string()), read_mesh((dir / "mixed.ply").string()));
  }
  // ...but a CR and an LF byte after end_header are a CRLF in such a header, so a body that starts with
  // an LF after a lone CR loses that byte, and the file is refused rather than misread.
  std::string lf_then_cr = header;
  lf_then_cr.back() = '\r';
  const IoError e = read_failure(dir, "ambiguous.ply", lf_then_cr + body(10));
  EXPECT_NE(e.byte_offset(), IoError::kNoOffset) << e.what();
}

// Bytes after the last element of a binary body are refused at their offset with their count, as data
// after an ascii body's last element is refused at its line (AsciiBodyEndsWithTheLastElement).
TEST(MeshIoPly, BinaryBodyEndsWithTheLastElement) {
  const fs::path dir = testing::scratch_dir("mesh_io_ply_binary_trailing");
  std::string written;
  {
    write_mesh((dir / "w.ply").string(), awkward_mesh(true, true, true));
    std::ifstream in(dir / "w.ply", std::ios::binary);
    written.assign(std::istreambuf_iterator<char>(in), {});
  }
  // The writer's faces come last; all_types_binary ends with a skipped element of fixed size.
  const std::pair<const char*, std::string> seeds[] = {{"written.ply", written},
                                                       {"types.ply", all_types_binary(false)},
                                                       {"types_be.ply", all_types_binary(true)}};
  const std::string tails[] = {"\n", "\r\n", " ", std::string(3, '\0'), "junk after the faces"};
  for (const auto& [name, good] : seeds) {
    SCOPED_TRACE(name);
    write_text(dir / name, good);
    ASSERT_NO_THROW(read_mesh((dir / name).string()));
    for (const std::string& tail : tails) {
      const IoError e = read_failure(dir, "tail.ply", good + tail);
      EXPECT_EQ(e.byte_offset(), good.size()) << e.what();
      const std::string count = std::to_string(tail.size()) + (tail.size() == 1 ? " byte" : " bytes");
      EXPECT_NE(std::string(e.what()).find("data after the last element declared in the header: " + count +
                                           " after the last element"),
                std::string::npos)
          << e.what();
    }
  }
}

// Provenance (ReadInfo::want_sources): each file face's corners rebuilt from the triangles and the
// triangle -> face map, as face_corners says, must be the polygon the file lists.
std::vector<std::vector<Index>> rebuilt_polygons(const TriMesh& m, const ReadInfo& info) {
  std::vector<std::vector<Index>> faces(info.face_corners.size());
  EXPECT_EQ(info.triangle_face.size(), m.num_faces());
  EXPECT_EQ(info.face_lines.size(), info.face_corners.size());
  for (std::size_t t = 0; t < std::min(info.triangle_face.size(), m.num_faces()); ++t) {
    EXPECT_TRUE(t == 0 || info.triangle_face[t - 1] <= info.triangle_face[t]) << t;
    std::vector<Index>& f = faces.at(info.triangle_face[t]);
    if (f.empty()) {
      f = {m.corner(t, 0), m.corner(t, 1)};
    } else {  // the fan (c0, c(i-1), c(i)) continues
      EXPECT_EQ(m.corner(t, 0), f[0]) << t;
      EXPECT_EQ(m.corner(t, 1), f.back()) << t;
    }
    f.push_back(m.corner(t, 2));
  }
  for (std::size_t f = 0; f < faces.size(); ++f) EXPECT_EQ(faces[f].size(), info.face_corners[f]) << f;
  return faces;
}

// A file written with what each face and vertex should be reported as.
struct ProvenanceFile {
  std::string text;
  std::vector<std::vector<Index>> faces;
  std::vector<std::size_t> face_lines, vertex_lines;
};

// Triangles, quads and pentagons over `nv` vertices, now and then with a repeated corner (kept as written).
std::vector<std::vector<Index>> random_polygons(std::mt19937& rng, Index nv, std::size_t count) {
  std::vector<std::vector<Index>> faces;
  for (std::size_t f = 0; f < count; ++f) {
    std::vector<Index> c(3 + rng() % 3);
    for (Index& i : c) i = static_cast<Index>(rng() % nv);
    faces.push_back(c);
  }
  return faces;
}

// Counts lines as the readers do while text is appended; `end` is the line end to use next.
struct LineWriter {
  std::string text;
  std::size_t line = 1;
  void put(const std::string& s, const char* end = "\n") {
    text += s;
    text += end;
    ++line;
  }
};

// OBJ with CRLF and LF mixed, comments and blank lines, continued v and f statements, positive and negative
// (relative) indices and corner forms with texcoords.
ProvenanceFile provenance_obj(std::mt19937& rng, Index nv, std::size_t nf) {
  ProvenanceFile file;
  file.faces = random_polygons(rng, nv, nf);
  LineWriter w;
  auto end = [&rng] { return rng() % 2 ? "\r\n" : "\n"; };
  w.put("# provenance", end());
  w.put("vt 0 0", end());
  for (Index v = 0; v < nv; ++v) {
    if (rng() % 4 == 0) w.put("", end());
    file.vertex_lines.push_back(w.line);
    if (rng() % 4 == 0) {
      w.put("v " + std::to_string(v) + " 1 \\", end());
      w.put("  2", end());
    } else {
      w.put("v " + std::to_string(v) + " 1 2", end());
    }
  }
  for (const std::vector<Index>& f : file.faces) {
    if (rng() % 4 == 0) w.put("# between faces", end());
    file.face_lines.push_back(w.line);
    std::string s = "f";
    for (std::size_t k = 0; k < f.size(); ++k) {
      const std::int64_t i = rng() % 2 ? std::int64_t{f[k]} + 1 : std::int64_t{f[k]} - std::int64_t{nv};
      s += " " + std::to_string(i) + (rng() % 3 == 0 ? "/1" : "");
      if (k + 1 < f.size() && rng() % 5 == 0) {  // continued after this corner
        w.put(s + " \\", end());
        s.clear();
      }
    }
    w.put(s, end());
  }
  file.text = std::move(w.text);
  return file;
}

// OFF whose counts sit on two lines after a comment, with blank lines between vertices and face colours.
ProvenanceFile provenance_off(std::mt19937& rng, Index nv, std::size_t nf) {
  ProvenanceFile file;
  file.faces = random_polygons(rng, nv, nf);
  LineWriter w;
  w.put("OFF");
  w.put("# counts on two lines");
  w.put(std::to_string(nv));
  w.put("  " + std::to_string(nf) + " 0");
  for (Index v = 0; v < nv; ++v) {
    if (rng() % 4 == 0) w.put("");
    file.vertex_lines.push_back(w.line);
    w.put(std::to_string(v) + " 1 2");
  }
  for (const std::vector<Index>& f : file.faces) {
    if (rng() % 4 == 0) w.put("# a comment line");
    file.face_lines.push_back(w.line);
    std::string s = std::to_string(f.size());
    for (Index c : f) s += " " + std::to_string(c);
    w.put(s + (rng() % 3 == 0 ? " 255 0 0" : ""));
  }
  file.text = std::move(w.text);
  return file;
}

// PLY with a skipped scalar before the index list; ascii (a vertex or face now and then spread over two
// lines, blank lines between) or binary (no lines: 0).
ProvenanceFile provenance_ply(std::mt19937& rng, Index nv, std::size_t nf, const char* format) {
  ProvenanceFile file;
  file.faces = random_polygons(rng, nv, nf);
  const bool ascii = std::string(format) == "ascii";
  LineWriter w;
  w.put("ply");
  w.put(std::string("format ") + format + " 1.0");
  w.put("element vertex " + std::to_string(nv));
  w.put("property float x");
  w.put("property float y");
  w.put("property float z");
  w.put("element face " + std::to_string(nf));
  w.put("property uchar flags");
  w.put("property list uchar int vertex_indices");
  w.put("end_header");
  Bytes b(std::string(format) == "binary_big_endian");
  for (Index v = 0; v < nv; ++v) {
    if (!ascii) {
      b.put(static_cast<float>(v)).put(1.0f).put(2.0f);
      file.vertex_lines.push_back(0);
      continue;
    }
    if (rng() % 4 == 0) w.put("");
    file.vertex_lines.push_back(w.line);
    if (rng() % 4 == 0) {
      w.put(std::to_string(v) + " 1");
      w.put("2");
    } else {
      w.put(std::to_string(v) + " 1 2");
    }
  }
  for (const std::vector<Index>& f : file.faces) {
    if (!ascii) {
      b.put(std::uint8_t{7}).put(static_cast<std::uint8_t>(f.size()));
      for (Index c : f) b.put(static_cast<std::int32_t>(c));
      file.face_lines.push_back(0);
      continue;
    }
    if (rng() % 4 == 0) w.put("");
    file.face_lines.push_back(w.line);
    std::string s = "7 " + std::to_string(f.size());
    if (rng() % 4 == 0) {
      w.put(s);
      s.clear();
    }
    for (Index c : f) s += " " + std::to_string(c);
    w.put(s);
  }
  file.text = std::move(w.text) + b.str();
  return file;
}

void expect_provenance(const std::string& name, const ProvenanceFile& file, Index first_vertex_number) {
  ReadInfo info;
  info.want_sources = true;
  const TriMesh m = read_mesh_data(name, file.text, &info);
  EXPECT_TRUE(info.want_sources);
  EXPECT_EQ(rebuilt_polygons(m, info), file.faces);
  EXPECT_EQ(info.face_lines, file.face_lines);
  EXPECT_EQ(info.vertex_lines, file.vertex_lines);
  EXPECT_EQ(info.first_vertex_number, first_vertex_number);

  // Not asked for: no provenance, the same mesh and counts.
  ReadInfo plain;
  const TriMesh same = read_mesh_data(name, file.text, &plain);
  EXPECT_EQ(same.indices, m.indices);
  EXPECT_EQ(plain.polygons_triangulated, info.polygons_triangulated);
  EXPECT_EQ(plain.first_vertex_number, first_vertex_number);
  EXPECT_TRUE(plain.triangle_face.empty() && plain.face_corners.empty() && plain.face_lines.empty() &&
              plain.vertex_lines.empty());
}

TEST(MeshIoProvenance, RebuildsEveryPolygonWithItsLine) {
  std::mt19937 rng(95);
  for (int round = 0; round < 40; ++round) {
    SCOPED_TRACE(round);
    const Index nv = static_cast<Index>(3 + rng() % 10);
    const std::size_t nf = 1 + rng() % 12;
    {
      const ProvenanceFile f = provenance_obj(rng, nv, nf);
      SCOPED_TRACE(f.text);
      expect_provenance("p.obj", f, 1);
    }
    {
      const ProvenanceFile f = provenance_off(rng, nv, nf);
      SCOPED_TRACE(f.text);
      expect_provenance("p.off", f, 0);
    }
    for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
      SCOPED_TRACE(format);
      const ProvenanceFile f = provenance_ply(rng, nv, nf, format);
      expect_provenance("p.ply", f, 0);
    }
  }
}

// A hand-made OBJ with every feature at once, checked against numbers worked out by hand.
TEST(MeshIoProvenance, ObjByHand) {
  const std::string obj = "v 0 0 0\r\nv 1 0 0\r\nv 1 1 \\\r\n 0\r\nv 0 1 0\nv 2 0 0\n# five\n"
                          "f 1 2 3 4\r\n"         // line 8
                          "f -4 \\\n  -1 -3\n"   // line 9, a continued triangle (2 5 3)
                          "\n"
                          "f 1/1 2 5 3 \\\n4\n";  // line 12, a pentagon on two lines
  ReadInfo info;
  info.want_sources = true;
  const TriMesh m = read_mesh_data("hand.obj", obj + "vt 0 0\n", &info);
  EXPECT_EQ(rebuilt_polygons(m, info), (std::vector<std::vector<Index>>{{0, 1, 2, 3}, {1, 4, 2}, {0, 1, 4, 2, 3}}));
  EXPECT_EQ(info.triangle_face, (std::vector<Index>{0, 0, 1, 2, 2, 2}));
  EXPECT_EQ(info.face_corners, (std::vector<Index>{4, 3, 5}));
  EXPECT_EQ(info.face_lines, (std::vector<std::size_t>{8, 9, 12}));
  EXPECT_EQ(info.vertex_lines, (std::vector<std::size_t>{1, 2, 3, 5, 6}));
  EXPECT_EQ(info.polygons_triangulated, 2u);
}

// Triangle strips are no polygons (face_corners 0); a strip whose triangles were all dropped owns none.
TEST(MeshIoProvenance, PlyStripsOwnTheTrianglesTheyKept) {
  const std::string ply = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                          "element tristrips 3\nproperty list int int vertex_indices\nend_header\n"
                          "0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n2 1 0\n"
                          "4 0 1 3 2\n"     // line 18, face 0
                          "4 0 1 2 3\n"     // line 19, strip: 2 triangles
                          "3 4 4 5\n"       // line 20, strip: degenerate, dropped
                          "\n5 1 4 3 5 -1\n";  // line 22, strip: 2 triangles
  ReadInfo info;
  info.want_sources = true;
  const TriMesh m = read_mesh_data("s.ply", ply, &info);
  EXPECT_EQ(info.strip_degenerates_dropped, 1u);
  EXPECT_EQ(m.num_faces(), 6u);
  EXPECT_EQ(info.triangle_face, (std::vector<Index>{0, 0, 1, 1, 3, 3}));
  EXPECT_EQ(info.face_corners, (std::vector<Index>{4, 0, 0, 0}));
  EXPECT_EQ(info.face_lines, (std::vector<std::size_t>{18, 19, 20, 22}));
  EXPECT_EQ(info.vertex_lines, (std::vector<std::size_t>{12, 13, 14, 15, 16, 17}));
}

// A failed read leaves `info` as it was.
TEST(MeshIoProvenance, FailedReadLeavesInfoAlone) {
  ReadInfo info;
  info.want_sources = true;
  info.face_lines = {42};
  EXPECT_THROW(read_mesh_data("bad.obj", "v 0 0 0\nf 1 2 3\n", &info), IoError);
  EXPECT_EQ(info.face_lines, (std::vector<std::size_t>{42}));
  EXPECT_TRUE(info.triangle_face.empty());
}

TEST(MeshIoWrite, MissingFolderThrowsAndCreatesNothing) {
  const fs::path dir = testing::scratch_dir("mesh_io_write_missing");
  const TriMesh mesh = awkward_mesh(true, true, true);
  for (const char* name : {"mesh.obj", "mesh.off", "mesh.ply"}) {
    const fs::path target = dir / "no_such_folder" / name;
    EXPECT_THROW(write_mesh(target.string(), mesh), IoError) << name;
    EXPECT_FALSE(fs::exists(target.parent_path()));
  }
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(MeshIoWrite, InvalidMeshThrowsBeforeTouchingTheFile) {
  const fs::path dir = testing::scratch_dir("mesh_io_write_invalid");
  TriMesh bad = awkward_mesh(false, false, false);
  bad.indices.push_back(0);
  bad.indices.push_back(1);
  bad.indices.push_back(17);  // out of range
  for (const char* name : {"mesh.obj", "mesh.off", "mesh.ply"}) {
    EXPECT_THROW(write_mesh((dir / name).string(), bad), InvalidInput) << name;
  }
  EXPECT_TRUE(fs::is_empty(dir));

  // An existing file is left untouched by a failed write.
  write_text(dir / "keep.ply", "old contents");
  TriMesh nan_normal = awkward_mesh(true, false, false);
  nan_normal.normals[2].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(write_mesh((dir / "keep.ply").string(), nan_normal), InvalidInput);
  TriMesh bright = awkward_mesh(false, false, true);
  bright.colors[1].x = 1.5f;
  EXPECT_THROW(write_mesh((dir / "keep.ply").string(), bright), InvalidInput);
  std::ifstream in(dir / "keep.ply");
  const std::string kept((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(kept, "old contents");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(MeshIoWrite, ObjCornerForms) {
  const fs::path dir = testing::scratch_dir("mesh_io_write_obj_forms");
  const std::pair<TriMesh, const char*> cases[] = {{awkward_mesh(false, false, false), "f 1 2 3\n"},
                                                   {awkward_mesh(false, true, false), "f 1/1 2/2 3/3\n"},
                                                   {awkward_mesh(true, false, false), "f 1//1 2//2 3//3\n"},
                                                   {awkward_mesh(true, true, false), "f 1/1/1 2/2/2 3/3/3\n"}};
  for (const auto& [mesh, first_face] : cases) {
    write_mesh((dir / "m.obj").string(), mesh);
    std::ifstream in(dir / "m.obj");
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(text.find(first_face), std::string::npos) << first_face;
  }
}

// Every bad fixture with an obj_/off_/ply_ prefix: IoError naming the file, the place and the reason.
struct BadCase {
  const char* file;
  const char* where;   // ":<line>: " or " (byte <offset>): "
  const char* reason;  // a substring of the reason
};

const BadCase kBadCases[] = {
    {"obj_bad_corner.obj", ":4: ", "bad face corner '1/1/1/1'"},
    {"obj_bad_number.obj", ":4: ", "bad number '1.5x' for vertex y"},
    {"obj_colour_mixed.obj", ":2: ", "v has no colour but earlier v statements do"},
    {"obj_colour_range.obj", ":1: ", "vertex colour component is outside [0, 1]"},
    {"obj_corner_bad_texcoord.obj", ":5: ", "bad texcoord index in face corner '1/x/'"},
    {"obj_corner_four_slots.obj", ":5: ", "bad normal index in face corner '3///'"},
    {"obj_index_garbage.obj", ":4: ", "bad vertex index in face corner 'three'"},
    {"obj_index_out_of_range.obj", ":6: ", "face refers to vertex 4 but the file has 3 v statements"},
    {"obj_index_zero.obj", ":4: ", "vertex index 0 is invalid"},
    {"obj_inf.obj", ":2: ", "vertex z is not finite"},
    {"obj_nan.obj", ":3: ", "vertex x is not finite"},
    {"obj_no_faces.obj", ":5: ", "no faces"},
    {"obj_normal_bad_number.obj", ":4: ", "bad number 'x' for normal z"},
    {"obj_normal_out_of_range.obj", ":5: ", "face refers to normal 5 but the file has 1 vn statements"},
    {"obj_overflow.obj", ":2: ", "vertex x is out of range"},
    {"obj_relative_out_of_range.obj", ":4: ", "relative vertex index -4 is out of range"},
    {"obj_texcoord_out_of_range.obj", ":5: ", "face refers to texcoord 2 but the file has 1 vt statements"},
    {"obj_two_corners.obj", ":4: ", "face has 2 corners"},
    {"obj_v_five_numbers.obj", ":1: ", "v statement has 5 numbers"},
    {"obj_v_too_few.obj", ":2: ", "missing vertex z"},
    {"off_bad_header.off", ":1: ", "not an OFF file"},
    {"off_binary.off", ":1: ", "binary OFF is not supported"},
    {"off_bad_number.off", ":4: ", "bad number '0..5' for vertex z"},
    {"off_colour_range.off", ":3: ", "integer colour component outside 0..255"},
    {"off_colour_without_coff.off", ":3: ", "unexpected text on a vertex line"},
    {"off_empty.off", ":1: ", "empty file"},
    {"off_huge_counts.off", ":3: ", "counts larger than the file can hold"},
    {"off_huge_faces.off", ":2: ", "counts larger than the file can hold"},
    {"off_index_out_of_range.off", ":6: ", "vertex index 3 out of range"},
    {"off_missing_counts.off", ":2: ", "missing vertex count"},
    {"off_nan.off", ":4: ", "vertex y is not finite"},
    {"off_negative_count.off", ":2: ", "negative vertex count"},
    {"off_negative_index.off", ":6: ", "vertex index -1 out of range"},
    {"off_no_faces.off", ":2: ", "no faces"},
    {"off_short_face.off", ":6: ", "face has 3 vertex indices but announces 4"},
    {"off_truncated_faces.off", ":7: ", "truncated: expected 3 faces, found 1"},
    {"off_truncated_vertices.off", ":6: ", "truncated: expected 5 vertices, found 3"},
    {"off_two_corners.off", ":6: ", "face has 2 corners"},
    {"off_unsupported_variant.off", ":1: ", "unsupported OFF variant '4OFF'"},
    {"ply_bad_magic.ply", ":1: ", "not a PLY file"},
    {"ply_bad_number_ascii.ply", ":12: ", "bad number '1.0.0'"},
    {"ply_colour_out_of_range.ply", ":14: ", "vertex 1: float colour 'red' is outside [0, 1]"},
    {"ply_data_after_body_ascii.ply", ":15: ", "data after the last element declared in the header: '3'"},
    {"ply_float_indices.ply", ":8: ", "vertex indices must have an integer type"},
    {"ply_format_version.ply", ":2: ", "unsupported PLY format version '2.0' (only 1.0 is supported)"},
    {"ply_huge_count_ascii.ply", ":7: ", "element face count 99999999999 is larger than the file can hold"},
    {"ply_huge_count_binary.ply", ":4: ", "element vertex count 1000000000000 is larger than the file can hold"},
    {"ply_index_out_of_range_ascii.ply", ":13: ", "face 0: vertex index 7 out of range"},
    {"ply_index_out_of_range_binary.ply", " (byte 214): ", "face 0: vertex index 7 out of range"},
    {"ply_index_out_of_range_binary_be.ply", " (byte 212): ", "face 0: vertex index 3 out of range"},
    {"ply_inf_double_binary_be.ply", " (byte 209): ", "vertex 1: 'z' is not finite"},
    {"ply_missing_end_header.ply", ":9: ", "no end_header line"},
    {"ply_missing_z.ply", ":3: ", "element vertex has no property 'z'"},
    {"ply_nan_ascii.ply", ":11: ", "vertex 1: 'y' is not finite"},
    {"ply_nan_binary.ply", " (byte 185): ", "vertex 1: 'y' is not finite"},
    {"ply_negative_list_count.ply", " (byte 203): ", "negative list count -1"},
    {"ply_negative_list_count_ascii.ply", ":13: ", "negative list count -3"},
    {"ply_no_faces.ply", ":7: ", "no faces (empty mesh)"},
    {"ply_no_format.ply", ":8: ", "no format line"},
    {"ply_no_vertex_indices.ply", ":7: ", "element face has no vertex_indices list"},
    {"ply_partial_normal.ply", ":7: ", "vertex property 'nx' without the rest of its group"},
    {"ply_property_before_element.ply", ":3: ", "property before any element"},
    {"ply_strip_bad_index.ply", ":13: ", "strip 0: vertex index -2 out of range"},
    {"ply_truncated_ascii.ply", ":14: ", "truncated body"},
    {"ply_truncated_binary.ply", " (byte 206): ", "truncated body"},
    {"ply_two_corners.ply", ":13: ", "face 0 has 2 corners"},
    {"ply_uchar_out_of_range.ply", ":14: ", "value '300' for a vertex property is out of range for its type"},
    {"ply_unknown_type.ply", ":4: ", "unknown property type 'float128'"},
    {"ply_unsupported_format.ply", ":2: ", "unsupported PLY format 'binary_middle_endian'"},
    {"ply_zero_faces.ply", ":7: ", "no faces (empty mesh)"},
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.file; }

class MeshIoBadFile : public ::testing::TestWithParam<BadCase> {};

TEST_P(MeshIoBadFile, ThrowsIoErrorWithFilePlaceAndReason) {
  const BadCase& c = GetParam();
  const std::string path = testing::test_data(std::string("bad/") + c.file);
  ASSERT_TRUE(fs::exists(path)) << path;
  try {
    read_mesh(path);
    FAIL() << "no exception for " << c.file;
  } catch (const IoError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(what.find(path + c.where), std::string::npos) << what;
    EXPECT_NE(what.find(c.reason), std::string::npos) << what;
    EXPECT_TRUE(e.line() != IoError::kNoLine || e.byte_offset() != IoError::kNoOffset) << what;
  }
}

std::string bad_case_name(const ::testing::TestParamInfo<BadCase>& info) {
  std::string name = info.param.file;
  std::replace(name.begin(), name.end(), '.', '_');
  return name;
}

INSTANTIATE_TEST_SUITE_P(MeshIo, MeshIoBadFile, ::testing::ValuesIn(kBadCases), bad_case_name);

TEST(MeshIoBadFiles, EveryFixtureHasAnExpectation) {
  std::set<std::string> listed;
  for (const BadCase& c : kBadCases) listed.insert(c.file);
  std::size_t found = 0;
  for (const auto& entry : fs::directory_iterator(testing::test_data("bad"))) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("obj_", 0) != 0 && name.rfind("off_", 0) != 0 && name.rfind("ply_", 0) != 0) continue;
    ++found;
    EXPECT_TRUE(listed.count(name)) << name << " has no entry in kBadCases";
  }
  EXPECT_EQ(found, listed.size());
}

// Every truncation of a good binary PLY is rejected with an IoError (never a crash or a bogus mesh).
TEST(MeshIoBadFiles, EveryTruncationOfABinaryPlyFails) {
  const fs::path dir = testing::scratch_dir("mesh_io_truncations");
  const std::string full = all_types_binary(false);
  const std::size_t header = full.find("end_header\n") + 11;
  write_text(dir / "t.ply", full);
  ASSERT_NO_THROW(read_mesh((dir / "t.ply").string()));
  std::size_t body_errors = 0;
  for (std::size_t n = 0; n < full.size(); ++n) {
    // A new name per cut: truncating a file in place makes ext4 flush it, which is slow.
    const fs::path cut = dir / ("t" + std::to_string(n) + ".ply");
    write_text(cut, full.substr(0, n));
    try {
      read_mesh(cut.string());
      ADD_FAILURE() << "accepted a file cut at " << n;
    } catch (const IoError& e) {
      EXPECT_TRUE(e.line() != IoError::kNoLine || e.byte_offset() != IoError::kNoOffset) << e.what();
      if (n > header && e.byte_offset() != IoError::kNoOffset) ++body_errors;
    }
  }
  // Cuts deep enough into the body pass the header's size check and fail while reading, at a byte.
  EXPECT_GT(body_errors, 0u);
}

// A small deterministic fuzzer: corrupted copies of good files either read as a valid mesh or throw
// IoError; nothing else (no crash, no other exception, no runaway allocation).
TEST(MeshIoBadFiles, CorruptedFilesReadOrThrowIoError) {
  const fs::path dir = testing::scratch_dir("mesh_io_fuzz");
  const TriMesh mesh = awkward_mesh(true, true, true);
  std::vector<std::pair<std::string, std::string>> seeds;
  for (const char* name : {"s.obj", "s.off", "s_bin.ply", "s_txt.ply"}) {
    WriteOptions options;
    options.binary = std::string(name) != "s_txt.ply";
    write_mesh((dir / name).string(), mesh, options);
    std::ifstream in(dir / name, std::ios::binary);
    seeds.emplace_back(name, std::string((std::istreambuf_iterator<char>(in)), {}));
  }
  seeds.emplace_back("types_be.ply", all_types_binary(true));
  seeds.emplace_back("types_txt.ply", all_types_ascii());
  std::uint64_t state = 0x9e3779b97f4a7c15ull;
  auto next = [&state] {  // xorshift64*
    state ^= state >> 12;
    state ^= state << 25;
    state ^= state >> 27;
    return state * 0x2545f4914f6cdd1dull;
  };
  const char kAlphabet[] = "0123456789-+.e /#\n\rnaxyzf v";
  std::size_t accepted = 0, rejected = 0;
  for (const auto& [name, contents] : seeds) {
    for (int trial = 0; trial < 150; ++trial) {
      std::string bytes = contents;
      const int edits = 1 + static_cast<int>(next() % 4);
      for (int e = 0; e < edits; ++e) {
        const std::size_t at = next() % bytes.size();
        switch (next() % 4) {
          case 0: bytes[at] = static_cast<char>(next() & 0xff); break;
          case 1: bytes[at] = kAlphabet[next() % (sizeof kAlphabet - 1)]; break;
          case 2: bytes.erase(at, 1 + next() % 8); break;
          default: bytes.insert(at, 1, kAlphabet[next() % (sizeof kAlphabet - 1)]); break;
        }
        if (bytes.empty()) bytes = "x";
      }
      const fs::path path = dir / (std::to_string(trial) + "_" + name);
      write_text(path, bytes);
      try {
        const TriMesh m = read_mesh(path.string());
        EXPECT_NO_THROW(m.validate());
        EXPECT_GT(m.num_faces(), 0u);
        ++accepted;
      } catch (const IoError& e) {
        EXPECT_TRUE(e.line() != IoError::kNoLine || e.byte_offset() != IoError::kNoOffset) << e.what();
        ++rejected;
      }
    }
  }
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(accepted, 0u);
}

struct RealCase {
  const char* file;
  std::size_t vertices;
  std::size_t faces;
};

void PrintTo(const RealCase& c, std::ostream* os) { *os << c.file; }

class MeshIoReal : public ::testing::TestWithParam<RealCase> {};

TEST_P(MeshIoReal, CountsMatch) {
  VARMESH_REQUIRE_SHARED(path, std::string("meshes/") + GetParam().file);
  const TriMesh m = read_mesh(path);
  EXPECT_EQ(m.num_vertices(), GetParam().vertices);
  EXPECT_EQ(m.num_faces(), GetParam().faces);
  EXPECT_NO_THROW(m.validate());
}

const RealCase kRealCases[] = {
    {"cow_viewpoint_2903v_tristrips.ply", 2903, 5804}, {"dragon_vrip_res4_5205v.ply", 5205, 11102},
    {"bun_zipper_35947v.obj", 35947, 69451},           {"armadillo_cgal_26002v.off", 26002, 52000},
    {"horse_quad_2400v.obj", 2400, 4796},              {"dragon_vrip_437645v_binary_le.ply", 437645, 871414},
};

std::string real_case_name(const ::testing::TestParamInfo<RealCase>& info) {
  std::string name = info.param.file;
  name = name.substr(0, name.find('.'));
  return name;
}

INSTANTIATE_TEST_SUITE_P(MeshIo, MeshIoReal, ::testing::ValuesIn(kRealCases), real_case_name);

TEST(MeshIoRealData, HorseQuadsAreTriangulated) {
  VARMESH_REQUIRE_SHARED(path, "meshes/horse_quad_2400v.obj");
  ReadInfo info;
  const TriMesh m = read_mesh(path, &info);
  EXPECT_EQ(info.polygons_triangulated, 2398u);
}

// The cow exists as triangle strips and as an OBJ of the same vertices: decoding the strips must give
// the OBJ's triangles with the same orientation.
TEST(MeshIoRealData, CowStripsMatchCowObj) {
  VARMESH_REQUIRE_SHARED(strips_path, "meshes/cow_viewpoint_2903v_tristrips.ply");
  VARMESH_REQUIRE_SHARED(obj_path, "meshes/cow_viewpoint_2903v.obj");
  const TriMesh s = read_mesh(strips_path), o = read_mesh(obj_path);
  ASSERT_EQ(s.positions, o.positions);
  auto canonical = [](const TriMesh& m) {
    std::set<std::array<Index, 3>> tris;
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      std::array<Index, 3> t = {m.corner(f, 0), m.corner(f, 1), m.corner(f, 2)};
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());  // keeps orientation
      tris.insert(t);
    }
    return tris;
  };
  EXPECT_EQ(canonical(s), canonical(o));
}

TEST(MeshIoRealData, DragonRoundTripsThroughEveryFormat) {
  VARMESH_REQUIRE_SHARED(path, "meshes/dragon_vrip_res4_5205v.ply");
  const TriMesh m = read_mesh(path);
  const fs::path dir = testing::scratch_dir("mesh_io_dragon_round_trip");
  for (const char* name : {"d.obj", "d.off", "d.ply"}) {
    write_mesh((dir / name).string(), m);
    expect_identical(m, read_mesh((dir / name).string()));
  }
}

}  // namespace
}  // namespace varmesh
