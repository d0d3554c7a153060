// PNG (libpng) and PGM (netpbm P2/P5) reading and writing.
//
// libpng reports errors by longjmp. Every libpng call that can fail runs inside one of the small
// png_*_guarded() functions below, which call setjmp themselves and hold no C++ object with a destructor,
// so a longjmp never skips one. The C++ callers own the png structs through RAII handles and turn a false
// return into IoError. Callbacks handed to libpng never let a C++ exception cross the C frames.
#include "multitri/image.hpp"

#include <png.h>

#include <bit>
#include <charconv>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>

#include "multitri/errors.hpp"
#include "multitri/file_util.hpp"

namespace varmesh {
namespace {

// Largest accepted width * height; checked before any pixel buffer is allocated.
constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 28;

// Deflate cannot compress better than 1032:1 (zlib FAQ); a little slack on top. A PNG whose IDAT bytes
// cannot possibly hold its claimed size is rejected before its pixel buffer is allocated.
constexpr std::uint64_t kMaxDeflateRatio = 1100;

std::string absurd_size_reason(std::uint64_t width, std::uint64_t height) {
  return "absurd size " + std::to_string(width) + "x" + std::to_string(height) + " (more than 2^28 pixels)";
}

// PNG: state shared with the libpng callbacks (plain data only).

constexpr std::size_t kMessageSize = 256;

// The error pointer of every png struct. The last warning is kept because libpng often explains an error
// in a warning just before it (e.g. "Image width is zero in IHDR", then "Invalid IHDR data").
struct PngMessages {
  char error[kMessageSize] = {};
  char warning[kMessageSize] = {};

  std::string reason() const {
    std::string text = std::string("libpng: ") + error;
    if (warning[0] != '\0') text += std::string(" (last warning: ") + warning + ")";
    return text;
  }
};

struct PngReadState {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  std::size_t pos = 0;  // bytes handed to libpng so far: the byte offset reported with an error
  PngMessages messages;
};

struct PngWriteState {
  std::string* out = nullptr;
  PngMessages messages;
};

void png_on_error(png_structp png, png_const_charp message) {
  auto* messages = static_cast<PngMessages*>(png_get_error_ptr(png));
  if (messages != nullptr) {
    std::snprintf(messages->error, kMessageSize, "%s", message != nullptr ? message : "unknown error");
  }
  png_longjmp(png, 1);
}

// The library never prints: warnings are only remembered for the next error message.
void png_on_warning(png_structp png, png_const_charp message) {
  auto* messages = static_cast<PngMessages*>(png_get_error_ptr(png));
  if (messages != nullptr && message != nullptr) std::snprintf(messages->warning, kMessageSize, "%s", message);
}

void png_on_read(png_structp png, png_bytep out, png_size_t length) {
  auto* state = static_cast<PngReadState*>(png_get_io_ptr(png));
  if (length > state->size - state->pos) {
    state->pos = state->size;
    png_error(png, "unexpected end of file");
  }
  std::memcpy(out, state->data + state->pos, length);
  state->pos += length;
}

void png_on_write(png_structp png, png_bytep data, png_size_t length) {
  auto* state = static_cast<PngWriteState*>(png_get_io_ptr(png));
  bool ok = true;
  try {
    state->out->append(reinterpret_cast<const char*>(data), length);
  } catch (...) {
    ok = false;
  }
  // png_error longjmps: call it outside the catch block so no exception object is abandoned.
  if (!ok) png_error(png, "out of memory while encoding");
}

void png_on_flush(png_structp) {}

struct PngReadHandle {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngReadHandle() = default;
  PngReadHandle(const PngReadHandle&) = delete;
  PngReadHandle& operator=(const PngReadHandle&) = delete;
  ~PngReadHandle() {
    if (png != nullptr) png_destroy_read_struct(&png, info != nullptr ? &info : nullptr, nullptr);
  }
};

struct PngWriteHandle {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngWriteHandle() = default;
  PngWriteHandle(const PngWriteHandle&) = delete;
  PngWriteHandle& operator=(const PngWriteHandle&) = delete;
  ~PngWriteHandle() {
    if (png != nullptr) png_destroy_write_struct(&png, info != nullptr ? &info : nullptr);
  }
};

// Image layout as stored in the file and as delivered after the transforms set up in png_read_layout_guarded.
struct PngLayout {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int file_bits_per_pixel = 0;
  int channels = 0;
  int bit_depth = 0;
  std::size_t rowbytes = 0;
  int passes = 1;
};

bool png_read_layout_guarded(png_structp png, png_infop info, PngLayout* layout) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  const int color_type = png_get_color_type(png, info);
  const int file_depth = png_get_bit_depth(png, info);
  layout->width = png_get_image_width(png, info);
  layout->height = png_get_image_height(png, info);
  layout->file_bits_per_pixel = file_depth * png_get_channels(png, info);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && file_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS) != 0) png_set_tRNS_to_alpha(png);
  // libpng delivers 16-bit samples big endian; Image::pixels16 holds native uint16.
  if (file_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  layout->passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  layout->channels = png_get_channels(png, info);
  layout->bit_depth = png_get_bit_depth(png, info);
  layout->rowbytes = png_get_rowbytes(png, info);
  return true;
}

