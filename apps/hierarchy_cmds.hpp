#pragma once
// `varmesh build` (a 4-k hierarchy saved as a .vrm Multi-Triangulation file) and `varmesh query` (a front of
// any .vrm file by error, camera or a linear ramp of triangle size); `varmesh pm build` / `varmesh pm query`,
// the same pair for the Kim-Lee progressive-mesh hierarchy (.vmh).
#include <cstddef>
#include <cstdint>
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
  float spacing = 1.0f;        ///< adaptive on a height field: distance between samples
  float z_scale = 1.0f;        ///< adaptive on a height field: factor on the heights
  bool heightfield_scale_given = false;  ///< --spacing or --z-scale given (set by the parser)
  std::string pictures;        ///< folder for PNGs of the levels (semiregular, simplify4k) or the result (adaptive)
  std::string up, view;        ///< pictures: "x,y,z" up axis and direction towards the eye (empty: defaults)
  /// semiregular: the most faces the finest mesh may have (base faces x 2^levels), checked before the build
  /// (peak memory about 250 bytes per finest face). 1 .. kHardMaxTriangles.
  std::uint64_t max_triangles = kDefaultMaxTriangles;
  bool max_triangles_given = false;  ///< set by the parser (refused with the other methods)
  bool quiet = false;

  static constexpr std::uint64_t kDefaultMaxTriangles = std::uint64_t{1} << 22;
  static constexpr std::uint64_t kHardMaxTriangles = std::uint64_t{1} << 31;
};
/// What `query` and `pm query` share: the hierarchy, the output, the view criteria and the picture.
struct ViewQueryArgs {
  std::string input, output, png;
  float error = -1.0f;
  std::string camera;     ///< ex,ey,ez,tx,ty,tz,fov
  float pixels = 1.0f, viewport = 1080.0f;
  std::size_t budget = 0;
  std::string up, view;   ///< --png: "x,y,z" up axis and direction towards the eye (empty: defaults)
  bool measure = false;   ///< report the distance from the finest (pm: original) mesh's vertices to the result
};

struct QueryArgs : ViewQueryArgs {
  std::string ramp;       ///< x0,y0,z0,x1,y1,z1,size0,size1
};

/// `varmesh pm build`: the Kim-Lee vertex hierarchy (QEM analysis) of a mesh, saved as a .vmh file.
struct PmBuildArgs {
  std::string input, output;
  std::string cost = "quadric";   ///< quadric | quadric-plain | lindstrom-turk
  std::size_t faces = 0, vertices = 0;  ///< stop targets (0: none; neither: the smallest base mesh)
  float max_error = -1.0f;        ///< skip the collapses whose node error would exceed this (object units; < 0: none)
  double lt_finish = 4.0;         ///< QemOptions::lt_finish (quadric costs; 0: off)
  bool lt_finish_given = false;   ///< --lt-finish on the command line (refused where it cannot apply)
  bool colors = false;            ///< GH98 colour quadrics when the mesh has vertex colours
  std::string non_manifold = "split";  ///< split | lock
  std::size_t threads = 1;        ///< QemOptions::threads (0: one per hardware thread)
  bool threads_given = false;     ///< --threads on the command line (refused where it cannot apply)
  bool measure = false;           ///< report the distance from the input's vertices to the base mesh
  bool quiet = false;
};

/// `varmesh pm query`: a selectively refined mesh of a .vmh hierarchy under one of the three schemes.
struct PmQueryArgs : ViewQueryArgs {
  std::string scheme = "kim-lee";  ///< kim-lee | hoppe97 | xia-varshney
};

void add_build_options(CLI::App& sub, BuildArgs& args);
void add_query_options(CLI::App& sub, QueryArgs& args);
void add_pm_build_options(CLI::App& sub, PmBuildArgs& args);
void add_pm_query_options(CLI::App& sub, PmQueryArgs& args);
int run_build(const BuildArgs& args);
/// `varmesh info` on a .vmh or .vrm file (told by its magic): loads it (with the loader's checks) and prints
/// a summary. Returns false, printing nothing, when the file is not a hierarchy file (or cannot be opened):
/// the caller then reads it as a mesh. Throws IoError for a hierarchy file the loader rejects.
bool print_hierarchy_info(const std::string& path);
int run_pm_build(const PmBuildArgs& args);
int run_pm_query(const PmQueryArgs& args);
int run_query(const QueryArgs& args);

}  // namespace varmesh::app
