#include "apps/commands.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <glm/mat4x4.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "apps/cli_util.hpp"
#include "apps/compare.hpp"
#include "apps/demo.hpp"
#include "apps/hierarchy_cmds.hpp"
#include "apps/render.hpp"
#include "apps/subdiv_cmd.hpp"
#include "fourk/grid48.hpp"
#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/query.hpp"

namespace varmesh::app {

std::string noun_for(std::uint64_t n, std::string_view noun) {
  std::string s(noun);
  if (n == 1 || s.empty()) return s;
  const std::size_t start = s.find_last_of(' ') + 1;  // npos + 1 = 0: a single word
  const std::string_view last = std::string_view(s).substr(start);
  auto ends_with = [&last](std::string_view tail) {
    return last.size() >= tail.size() && last.compare(last.size() - tail.size(), tail.size(), tail) == 0;
  };
  const auto is_vowel = [](char c) { return c == 'a' || c == 'e' || c == 'i' || c == 'o' || c == 'u'; };
  if (last == "vertex") return s.substr(0, start) + "vertices";
  if (last == "leaf") return s.substr(0, start) + "leaves";
  if (last.size() >= 2 && last.back() == 'y' && !is_vowel(last[last.size() - 2])) return s.substr(0, s.size() - 1) + "ies";
  if (ends_with("s") || ends_with("x") || ends_with("z") || ends_with("ch") || ends_with("sh")) return s + "es";
  return s + "s";
}

std::string count_noun(std::uint64_t n, std::string_view noun) { return std::to_string(n) + " " + noun_for(n, noun); }

std::vector<float> parse_floats(const std::string& text, const std::string& option, std::size_t count) {
  std::vector<float> out;
  const char* p = text.data();
  const char* end = p + text.size();
  while (p < end) {
    float v = 0.0f;
    auto [next, ec] = std::from_chars(p, end, v);
    if (ec != std::errc() || !std::isfinite(v))
      throw InvalidInput(option + ": '" + text + "' is not a comma-separated list of numbers");
    out.push_back(v);
    p = next;
    if (p < end) {
      if (*p != ',') throw InvalidInput(option + ": expected ',' in '" + text + "'");
      ++p;
    }
  }
  if (out.size() != count)
    throw InvalidInput(option + ": expected " + std::to_string(count) + " numbers, got " + std::to_string(out.size()));
  return out;
}

glm::vec3 parse_vec3(const std::string& text, const std::string& option) {
  const auto v = parse_floats(text, option, 3);
  return {v[0], v[1], v[2]};
}

glm::vec3 parse_direction(const std::string& text, const std::string& option) {
  const glm::dvec3 v(parse_vec3(text, option));
  const double length = glm::length(v);
  if (!(length > 0.0)) throw InvalidInput(option + ": the direction is zero");
  return glm::vec3(v / length);
}

void add_error_and_camera_criteria(float error, const std::string& camera, float pixels, float viewport,
                                   std::vector<Criterion>& parts) {
  if (!(error < 0.0f)) {  // NaN counts as given: it must not pass for "no --error"
    if (!std::isfinite(error)) throw InvalidInput("--error must be finite");
    parts.push_back(Criterion::object_error(error));
  }
  if (camera.empty()) return;
  const auto c = parse_floats(camera, "--camera", 7);
  Camera cam;
  cam.eye = {c[0], c[1], c[2]};
  cam.target = {c[3], c[4], c[5]};
  cam.fov_y_deg = c[6];
  if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f))
    throw InvalidInput("--camera: the field of view must be in (0, 180) degrees");
  if (cam.eye == cam.target) throw InvalidInput("--camera: eye and target coincide");
  if (!(pixels > 0.0f) || !(viewport > 0.0f)) throw InvalidInput("--pixels and --viewport must be > 0");
  // Both planes relative to the viewing distance: an absolute far plane (1e7) culled every node of a model
  // in large units (a bunny scaled by 1e9 came back as its base mesh), and at small scales the far/near
  // ratio lost the frustum's precision. The far plane is meant to cull nothing.
  const float distance = glm::length(cam.eye - cam.target);
  cam.z_near = 1e-4f * distance;
  cam.z_far = 1e8f * distance;
  if (!std::isfinite(cam.z_far)) throw InvalidInput("--camera: eye and target are too far apart");
  // Distinct points whose distance squares to zero in float (1e-30 apart): the near plane would be 0.
  if (!(cam.z_near > 0.0f)) throw InvalidInput("--camera: eye and target are too close together");
  parts.push_back(Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                     Criterion::screen_error(cam, viewport, pixels)}));
}

void parse_collapse_cost(const std::string& text, CollapseCost& cost, bool& preserve_volume) {
  cost = CollapseCost::kQuadric;
  preserve_volume = true;
  if (text == "quadric-plain") preserve_volume = false;
  else if (text == "lindstrom-turk") cost = CollapseCost::kLindstromTurk;
  else if (text != "quadric") throw InvalidInput("--cost: unknown '" + text + "' (known: quadric, quadric-plain, lindstrom-turk)");
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

bool is_mesh_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".obj" || ext == ".off" || ext == ".ply";
}

void require_mesh_output(const std::string& path, const char* command, const char* option) {
  if (!is_mesh_file(path))
    throw InvalidInput(std::string(command) + ": " + option + " must end in .obj, .ply or .off, not '" + path + "'");
  check_output_file(path);
}

void require_png(const std::string& path, const char* command, const char* option) {
  if (!path.empty() && lower_extension(path) != ".png")
    throw InvalidInput(std::string(command) + ": " + option + " must end in .png, not '" + path + "'");
  check_output_file(path);
}

namespace {
std::string check_sign(const std::string& text, bool zero_ok) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') return "'" + text + "' is not a number";
  if (std::isnan(v)) return "";  // named by the command, with what it means there
  // The options are floats: a value past FLT_MAX (1e39) would become inf when CLI11 stores it.
  if (std::isinf(v) || std::abs(v) > double(std::numeric_limits<float>::max())) return "must be a finite number, not " + text;
  if (zero_ok ? v < 0.0 : !(v > 0.0)) return std::string("must be ") + (zero_ok ? ">= 0" : "> 0") + ", not " + text;
  return "";
}
}  // namespace

std::string check_non_negative(const std::string& text) { return check_sign(text, true); }
std::string check_positive(const std::string& text) { return check_sign(text, false); }

