#pragma once
/// Height fields (regular grids of heights) and their readers.
///
/// A HeightField holds width x height samples, row-major, row 0 first; sample (x, y) sits at world position
/// (x * spacing_x, y * spacing_y, z) (see to_world()). Readers throw IoError naming the file and the byte
/// offset or line with the reason (truncated data, bad header, NaN/Inf samples, absurd sizes).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

namespace varmesh {

struct HeightField {
  std::size_t width = 0;
  std::size_t height = 0;
  std::vector<float> z;  ///< width * height samples, row-major, row 0 first
  float spacing_x = 1.0f;  ///< world distance between columns
  float spacing_y = 1.0f;  ///< world distance between rows

  float at(std::size_t x, std::size_t y) const noexcept { return z[y * width + x]; }
  glm::vec3 to_world(std::size_t x, std::size_t y) const noexcept {
    return {static_cast<float>(x) * spacing_x, static_cast<float>(y) * spacing_y, at(x, y)};
  }
  /// Throws InvalidInput if sizes disagree, a size is 0, a spacing is not positive and finite, or a sample
  /// is not finite (the element is the sample index y * width + x). O(width * height).
  void validate() const;
};

/// How image pixels become heights.
enum class PixelDecoding {
  kGray,         ///< raw sample value, not normalized: 0..255 or 0..65535; first channel of gray and
                 ///< gray+alpha, Rec. 601 luma (0.299 R + 0.587 G + 0.114 B) of RGB and RGBA
  kTerrainRgb,   ///< Mapbox Terrain-RGB: height_m = -10000 + (R*65536 + G*256 + B) * 0.1 (8-bit RGB(A) PNG)
};

struct HeightFieldReadOptions {
  PixelDecoding decoding = PixelDecoding::kGray;
  float z_scale = 1.0f;       ///< multiplies decoded heights
  std::size_t raw_width = 0;  ///< required for .raw / .f32 files (float32 little endian, row-major)
  std::size_t raw_height = 0;
};

/// Reads a height field by extension (case-insensitive): .pgm (P2/P5, 8 or 16 bit), .png (8 or 16 bit gray,
/// gray+alpha, RGB, RGBA; Terrain-RGB with PixelDecoding::kTerrainRgb), .raw/.f32 (float32 LE, size from
/// the options). Heights are decoded in double, multiplied by z_scale, then stored as float; spacing is 1.
/// A PGM carrying the comment "# varmesh z_range <min> <max>" (as written by write_heightfield_pgm16) has
/// its samples mapped back linearly from [0, maxval] to [min, max] before z_scale.
/// Throws IoError (see read_png / read_pgm; raw: file size != 4 * raw_width * raw_height, NaN/Inf sample
/// with its byte offset, more than 2^28 samples; unknown extension; Terrain-RGB on a non-8-bit-RGB(A) PNG)
/// and InvalidInput (raw size missing, z_scale not finite, Terrain-RGB asked for a .pgm/.raw file, a
/// z_scale that overflows a sample).
HeightField read_heightfield(const std::string& path, const HeightFieldReadOptions& options = {});

/// Writes a height field as 16-bit binary PGM (P5, maxval 65535), linearly mapping [min, max] of the samples
/// to [0, 65535] (rounded; a flat field writes 0s) and recording min and max in a "# varmesh z_range" header
/// comment, so read_heightfield restores heights within half a step, (max - min) / 131070. Spacing is not
/// stored. Atomic. Throws InvalidInput (validate()) or IoError.
void write_heightfield_pgm16(const std::string& path, const HeightField& field);

/// Writes a height field as raw float32 little endian, row-major, no header (bit-exact round trip with
/// read_heightfield given the same width and height). Atomic. Throws InvalidInput (validate()) or IoError.
void write_heightfield_raw(const std::string& path, const HeightField& field);

}  // namespace varmesh
