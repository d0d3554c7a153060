#pragma once
// `varmesh compare`: the experiments of Kim-Lee 2001 Table 2 (Figures 8-10) on one vertex hierarchy per
// case, refined under the three dependency rules of pm/sr_mesh.hpp (Xia-Varshney 1996, Hoppe 1997,
// Kim-Lee 2001):
// - image: a 2D regular mesh with a vertex per pixel and colour quadrics (GH98), refined until every Sobel
//   feature pixel is a vertex of the mesh;
// - terrain: a 2.5D grid refined wherever a node's bounding sphere meets a view frustum;
// - bunny, cow, dragon: 3D models refined where the sphere meets a frustum and the normal cone is not
//   entirely back-facing.
// It prints the table (#V, #F, #DC, forced vsplits and ecols, time), checks kim-lee <= hoppe97 <=
// xia-varshney in #V and #F per case, and writes table.md, table.csv, compare_notes.md and PNG pictures
// (<case>_schemes.png side by side, <case>_dual_pieces.png, image_features.png) into the output folder.
// Missing data files are replaced by packaged or generated inputs (said in the output), so the command runs
// without the data folder; an environment variable that names nothing is an error (run_compare).
#include <string>

namespace CLI { class App; }

namespace varmesh::app {

struct CompareArgs {
  std::string out_dir = "varmesh_compare";
  std::string cases = "image,terrain,bunny,cow,dragon";
  /// Data folder; empty: $VARMESH_DATA when set (it must then name a folder), else ../shared/data (relative
  /// to the working directory, used when it is there). $VARMESH_PACKAGED_MESHES names the archive of the
  /// packaged cow and bunny ("none": no archive); when set, it must name a readable file.
  std::string data_dir;
  std::string image;                     ///< image file for the image case (default: images/peppers_256_gray.png)
  std::string feature_fraction = "0.05"; ///< fraction of pixels kept as Sobel feature points, in (0, 1]
  std::string grid_size;                 ///< side of the image and terrain grids (default 128, --quick 64)
  std::string panel = "400";             ///< side of one picture panel in pixels
  /// Collapse order and placement of the analysis: "quadric" (Garland-Heckbert, the default) or
  /// "lindstrom-turk" (pm/qem_analysis.hpp CollapseCost; the image case's colour quadrics stay GH).
  std::string cost = "quadric";
  bool quick = false;                    ///< small inputs: a fast run
  bool quiet = false;                    ///< no progress on stderr
};

/// Registers the subcommand's options on `sub`.
void add_compare_options(CLI::App& sub, CompareArgs& args);
/// Runs it; returns the process exit status: 0, or 3 when a mesh fails SrMesh::validate() or the kim-lee or
/// hoppe97 result misses a required vertex (a xia-varshney dependency cycle that leaves some out is reported
/// in the "missing" row and compare_notes.md, not as a failure). The expected ordering failing is reported,
/// not a failure either. Throws InvalidInput on bad options (and on $VARMESH_DATA or $VARMESH_PACKAGED_MESHES
/// set to something that is not there) and IoError on unreadable files (the caller prints); nothing is
/// written before the options are checked.
int run_compare(const CompareArgs& args);

}  // namespace varmesh::app