std::string check_count(const std::string& text) {
  std::uint64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [next, ec] = std::from_chars(text.data(), end, v);
  if (ec == std::errc::result_out_of_range) return "must be an integer below 2^64, not " + text;
  if (ec != std::errc() || next != end) return "must be an integer >= 0, not '" + text + "'";
  return "";
}

std::string check_file_name(const std::string& text) { return text.empty() ? "empty file name" : ""; }
std::string check_not_empty(const std::string& text) { return text.empty() ? "empty value" : ""; }

namespace {

// Each side of a raw height field: the reader's limit on the sample count (2^28) bounds both.
constexpr std::uint64_t kMaxRawSide = std::uint64_t{1} << 28;

// A positive integer of at most kMaxRawSide written in decimal digits only; 0 when it is not one.
std::uint64_t parse_side(std::string_view text) {
  std::uint64_t v = 0;
  const auto [next, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec == std::errc::result_out_of_range) return kMaxRawSide + 1;
  return ec == std::errc() && next == text.data() + text.size() ? v : 0;
}

std::string format_g(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

}  // namespace

void apply_raw_size(const std::string& text, const std::string& path, HeightFieldReadOptions& options) {
  const std::string ext = lower_extension(path);
  const bool raw = ext == ".raw" || ext == ".f32";
  if (text.empty()) {
    if (raw) throw InvalidInput("'" + path + "' is a headerless float32 height field: give its size with --raw-size W,H");
    return;
  }
  if (!raw) throw InvalidInput("--raw-size is for a .raw or .f32 height field, not '" + path + "'");
  // Integers, not floats: a float holds 16777217 as 16777216, and casting 1e20 to size_t is undefined.
  const std::size_t comma = text.find(',');
  const std::string_view t(text);
  const std::uint64_t w = comma == std::string::npos ? 0 : parse_side(t.substr(0, comma));
  const std::uint64_t h = comma == std::string::npos ? 0 : parse_side(t.substr(comma + 1));
  if (w == 0 || h == 0) throw InvalidInput("--raw-size: expected two positive integers W,H, not '" + text + "'");
  if (w > kMaxRawSide || h > kMaxRawSide)
    throw InvalidInput("--raw-size: W and H must be at most " + std::to_string(kMaxRawSide) + " (2^28 samples in all), not '" + text + "'");
  options.raw_width = static_cast<std::size_t>(w);
  options.raw_height = static_cast<std::size_t>(h);
}

HeightField read_checked_heightfield(const std::string& path, const HeightFieldReadOptions& options, float spacing) {
  if (options.decoding == PixelDecoding::kTerrainRgb && lower_extension(path) != ".png")
    throw InvalidInput("--terrain-rgb decodes PNG pictures only, not '" + path + "'");
  if (!std::isfinite(options.z_scale)) throw InvalidInput("--z-scale must be a finite number");
  if (!(spacing > 0.0f) || !std::isfinite(spacing)) throw InvalidInput("--spacing must be finite and > 0");
  HeightField field;
  try {
    field = read_heightfield(path, options);
  } catch (const InvalidInput&) {
    // The options are checked above: what is left is a z_scale that overflows a sample (read_heightfield's
    // contract).
    throw InvalidInput("--z-scale " + format_g(options.z_scale) + " makes heights of '" + path +
                       "' overflow float (more than 3.4e38)");
  }
  field.spacing_x = field.spacing_y = spacing;
  // The mesh spans at most the field's box. Its diagonal must be measurable in float, as read_input_mesh
  // demands of every mesh (with a margin for the rounding of positions): else the tool could not read back
  // what it writes, and the builders fail on infinite radii.
  const auto [lo, hi] = std::minmax_element(field.z.begin(), field.z.end());
  const double dz = double(*hi) - double(*lo);
  const double dx = double(field.width - 1) * double(spacing), dy = double(field.height - 1) * double(spacing);
  const double limit = 0.999 * double(std::numeric_limits<float>::max());
  auto too_big = [limit](double x, double y, double z) { return !(x * x + y * y + z * z <= limit); };
  if (!too_big(dx, dy, dz)) return field;
  const std::string tail = ", more than about 1.8e19: squared distances overflow float (the bounding box's diagonal "
                           "cannot be measured, and varmesh could not read the mesh back)";
  const std::string heights = "the heights span " + format_g(dz);
  if (too_big(0.0, 0.0, dz)) {
    if (options.z_scale == 1.0f) throw IoError(path, heights + tail + "; scale them down");
    throw InvalidInput("--z-scale " + format_g(options.z_scale) + ": " + heights + " in '" + path + "'" + tail);
  }
  const std::string diagonal = "the terrain's bounding box is " + format_g(std::sqrt(dx * dx + dy * dy + dz * dz)) +
                               " across (" + std::to_string(field.width) + " x " + std::to_string(field.height) +
                               " samples " + format_g(spacing) + " apart";
  if (too_big(dx, dy, 0.0)) throw InvalidInput("--spacing " + format_g(spacing) + ": " + diagonal + ")" + tail);
  throw InvalidInput("--spacing " + format_g(spacing) +
                     (options.z_scale != 1.0f ? " and --z-scale " + format_g(options.z_scale) : "") + ": " + diagonal +
                     ", " + heights + " in '" + path + "')" + tail);
}

namespace {

// The path compared when a file does not exist: absolute, normalized, links in its existing part resolved.
std::filesystem::path comparable_path(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec);
  if (ec) return fs::path(path).lexically_normal();
  const fs::path canonical = fs::weakly_canonical(abs, ec);
  return ec ? abs.lexically_normal() : canonical.lexically_normal();
}

}  // namespace

void check_output_file(const std::string& path) {
  namespace fs = std::filesystem;
  if (path.empty()) return;
  // The file itself (links followed), then the folder it goes in: a missing folder was found only when
  // the result was written, after all the work (seconds on the full dragon).
  const fs::path target = resolve_output_path(path);
  const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  const fs::file_status st = fs::status(folder, ec);
  if (!fs::exists(st))
    throw IoError(path, "its folder '" + folder.string() + "' does not exist: make it first (nothing was written)");
  if (!fs::is_directory(st)) throw IoError(path, "'" + folder.string() + "' is not a folder (nothing was written)");
}

