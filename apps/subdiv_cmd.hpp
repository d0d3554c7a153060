#pragma once
// `varmesh subdiv`: uniform or adaptive subdivision of a polygon mesh with the primal schemes of
// fourk/subdiv.hpp (4-8, Catmull-Clark, linear, quasi 4-8) and the dual schemes of fourk/subdiv_dual.hpp
// (Zwart-Powell, Doo-Sabin), and `--figure`: every scheme on one input, rendered with one camera (the
// analogue of Velho-Gomes 2000, Figure 19).
#include <cstdint>
#include <string>

namespace CLI { class App; }

namespace varmesh::app {

struct SubdivArgs {
  std::string input;   ///< mesh file (.obj/.off/.ply) or a built-in quad mesh: cube | torus
  std::string output;  ///< .obj/.off/.ply (not with --figure)
  std::string scheme;  ///< 48 | zwart-powell | catmull-clark | doo-sabin | quasi48 | linear (empty: 48)
  int levels = 0;      ///< dyadic levels (faces x4 each), when levels_given
  int steps = 0;       ///< the scheme's elementary steps (binary 4-8 steps, Zwart-Powell or Doo-Sabin steps), when steps_given
  bool levels_given = false, steps_given = false;  ///< set by the parser: no value of the option means "not given"
  bool adaptive = false;
  float error = -1.0f;  ///< --adaptive: largest node error (object units); < 0: not given (the parser takes >= 0 only)
  std::string camera;   ///< --adaptive: ex,ey,ez,tx,ty,tz,fov
  float pixels = 1.0f, viewport = 1080.0f;
  std::string png;     ///< render the result to this PNG
  std::string figure;  ///< folder: every scheme on INPUT, one PNG each plus a combined grid
  std::string view;    ///< pictures: direction from the model's centre to the eye (default: a 3/4 view, z up)
  std::string up;      ///< pictures: the up axis (default 0,0,1)
  std::uint64_t max_triangles;  ///< refuse results with more triangles than this (checked before running)

  static constexpr std::uint64_t kDefaultMaxTriangles = std::uint64_t{1} << 25;
  static constexpr std::uint64_t kHardMaxTriangles = std::uint64_t{1} << 31;
  SubdivArgs() : max_triangles(kDefaultMaxTriangles) {}
};

void add_subdiv_options(CLI::App& sub, SubdivArgs& args);

/// Runs the command: prints a short report on stdout, returns 0. Throws InvalidInput / IoError (the caller
/// prints them on one line); nothing is written unless everything before the writes succeeded.
int run_subdiv(const SubdivArgs& args);

}  // namespace varmesh::app