bool png_read_pixels_guarded(png_structp png, unsigned char* pixels, std::size_t rowbytes, png_uint_32 height,
                             int passes) {
  if (setjmp(png_jmpbuf(png))) return false;
  // With interlace handling on, every pass visits every row and combines into what is already there.
  for (int pass = 0; pass < passes; ++pass) {
    for (png_uint_32 y = 0; y < height; ++y) png_read_row(png, pixels + std::size_t{y} * rowbytes, nullptr);
  }
  png_read_end(png, nullptr);  // verifies the remaining chunks' CRCs up to IEND
  return true;
}

struct PngWriteJob {
  png_uint_32 width;
  png_uint_32 height;
  int bit_depth;
  int color_type;
  const unsigned char* pixels;
  std::size_t rowbytes;
};

bool png_write_guarded(png_structp png, png_infop info, const PngWriteJob* job) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_IHDR(png, info, job->width, job->height, job->bit_depth, job->color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (job->bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  for (png_uint_32 y = 0; y < job->height; ++y) png_write_row(png, job->pixels + std::size_t{y} * job->rowbytes);
  png_write_end(png, nullptr);
  return true;
}

std::uint32_t read_be32(std::string_view data, std::size_t pos) {
  return (std::uint32_t{static_cast<unsigned char>(data[pos])} << 24) |
         (std::uint32_t{static_cast<unsigned char>(data[pos + 1])} << 16) |
         (std::uint32_t{static_cast<unsigned char>(data[pos + 2])} << 8) |
         std::uint32_t{static_cast<unsigned char>(data[pos + 3])};
}

// Sum of the IDAT chunk lengths, walking the chunk list (stops quietly at a truncated chunk: libpng reports
// that later with its own message).
std::uint64_t idat_bytes(std::string_view data) {
  std::uint64_t total = 0;
  std::size_t pos = 8;
  while (data.size() - pos >= 12) {
    const std::uint64_t length = read_be32(data, pos);
    const std::string_view type(data.data() + pos + 4, 4);
    if (type == "IDAT") total += length;
    if (type == "IEND" || length > data.size() - pos - 12) break;
    pos += static_cast<std::size_t>(length) + 12;
  }
  return total;
}


// A cursor over a PGM file that tracks the 1-based line for error messages.
class PgmParser {
 public:
  PgmParser(const std::string& path, const std::string& data) : path_(path), data_(data) {}

  // At the end of the file, names the last line that has content rather than the empty one after it.
  [[noreturn]] void fail(const std::string& reason, bool with_offset) const {
    const bool after_final_newline = at_end() && line_ > 1 && data_.back() == '\n';
    throw IoError(path_, reason, after_final_newline ? line_ - 1 : line_, with_offset ? pos_ : IoError::kNoOffset);
  }

  bool at_end() const { return pos_ >= data_.size(); }
  std::size_t pos() const { return pos_; }
  std::size_t line() const { return line_; }
  void advance(std::size_t n) { pos_ += n; }

  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

  // Skips whitespace and '#' comments (which run to the end of the line).
  void skip_space_and_comments() {
    while (!at_end()) {
      const char c = data_[pos_];
      if (c == '#') {
        while (!at_end() && data_[pos_] != '\n') ++pos_;
      } else if (is_space(c)) {
        if (c == '\n') ++line_;
        ++pos_;
      } else {
        return;
      }
    }
  }

  // A decimal unsigned integer ending at whitespace, '#' or the end of the file.
  std::uint64_t number(const char* what, bool with_offset) {
    skip_space_and_comments();
    if (at_end()) fail(std::string("truncated: file ends before the ") + what, with_offset);
    const char* first = data_.data() + pos_;
    const char* last = data_.data() + data_.size();
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(first, last, value);
    if (ec == std::errc::result_out_of_range) fail(std::string(what) + " is too large", with_offset);
    if (ec != std::errc() || (end != last && !is_space(*end) && *end != '#')) {
      const char* stop = end;
      while (stop != last && !is_space(*stop) && stop - first < 20) ++stop;
      fail(std::string("expected ") + what + " (a non-negative integer), found '" + std::string(first, stop) + "'",
           with_offset);
    }
    pos_ += static_cast<std::size_t>(end - first);
    return value;
  }

 private:
  const std::string& path_;
  const std::string& data_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

}  // namespace

float Image::value(std::size_t x, std::size_t y, int c) const noexcept {
  const std::size_t i = (y * width + x) * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c);
  if (bit_depth == 16) return static_cast<float>(pixels16[i]) / 65535.0f;
  return static_cast<float>(pixels[i]) / 255.0f;
}