namespace {

// The same file by std::filesystem::equivalent when both exist (links and hard links included), else the
// same normalized absolute path.
bool same_file(const std::string& x, const std::string& y) {
  namespace fs = std::filesystem;
  std::error_code ec1, ec2, ec3;
  const bool both = fs::exists(x, ec1) && fs::exists(y, ec2);
  return both ? fs::equivalent(x, y, ec3) : comparable_path(x) == comparable_path(y);
}

}  // namespace

void add_screen_error_options(CLI::App& sub, float& pixels, float& viewport, CLI::Option* camera) {
  sub.add_option("--pixels", pixels, "with --camera: screen-space error in pixels (default 1)")
      ->option_text("PIXELS")
      ->check(check_positive)
      ->needs(camera);
  sub.add_option("--viewport", viewport, "with --camera: viewport height in pixels (default 1080)")
      ->option_text("PIXELS")
      ->check(check_positive)
      ->needs(camera);
}

void refuse_same_output(const std::string& first, const std::string& first_what, const std::string& second,
                        const std::string& second_what) {
  if (first.empty() || second.empty()) return;
  // Links are written through (resolve_output_path), so two links to one new file are one output.
  if (same_file(resolve_output_path(first).string(), resolve_output_path(second).string()))
    throw InvalidInput(first_what + " '" + first + "' and " + second_what + " '" + second +
                       "' are the same file: one output would overwrite the other; choose another name");
}

void refuse_same_file(const std::string& input, const std::string& input_what, const std::string& output,
                      const std::string& output_what) {
  if (input.empty() || output.empty()) return;
  if (same_file(input, output))
    throw InvalidInput(output_what + " '" + output + "' is the same file as " + input_what + " '" + input +
                       "': writing it would destroy the input; choose another name");
}

bool path_within(const std::string& inner, const std::string& outer) {
  std::filesystem::path i = comparable_path(inner), o = comparable_path(outer);
  if (i.filename().empty()) i = i.parent_path();  // a trailing separator
  if (o.filename().empty()) o = o.parent_path();
  return std::mismatch(i.begin(), i.end(), o.begin(), o.end()).second == o.end();
}

void check_picture_axes(const std::string& up, const std::string& view) {
  if (!up.empty()) parse_direction(up, "--up");
  if (!view.empty()) parse_direction(view, "--view");
}

namespace {

TriMesh checked_extent(TriMesh mesh, const std::string& path) {
  Box3 box;
  for (Index i : mesh.indices) box.add(mesh.positions[i]);
  if (!std::isfinite(box.diagonal()))
    throw IoError(path, "the coordinates span more than about 1.8e19: squared distances overflow float (the "
                        "bounding box's diagonal cannot be measured); scale the model down");
  return mesh;
}

}  // namespace

TriMesh read_input_mesh(const std::string& path, ReadInfo* info) { return checked_extent(read_mesh(path, info), path); }

TriMesh read_input_mesh_data(const std::string& name, std::string_view data) {
  return checked_extent(read_mesh_data(name, data), name);
}

void write_staged(const std::string& target, const std::function<void(const std::string& staged)>& write,
                  const std::function<void()>& then_) {
  namespace fs = std::filesystem;
  // Checked first: the rename at the end would fail (a folder) or replace a FIFO or device after the rest
  // (the pictures) had been written. A symbolic link is written through: the file staged beside its target.
  const fs::path t = resolve_output_path(target);
  const std::string suffix = ".partial-" + std::to_string(::getpid()) + fs::path(target).extension().string();
  const fs::path staged = t.parent_path() / bounded_file_name(".", t.stem().string(), suffix);
  std::error_code ec;
  try {
    write(staged.string());
  } catch (const IoError& e) {
    fs::remove(staged, ec);
    throw IoError(target, e.reason());  // the user's name, not the staging one
  } catch (...) {
    fs::remove(staged, ec);
    throw;
  }
  try {
    then_();
  } catch (...) {
    fs::remove(staged, ec);
    throw;
  }
  fs::rename(staged, t, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(staged, ec);
    throw IoError(target, "cannot move the written file into place: " + why);
  }
}

void write_mesh_and_picture(const std::string& mesh_path, const TriMesh& mesh, const std::string& png_path,
                            const Image* picture) {
  if (!picture) {
    write_mesh(mesh_path, mesh);
    return;
  }
  // The mesh is moved into place after the picture is written: a picture that cannot be written leaves
  // whatever was at mesh_path as it was (removing the new mesh instead had deleted a file the user had).
  write_staged(mesh_path, [&](const std::string& staged) { write_mesh(staged, mesh); },
               [&] { write_png(png_path, *picture); });
}

namespace {

// Every staging folder of this process and its output folder, for StagedFolder::user_path (kept after the
// object is gone: the error handler runs once the stack has unwound).
std::vector<std::pair<std::string, std::string>>& staging_folders() {
  static std::vector<std::pair<std::string, std::string>> folders;
  return folders;
}

}  // namespace

void StagedFolder::check_targets(const std::string& folder, const std::vector<std::string>& names) {
  namespace fs = std::filesystem;
  if (folder.empty()) throw InvalidInput("the output folder's name is empty");
  std::error_code ec;
  const fs::file_status st = fs::status(folder, ec);  // a link to a folder is a folder
  if (fs::exists(st) && !fs::is_directory(st)) throw IoError(folder, "exists and is not a folder: the files cannot be put in it");
  if (!fs::exists(st) && fs::is_symlink(fs::symlink_status(folder, ec)))
    throw IoError(folder, "is a symbolic link to nothing: make the folder it points to first");
  for (const std::string& name : names) resolve_output_path((fs::path(folder) / name).string());
}

StagedFolder::StagedFolder(const std::string& folder) : folder_(folder) {
  namespace fs = std::filesystem;
  check_targets(folder, {});
  std::error_code ec;
  // symlink_status: a dangling link is the user's, not a folder to make (or to take back).
  for (fs::path p = fs::absolute(folder).lexically_normal(); !p.empty(); p = p.parent_path()) {
    if (fs::exists(fs::symlink_status(p, ec))) break;
    made_.push_back(p.string());
    if (p == p.parent_path()) break;
  }
  try {
    fs::create_directories(folder);
    // A name no one else uses: a folder left by a killed run (same pid in a container) is not ours to fill
    // or to remove.
    const unsigned long long salt =
        static_cast<unsigned long long>(std::chrono::steady_clock::now().time_since_epoch().count());
    for (unsigned attempt = 0; stage_.empty(); ++attempt) {
      const fs::path p = fs::path(folder) / (".varmesh-partial-" + std::to_string(::getpid()) + "-" +
                                             std::to_string((salt + attempt) % 1000000007ull));
      if (fs::create_directory(p)) stage_ = p.string();
      else if (attempt > 100) throw IoError(folder, "cannot make a staging folder in it");
    }
  } catch (const fs::filesystem_error& e) {
    for (const std::string& p : made_) fs::remove(p, ec);
    throw IoError(folder, e.code().message());
  }
  for (const std::string& p : made_) cleanup_.push_back(InterruptCleanup::add(p, true));
  cleanup_.push_back(InterruptCleanup::add(stage_, true));
  staging_folders().emplace_back(stage_, folder_);
}

