// Height-field readers and writers on top of the PNG/PGM image readers.
//
// Terrain-RGB is Mapbox's encoding of elevations in 8-bit RGB tiles (docs.mapbox.com, "Mapbox Terrain-RGB"):
// height_m = -10000 + (R * 65536 + G * 256 + B) * 0.1, evaluated in double so that equal codes give
// bit-identical floats whichever reader produced them.
#include "multitri/heightfield.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string_view>
#include <system_error>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"
#include "multitri/image.hpp"

namespace varmesh {
namespace {

constexpr std::uint64_t kMaxSamples = std::uint64_t{1} << 28;

// write_heightfield_pgm16 records the height range it quantized in this header comment, so that
// read_heightfield can undo the mapping: "# varmesh z_range <min> <max>".
constexpr std::string_view kZRangeTag = "varmesh z_range";

struct ZRange {
  double min = 0.0;
  double max = 0.0;
  double maxval = 65535.0;
};

std::string lowercase_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c); });
  return ext;
}

std::string float_text(float v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);  // shortest round-trip form
  return std::string(buffer, result.ptr);
}

bool is_pgm_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// Scans the header of a PGM (already validated by read_pgm) for the z_range comment and the maxval.
std::optional<ZRange> find_z_range(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string header(4096, '\0');
  in.read(header.data(), static_cast<std::streamsize>(header.size()));
  header.resize(static_cast<std::size_t>(in.gcount()));

  std::optional<ZRange> range;
  std::size_t pos = 2;  // after the magic number
  std::size_t line = 1;
  int numbers = 0;
  while (pos < header.size() && numbers < 3) {
    const char c = header[pos];
    if (c == '\n') {
      ++line;
      ++pos;
    } else if (is_pgm_space(c)) {
      ++pos;
    } else if (c == '#') {
      std::size_t end = header.find('\n', pos);
      if (end == std::string::npos) end = header.size();
      std::string_view comment(header.data() + pos + 1, end - pos - 1);
      while (!comment.empty() && is_pgm_space(comment.front())) comment.remove_prefix(1);
      if (comment.substr(0, kZRangeTag.size()) == kZRangeTag) {
        comment.remove_prefix(kZRangeTag.size());
        float values[2] = {0.0f, 0.0f};
        bool ok = true;
        for (float& v : values) {
          while (!comment.empty() && is_pgm_space(comment.front())) comment.remove_prefix(1);
          const auto [ptr, ec] = std::from_chars(comment.data(), comment.data() + comment.size(), v);
          ok = ok && ec == std::errc() && std::isfinite(v);
          comment.remove_prefix(static_cast<std::size_t>(ptr - comment.data()));
        }
        if (!ok || values[1] < values[0]) {
          throw IoError(path, "bad '# varmesh z_range <min> <max>' comment (need finite min <= max)", line);
        }
        range = ZRange{values[0], values[1], 65535.0};
      }
      pos = end;
    } else {
      std::size_t end = pos;
      while (end < header.size() && !is_pgm_space(header[end]) && header[end] != '#') ++end;
      ++numbers;
      if (numbers == 3 && range) {
        std::uint32_t maxval = 0;
        const auto parsed = std::from_chars(header.data() + pos, header.data() + end, maxval);
        if (parsed.ec == std::errc() && maxval > 0) range->maxval = maxval;
      }
      pos = end;
    }
  }
  return range;
}

// First channel for gray and gray+alpha, Rec. 601 luma for RGB and RGBA; raw sample values (not normalized).
double gray_sample(const Image& image, std::size_t i) {
  const std::size_t base = i * static_cast<std::size_t>(image.channels);
  auto sample = [&](std::size_t k) -> double {
    return image.bit_depth == 16 ? image.pixels16[base + k] : image.pixels[base + k];
  };
  if (image.channels >= 3) return 0.299 * sample(0) + 0.587 * sample(1) + 0.114 * sample(2);
  return sample(0);
}

