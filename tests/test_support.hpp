#pragma once
// Helpers shared by the test suites: where test data lives, and a skip with a clear message when the
// shared data folder (../shared/data, present in CI) is absent.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace varmesh::testing {

inline std::string shared_data(const std::string& relative) { return std::string(VARMESH_SHARED_DATA_DIR) + "/" + relative; }
inline std::string test_data(const std::string& relative) { return std::string(VARMESH_TEST_DATA_DIR) + "/" + relative; }

/// A fresh empty folder under the build tree for one test's outputs.
inline std::filesystem::path scratch_dir(const std::string& name) {
  auto dir = std::filesystem::path(VARMESH_BINARY_DIR) / "test_scratch" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace varmesh::testing

/// Skips the current test when a file of ../shared/data is missing. Use inside a TEST body.
#define VARMESH_REQUIRE_SHARED(path_var, relative)                                                       \
  const std::string path_var = ::varmesh::testing::shared_data(relative);                               \
  if (!std::filesystem::exists(path_var)) {                                                              \
    GTEST_SKIP() << "shared test data missing: " << path_var << " (../shared/data is not beside the clone)"; \
  }
