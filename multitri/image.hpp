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

/// Reads a PNG (any colour type, interlaced or not; palette expanded to RGB, gray bit depth < 8 expanded to
/// 8, a tRNS chunk expanded to an alpha channel; 16-bit kept, in native byte order in `pixels16`). Sample
/// values are as stored (no gamma correction).
/// Throws IoError naming the file, libpng's reason and the read position (byte offset) where decoding
/// stopped: bad signature, truncated data, CRC errors, corrupt zlib streams, width * height above 2^28
/// pixels ("absurd size"), or too few IDAT bytes for the claimed size. Oversized or truncated images are
/// rejected before the pixel buffer is allocated. O(file size + pixels).
Image read_png(const std::string& path);

/// Reads a binary or ascii PGM (P5/P2) with maxval 1..65535 into a 1-channel image: bit_depth 8 when
/// maxval <= 255, else 16 (P5 16-bit samples are big endian in the file). Samples are kept as stored, not
/// rescaled to the full range, so Image::value() is sample / 255 or sample / 65535 whatever the maxval.
/// Header '#' comments are allowed. Data after the raster (further images) is ignored.
/// Throws IoError naming the file, the line (header and P2 samples) and the byte offset (P5): bad magic,
/// bad or missing numbers, zero size, maxval 0 or > 65535, width * height above 2^28 ("absurd size", checked
/// before allocating), truncated data, samples above maxval.
Image read_pgm(const std::string& path);

/// Writes a non-interlaced PNG, 8 or 16-bit as the image says, colour type from `channels`. Atomic
/// (temporary file + rename): on failure `path` is untouched. Throws InvalidInput if the image is
/// inconsistent (zero size, channels outside 1..4, bit_depth not 8/16, wrong buffer size) and IoError if
/// encoding or writing fails.
void write_png(const std::string& path, const Image& image);

}  // namespace varmesh