HeightField field_from_image(const std::string& path, const Image& image, const HeightFieldReadOptions& options,
                             const std::optional<ZRange>& range) {
  HeightField field;
  field.width = image.width;
  field.height = image.height;
  const std::size_t count = image.width * image.height;
  field.z.resize(count);
  const double z_scale = options.z_scale;
  if (options.decoding == PixelDecoding::kTerrainRgb) {
    if (image.bit_depth != 8 || image.channels < 3) {
      throw IoError(path, "Terrain-RGB decoding needs an 8-bit RGB or RGBA image, this one has " +
                              std::to_string(image.channels) + " channel(s) of " +
                              std::to_string(image.bit_depth) + " bits");
    }
    const auto channels = static_cast<std::size_t>(image.channels);
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint8_t* p = &image.pixels[i * channels];
      const std::uint32_t code = (std::uint32_t{p[0]} << 16) | (std::uint32_t{p[1]} << 8) | std::uint32_t{p[2]};
      field.z[i] = static_cast<float>((-10000.0 + code * 0.1) * z_scale);
    }
  } else if (range) {
    const double step = (range->max - range->min) / range->maxval;
    for (std::size_t i = 0; i < count; ++i) {
      field.z[i] = static_cast<float>((range->min + gray_sample(image, i) * step) * z_scale);
    }
  } else {
    for (std::size_t i = 0; i < count; ++i) field.z[i] = static_cast<float>(gray_sample(image, i) * z_scale);
  }
  return field;
}

HeightField read_raw_field(const std::string& path, const HeightFieldReadOptions& options) {
  if (options.raw_width == 0 || options.raw_height == 0) {
    throw InvalidInput("read_heightfield: .raw/.f32 files need raw_width and raw_height (got " +
                       std::to_string(options.raw_width) + "x" + std::to_string(options.raw_height) + ")");
  }
  if (options.raw_width > kMaxSamples || options.raw_height > kMaxSamples ||
      std::uint64_t{options.raw_width} * options.raw_height > kMaxSamples) {
    throw IoError(path, "absurd size " + std::to_string(options.raw_width) + "x" +
                            std::to_string(options.raw_height) + " (more than 2^28 samples)");
  }
  const std::size_t count = options.raw_width * options.raw_height;
  const std::uint64_t expected = std::uint64_t{count} * 4;
  // Compare sizes before reading, so a wrong, huge file is never loaded.
  std::error_code ec;
  const std::uintmax_t on_disk = std::filesystem::file_size(path, ec);
  auto size_error = [&](std::uint64_t actual) {
    return IoError(path,
                   "file has " + std::to_string(actual) + " bytes, " + std::to_string(options.raw_width) + "x" +
                       std::to_string(options.raw_height) + " float32 samples need " + std::to_string(expected),
                   IoError::kNoLine, std::min<std::uint64_t>(actual, expected));
  };
  if (!ec && on_disk != expected) throw size_error(on_disk);
  const FileBytes data = read_file_bytes(path);
  if (data.size() != expected) throw size_error(data.size());

  HeightField field;
  field.width = options.raw_width;
  field.height = options.raw_height;
  field.z.resize(count);
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  for (std::size_t i = 0; i < count; ++i) {
    const unsigned char* b = bytes + 4 * i;
    const std::uint32_t bits = std::uint32_t{b[0]} | (std::uint32_t{b[1]} << 8) | (std::uint32_t{b[2]} << 16) |
                               (std::uint32_t{b[3]} << 24);
    const float v = std::bit_cast<float>(bits);
    if (!std::isfinite(v)) {
      throw IoError(path,
                    std::string(std::isnan(v) ? "NaN" : "infinite") + " sample at (" +
                        std::to_string(i % field.width) + ", " + std::to_string(i / field.width) + ")",
                    IoError::kNoLine, 4 * std::uint64_t{i});
    }
    field.z[i] = static_cast<float>(double{v} * options.z_scale);  // exact when z_scale is 1
  }
  return field;
}

}  // namespace

