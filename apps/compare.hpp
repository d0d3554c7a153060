#pragma once
// `varmesh compare`: the experiments of Kim-Lee 2001 Table 2 (placeholder, being written).
#include <string>

namespace CLI { class App; }

namespace varmesh::app {

struct CompareArgs {
  std::string out_dir = "varmesh_compare";
};

/// Registers the subcommand's options on `sub`.
void add_compare_options(CLI::App& sub, CompareArgs& args);
/// Runs it; returns the process exit status. Throws on bad input (the caller prints).
int run_compare(const CompareArgs& args);

}  // namespace varmesh::app
