// Multi-Triangulation files: exact round trips and rejection of every kind of damage.
#include "multitri/mt_io.hpp"

#include <cstdio>
#include <string>
#include <filesystem>

#include <gtest/gtest.h>

#include "fourk/bisection.hpp"
#include "multitri/errors.hpp"
#include "multitri/mt_front.hpp"
#include "mt_file_edit.hpp"
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

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// The error decode_mt throws for `bytes`, or a failure when it throws none (or another type).
IoError decode_error(const std::string& bytes, const std::string& name) {
  try {
    decode_mt(bytes, name);
  } catch (const IoError& e) {
    return e;
  }
  ADD_FAILURE() << name << ": decoded without an IoError";
  return IoError(name, "no error");
}

// Where the sections of a version-2 file start, from mt_io.hpp's layout.
struct VrmLayout {
  std::size_t positions, faces, base_size, nodes, checksum;
};
VrmLayout layout_of(const Mt& mt, std::size_t file_size) {
  VrmLayout at{};
  at.positions = testing::kVrmHeaderBytes;
  at.faces = at.positions + 12 * mt.num_vertices();
  at.base_size = at.faces + 12 * mt.num_faces();
  at.nodes = at.base_size + 4;
  at.checksum = file_size - 8;
  return at;
}

// A file cut anywhere says so: "truncated", the file name, and (once the header is complete) how many
// bytes it has and how many its header declares. Before, every cut past the header read "checksum
// mismatch (file corrupt or truncated)".
TEST(MtIo, EveryTruncationIsReportedAsTruncated) {
  const std::string bytes = encode_mt(square_mt(2));
  ASSERT_EQ(testing::get_le(bytes, testing::kVrmSizeAt, 8), bytes.size());
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    const IoError e = decode_error(bytes.substr(0, len), "cut.vrm");
    EXPECT_EQ(e.file(), "cut.vrm");
    EXPECT_TRUE(contains(e.what(), "cut.vrm")) << e.what();
    EXPECT_TRUE(contains(e.reason(), "truncated")) << "length " << len << ": " << e.what();
    EXPECT_FALSE(contains(e.reason(), "checksum mismatch")) << "length " << len << ": " << e.what();
    if (len >= testing::kVrmHeaderBytes) {
      EXPECT_TRUE(contains(e.reason(), "has " + std::to_string(len) + " bytes but its header declares " +
                                           std::to_string(bytes.size())))
          << e.what();
      EXPECT_EQ(e.byte_offset(), len);
    }
  }
}

// A larger MT, cut at a sample of offsets (every section is hit).
TEST(MtIo, TruncationOfALargerMtIsReportedAsTruncated) {
  const std::string bytes = encode_mt(square_mt(6));
  for (std::size_t len = 0; len < bytes.size(); len += 1 + len / 7) {
    const IoError e = decode_error(bytes.substr(0, len), "big.vrm");
    EXPECT_TRUE(contains(e.reason(), "truncated")) << "length " << len << ": " << e.what();
  }
  const IoError last = decode_error(bytes.substr(0, bytes.size() - 1), "big.vrm");
  EXPECT_TRUE(contains(last.reason(), "1 missing")) << last.what();
  EXPECT_TRUE(contains(last.reason(), "in the middle of the checksum")) << last.what();
}

