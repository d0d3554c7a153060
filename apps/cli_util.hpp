#pragma once
// Small helpers shared by the subcommands: parsing "x,y,z" lists, timing, progress on stderr.
#include <chrono>
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

namespace varmesh::app {

/// Parses comma-separated numbers; throws InvalidInput naming the option on a bad list or count.
std::vector<float> parse_floats(const std::string& text, const std::string& option, std::size_t count);
glm::vec3 parse_vec3(const std::string& text, const std::string& option);

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

/// `--raw-size W,H` (two positive integers) of the height field `path` into `options`; nothing when `text` is
/// empty. Throws InvalidInput naming the option when it is malformed, or given for a file that is not a raw
/// height field (.raw, .f32, any case), where it would be ignored.
void apply_raw_size(const std::string& text, const std::string& path, HeightFieldReadOptions& options);

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
/// temporary name beside `target` (same folder, so the rename stays within one file system; same extension,
/// since writers pick the format by it; hidden, with the pid), then then_() writes the rest (pictures), then
/// the file is renamed into place. `target` naming a folder is refused before anything is written. On any
/// failure the staged file is removed and `target` is left as it was (an existing file included); an
/// IoError of write() is rethrown naming `target`, not the staging name.
void write_staged(const std::string& target, const std::function<void(const std::string& staged)>& write,
                  const std::function<void()>& then_);

/// An output folder written all or nothing: files go to a staging folder inside it (path(), a fresh name
/// per object) and are moved into the folder by commit(). Without commit() - an exception on the way - the
/// destructor removes the staging folder and the folders this object created (the output folder and
/// missing parents), so the folder is left as it was, files of earlier runs included. commit() first checks
/// that no target is a folder; a rename that still fails (e.g. a target owned by another user in a sticky
/// folder) throws with the files moved so far in place. Throws IoError naming the folder when it cannot be
/// created.
class StagedFolder {
 public:
  explicit StagedFolder(const std::string& folder);
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  /// Where to write `name` now; the name is remembered for commit().
  std::string path(const std::string& name);
  void commit();

 private:
  std::string folder_, stage_;
  std::vector<std::string> made_, names_;
  bool committed_ = false;
};

/// Wall-clock stopwatch in milliseconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double ms() const { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Announces a step on stderr and, when it took more than a second, how long it took.
class Step {
 public:
  Step(const char* what, bool quiet);
  ~Step();
  Step(const Step&) = delete;
  Step& operator=(const Step&) = delete;
  double ms() const { return watch_.ms(); }

 private:
  const char* what_;
  bool quiet_;
  Stopwatch watch_;
};

}  // namespace varmesh::app
