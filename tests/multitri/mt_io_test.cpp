// Multi-Triangulation files: exact round trips and rejection of every kind of damage.
#include "multitri/mt_io.hpp"

#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "fourk/bisection.hpp"
#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

Mt square_mt(int levels) {
  TriMesh base;
  base.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.2f}, {0, 1, 0}};
  base.indices = {0, 1, 2, 0, 2, 3};
  BisectionOptions opt;
  opt.place_vertex = [](const BisectionSplit& s) {
    const glm::vec3 m = 0.5f * (s.positions[s.e0] + s.positions[s.e1]);
    return glm::vec3(m.x, m.y, 0.3f * m.x * m.y);
  };
  opt.node_error = [](const BisectionSplit& s) { return 1.0f / static_cast<float>(1 + s.level); };
  return build_bisection_mt(base, mark_longest_edges(base), levels, opt);
}

void expect_same(const Mt& a, const Mt& b) {
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  ASSERT_EQ(a.num_faces(), b.num_faces());
  ASSERT_EQ(a.num_vertices(), b.num_vertices());
  EXPECT_EQ(a.positions(), b.positions());
  for (FaceId f = 0; f < a.num_faces(); ++f) EXPECT_EQ(a.face(f), b.face(f)) << "face " << f;
  for (NodeId n = 0; n < a.num_nodes(); ++n) {
    EXPECT_EQ(a.kind(n), b.kind(n));
    EXPECT_EQ(a.image_begin(n), b.image_begin(n));
    EXPECT_EQ(a.image_end(n), b.image_end(n));
    const auto pa = a.pre_image(n), pb = b.pre_image(n);
    EXPECT_TRUE(std::equal(pa.begin(), pa.end(), pb.begin(), pb.end())) << "node " << n;
    EXPECT_EQ(a.bound(n).error, b.bound(n).error);
    EXPECT_EQ(a.bound(n).radius, b.bound(n).radius);
  }
}

TEST(MtIo, RoundTripIsExact) {
  const Mt mt = square_mt(6);
  const auto dir = testing::scratch_dir("mt_io_roundtrip");
  const std::string path = (dir / "square.vrm").string();
  write_mt(path, mt);
  const Mt back = read_mt(path);
  back.validate();
  expect_same(mt, back);
  MtFront f(back);
  for (NodeId n = 1; n < back.num_nodes(); ++n) f.refine(n);
  EXPECT_EQ(f.num_faces(), 2u << 6);
}

TEST(MtIo, EveryTruncationIsRejected) {
  const std::string bytes = encode_mt(square_mt(2));
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    EXPECT_THROW(decode_mt(std::string_view(bytes).substr(0, len), "cut.vrm"), IoError) << "length " << len;
  }
}

TEST(MtIo, EveryFlippedByteIsRejected) {
  const std::string bytes = encode_mt(square_mt(2));
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::string bad = bytes;
    bad[i] = static_cast<char>(bad[i] ^ 0x5a);
    EXPECT_THROW(decode_mt(bad, "flip.vrm"), IoError) << "byte " << i;
  }
}

TEST(MtIo, MessagesNameTheProblem) {
  std::string bytes = encode_mt(square_mt(1));
  try {
    decode_mt("NOTANMT!xxxxxxxxxxxx", "junk.vrm");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("bad magic"), std::string::npos);
    EXPECT_EQ(e.file(), "junk.vrm");
  }
  std::string future = bytes;
  future[8] = 2;
  try {
    decode_mt(future, "future.vrm");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos);
  }
  EXPECT_THROW(read_mt("/nonexistent/dir/x.vrm"), IoError);
  // A failed write leaves nothing behind.
  const auto dir = testing::scratch_dir("mt_io_fail");
  EXPECT_THROW(write_mt((dir / "missing_subdir" / "x.vrm").string(), square_mt(1)), IoError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// FNV-1a 64 written here again (mt_io.hpp documents it), so a test can re-seal an edited file.
void reseal(std::string& b) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t i = 0; i + 8 < b.size(); ++i) {
    h ^= static_cast<unsigned char>(b[i]);
    h *= 0x100000001b3ull;
  }
  for (int k = 0; k < 8; ++k) b[b.size() - 8 + static_cast<std::size_t>(k)] = static_cast<char>(h >> (8 * k));
}

// Corners exchanged between faces of two successive nodes, re-sealed: a fuzzer found such a file (two
// border splits of an adaptive height field) that loaded and passed Mt::validate, while the front after one
// of the splits used a directed edge twice. Every edit the reader accepts must give conforming fronts.
TEST(MtIo, EditedFacesBehindAValidChecksumGiveConformingFronts) {
  const Mt mt = square_mt(4);
  const std::string good = encode_mt(mt);
  const std::size_t faces_at = 24 + 12 * mt.num_vertices();
  std::size_t accepted = 0, refused = 0;
  for (NodeId n = 1; n + 1 < mt.num_nodes(); ++n)
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f)
      for (FaceId g = mt.image_begin(n + 1); g < mt.image_end(n + 1); ++g)
        for (std::size_t k = 0; k < 3; ++k) {
          std::string b = good;
          for (std::size_t byte = 0; byte < 4; ++byte) std::swap(b[faces_at + 12 * f + 4 * k + byte], b[faces_at + 12 * g + 4 * k + byte]);
          reseal(b);
          Mt e;
          try {
            e = decode_mt(b, "edit.vrm");
          } catch (const IoError&) {
            ++refused;
            continue;
          }
          ++accepted;
          MtFront front(e);
          for (NodeId m = 1; m < e.num_nodes(); ++m) {
            front.refine(m);
            ASSERT_NO_THROW(front.validate()) << "faces " << f << ", " << g << " corner " << k << ", after node " << m;
          }
        }
  EXPECT_GT(refused, 0u);
  std::printf("edited files: %zu refused, %zu accepted\n", refused, accepted);
}


TEST(MtIo, AnEmptyMtIsRefusedBeforeAnyFileIsWritten) {
  EXPECT_THROW(encode_mt(Mt{}), InvalidInput);
  const auto path = testing::scratch_dir("mt_io_empty") / "empty.vrm";
  EXPECT_THROW(write_mt(path.string(), Mt{}), InvalidInput);
  EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
}  // namespace varmesh