Image read_png(const std::string& path) {
  const FileBytes data = read_file_bytes(path);
  if (data.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(data.data()), 0, 8) != 0) {
    throw IoError(path, "not a PNG file (bad signature)", IoError::kNoLine, 0);
  }
  PngReadState state;
  state.data = reinterpret_cast<const unsigned char*>(data.data());
  state.size = data.size();
  PngReadHandle handle;
  handle.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state.messages, png_on_error, png_on_warning);
  if (handle.png == nullptr) throw IoError(path, "libpng: cannot create a read struct");
  handle.info = png_create_info_struct(handle.png);
  if (handle.info == nullptr) throw IoError(path, "libpng: cannot create an info struct");
  png_set_read_fn(handle.png, &state, png_on_read);

  PngLayout layout;
  if (!png_read_layout_guarded(handle.png, handle.info, &layout)) {
    throw IoError(path, state.messages.reason(), IoError::kNoLine, state.pos);
  }
  const std::uint64_t pixel_count = std::uint64_t{layout.width} * layout.height;
  if (pixel_count > kMaxPixels) throw IoError(path, absurd_size_reason(layout.width, layout.height), IoError::kNoLine, 16);
  const std::uint64_t min_raw_bytes = pixel_count * static_cast<std::uint64_t>(layout.file_bits_per_pixel) / 8;
  const std::uint64_t compressed = idat_bytes(data);
  if (min_raw_bytes / kMaxDeflateRatio > compressed + 64) {
    throw IoError(path,
                  "too little image data: " + std::to_string(compressed) + " IDAT bytes cannot hold " +
                      std::to_string(layout.width) + "x" + std::to_string(layout.height) +
                      " pixels (truncated file?)",
                  IoError::kNoLine, state.pos);
  }
  const int bytes_per_sample = layout.bit_depth == 16 ? 2 : 1;
  if ((layout.bit_depth != 8 && layout.bit_depth != 16) || layout.channels < 1 || layout.channels > 4 ||
      layout.rowbytes != std::size_t{layout.width} * static_cast<std::size_t>(layout.channels * bytes_per_sample)) {
    throw IoError(path, "unsupported PNG layout after expansion (bit depth " + std::to_string(layout.bit_depth) +
                            ", " + std::to_string(layout.channels) + " channels)");
  }

  Image image;
  image.width = layout.width;
  image.height = layout.height;
  image.channels = layout.channels;
  image.bit_depth = layout.bit_depth;
  const std::size_t samples = static_cast<std::size_t>(pixel_count) * static_cast<std::size_t>(layout.channels);
  unsigned char* buffer = nullptr;
  if (layout.bit_depth == 16) {
    image.pixels16.resize(samples);
    buffer = reinterpret_cast<unsigned char*>(image.pixels16.data());
  } else {
    image.pixels.resize(samples);
    buffer = image.pixels.data();
  }
  if (!png_read_pixels_guarded(handle.png, buffer, layout.rowbytes, layout.height, layout.passes)) {
    throw IoError(path, state.messages.reason(), IoError::kNoLine, state.pos);
  }
  return image;
}