// The message names the element where the data stops, at the offsets mt_io.hpp's layout gives.
TEST(MtIo, TruncationNamesWhereTheDataEnds) {
  const Mt mt = square_mt(2);
  const std::string bytes = encode_mt(mt);
  const VrmLayout at = layout_of(mt, bytes.size());
  const std::string nv = std::to_string(mt.num_vertices()), nf = std::to_string(mt.num_faces());
  const std::string last_node = std::to_string(mt.num_nodes() - 1);
  const struct {
    std::size_t len;
    std::string where;
  } cases[] = {
      {at.positions, "before the position of vertex 0 (of " + nv + ")"},
      {at.positions + 12 * 2 + 5, "in the middle of the position of vertex 2 (of " + nv + ")"},
      {at.faces, "before face 0 (of " + nf + ")"},
      {at.faces + 12 * 3 + 11, "in the middle of face 3 (of " + nf + ")"},
      {at.base_size + 2, "in the middle of the base image size"},
      {at.nodes, "before the record of node 1 (nodes 1 to " + last_node + ")"},
      {at.nodes + 7, "in the middle of the record of node 1 (nodes 1 to " + last_node + ")"},
      {at.checksum, "before the checksum"},
  };
  for (const auto& c : cases) {
    const IoError e = decode_error(bytes.substr(0, c.len), "cut.vrm");
    EXPECT_TRUE(contains(e.reason(), "the data ends " + c.where)) << e.what();
    EXPECT_TRUE(contains(e.reason(), std::to_string(bytes.size() - c.len) + " missing")) << e.what();
  }
  // Inside the header, the message says which part.
  EXPECT_TRUE(contains(decode_error("", "e.vrm").reason(), "truncated: the file is empty"));
  EXPECT_TRUE(contains(decode_error(bytes.substr(0, 5), "e.vrm").reason(), "5 bytes and ends inside the magic"));
  EXPECT_TRUE(contains(decode_error(bytes.substr(0, 10), "e.vrm").reason(), "ends inside the format version"));
  EXPECT_TRUE(contains(decode_error(bytes.substr(0, 30), "e.vrm").reason(), "30 bytes, less than the 40-byte header"));
}

// Damage that keeps the length is a checksum mismatch (of the header, or of the file), never "truncated":
// the header's own checksum vouches for the size it declares. Bytes of the magic are refused as a bad magic;
// a damaged version field as a corrupt file, since the header checksum matches with the field read as 2
// (it read "unsupported MT file version", as if the file were of a newer format).
TEST(MtIo, EveryFlippedByteIsAChecksumMismatch) {
  const std::string bytes = encode_mt(square_mt(2));
  for (std::size_t i = 0; i < bytes.size(); ++i)
    for (unsigned mask : {0x01u, 0x5au, 0x80u}) {
      std::string bad = bytes;
      bad[i] = static_cast<char>(static_cast<unsigned char>(bad[i]) ^ mask);
      const IoError e = decode_error(bad, "flip.vrm");
      EXPECT_EQ(e.file(), "flip.vrm");
      if (i < testing::kVrmVersionAt) {
        EXPECT_TRUE(contains(e.reason(), "bad magic")) << "byte " << i << ": " << e.what();
      } else if (i < testing::kVrmCountsAt) {
        const std::uint64_t reads = testing::get_le(bad, testing::kVrmVersionAt, 4);
        EXPECT_TRUE(contains(e.reason(), "the file is corrupt: its format version reads " + std::to_string(reads) +
                                             ", but its header checksum matches version 2 (the version field is damaged)"))
            << "byte " << i << ": " << e.what();
        EXPECT_TRUE(contains(e.what(), "flip.vrm")) << e.what();
        EXPECT_EQ(e.byte_offset(), testing::kVrmVersionAt);
      } else if (i < testing::kVrmHeaderBytes) {
        EXPECT_TRUE(contains(e.reason(), "checksum mismatch in the header")) << "byte " << i << ": " << e.what();
        EXPECT_EQ(e.byte_offset(), testing::kVrmHeaderSumAt);
      } else {
        EXPECT_TRUE(contains(e.reason(), "checksum mismatch: stored")) << "byte " << i << ": " << e.what();
        EXPECT_EQ(e.byte_offset(), bytes.size() - 8);
      }
    }
}