StagedFolder::~StagedFolder() {
  if (committed_) return;
  std::error_code ec;
  if (!stage_.empty()) std::filesystem::remove_all(stage_, ec);
  for (const std::string& p : made_) std::filesystem::remove(p, ec);  // deepest first; only if empty
  forget_cleanup();
}

void StagedFolder::forget_cleanup() {
  for (const int slot : cleanup_) InterruptCleanup::forget(slot);
  cleanup_.clear();
}

std::string StagedFolder::path(const std::string& name) {
  names_.push_back(name);
  const std::string p = (std::filesystem::path(stage_) / name).string();
  cleanup_.push_back(InterruptCleanup::add(p, false));
  return p;
}

std::string StagedFolder::user_path(const std::string& path) {
  namespace fs = std::filesystem;
  for (const auto& [stage, folder] : staging_folders()) {
    const fs::path rel = fs::path(path).lexically_relative(stage);
    if (rel.empty() || *rel.begin() == "..") continue;
    return rel == "." ? folder : (fs::path(folder) / rel).string();
  }
  return path;
}

void StagedFolder::commit() {
  namespace fs = std::filesystem;
  struct Move {
    fs::path from, to;
    std::string user;     // the user's name of the target
    bool copied = false;  // `from` is a copy beside a link's target, to be removed unless moved
  };
  std::vector<Move> moves;
  auto remove_copies = [&moves](std::size_t first) {
    std::error_code ec;
    for (std::size_t i = first; i < moves.size(); ++i)
      if (moves[i].copied) fs::remove(moves[i].from, ec);
  };
  // What would stop a move is looked for before the first move, so that nothing is moved when one cannot be.
  try {
    for (const std::string& name : names_) {
      Move m{fs::path(stage_) / name, {}, (fs::path(folder_) / name).string()};
      m.to = resolve_output_path(m.user);  // a folder, FIFO, device, socket: refused
      if (m.to != fs::path(m.user)) {
        // A symbolic link, written through. Its target may lie on another file system than the staging
        // folder: the file is copied beside it first, and renamed onto it with the others.
        const std::string suffix = ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(moves.size());
        const fs::path copy = m.to.parent_path() / bounded_file_name(".", m.to.filename().string(), suffix);
        std::error_code ec;
        fs::copy_file(m.from, copy, fs::copy_options::overwrite_existing, ec);
        if (ec) {
          const std::string why = ec.message();
          fs::remove(copy, ec);
          throw IoError(m.user, "cannot write beside the symbolic link's target " + m.to.string() + ": " + why);
        }
        cleanup_.push_back(InterruptCleanup::add(copy.string(), false));
        m.from = copy;
        m.copied = true;
      }
      moves.push_back(std::move(m));
    }
  } catch (...) {
    remove_copies(0);
    throw;
  }
  for (std::size_t i = 0; i < moves.size(); ++i) {
    std::error_code ec;
    fs::rename(moves[i].from, moves[i].to, ec);
    if (ec) {
      remove_copies(i);
      throw IoError(moves[i].user, "cannot move the written file into place: " + ec.message());
    }
  }
  std::error_code ec;
  fs::remove_all(stage_, ec);  // the files copied to links' targets are still in it
  committed_ = true;
  forget_cleanup();
}

namespace {
const char* failed_step = nullptr;
}  // namespace

Step::Step(const char* what, bool quiet) : what_(what), quiet_(quiet), exceptions_(std::uncaught_exceptions()) {
  if (!quiet_) std::fprintf(stderr, "[varmesh] %s ...\n", what_);
}

Step::~Step() {
  // Unwinding: the innermost step is destroyed first and is the one named.
  if (std::uncaught_exceptions() > exceptions_ && !failed_step) failed_step = what_;
  const double t = watch_.ms();
  if (!quiet_ && t > 1000.0 && !failed_step) std::fprintf(stderr, "[varmesh] %s done in %.1f s\n", what_, t / 1000.0);
}

const char* Step::failed() { return failed_step; }

