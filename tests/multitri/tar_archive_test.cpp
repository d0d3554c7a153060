// read_tar_member: archives written by GNU tar (the independent oracle: Debian's essential `tar`) in its
// three header formats, plain and gzip-compressed, and damaged copies of them.
#include "multitri/tar_archive.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

void write_bytes(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << bytes;
}

std::string random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng() & 0xffu);
  return s;
}

// A tree of files: sizes on and around the 512-byte block, a name over 100 characters (GNU 'L' or pax
// `path` records, or ustar's prefix field, depending on the format), a folder and a symbolic link.
struct Tree {
  fs::path root;
  std::vector<std::pair<std::string, std::string>> files;  // relative name, contents
};

Tree make_tree(const fs::path& dir) {
  Tree t;
  t.root = dir / "tree";
  fs::remove_all(t.root);
  const std::string long_dir = "a_folder_whose_name_is_rather_long_to_push_the_path_over_one_hundred_characters";
  t.files = {{"empty.txt", ""},
             {"one.bin", random_bytes(1, 1)},
             {"block.bin", random_bytes(512, 2)},
             {"block_plus.bin", random_bytes(513, 3)},
             {"big.bin", random_bytes(200000, 4)},
             {"meshes/cow.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},
             {long_dir + "/and_a_file_name_that_is_long_as_well_so_the_whole_path_exceeds_the_limit.off", random_bytes(700, 5)}};
  for (const auto& [name, bytes] : t.files) write_bytes(t.root / name, bytes);
  fs::create_directories(t.root / "empty_folder");
  fs::create_symlink("one.bin", t.root / "link_to_one");
  return t;
}

fs::path run_tar(const Tree& t, const fs::path& archive, const std::string& flags) {
  const std::string cmd = "tar " + flags + " -cf '" + archive.string() + "' -C '" + t.root.string() + "' .";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return archive;
}

TEST(TarArchive, ReadsEveryMemberGnuTarWroteInEachFormat) {
  const fs::path dir = testing::scratch_dir("tar_formats");
  const Tree t = make_tree(dir);
  for (const std::string format : {"gnu", "posix", "ustar"}) {
    for (const bool gz : {false, true}) {
      // ustar holds the long name by splitting it at a '/' into its prefix and name fields (82 + 73
      // characters here); gnu writes an 'L' entry, posix a pax `path` record.
      const fs::path archive = run_tar(t, dir / ("t_" + format + (gz ? ".tar.gz" : ".tar")),
                                       "--format=" + format + (gz ? " -z" : ""));
      for (const auto& [name, bytes] : t.files) {
        SCOPED_TRACE(format + (gz ? " gz " : " ") + name);
        const auto got = read_tar_member(archive.string(), "./" + name);
        ASSERT_TRUE(got.has_value());
        EXPECT_EQ(*got, bytes);
        const auto again = read_tar_member(archive.string(), name);  // without the "./" tar stored
        ASSERT_TRUE(again.has_value());
        EXPECT_EQ(*again, bytes);
      }
      EXPECT_FALSE(read_tar_member(archive.string(), "no_such_file").has_value());
      EXPECT_FALSE(read_tar_member(archive.string(), "empty_folder").has_value());  // not a regular file
      EXPECT_FALSE(read_tar_member(archive.string(), "link_to_one").has_value());
      EXPECT_FALSE(read_tar_member(archive.string(), "meshes").has_value());
    }
  }
}

TEST(TarArchive, DamagedArchivesAreRefusedByOffset) {
  const fs::path dir = testing::scratch_dir("tar_damaged");
  const Tree t = make_tree(dir);
  const fs::path plain = run_tar(t, dir / "t.tar", "--format=gnu");
  const std::string bytes = read_file(plain.string());
  // The offset of big.bin's header, from GNU tar's own listing order: found by its name in the bytes.
  const std::size_t big_header = bytes.find("./big.bin");
  ASSERT_NE(big_header, std::string::npos);
  ASSERT_EQ(big_header % 512, 0u);

  // Cut inside big.bin's data: a search past it (or for big.bin itself) reports the truncation.
  const fs::path cut = dir / "cut.tar";
  write_bytes(cut, bytes.substr(0, big_header + 512 + 1000));
  try {
    read_tar_member(cut.string(), "no_such_file");
    ADD_FAILURE() << "a truncated archive was read";
  } catch (const IoError& e) {
    EXPECT_EQ(e.file(), cut.string());
    EXPECT_NE(std::string(e.what()).find("ends inside"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_tar_member(cut.string(), "big.bin"), IoError);

  // Cut inside a header.
  write_bytes(cut, bytes.substr(0, big_header + 100));
  EXPECT_THROW(read_tar_member(cut.string(), "no_such_file"), IoError);

  // A flipped byte in big.bin's header name: the checksum no longer matches, at that header's offset.
  std::string flipped = bytes;
  flipped[big_header + 4] = static_cast<char>(flipped[big_header + 4] ^ 0x20);
  const fs::path bad = dir / "bad.tar";
  write_bytes(bad, flipped);
  try {
    read_tar_member(bad.string(), "no_such_file");
    ADD_FAILURE() << "a header with a wrong checksum was read";
  } catch (const IoError& e) {
    EXPECT_EQ(e.byte_offset(), big_header);
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }

  // A file that is no archive at all.
  const fs::path text = dir / "text.tar";
  write_bytes(text, std::string(2000, 'x'));
  EXPECT_THROW(read_tar_member(text.string(), "a"), IoError);

  // A member above the size limit is refused; the same member under a larger limit is read.
  EXPECT_THROW(read_tar_member(plain.string(), "big.bin", 199999), IoError);
  EXPECT_TRUE(read_tar_member(plain.string(), "big.bin", 200000).has_value());

  // Missing files and folders.
  EXPECT_THROW(read_tar_member((dir / "missing.tar.gz").string(), "a"), IoError);
  EXPECT_THROW(read_tar_member(dir.string(), "a"), IoError);
}

TEST(TarArchive, CorruptCompressedStreamIsAnError) {
  const fs::path dir = testing::scratch_dir("tar_gz_corrupt");
  const Tree t = make_tree(dir);
  const fs::path gz = run_tar(t, dir / "t.tar.gz", "--format=gnu -z");
  std::string bytes = read_file(gz.string());
  ASSERT_GT(bytes.size(), 400u);
  // Garbage over the middle of the deflate stream (after the 10-byte gzip header).
  for (std::size_t i = bytes.size() / 3; i < bytes.size() / 3 + 64; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
  const fs::path bad = dir / "bad.tar.gz";
  write_bytes(bad, bytes);
  EXPECT_THROW(read_tar_member(bad.string(), "no_such_file"), IoError);
  // Truncated compressed stream.
  const std::string whole = read_file(gz.string());
  write_bytes(bad, whole.substr(0, whole.size() / 2));
  EXPECT_THROW(read_tar_member(bad.string(), "no_such_file"), IoError);
}

TEST(TarArchive, ReadsTheCgalDemoModelsWhenInstalled) {
  const std::string archive = "/usr/share/doc/libcgal-dev/data.tar.gz";
  if (!fs::exists(archive)) GTEST_SKIP() << archive << " missing (Debian package libcgal-demo is not installed)";
  for (const char* member : {"data/meshes/cow.off", "data/meshes/bunny00.off"}) {
    const auto got = read_tar_member(archive, member);
    ASSERT_TRUE(got.has_value()) << member;
    EXPECT_EQ(got->substr(0, 3), "OFF") << member;
  }
}

}  // namespace
}  // namespace varmesh