// The checksums tell a damaged version field from a format this build does not know.
TEST(MtIo, AVersionFieldIsJudgedByTheChecksums) {
  const std::string v2 = encode_mt(square_mt(2));
  const std::string v1 = testing::as_version_1(v2);
  auto expect_error = [](const std::string& bytes, const std::string& name, const std::string& reason) {
    const IoError e = decode_error(bytes, name);
    EXPECT_EQ(e.file(), name);
    EXPECT_TRUE(contains(e.what(), name)) << e.what();
    EXPECT_TRUE(contains(e.reason(), reason)) << e.what();
    EXPECT_EQ(e.byte_offset(), testing::kVrmVersionAt) << e.what();
  };
  {
    std::string b = v2;  // a version-2 file whose field reads 1 is not parsed as version 1
    testing::put_le(b, testing::kVrmVersionAt, 1, 4);
    expect_error(b, "one.vrm", "the file is corrupt: its format version reads 1, but its header checksum matches version 2");
  }
  {
    std::string b = v2;  // an intact header of version 3: a newer format, not damage
    testing::put_le(b, testing::kVrmVersionAt, 3, 4);
    testing::reseal_all(b);
    expect_error(b, "new.vrm", "unsupported MT file version 3 (this build reads versions 1 and 2; the header checksum matches");
  }
  {
    std::string b = v2;  // version 3 and a damaged vertex count: laid out as version 2, header checksum fails
    testing::put_le(b, testing::kVrmVersionAt, 3, 4);
    b[testing::kVrmCountsAt] = static_cast<char>(b[testing::kVrmCountsAt] ^ 0x10);
    expect_error(b, "two.vrm", "the file is corrupt: its format version reads 3, which this build does not know, "
                               "and its version-2 header fails its checksum");
  }
  for (std::size_t i = testing::kVrmVersionAt; i < testing::kVrmCountsAt; ++i)
    for (unsigned mask : {0x01u, 0x5au, 0x80u}) {
      std::string b = v1;  // a damaged version-1 field: the whole file's checksum matches with it read as 1
      b[i] = static_cast<char>(static_cast<unsigned char>(b[i]) ^ mask);
      SCOPED_TRACE("byte " + std::to_string(i) + " ^ " + std::to_string(mask));
      expect_error(b, "old.vrm", "the file is corrupt: its format version reads " +
                                     std::to_string(testing::get_le(b, testing::kVrmVersionAt, 4)) +
                                     ", but its checksum matches version 1");
    }
  {
    std::string b = v1;  // version 3 re-sealed, no version-2 header: nothing vouches for either reading
    testing::put_le(b, testing::kVrmVersionAt, 3, 4);
    testing::reseal(b);
    expect_error(b, "odd.vrm", "unsupported MT file version 3 (this build reads versions 1 and 2; no checksum shows");
    expect_error(v2.substr(0, 20).replace(testing::kVrmVersionAt, 1, 1, '\x07'), "short.vrm",
                 "unsupported MT file version 7");
  }
}

TEST(MtIo, BytesAfterTheDeclaredEndAreRefused) {
  const std::string bytes = encode_mt(square_mt(2));
  const IoError e = decode_error(bytes + "x", "long.vrm");
  EXPECT_TRUE(contains(e.reason(), "1 unexpected byte after the end the header declares")) << e.what();
  EXPECT_EQ(e.byte_offset(), bytes.size());
  EXPECT_TRUE(contains(decode_error(bytes + bytes, "twice.vrm").reason(),
                       std::to_string(bytes.size()) + " unexpected bytes"));
}

// Counts that disagree with the file, behind valid checksums (a file edited by hand): refused by name.
TEST(MtIo, CountsThatDisagreeWithTheSizeAreRefused) {
  const Mt mt = square_mt(2);
  const std::string good = encode_mt(mt);
  const VrmLayout at = layout_of(mt, good.size());
  {
    std::string b = good;  // 2^28 vertices: 3 GB of positions
    testing::put_le(b, testing::kVrmCountsAt, 1u << 28, 4);
    testing::reseal_all(b);
    const IoError e = decode_error(b, "edit.vrm");
    EXPECT_TRUE(contains(e.reason(), "268435456 vertices")) << e.what();
    EXPECT_TRUE(contains(e.reason(), "bytes, the file has " + std::to_string(good.size()))) << e.what();
    EXPECT_EQ(e.byte_offset(), testing::kVrmCountsAt);
  }
  {
    std::string b = good;  // node 1 removes more faces than the rest of the file holds
    testing::put_le(b, at.nodes + 5, 0xFFFFFFF0u, 4);
    testing::reseal_all(b);
    const IoError e = decode_error(b, "edit.vrm");
    EXPECT_TRUE(contains(e.reason(), "removed count 4294967280 needs")) << e.what();
    EXPECT_EQ(e.byte_offset(), at.nodes + 5);
  }
  {
    std::string b = good;  // node 1 removes one face fewer: its records end 4 bytes before the checksum
    const std::uint64_t r = testing::get_le(b, at.nodes + 5, 4);
    ASSERT_GT(r, 0u);
    testing::put_le(b, at.nodes + 5, r - 1, 4);
    testing::reseal_all(b);
    EXPECT_THROW(decode_mt(b, "edit.vrm"), IoError);
  }
}