namespace {

int cmd_info(const std::string& path) {
  if (print_hierarchy_info(path)) return 0;
  ReadInfo info;
  const TriMesh mesh = read_mesh(path, &info);
  const MeshReport report = analyze_mesh(mesh);
  std::printf("%s\n%s", path.c_str(), format_report(report).c_str());
  if (info.polygons_triangulated) std::printf("polygons triangulated: %zu\n", info.polygons_triangulated);
  if (info.attribute_conflicts) std::printf("attribute conflicts (first kept): %zu\n", info.attribute_conflicts);
  if (info.strip_degenerates_dropped) std::printf("degenerate strip triangles dropped: %zu\n", info.strip_degenerates_dropped);
  return 0;
}

struct TerrainArgs {
  std::string input, output, png, camera;
  float error = -1.0f;
  float pixels = 1.0f;
  float viewport = 1080.0f;
  std::size_t budget = 0;
  float z_scale = 1.0f;
  float spacing = 1.0f;
  std::string raw_size;
  bool terrain_rgb = false;
  bool flip_rows = false;
  bool fast_bound = false;
  bool measure = false;
  bool quiet = false;
};

int cmd_terrain(const TerrainArgs& a) {
  if (std::isnan(a.error)) throw InvalidInput("terrain: --error must be a number, not NaN");
  if (a.error < 0.0f && a.camera.empty() && a.budget == 0)
    throw InvalidInput("terrain: give --error E, --camera ... or --budget N (or several)");
  require_mesh_output(a.output, "terrain");
  require_png(a.png, "terrain");
  refuse_same_file(a.input, "the input height field", a.output, "-o");
  refuse_same_file(a.input, "the input height field", a.png, "--png");
  refuse_same_output(a.output, "-o", a.png, "--png");
  HeightFieldReadOptions ro;
  ro.decoding = a.terrain_rgb ? PixelDecoding::kTerrainRgb : PixelDecoding::kGray;
  if (!std::isfinite(a.z_scale)) throw InvalidInput("terrain: --z-scale must be a finite number");
  if (!(a.spacing > 0.0f) || !std::isfinite(a.spacing)) throw InvalidInput("terrain: --spacing must be finite and > 0");
  ro.z_scale = a.z_scale;
  apply_raw_size(a.raw_size, a.input, ro);
  // The camera is checked before the work; its planes need the terrain's extent (below).
  Camera cam;
  if (!a.camera.empty()) {
    const auto c = parse_floats(a.camera, "--camera", 7);
    cam.eye = {c[0], c[1], c[2]};
    cam.target = {c[3], c[4], c[5]};
    cam.fov_y_deg = c[6];
    if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f)) throw InvalidInput("--camera: the field of view must be in (0, 180) degrees");
    if (cam.eye == cam.target) throw InvalidInput("--camera: eye and target coincide");
    if (!(a.pixels > 0.0f) || !std::isfinite(a.pixels) || !(a.viewport > 0.0f) || !std::isfinite(a.viewport))
      throw InvalidInput("terrain: --pixels and --viewport must be finite and > 0");
  }
  HeightField field = read_checked_heightfield(a.input, ro, a.spacing);
  if (a.flip_rows)  // the file's first row at the largest y: a north-up map reads right from above, z up
    for (std::size_t r = 0; r < field.height / 2; ++r)
      std::swap_ranges(field.z.begin() + static_cast<std::ptrdiff_t>(r * field.width),
                       field.z.begin() + static_cast<std::ptrdiff_t>((r + 1) * field.width),
                       field.z.begin() + static_cast<std::ptrdiff_t>((field.height - 1 - r) * field.width));
  Grid48Options go;
  go.exact_errors = !a.fast_bound;
  Stopwatch build_watch;
  // The grid's own checks (e.g. fewer than 2 x 2 samples) name no file: add it.
  const Grid48 grid = [&] {
    try {
      return Grid48(field, go);
    } catch (const InvalidInput& e) {
      throw IoError(a.input, e.what());
    }
  }();
  const double build_ms = build_watch.ms();
  Query q;
  std::vector<Criterion> parts;
  if (!a.camera.empty()) {
    // Near and far planes from the terrain's own size (a fixed far plane of 1e7 made the answer depend on
    // the units: the same scene scaled by 1e5 lost triangles).
    const glm::vec3 lo(0.0f, 0.0f, *std::min_element(field.z.begin(), field.z.end()));
    const glm::vec3 hi(float(field.width - 1) * a.spacing, float(field.height - 1) * a.spacing,
                       *std::max_element(field.z.begin(), field.z.end()));
    const float reach = glm::length(cam.eye - 0.5f * (lo + hi)) + glm::length(hi - lo);
    // The terrain's own span is measurable (read_checked_heightfield): only the eye can be this far away.
    if (!std::isfinite(2.0f * reach))
      throw InvalidInput("--camera: the eye is too far from the terrain (" + a.camera + ")");
    // The near plane at most 1e12 times nearer than the far one: beyond that ratio (--spacing 1e-40) the far
    // plane's rows cancel even in double, and the frustum has no far plane.
    cam.z_near = std::max(std::min(0.1f * a.spacing, 1e-3f * reach), 1e-12f * reach);
    cam.z_far = std::max(2.0f * reach, 10.0f * cam.z_near);
    if (!(cam.z_near > 0.0f))
      throw InvalidInput("--camera: the eye and the terrain are too close together to be told apart in float (" +
                         a.camera + ", --spacing " + format_g(a.spacing) + ")");
    parts.push_back(Criterion::outside_frustum(cam.frustum()));
    parts.push_back(Criterion::screen_error(cam, a.viewport, a.pixels));
  }
  if (a.error >= 0.0f) parts.push_back(Criterion::object_error(a.error));
  // --budget alone (as in query and pm query): nothing is fine, the budget is the only limit.
  q.criterion = parts.empty()         ? Criterion::custom([](const ElementBound&) { return false; })
                : parts.size() == 1 ? parts[0]
                                    : Criterion::any_of(parts);
  q.triangle_budget = a.budget;
  Grid48Front front(grid);
  Stopwatch extract_watch;
  TriMesh mesh = front.extract_mesh(q);  // the front and its mesh in one pass where the query allows
  // The budget counts the hierarchy's triangles, and clipping them to the grid's rectangle (a grid that is
  // not 2^k + 1 samples wide) splits some: ask again for less until the clipped mesh fits (528 triangles
  // for --budget 500 on Jacksboro before).
  for (int round = 0; a.budget > 0 && mesh.num_faces() > a.budget && q.triangle_budget > 1 && round < 16; ++round) {
    const std::size_t over = mesh.num_faces() - a.budget;
    q.triangle_budget = q.triangle_budget > over + 1 ? q.triangle_budget - over : 1;
    mesh = front.extract_mesh(q);
  }
  const double extract_ms = extract_watch.ms();
  // The picture is rendered before anything is written, and a failed PNG write takes the mesh with it: a failed
  // run leaves no output.
  Image picture;
  if (!a.png.empty()) {
    RenderOptions o;
    o.width = 1024;
    o.height = 768;
    o.height_ramp = true;
    o.wireframe = mesh.num_faces() < 40000;  // denser wireframes turn black at this size
    picture = render_mesh(mesh, default_camera_for(mesh, 4.0f / 3.0f), o);
  }
  write_mesh_and_picture(a.output, mesh, a.png, a.png.empty() ? nullptr : &picture);
  std::printf("grid %zux%zu (lattice %zux%zu, tile %zu), hierarchy %.1f MB built in %.1f ms\n", field.width, field.height,
              grid.lattice_width(), grid.lattice_height(), grid.tile_size(), double(grid.memory_bytes()) / 1e6, build_ms);
  std::printf("extracted %s, %s in %.2f ms (mesh included) -> %s\n", count_noun(mesh.num_faces(), "triangle").c_str(),
              count_noun(mesh.num_vertices(), "vertex").c_str(), extract_ms, a.output.c_str());
  if (a.budget > 0 && mesh.num_faces() > a.budget)
    std::printf("note: the coarsest mesh of this grid has %zu triangles, more than --budget %zu\n", mesh.num_faces(), a.budget);
  if (a.measure) std::printf("measured max vertical error over all samples: %.6g\n", grid.max_vertical_error(mesh));
  return 0;
}