void write_png(const std::string& path, const Image& image) {
  if (image.width == 0 || image.height == 0) throw InvalidInput("write_png: image is empty");
  if (image.width > PNG_UINT_31_MAX || image.height > PNG_UINT_31_MAX) {
    throw InvalidInput("write_png: image is too large for PNG");
  }
  if (image.channels < 1 || image.channels > 4) {
    throw InvalidInput("write_png: channels must be 1..4, got " + std::to_string(image.channels));
  }
  if (image.bit_depth != 8 && image.bit_depth != 16) {
    throw InvalidInput("write_png: bit_depth must be 8 or 16, got " + std::to_string(image.bit_depth));
  }
  const auto channels = static_cast<std::size_t>(image.channels);
  if (image.width > std::numeric_limits<std::size_t>::max() / image.height / channels / 2) {
    throw InvalidInput("write_png: image size overflows");
  }
  const std::size_t samples = image.width * image.height * channels;
  const std::size_t stored = image.bit_depth == 16 ? image.pixels16.size() : image.pixels.size();
  if (stored != samples) {
    throw InvalidInput("write_png: " + std::string(image.bit_depth == 16 ? "pixels16" : "pixels") + " holds " +
                       std::to_string(stored) + " samples, " + std::to_string(image.width) + "x" +
                       std::to_string(image.height) + "x" + std::to_string(image.channels) + " needs " +
                       std::to_string(samples));
  }
  static constexpr int kColorTypes[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                        PNG_COLOR_TYPE_RGB_ALPHA};
  const int bytes_per_sample = image.bit_depth == 16 ? 2 : 1;
  PngWriteJob job{static_cast<png_uint_32>(image.width),
                  static_cast<png_uint_32>(image.height),
                  image.bit_depth,
                  kColorTypes[image.channels - 1],
                  image.bit_depth == 16 ? reinterpret_cast<const unsigned char*>(image.pixels16.data())
                                        : image.pixels.data(),
                  image.width * channels * static_cast<std::size_t>(bytes_per_sample)};

  std::string encoded;
  PngWriteState state;
  state.out = &encoded;
  {
    PngWriteHandle handle;
    handle.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state.messages, png_on_error, png_on_warning);
    if (handle.png == nullptr) throw IoError(path, "libpng: cannot create a write struct");
    handle.info = png_create_info_struct(handle.png);
    if (handle.info == nullptr) throw IoError(path, "libpng: cannot create an info struct");
    png_set_write_fn(handle.png, &state, png_on_write, png_on_flush);
    if (!png_write_guarded(handle.png, handle.info, &job)) {
      throw IoError(path, state.messages.reason());
    }
  }
  write_file_atomically(path, encoded);
}