// A cut version-1 file names the node record where its data stops (the name is built only then).
TEST(MtIo, VersionOneTruncationNamesTheNode) {
  const Mt mt = square_mt(3);
  const std::string v1 = testing::as_version_1(encode_mt(mt));
  // Version 1 has no bytes 24 .. 39; the records follow the positions, the faces and the base image size.
  std::size_t at = 24 + 12 * mt.num_vertices() + 12 * mt.num_faces() + 4;
  const std::string last = std::to_string(mt.num_nodes() - 1);
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    const std::size_t record = 13 + 4 * mt.pre_image(n).size();
    const std::string where = "the record of node " + std::to_string(n) + " (nodes 1 to " + last + ")";
    EXPECT_TRUE(contains(decode_error(v1.substr(0, at), "old.vrm").reason(), "the data ends before " + where));
    EXPECT_TRUE(contains(decode_error(v1.substr(0, at + record - 1), "old.vrm").reason(),
                         "the data ends in the middle of " + where));
    at += record;
  }
  EXPECT_EQ(at + 8, v1.size());
}

// Version-1 files (no size, no header checksum) are still read; a cut one is refused and says it may be cut.
TEST(MtIo, VersionOneFilesAreStillRead) {
  const Mt mt = square_mt(3);
  const std::string v1 = testing::as_version_1(encode_mt(mt));
  const Mt back = decode_mt(v1, "old.vrm");
  back.validate();
  expect_same(mt, back);
  for (std::size_t len = 0; len < v1.size(); ++len) {
    const IoError e = decode_error(v1.substr(0, len), "old.vrm");
    EXPECT_TRUE(contains(e.reason(), "truncated")) << "length " << len << ": " << e.what();
  }
  for (std::size_t i = 0; i < v1.size(); ++i) {
    std::string bad = v1;
    bad[i] = static_cast<char>(bad[i] ^ 0x5a);
    EXPECT_THROW(decode_mt(bad, "old.vrm"), IoError) << "byte " << i;
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
  future[8] = 3;
  testing::reseal_all(future);
  try {
    decode_mt(future, "future.vrm");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("version 3"), std::string::npos);
  }
  EXPECT_THROW(read_mt("/nonexistent/dir/x.vrm"), IoError);
  // A failed write leaves nothing behind.
  const auto dir = testing::scratch_dir("mt_io_fail");
  EXPECT_THROW(write_mt((dir / "missing_subdir" / "x.vrm").string(), square_mt(1)), IoError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// Corners exchanged between faces of two successive nodes, re-sealed: a fuzzer found such a file (two
// border splits of an adaptive height field) that loaded and passed Mt::validate, while the front after one
// of the splits used a directed edge twice. Every edit the reader accepts must give conforming fronts.
TEST(MtIo, EditedFacesBehindAValidChecksumGiveConformingFronts) {
  const Mt mt = square_mt(4);
  const std::string good = encode_mt(mt);
  const std::size_t faces_at = testing::kVrmHeaderBytes + 12 * mt.num_vertices();
  std::size_t accepted = 0, refused = 0;
  for (NodeId n = 1; n + 1 < mt.num_nodes(); ++n)
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f)
      for (FaceId g = mt.image_begin(n + 1); g < mt.image_end(n + 1); ++g)
        for (std::size_t k = 0; k < 3; ++k) {
          std::string b = good;
          for (std::size_t byte = 0; byte < 4; ++byte) std::swap(b[faces_at + 12 * f + 4 * k + byte], b[faces_at + 12 * g + 4 * k + byte]);
          testing::reseal(b);
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
  // Some edits pass the reader (47 of 492 when written), or the fronts above check nothing.
  EXPECT_GT(accepted, 0u);
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