struct RenderArgs {
  std::string input, output, eye, target, up, view;
  int width = 1024, height = 768;
  float fov = 40.0f;
  bool wireframe = false, flat = false, ramp = false;
};

std::string xyz(const glm::vec3& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%g,%g,%g", double(v.x), double(v.y), double(v.z));
  return buf;
}

// What a face's corners project to in a `width` x `height` picture through `cam` (its aspect made the
// picture's, as render_mesh does): the largest face's area in square pixels and the extent of the faces'
// corners in pixels. Faces with a corner behind the eye are left out; the default views have none.
struct ProjectedSize {
  double largest_face = 0.0;
  glm::dvec2 extent{0.0};
};

ProjectedSize projected_size(const TriMesh& mesh, Camera cam, int width, int height) {
  cam.aspect = float(width) / float(height);
  const glm::dmat4 clip_from_world = glm::dmat4(cam.projection()) * glm::dmat4(cam.view());
  ProjectedSize r;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    glm::dvec2 p[3];
    bool in_front = true;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec4 c = clip_from_world * glm::dvec4(glm::dvec3(mesh.positions[mesh.corner(f, k)]), 1.0);
      in_front = in_front && c.w > 0.0;
      p[k] = {(c.x / c.w + 1.0) * 0.5 * width, (c.y / c.w + 1.0) * 0.5 * height};
    }
    if (!in_front) continue;
    const glm::dvec2 u = p[1] - p[0], v = p[2] - p[0];
    r.largest_face = std::max(r.largest_face, 0.5 * std::abs(u.x * v.y - u.y * v.x));
    for (const glm::dvec2& q : p) {
      lo = glm::min(lo, q);
      hi = glm::max(hi, q);
    }
  }
  if (lo.x <= hi.x) r.extent = hi - lo;
  return r;
}

// A default view that shows nothing is blamed on the picture rather than the mesh when the picture is
// under kSmallPicture pixels on its shorter side and, in the same view on a picture enlarged to that side,
// the largest face would cover kFewPixels square pixels: there the frame is too coarse for faces of a fair
// size (a one-triangle mesh in a 1024 x 1 picture), not the faces too small for the frame.
constexpr int kSmallPicture = 256;
constexpr double kFewPixels = 8.0;

int cmd_render(const RenderArgs& a) {
  if (a.output.empty()) throw InvalidInput("render: -o must end in .png");
  require_png(a.output, "render", "-o");
  refuse_same_file(a.input, "the input mesh", a.output, "-o");
  if (!a.view.empty() && !a.eye.empty()) throw InvalidInput("render: --view and --eye both place the eye; give one of them");
  check_picture_axes(a.up, a.view);
  // CLI11's range check lets NaN through.
  if (!(a.fov >= 1.0f && a.fov <= 170.0f)) throw InvalidInput("--fov must be a number in [1, 170]");
  const glm::vec3 up = a.up.empty() ? glm::vec3(0.0f, 0.0f, 1.0f) : parse_direction(a.up, "--up");
  const TriMesh mesh = read_input_mesh(a.input);
  const float aspect = float(a.width) / float(a.height);
  // The default 3/4 view, or (--up, --view) the framing of query's and subdiv's pictures.
  Camera cam = a.up.empty() && a.view.empty()
                   ? default_camera_for(mesh, aspect)
                   : picture_camera_for(mesh, up, a.view.empty() ? glm::vec3(0.0f) : parse_direction(a.view, "--view"), aspect);
  if (a.eye.empty()) {
    // The framing is kept under --fov: the eye moves along the view so that the picture holds the same.
    const double grow = std::tan(glm::radians(0.5 * double(cam.fov_y_deg))) / std::tan(glm::radians(0.5 * double(a.fov)));
    const glm::dvec3 t(cam.target), e(cam.eye);
    cam.eye = glm::vec3(t + (e - t) * grow);
    cam.z_near = static_cast<float>(double(cam.z_near) * grow);
    cam.z_far = static_cast<float>(double(cam.z_far) * grow);
  }
  if (!a.eye.empty()) cam.eye = parse_vec3(a.eye, "--eye");
  if (!a.target.empty()) cam.target = parse_vec3(a.target, "--target");
  if (!a.up.empty()) cam.up = up;
  cam.fov_y_deg = a.fov;
  if (!a.eye.empty() || !a.target.empty()) {
    // Near and far planes around the mesh's bounding sphere seen from the eye (they were measured from the
    // target, so a target away from the mesh put the mesh past the far plane: a blank picture).
    Box3 box;
    for (Index i : mesh.indices) box.add(mesh.positions[i]);
    const glm::vec3 c = box.center();
    const float r = std::max(0.5f * box.diagonal(), 1e-3f * std::max(1.0f, glm::length(c)));
    const float d = glm::length(cam.eye - c);
    cam.z_far = d + r;
    cam.z_near = std::max(1e-4f * (d + r), d - r);
    if (!(cam.z_near < cam.z_far) || !std::isfinite(cam.z_far))
      throw InvalidInput("render: --eye " + a.eye + " is too far from the mesh to see it (" + std::to_string(d) + " units away)");
  }
  cam.up = cam.view_up();  // a top view with the default +z up: another axis, as Camera::view() does
  RenderOptions o;
  o.width = a.width;
  o.height = a.height;
  o.wireframe = a.wireframe;
  o.smooth = !a.flat;
  o.height_ramp = a.ramp;
  const Image picture = render_mesh(mesh, cam, o);
  // A camera that sees none of the mesh (a --target or --eye away from it) gave a white picture and
  // "rendered N triangles": refused, nothing written.
  const std::size_t drawn = pixels_unlike(picture, o.background);
  // The default view frames the whole bounding box: when it shows nothing, either the picture is too small
  // for faces of a fair size (a 1024 x 1 picture blamed the mesh for it) or the faces are far smaller than
  // the box (a stray vertex far away), which the camera's position did not say.
  if (drawn == 0 && a.eye.empty() && a.target.empty()) {
    const int shorter = std::min(a.width, a.height);
    const ProjectedSize size = projected_size(mesh, cam, a.width, a.height);
    const double grow = double(kSmallPicture) / double(shorter);
    if (shorter < kSmallPicture && size.largest_face * grow * grow >= kFewPixels) {
      char extent[64];
      std::snprintf(extent, sizeof extent, "%.2g x %.2g", size.extent.x, size.extent.y);
      throw InvalidInput("render: the picture, " + std::to_string(a.width) + " x " + std::to_string(a.height) +
                         " pixels, is too small to show the mesh: the mesh spans about " + extent +
                         " pixels in it and no face covers a pixel's centre; give a larger " +
                         (a.height == shorter ? "--height" : "--width") + "; nothing was written");
    }
    Box3 box;
    for (Index i : mesh.indices) box.add(mesh.positions[i]);
    throw IoError(a.input, "no face covers a pixel of the default view, which frames the bounding box of the faces (" +
                               format_g(double(box.diagonal())) +
                               " across): the faces are far smaller than the box (a vertex far from the others?), or "
                               "have no area; nothing was written");
  }
  if (drawn == 0)
    throw InvalidInput("render: the camera sees none of the mesh (eye " + xyz(cam.eye) + ", target " + xyz(cam.target) +
                       "): the picture would be empty; nothing was written");
  write_png(a.output, picture);
  std::printf("rendered %s -> %s (%.1f %% of the pixels show the mesh)\n", count_noun(mesh.num_faces(), "triangle").c_str(),
              a.output.c_str(), 100.0 * double(drawn) / double(picture.width * picture.height));
  return 0;
}

