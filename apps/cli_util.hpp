#pragma once
// Small helpers shared by the subcommands: counts in words, parsing "x,y,z" lists, timing, progress on stderr.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "multitri/tri_mesh.hpp"
#include "pm/qem_analysis.hpp"

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace varmesh::app {

/// `n` and `noun` in the number that agrees with n: "1 triangle", "0 triangles", "2 triangles". Only the last
/// word of `noun` changes ("binary step" -> "binary steps", "vertex copy" -> "vertex copies"), by the rules
/// the commands' nouns need: vertex -> vertices, leaf -> leaves, a consonant and y -> ies, s, x, z, ch and sh
/// -> es, else an s. `noun` is the singular, in lower case.
std::string count_noun(std::uint64_t n, std::string_view noun);
/// The noun alone, in the number that agrees with n ("triangle" for 1, "triangles" otherwise).
std::string noun_for(std::uint64_t n, std::string_view noun);

/// Parses comma-separated numbers; throws InvalidInput naming the option on a bad list or count.
std::vector<float> parse_floats(const std::string& text, const std::string& option, std::size_t count);
glm::vec3 parse_vec3(const std::string& text, const std::string& option);
/// A direction "x,y,z" (--up, --view) as a unit vector, normalized in double so that any finite non-zero
/// input is one (3e19,0,0 squares past float's range; 1e-30,0,0 squares to zero in float). Throws
/// InvalidInput "<option>: the direction is zero" for 0,0,0, and as parse_floats.
glm::vec3 parse_direction(const std::string& text, const std::string& option);

/// The criteria of `--error E` (given unless negative, so that NaN is rejected rather than taken for "not
/// given"; object units) and `--camera ex,ey,ez,tx,ty,tz,fov` (non-empty: frustum, back faces and `pixels` of
/// screen-space error on a `viewport`-pixel-high image), appended to `parts`. Throws InvalidInput naming the
/// option on a non-finite error, a bad camera or non-positive sizes.
void add_error_and_camera_criteria(float error, const std::string& camera, float pixels, float viewport,
                                   std::vector<Criterion>& parts);

/// `--cost` of the commands that build a vertex hierarchy: quadric (the default: quadric order,
/// volume-preserving placement), quadric-plain (QemOptions::preserve_volume = false) or lindstrom-turk.
/// Throws InvalidInput naming the option on anything else.
void parse_collapse_cost(const std::string& text, CollapseCost& cost, bool& preserve_volume);

/// A mesh file name: the extension .obj, .off or .ply, in any case (as read_mesh and write_mesh take them).
bool is_mesh_file(const std::string& path);
/// The extension of `path` with its dot, in lower case (".obj" for "a/B.OBJ"; empty when there is none).
std::string lower_extension(const std::string& path);
/// Output-name checks made before any work, so that a wrong name costs nothing and writes nothing. Throw
/// InvalidInput "<command>: <option> must end in ..., not '<path>'". require_png accepts an empty path (no
/// picture asked for).
void require_mesh_output(const std::string& path, const char* command, const char* option = "-o");
void require_png(const std::string& path, const char* command, const char* option = "--png");

/// Validators for CLI11's Option::check: "" when `text` is a number >= 0 (resp. > 0), else a message. NaN
/// passes both: the commands reject it themselves, naming the option.
std::string check_non_negative(const std::string& text);
std::string check_positive(const std::string& text);
/// Validator of counts (--budget, --faces): "" when `text` is an integer >= 0 that fits 64 bits, else a
/// message ("must be an integer >= 0, not -1"; CLI11's NonNegativeNumber printed DBL_MAX in 309 digits).
std::string check_count(const std::string& text);
/// Validators of string options whose empty value would read as "not given": "" unless `text` is empty
/// ("empty file name" for files and folders, "empty value" for the rest).
std::string check_file_name(const std::string& text);
std::string check_not_empty(const std::string& text);

/// `--raw-size W,H` (two integers in 1..2^28) of the height field `path` into `options`. Throws InvalidInput
/// naming the option when it is malformed or out of range, given for a file that is not a raw height field
/// (.raw, .f32, any case; it would be ignored), or missing (`text` empty) for one that is.
void apply_raw_size(const std::string& text, const std::string& path, HeightFieldReadOptions& options);

/// read_heightfield(path, options) with the samples `spacing` apart, and the checks that name the user's file
/// or option rather than an internal function: Terrain-RGB decoding of a file that is not a PNG, a z_scale
/// (--z-scale) that makes a sample infinite, and coordinates that span more than about 1.8e19 (the limit of
/// read_input_mesh: the bounding box's diagonal overflows float, and the tool could not read its own output),
/// blamed on the file's heights, on --z-scale (options.z_scale != 1) or on --spacing (spacing != 1).
/// Throws IoError naming the file, or InvalidInput naming the option.
HeightField read_checked_heightfield(const std::string& path, const HeightFieldReadOptions& options, float spacing = 1.0f);

/// Output checks made before any work. check_output_file: resolve_output_path (multitri/file_util.hpp): a
/// folder, FIFO, device or socket at `path` is refused with IoError naming it. refuse_same_file: InvalidInput
/// when writing `output` would replace the input `input`: the same file by std::filesystem::equivalent when
/// both exist (links and hard links included), else the same normalized absolute path; the message names both
/// (`output_what` and `input_what` say which options they are, e.g. "--png", "the input").
void check_output_file(const std::string& path);
void refuse_same_file(const std::string& input, const std::string& input_what, const std::string& output,
                      const std::string& output_what);
/// --pixels and --viewport of a command with --camera (screen-space error in pixels, viewport height),
/// both needing `camera`, with option texts (CLI11's "FLOAT Needs: --camera" ran into the descriptions).
void add_screen_error_options(CLI::App& sub, float& pixels, float& viewport, CLI::Option* camera);

/// InvalidInput when two outputs of one command are the same file (symbolic links followed, as the writers
/// do; hard links by std::filesystem::equivalent): the second would replace the first. Names both options.
void refuse_same_output(const std::string& first, const std::string& first_what, const std::string& second,
                        const std::string& second_what);
/// True when `inner` is `outer` or lies inside the folder `outer` (normalized absolute paths, links in the
/// existing part resolved).
bool path_within(const std::string& inner, const std::string& outer);

/// The pictures' --up and --view, checked before any work: three numbers each, --view not zero.
void check_picture_axes(const std::string& up, const std::string& view);

/// read_mesh(), and an IoError naming the file when the coordinates span more than float can measure (the
/// bounding box's diagonal overflows, e.g. coordinates near +-3.4e38): every edge length, normal and
/// bounding sphere downstream would be infinite. read_mesh() itself keeps such files (it round-trips any
/// finite float); the commands that compute geometry read through this.
TriMesh read_input_mesh(const std::string& path, ReadInfo* info = nullptr);

/// The same, for a file's contents already in memory (a member of an archive); `name` gives the format and
/// names the file in errors.
TriMesh read_input_mesh_data(const std::string& name, std::string_view data);

/// Writes `mesh` to `mesh_path` and `picture` (when not null) to `png_path`, both or neither: the mesh is
/// staged under a temporary name and moved into place after the picture is written, so a failed run leaves
/// both paths as they were (an existing file included). Rethrows the error, naming the user's path.
void write_mesh_and_picture(const std::string& mesh_path, const TriMesh& mesh, const std::string& png_path,
                            const Image* picture);

/// Writes the file `target` and what goes with it, all or nothing: write(staged) writes the file under a
/// temporary name beside the file replaced (resolve_output_path: a symbolic link's target, so the link stays;
/// same folder, so the rename stays within one file system; the extension of `target`, since writers pick
/// the format by it; hidden, with the pid), then then_() writes the rest (pictures), then the file is
/// renamed into place. `target` naming a folder, FIFO, device or socket is refused before anything is
/// written. On any failure the staged file is removed and `target` is left as it was (an existing file
/// included); an IoError of write() is rethrown naming `target`, not the staging name.
void write_staged(const std::string& target, const std::function<void(const std::string& staged)>& write,
                  const std::function<void()>& then_);

/// An output folder written all or nothing: files go to a staging folder inside it (path(), a fresh name
/// per object) and are moved into the folder by commit(). Without commit() - an exception on the way - the
/// destructor removes the staging folder and the folders this object created (the output folder and
/// missing parents), so the folder is left as it was, files of earlier runs included. commit() first checks
/// every target by the policy of resolve_output_path (a folder, FIFO, device or socket is refused; a
/// symbolic link is written through, its target replaced) and copies the files bound for links beside their
/// targets; a rename that still fails (e.g. a target owned by another user in a sticky folder) throws with
/// the files moved so far in place. Throws IoError naming the folder when it cannot be created or exists as
/// something else than a folder. check_targets() makes commit()'s checks before any work, for names known
/// in advance.
class StagedFolder {
 public:
  explicit StagedFolder(const std::string& folder);
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  /// Where to write `name` now; the name is remembered for commit().
  std::string path(const std::string& name);
  void commit();
  /// Throws IoError when `folder` exists and is not a folder (or a link to one), or when one of `names` in
  /// it could not be replaced by a file (see resolve_output_path). Creates nothing.
  static void check_targets(const std::string& folder, const std::vector<std::string>& names);
  /// The user's name for `path`: a path inside the staging folder of any StagedFolder of this process
  /// (live or gone) is mapped to the same name in its output folder; any other path is returned as it is.
  /// The command line's error handler maps the file of an IoError through it, so that a failed write names
  /// the final path, not the staging one.
  static std::string user_path(const std::string& path);

 private:
  std::string folder_, stage_;
  std::vector<std::string> made_, names_;
  bool committed_ = false;
  // Its entries in InterruptCleanup: the folders it made, the staging folder and the files written there
  // (an interrupted command leaves none of them), forgotten once committed or removed.
  std::vector<int> cleanup_;
  void forget_cleanup();
};

/// Wall-clock stopwatch in milliseconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double ms() const { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Announces a step on stderr and, when it took more than a second, how long it took. A step left by an
/// exception is remembered (the innermost one): failed() names it, for the error handler ("out of memory
/// while building the 4-8 hierarchy"); null when no step failed.
class Step {
 public:
  Step(const char* what, bool quiet);
  ~Step();
  Step(const Step&) = delete;
  Step& operator=(const Step&) = delete;
  double ms() const { return watch_.ms(); }
  static const char* failed();

 private:
  const char* what_;
  bool quiet_;
  int exceptions_;  ///< std::uncaught_exceptions() at construction
  Stopwatch watch_;
};

}  // namespace varmesh::app
