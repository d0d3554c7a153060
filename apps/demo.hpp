#pragma once
// `varmesh demo`: the main job on an embedded default (a generated fractal terrain).
#include <cstddef>
#include <string>

namespace varmesh::app {

struct DemoArgs {
  std::string out_dir = "varmesh_demo";
  std::size_t size = 1025;
  float error = -1.0f;   ///< < 0: 0.5 % of the height range
  float pixels = 1.0f;
  std::string heightfield;  ///< optional input instead of the generated terrain
  std::string raw_size;     ///< W,H of a headerless .raw/.f32 height field (as terrain --raw-size)
  bool quiet = false;
};

/// Runs the demo; returns the process exit status. Throws on bad input (the caller prints).
int run_demo(const DemoArgs& args);

}  // namespace varmesh::app