// Levenshtein distance of two short words (option names).
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// The first argument shaped like an option that neither `cmd` nor a command above it has, as a message that
// names it and the nearest long option of `cmd` when one is close; empty when every such argument is known
// (the caller then reports CLI11's own message). A negative number is a value, not an option.
std::string unknown_option_message(const CLI::App& cmd, int argc, char** argv) {
  auto known = [&](const std::string& name) {
    for (const CLI::App* c = &cmd; c != nullptr; c = c->get_parent())
      if (c->get_option_no_throw(name) != nullptr) return true;
    return false;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 2 || arg[0] != '-') continue;
    if (arg[1] != '-' && (std::isdigit(static_cast<unsigned char>(arg[1])) || arg[1] == '.')) continue;
    const bool is_long = arg[1] == '-';
    const std::string name = is_long ? arg.substr(0, arg.find('=')) : arg.substr(0, 2);  // "-ofile": -o
    if (known(name)) continue;
    std::string where = "varmesh";
    std::vector<std::string> path;
    for (const CLI::App* c = &cmd; c != nullptr && c->get_parent() != nullptr; c = c->get_parent()) path.push_back(c->get_name());
    for (auto it = path.rbegin(); it != path.rend(); ++it) where += " " + *it;
    std::string nearest;
    std::size_t best = std::max<std::size_t>(2, name.size() / 3) + 1;  // closer than this to count
    for (const CLI::Option* opt : cmd.get_options())
      for (const std::string& l : opt->get_lnames())
        if (const std::size_t d = edit_distance(name, "--" + l); d < best) {
          best = d;
          nearest = "--" + l;
        }
    return "unknown option '" + name + "' for " + where + (nearest.empty() ? "" : " (did you mean " + nearest + "?)") +
           "; see " + where + " --help";
  }
  return {};
}

}  // namespace

