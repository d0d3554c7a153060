#include "apps/compare.hpp"

#include <stdexcept>

#include <CLI/CLI.hpp>

namespace varmesh::app {

void add_compare_options(CLI::App& sub, CompareArgs& args) { sub.add_option("--out", args.out_dir, "output folder"); }

int run_compare(const CompareArgs&) { throw std::runtime_error("compare: not implemented yet"); }

}  // namespace varmesh::app