void HeightField::validate() const {
  if (width == 0 || height == 0) {
    throw InvalidInput("height field is empty (" + std::to_string(width) + "x" + std::to_string(height) + ")");
  }
  if (width > std::numeric_limits<std::size_t>::max() / height) throw InvalidInput("height field size overflows");
  if (z.size() != width * height) {
    throw InvalidInput("height field holds " + std::to_string(z.size()) + " samples, " + std::to_string(width) +
                       "x" + std::to_string(height) + " needs " + std::to_string(width * height));
  }
  if (!(std::isfinite(spacing_x) && spacing_x > 0.0f && std::isfinite(spacing_y) && spacing_y > 0.0f)) {
    throw InvalidInput("height field spacing must be positive and finite");
  }
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (!std::isfinite(z[i])) {
      throw InvalidInput("height field sample (" + std::to_string(i % width) + ", " + std::to_string(i / width) +
                             ") is not finite",
                         i);
    }
  }
}

HeightField read_heightfield(const std::string& path, const HeightFieldReadOptions& options) {
  if (!std::isfinite(options.z_scale)) throw InvalidInput("read_heightfield: z_scale must be finite");
  const std::string ext = lowercase_extension(path);
  HeightField field;
  if (ext == ".pgm") {
    if (options.decoding != PixelDecoding::kGray) {
      throw InvalidInput("read_heightfield: Terrain-RGB decoding applies only to PNG files");
    }
    const Image image = read_pgm(path);
    field = field_from_image(path, image, options, find_z_range(path));
  } else if (ext == ".png") {
    const Image image = read_png(path);
    field = field_from_image(path, image, options, std::nullopt);
  } else if (ext == ".raw" || ext == ".f32") {
    if (options.decoding != PixelDecoding::kGray) {
      throw InvalidInput("read_heightfield: Terrain-RGB decoding applies only to PNG files");
    }
    field = read_raw_field(path, options);
  } else {
    throw IoError(path, "unknown height-field extension '" + ext + "' (expected .pgm, .png, .raw or .f32)");
  }
  field.validate();  // only a z_scale that overflows a sample to infinity can fail here
  return field;
}

void write_heightfield_pgm16(const std::string& path, const HeightField& field) {
  field.validate();
  const auto [lo, hi] = std::minmax_element(field.z.begin(), field.z.end());
  const float z_min = *lo;
  const float z_max = *hi;
  const double range = double{z_max} - double{z_min};
  std::string out = "P5\n# " + std::string(kZRangeTag) + " " + float_text(z_min) + " " + float_text(z_max) + "\n" +
                    std::to_string(field.width) + " " + std::to_string(field.height) + "\n65535\n";
  const std::size_t header = out.size();
  out.resize(header + 2 * field.z.size());
  for (std::size_t i = 0; i < field.z.size(); ++i) {
    const double t = range > 0.0 ? (double{field.z[i]} - z_min) / range : 0.0;
    const auto q = static_cast<std::uint16_t>(std::clamp(std::lround(t * 65535.0), 0L, 65535L));
    out[header + 2 * i] = static_cast<char>(q >> 8);
    out[header + 2 * i + 1] = static_cast<char>(q & 0xff);
  }
  write_file_atomically(path, out);
}

void write_heightfield_raw(const std::string& path, const HeightField& field) {
  field.validate();
  std::string out(4 * field.z.size(), '\0');
  for (std::size_t i = 0; i < field.z.size(); ++i) {
    const auto bits = std::bit_cast<std::uint32_t>(field.z[i]);
    for (int k = 0; k < 4; ++k) out[4 * i + static_cast<std::size_t>(k)] = static_cast<char>((bits >> (8 * k)) & 0xff);
  }
  write_file_atomically(path, out);
}

}  // namespace varmesh