int run(int argc, char** argv) {
  // A file-size limit (ulimit -f) would kill the process with SIGXFSZ in the middle of a write, leaving the
  // staged temporary file behind. Ignored, the write fails with EFBIG instead, like a full disk: the writer
  // removes what it staged and the error names the file.
  std::signal(SIGXFSZ, SIG_IGN);
  // Interrupted (Ctrl-C, kill, a closed terminal or pipe), the command removes its temporary files and
  // staging folders before it ends by that signal: no .tmp.* file or .varmesh-partial-* folder is left.
  InterruptCleanup::install_handlers();
  CLI::App app{"varmesh: variable-resolution triangle meshes (Multi-Triangulations, 4-k meshes, progressive meshes)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "varmesh 0.1.0");

  std::string info_path;
  auto* info = app.add_subcommand("info", "Print the topology report of a mesh (OBJ, OFF, PLY), or a summary of a hierarchy file (.vmh, .vrm)");
  info->add_option("FILE", info_path, "mesh or hierarchy file")->required();

  TerrainArgs ta;
  auto* terrain = app.add_subcommand("terrain", "Build the 4-8 hierarchy of a height field and extract an adapted mesh by error, camera or budget");
  terrain->add_option("HEIGHTFIELD", ta.input, "height field: .pgm, .png, .raw/.f32 (float32 LE, give --raw-size)")->required();
  terrain->add_option("-o,--output", ta.output, "output mesh (.obj, .ply, .off)")->required();
  terrain->add_option("--error", ta.error, "largest vertical error allowed (height units); guaranteed over every sample")->check(check_non_negative);
  auto* terrain_camera = terrain->add_option("--camera", ta.camera, "view-dependent: ex,ey,ez,tx,ty,tz,fov_degrees (world units: x = column * spacing)")->check(check_not_empty);
  add_screen_error_options(*terrain, ta.pixels, ta.viewport, terrain_camera);
  terrain->add_option("--budget", ta.budget, "triangle budget (priority-driven, largest error first)")->check(check_count);
  terrain->add_option("--z-scale", ta.z_scale, "multiply heights by this factor");
  terrain->add_option("--spacing", ta.spacing, "distance between samples (default 1)");
  terrain->add_option("--raw-size", ta.raw_size, "W,H of a .raw/.f32 file")->check(check_not_empty);
  terrain->add_flag("--terrain-rgb", ta.terrain_rgb, "decode a Mapbox Terrain-RGB PNG");
  terrain->add_flag("--flip-rows", ta.flip_rows, "put the file's first row at the largest y (a north-up map then reads right from above, z up; default: row r at y = r * spacing)");
  terrain->add_flag("--fast-bound", ta.fast_bound, "looser O(1)-per-node error bounds instead of exact errors (more triangles for the same threshold)");
  terrain->add_flag("--measure", ta.measure, "measure the true max vertical error of the result over all samples");
  terrain->add_option("--png", ta.png, "also render the result to this PNG")->check(check_file_name);

  RenderArgs ra;
  auto* render = app.add_subcommand("render", "Render a mesh to a PNG with a small software rasterizer");
  render->add_option("MESH", ra.input, "mesh file")->required();
  render->add_option("-o,--output", ra.output, "output .png")->required();
  render->add_option("--width", ra.width, "image width in pixels (default 1024)")->check(CLI::Range(1, 16384));
  render->add_option("--height", ra.height, "image height in pixels (default 768)")->check(CLI::Range(1, 16384));
  render->add_option("--eye", ra.eye, "camera position x,y,z (default: a 3/4 view)")->check(check_not_empty);
  render->add_option("--target", ra.target, "camera target x,y,z (default: the bounding sphere centre)")->check(check_not_empty);
  render->add_option("--fov", ra.fov, "vertical field of view in degrees (default 40; without --eye the mesh stays framed)")->check(CLI::Range(1.0, 170.0));
  render->add_option("--up", ra.up, "the direction that is up in the picture, x,y,z (default 0,0,1; e.g. 0,1,0 for y-up models)")->check(check_not_empty);
  render->add_option("--view", ra.view, "look from this direction (towards the eye), x,y,z, framing the mesh (instead of --eye)")->check(check_not_empty);
  render->add_flag("--wireframe", ra.wireframe, "draw edges");
  render->add_flag("--flat", ra.flat, "flat shading");
  render->add_flag("--height-ramp", ra.ramp, "colour by height (terrains)");

  DemoArgs da;
  auto* demo = app.add_subcommand("demo", "Fractal terrain: build, uniform-error and view-dependent meshes, table, OBJ + PNG");
  add_demo_options(*demo, da);

  BuildArgs ba;
  auto* build = app.add_subcommand("build", "Build a 4-k hierarchy (semiregular, adaptive, simplify4k) and save it as .vrm");
  add_build_options(*build, ba);
  QueryArgs qa;
  auto* query = app.add_subcommand("query", "Extract a front of a .vrm hierarchy by error, camera, ramp or budget");
  add_query_options(*query, qa);

  PmBuildArgs pba;
  PmQueryArgs pqa;
  auto* pm = app.add_subcommand("pm", "Progressive meshes (Kim-Lee): build a vertex hierarchy (.vmh), query selectively refined meshes");
  pm->require_subcommand(1);
  auto* pm_build = pm->add_subcommand("build", "QEM analysis of a mesh into a vertex hierarchy, saved as .vmh");
  add_pm_build_options(*pm_build, pba);
  auto* pm_query = pm->add_subcommand("query", "Selectively refined mesh of a .vmh hierarchy by error, camera or budget");
  add_pm_query_options(*pm_query, pqa);

  SubdivArgs sa;
  auto* subdiv = app.add_subcommand("subdiv", "Subdivide a polygon mesh: 4-8, Catmull-Clark, Zwart-Powell, Doo-Sabin, quasi 4-8, linear; uniform or adaptive");
  add_subdiv_options(*subdiv, sa);

  CompareArgs ca;
  auto* compare = app.add_subcommand("compare", "Kim-Lee Table 2: three selective refinement schemes on image, terrain and 3D models, table + PNG");
  add_compare_options(*compare, ca);

  // A misspelt command ("varmesh biuld", "varmesh pm qeury"): CLI11 says only that a subcommand is
  // required. Name the word and the commands known there.
  const CLI::App* at = &app;  // the command the arguments name (after the loop)
  {
    for (int i = 1; i < argc && !at->get_subcommands({}).empty(); ++i) {
      const std::string word = argv[i];
      if (word.empty() || word[0] == '-') continue;  // --help, --version
      const CLI::App* next = nullptr;
      std::string known;
      for (const CLI::App* sub : at->get_subcommands({})) {
        if (sub->get_name() == word) next = sub;
        known += (known.empty() ? "" : ", ") + sub->get_name();
      }
      if (!next) {
        const std::string where = at == &app ? "varmesh" : "varmesh " + at->get_name();
        std::fprintf(stderr, "varmesh: error: '%s' is not a command of %s (known: %s; see --help)\n", word.c_str(),
                     where.c_str(), known.c_str());
        return 1;
      }
      at = next;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version print and succeed; every other parse error is one line and status 1, like the
    // errors of the commands themselves (CLI11's own exit codes 100+ and its "Run with --help" line are
    // not what the README promises).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    // A misspelt option ("--eror 20"): CLI11 lists the arguments it did not expect, the option's value
    // first, and suggests nothing, or reports first a required option the misspelling left out ("--outptu").
    // Name the option and the nearest one the command has.
    if (const std::string unknown = unknown_option_message(*at, argc, argv); !unknown.empty()) {
      std::fprintf(stderr, "varmesh: error: %s\n", unknown.c_str());
      return 1;
    }
    std::fprintf(stderr, "varmesh: error: %s (see --help)\n", e.what());
    return 1;
  }
  // What the command is about, for an out-of-memory message.
  std::string doing;
  for (const CLI::App* sub = &app; !sub->get_subcommands().empty();) {
    sub = sub->get_subcommands().front();
    doing += (doing.empty() ? "" : " ") + sub->get_name();
  }
  try {
    if (*info) return cmd_info(info_path);
    if (*terrain) return cmd_terrain(ta);
    if (*render) return cmd_render(ra);
    if (*demo) return run_demo(da);
    if (*compare) return run_compare(ca);
    if (*build) return run_build(ba);
    if (*query) return run_query(qa);
    if (*subdiv) return run_subdiv(sa);
    if (*pm_build) return run_pm_build(pba);
    if (*pm_query) return run_pm_query(pqa);
  } catch (const IoError& e) {
    // A file written into a staging folder is named by its final path.
    const std::string file = StagedFolder::user_path(e.file());
    std::fprintf(stderr, "varmesh: error: %s\n",
                 file == e.file() ? e.what() : IoError(file, e.reason(), e.line(), e.byte_offset()).what());
    return 1;
  } catch (const std::bad_alloc&) {
    const char* step = Step::failed();
    std::fprintf(stderr, "varmesh: error: out of memory%s%s (varmesh %s): the input or the options ask for more memory than is available\n",
                 step ? " while " : "", step ? step : "", doing.c_str());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    const std::string file = StagedFolder::user_path(e.path1().string());
    std::fprintf(stderr, "varmesh: error: %s\n", file.empty() ? e.what() : (file + ": " + e.code().message()).c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "varmesh: error: %s\n", e.what());
    return 1;
  }
  return 2;
}

}  // namespace varmesh::app
