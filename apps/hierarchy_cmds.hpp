#pragma once
// `varmesh build` (a 4-k hierarchy saved as a .vrm Multi-Triangulation file) and `varmesh query` (a front of
// any .vrm file by error, camera or a linear ramp of triangle size).
#include <cstddef>
#include <string>

namespace CLI { class App; }

namespace varmesh::app {

struct BuildArgs {
  std::string input;   ///< mesh file, height field, or a built-in surface: torus, saddle, implicit-torus
  std::string output;  ///< .vrm
  std::string method = "semiregular";
  int levels = -1;             ///< semiregular: binary levels (default 4); simplify4k: at most this many (default all)
  float tolerance = -1.0f;     ///< adaptive: geometric tolerance (default: 1% of the bounding-box diagonal)
  std::string raw_size;        ///< adaptive on a .raw height field
  std::string pictures;        ///< folder for PNGs of the levels (semiregular, simplify4k) or the result (adaptive)
  std::string up, view;        ///< pictures: "x,y,z" up axis and direction towards the eye (empty: defaults)
  bool quiet = false;
};
struct QueryArgs {
  std::string input, output, png;
  float error = -1.0f;
  std::string camera;     ///< ex,ey,ez,tx,ty,tz,fov
  float pixels = 1.0f, viewport = 1080.0f;
  std::string ramp;       ///< x0,y0,z0,x1,y1,z1,size0,size1
  std::size_t budget = 0;
  std::string up, view;   ///< --png: "x,y,z" up axis and direction towards the eye (empty: defaults)
};

void add_build_options(CLI::App& sub, BuildArgs& args);
void add_query_options(CLI::App& sub, QueryArgs& args);
int run_build(const BuildArgs& args);
int run_query(const QueryArgs& args);

}  // namespace varmesh::app
