#pragma once
// `varmesh demo`: the main job on an embedded default (a generated fractal terrain).
#include <cstddef>
#include <string>

namespace CLI { class App; }

namespace varmesh::app {

struct DemoArgs {
  std::string out_dir = "varmesh_demo";
  std::size_t size = 1025;
  float error = -1.0f;   ///< < 0: 0.5 % of the height range
  float pixels = 1.0f;
  std::string heightfield;  ///< optional input instead of the generated terrain
  std::string raw_size;     ///< W,H of a headerless .raw/.f32 height field (as terrain --raw-size)
  /// --heightfield: distance between samples and height factor, as terrain's --spacing and --z-scale. With
  /// neither given, a height field whose heights span more than half its width at spacing 1 (heights in
  /// metres, samples tens of metres apart) is laid out with a round spacing that makes the relief about a
  /// fifth of the width, and the output says so.
  float spacing = 1.0f;
  float z_scale = 1.0f;
  bool spacing_given = false, z_scale_given = false;  ///< set by the parser
  bool quiet = false;
};

/// Registers the subcommand's options on `sub`.
void add_demo_options(CLI::App& sub, DemoArgs& args);

/// Runs the demo; returns the process exit status. Throws on bad input (the caller prints).
int run_demo(const DemoArgs& args);

}  // namespace varmesh::app
