// InterruptCleanup: the temporary files and folders recorded while they exist, and what a signal's handler
// removes (recorded files, then recorded folders that are empty) before the process ends by that signal.
// read_file_bytes: every byte in place, for sizes on both sides of the two-thread read, and the refusals.
#include "multitri/file_util.hpp"

#include <gtest/gtest.h>

#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "multitri/errors.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

TEST(InterruptCleanup, EntriesAreRecordedUntilForgotten) {
  const std::size_t before = InterruptCleanup::pending();
  const int a = InterruptCleanup::add("some/file", false);
  const int b = InterruptCleanup::add("some/folder", true);
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  EXPECT_NE(a, b);
  EXPECT_EQ(InterruptCleanup::pending(), before + 2);
  InterruptCleanup::forget(a);
  EXPECT_EQ(InterruptCleanup::pending(), before + 1);
  {
    const CleanupGuard guard("another/file", false);
    EXPECT_EQ(InterruptCleanup::pending(), before + 2);
  }
  EXPECT_EQ(InterruptCleanup::pending(), before + 1);
  InterruptCleanup::forget(b);
  InterruptCleanup::forget(-1);  // an entry that was not recorded
  EXPECT_EQ(InterruptCleanup::pending(), before);
  // Too long or empty: not recorded (best effort), and forgetting the -1 is harmless.
  EXPECT_EQ(InterruptCleanup::add(std::string(InterruptCleanup::kMaxPath + 1, 'x'), false), -1);
  EXPECT_EQ(InterruptCleanup::add("", false), -1);
  const int longest = InterruptCleanup::add(std::string(InterruptCleanup::kMaxPath, 'x'), false);
  EXPECT_GE(longest, 0);
  EXPECT_EQ(InterruptCleanup::pending(), before + 1);
  InterruptCleanup::forget(longest);
}

TEST(InterruptCleanup, SlotsRunOutWithoutHarm) {
  std::vector<int> slots;
  for (std::size_t i = 0; i < InterruptCleanup::kMaxEntries + 5; ++i)
    slots.push_back(InterruptCleanup::add("f" + std::to_string(i), false));
  std::size_t recorded = 0;
  for (int s : slots) recorded += s >= 0;
  EXPECT_LE(recorded, InterruptCleanup::kMaxEntries);
  EXPECT_EQ(slots.back(), -1);
  for (int s : slots) InterruptCleanup::forget(s);
  const int again = InterruptCleanup::add("again", false);
  EXPECT_GE(again, 0) << "forgotten slots are free again";
  InterruptCleanup::forget(again);
}

TEST(InterruptCleanup, AtomicWritesForgetTheirTemporaryFile) {
  const fs::path dir = testing::scratch_dir("interrupt_cleanup_writes");
  const std::size_t before = InterruptCleanup::pending();
  write_file_atomically((dir / "ok.txt").string(), "contents\n");
  EXPECT_EQ(InterruptCleanup::pending(), before);
  EXPECT_THROW(write_file_atomically((dir / "no" / "such" / "folder.txt").string(), "x"), IoError);
  EXPECT_EQ(InterruptCleanup::pending(), before);
}

// The handler in a child process (a death test): recorded files go, recorded folders go once empty (the
// nested ones too, in any order of recording), an unrecorded file keeps its folder, and the process ends
// by the signal it got.
TEST(InterruptCleanupDeathTest, ASignalRemovesWhatIsRecorded) {
  const fs::path dir = testing::scratch_dir("interrupt_cleanup_signal");
  const fs::path file = dir / "file.tmp", outer = dir / "outer", inner = outer / "inner", kept = dir / "kept";
  auto make = [&] {
    fs::create_directories(inner);
    fs::create_directories(kept);
    std::ofstream(file) << "x";
    std::ofstream(inner / "staged.obj") << "x";
    std::ofstream(kept / "users.obj") << "x";
  };
  for (const int sig : {SIGTERM, SIGINT, SIGHUP, SIGPIPE}) {
    make();
    EXPECT_EXIT(
        {
          InterruptCleanup::install_handlers();
          InterruptCleanup::add(outer.string(), true);  // the outer folder first: removed after the inner
          InterruptCleanup::add(inner.string(), true);
          InterruptCleanup::add((inner / "staged.obj").string(), false);
          InterruptCleanup::add(file.string(), false);
          InterruptCleanup::add(kept.string(), true);  // not empty: stays
          std::raise(sig);
        },
        ::testing::KilledBySignal(sig), "")
        << "signal " << sig;
    EXPECT_FALSE(fs::exists(file)) << sig;
    EXPECT_FALSE(fs::exists(outer)) << sig;
    EXPECT_TRUE(fs::exists(kept / "users.obj")) << sig;
  }
}

// Sizes around the one from which two threads read halves, each byte a function of its offset (a half
// read into the wrong place, or a chunk boundary off by one, changes some byte).
TEST(ReadFileBytes, EveryByteArrivesInPlace) {
  const fs::path dir = testing::scratch_dir("read_file_bytes");
  auto byte_at = [](std::size_t i) { return static_cast<char>((i * 2654435761u) >> 13); };
  for (const std::size_t size : {std::size_t{0}, std::size_t{1}, std::size_t{4097}, kParallelReadBytes - 1,
                                 kParallelReadBytes, kParallelReadBytes + 3}) {
    std::string contents(size, '\0');
    for (std::size_t i = 0; i < size; ++i) contents[i] = byte_at(i);
    const fs::path path = dir / ("f" + std::to_string(size));
    std::ofstream(path, std::ios::binary).write(contents.data(), static_cast<std::streamsize>(size));
    const FileBytes got = read_file_bytes(path.string());
    ASSERT_EQ(got.size(), size);
    EXPECT_TRUE(got.view() == contents) << size;
    EXPECT_EQ(read_file(path.string()), contents) << size;
  }
}

TEST(ReadFileBytes, RefusesWhatIsNotARegularFile) {
  const fs::path dir = testing::scratch_dir("read_file_bytes_refusals");
  auto message = [](const fs::path& p) {
    try {
      read_file_bytes(p.string());
    } catch (const IoError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(dir).find("folder"), std::string::npos) << message(dir);
  EXPECT_NE(message(dir / "missing").find("cannot open"), std::string::npos) << message(dir / "missing");
  EXPECT_NE(message("/dev/null").find("not a regular file"), std::string::npos) << message("/dev/null");
}

}  // namespace
}  // namespace varmesh
