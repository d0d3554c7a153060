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
  /// Throws InvalidInput if sizes disagree, a size is 0, or a sample is not finite (names the sample).
  void validate() const;
};

/// How image pixels become heights.
enum class PixelDecoding {
  kGray,         ///< first channel (or luminance) as is: 0..255 or 0..65535
  kTerrainRgb,   ///< Mapbox Terrain-RGB: height_m = -10000 + (R*65536 + G*256 + B) * 0.1
};

struct HeightFieldReadOptions {
  PixelDecoding decoding = PixelDecoding::kGray;
  float z_scale = 1.0f;       ///< multiplies decoded heights
  std::size_t raw_width = 0;  ///< required for .raw / .f32 files (float32 little endian, row-major)
  std::size_t raw_height = 0;
};

/// Reads a height field by extension: .pgm (P2/P5, 8 or 16 bit), .png (8 or 16 bit gray, gray+alpha, RGB,
/// RGBA; Terrain-RGB with PixelDecoding::kTerrainRgb), .raw/.f32 (float32 LE, size from the options).
HeightField read_heightfield(const std::string& path, const HeightFieldReadOptions& options = {});

/// Writes a height field as 16-bit PGM, linearly mapping [min, max] to [0, 65535]. Atomic.
void write_heightfield_pgm16(const std::string& path, const HeightField& field);

/// Writes a height field as raw float32 little endian, row-major. Atomic.
void write_heightfield_raw(const std::string& path, const HeightField& field);

}  // namespace varmesh
