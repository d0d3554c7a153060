#pragma once
/// 8-bit images and PNG/PGM files (libpng). Used for renders, for image input to builders, and by tests.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace varmesh {

/// Row-major, row 0 at the top, `channels` interleaved 8-bit channels (1 gray, 2 gray+alpha, 3 RGB, 4 RGBA)
/// or 16-bit samples when `bit_depth` is 16 (then `pixels16` is used instead of `pixels`).
struct Image {
  std::size_t width = 0;
  std::size_t height = 0;
  int channels = 3;
  int bit_depth = 8;
  std::vector<std::uint8_t> pixels;    ///< bit_depth 8: width * height * channels
  std::vector<std::uint16_t> pixels16; ///< bit_depth 16: width * height * channels

  /// Channel c of pixel (x, y) as a value in [0, 1].
  float value(std::size_t x, std::size_t y, int c) const noexcept;
};

/// Reads a PNG (any colour type; palette expanded to RGB, bit depth < 8 expanded to 8; 16-bit kept).
/// Throws IoError naming the file and libpng's reason.
Image read_png(const std::string& path);

/// Reads a binary or ascii PGM (P5/P2) with maxval up to 65535. Throws IoError (byte offset or line).
Image read_pgm(const std::string& path);

/// Writes a PNG, 8 or 16-bit as the image says. Atomic (temporary file + rename). Throws IoError.
void write_png(const std::string& path, const Image& image);

}  // namespace varmesh