Image read_pgm(const std::string& path) {
  const std::string data = read_file(path);
  PgmParser in(path, data);
  if (data.size() < 2 || data[0] != 'P' || (data[1] != '5' && data[1] != '2')) {
    throw IoError(path, "not a PGM file (expected the magic number P5 or P2)", 1, 0);
  }
  const bool binary = data[1] == '5';
  in.advance(2);
  if (!in.at_end() && !PgmParser::is_space(data[2]) && data[2] != '#') {
    in.fail("not a PGM file (expected whitespace after the magic number)", binary);
  }
  const std::uint64_t width = in.number("width", binary);
  const std::uint64_t height = in.number("height", binary);
  const std::size_t size_line = in.line();
  if (width == 0 || height == 0) {
    throw IoError(path, "empty image " + std::to_string(width) + "x" + std::to_string(height), size_line);
  }
  if (width > kMaxPixels || height > kMaxPixels || width * height > kMaxPixels) {
    throw IoError(path, absurd_size_reason(width, height), size_line);
  }
  const std::uint64_t maxval = in.number("maxval", binary);
  const std::size_t maxval_line = in.line();
  if (maxval == 0 || maxval > 65535) {
    throw IoError(path, "maxval " + std::to_string(maxval) + " is outside 1..65535", maxval_line);
  }

  Image image;
  image.width = static_cast<std::size_t>(width);
  image.height = static_cast<std::size_t>(height);
  image.channels = 1;
  image.bit_depth = maxval > 255 ? 16 : 8;
  const std::size_t count = image.width * image.height;

  auto store = [&](std::size_t i, std::uint64_t v) {
    if (image.bit_depth == 16) {
      image.pixels16[i] = static_cast<std::uint16_t>(v);
    } else {
      image.pixels[i] = static_cast<std::uint8_t>(v);
    }
  };

  if (binary) {
    // Exactly one whitespace byte separates maxval from the samples.
    if (in.at_end()) throw IoError(path, "truncated: file ends after maxval", in.line(), in.pos());
    if (!PgmParser::is_space(data[in.pos()])) {
      in.fail("expected one whitespace byte between maxval and the binary samples", true);
    }
    const std::size_t start = in.pos() + 1;
    const std::size_t bytes_per_sample = maxval > 255 ? 2 : 1;
    const std::uint64_t needed = std::uint64_t{count} * bytes_per_sample;
    if (data.size() - start < needed) {
      throw IoError(path,
                    "truncated: " + std::to_string(width) + "x" + std::to_string(height) + " samples need " +
                        std::to_string(needed) + " bytes, the file has " + std::to_string(data.size() - start),
                    IoError::kNoLine, data.size());
    }
    if (image.bit_depth == 16) {
      image.pixels16.resize(count);
    } else {
      image.pixels.resize(count);
    }
    const auto* bytes = reinterpret_cast<const unsigned char*>(data.data()) + start;
    for (std::size_t i = 0; i < count; ++i) {
      // 16-bit samples are big endian (netpbm).
      const std::uint64_t v = bytes_per_sample == 2 ? (std::uint64_t{bytes[2 * i]} << 8) | bytes[2 * i + 1]
                                                    : std::uint64_t{bytes[i]};
      if (v > maxval) {
        throw IoError(path, "sample " + std::to_string(v) + " exceeds maxval " + std::to_string(maxval),
                      IoError::kNoLine, start + i * bytes_per_sample);
      }
      store(i, v);
    }
  } else {
    // Each ascii sample needs at least two bytes (digit + separator) except the last: bound the allocation
    // by the file size so a tiny file cannot claim a huge raster.
    const std::size_t remaining = data.size() - in.pos();
    if (count > remaining / 2 + 1) {
      throw IoError(path,
                    "truncated: " + std::to_string(width) + "x" + std::to_string(height) +
                        " ascii samples cannot fit in the remaining " + std::to_string(remaining) + " bytes",
                    in.line());
    }
    if (image.bit_depth == 16) {
      image.pixels16.resize(count);
    } else {
      image.pixels.resize(count);
    }
    for (std::size_t i = 0; i < count; ++i) {
      in.skip_space_and_comments();
      if (in.at_end()) {
        in.fail("truncated: expected " + std::to_string(count) + " samples, found " + std::to_string(i), false);
      }
      const std::uint64_t v = in.number("sample", false);
      if (v > maxval) in.fail("sample " + std::to_string(v) + " exceeds maxval " + std::to_string(maxval), false);
      store(i, v);
    }
  }
  return image;
}

}  // namespace varmesh
