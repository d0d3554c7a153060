#include "multitri/image.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "multitri/errors.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

// A minimal PNG encoder (zlib "stored" blocks, filter 0) for colour types and interlacing that write_png does
// not produce, so the reader's expansions can be checked against known pixels.
std::uint32_t crc32(const std::string& bytes) {
  std::uint32_t crc = 0xffffffffu;
  for (unsigned char b : bytes) {
    crc ^= b;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xffffffffu;
}

void put_be32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((v >> shift) & 0xff));
}

std::string png_chunk(const std::string& type, const std::string& data) {
  std::string out;
  put_be32(out, static_cast<std::uint32_t>(data.size()));
  const std::string body = type + data;
  out += body;
  put_be32(out, crc32(body));
  return out;
}

std::string zlib_stored(const std::string& raw) {
  std::string out = "\x78\x01";
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(raw.size() - pos, 65535);
    const bool last = pos + n == raw.size();
    out.push_back(last ? '\x01' : '\x00');
    out.push_back(static_cast<char>(n & 0xff));
    out.push_back(static_cast<char>(n >> 8));
    out.push_back(static_cast<char>(~n & 0xff));
    out.push_back(static_cast<char>((~n >> 8) & 0xff));
    out.append(raw, pos, n);
    pos += n;
  } while (pos < raw.size());
  std::uint32_t a = 1;
  std::uint32_t b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  put_be32(out, (b << 16) | a);
  return out;
}

struct RawPng {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  int bit_depth = 8;
  int color_type = 0;
  int bits_per_pixel = 8;  // bit_depth * samples per pixel
  std::string extra_chunks;  // e.g. PLTE, tRNS, before IDAT
  // Sample (x, y) as bits_per_pixel bits, most significant first.
  std::vector<std::uint64_t> pixels;
};

std::string encode_png(const RawPng& png, bool interlaced) {
  auto scanlines = [&](std::uint32_t x0, std::uint32_t y0, std::uint32_t dx, std::uint32_t dy) {
    std::string out;
    if (x0 >= png.width || y0 >= png.height) return out;
    for (std::uint32_t y = y0; y < png.height; y += dy) {
      out.push_back('\0');
      std::string row;
      std::uint64_t acc = 0;
      int bits = 0;
      for (std::uint32_t x = x0; x < png.width; x += dx) {
        acc = (acc << png.bits_per_pixel) | png.pixels[std::size_t{y} * png.width + x];
        bits += png.bits_per_pixel;
        while (bits >= 8) {
          bits -= 8;
          row.push_back(static_cast<char>((acc >> bits) & 0xff));
        }
      }
      if (bits > 0) row.push_back(static_cast<char>((acc << (8 - bits)) & 0xff));
      out += row;
    }
    return out;
  };
  std::string raw;
  if (interlaced) {
    static constexpr std::uint32_t kX0[] = {0, 4, 0, 2, 0, 1, 0};
    static constexpr std::uint32_t kY0[] = {0, 0, 4, 0, 2, 0, 1};
    static constexpr std::uint32_t kDx[] = {8, 8, 4, 4, 2, 2, 1};
    static constexpr std::uint32_t kDy[] = {8, 8, 8, 4, 4, 2, 2};
    for (int p = 0; p < 7; ++p) raw += scanlines(kX0[p], kY0[p], kDx[p], kDy[p]);
  } else {
    raw = scanlines(0, 0, 1, 1);
  }
  std::string ihdr;
  put_be32(ihdr, png.width);
  put_be32(ihdr, png.height);
  ihdr.push_back(static_cast<char>(png.bit_depth));
  ihdr.push_back(static_cast<char>(png.color_type));
  ihdr.push_back('\0');
  ihdr.push_back('\0');
  ihdr.push_back(interlaced ? '\1' : '\0');
  return std::string("\x89PNG\r\n\x1a\n", 8) + png_chunk("IHDR", ihdr) + png.extra_chunks +
         png_chunk("IDAT", zlib_stored(raw)) + png_chunk("IEND", "");
}

Image random_image(std::size_t width, std::size_t height, int channels, int bit_depth, unsigned seed) {
  std::mt19937 rng(seed);
  Image image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  image.bit_depth = bit_depth;
  const std::size_t n = width * height * static_cast<std::size_t>(channels);
  if (bit_depth == 16) {
    image.pixels16.resize(n);
    for (auto& v : image.pixels16) v = static_cast<std::uint16_t>(rng() & 0xffff);
  } else {
    image.pixels.resize(n);
    for (auto& v : image.pixels) v = static_cast<std::uint8_t>(rng() & 0xff);
  }
  return image;
}

void expect_same(const Image& a, const Image& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.bit_depth, b.bit_depth);
  EXPECT_EQ(a.pixels, b.pixels);
  EXPECT_EQ(a.pixels16, b.pixels16);
}

class ImageIoPngRoundTrip : public ::testing::TestWithParam<std::array<int, 2>> {};

TEST_P(ImageIoPngRoundTrip, WriteThenReadIsIdentical) {
  const auto [channels, bit_depth] = GetParam();
  const auto dir = varmesh::testing::scratch_dir("image_io_png_round_trip_" + std::to_string(channels) + "_" +
                                                 std::to_string(bit_depth));
  const Image image = random_image(37, 23, channels, bit_depth, static_cast<unsigned>(channels * 100 + bit_depth));
  const std::string path = (dir / "image.png").string();
  write_png(path, image);
  expect_same(read_png(path), image);
  // The atomic writer leaves only the target behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

INSTANTIATE_TEST_SUITE_P(ImageIo, ImageIoPngRoundTrip,
                         ::testing::Values(std::array<int, 2>{1, 8}, std::array<int, 2>{2, 8},
                                           std::array<int, 2>{3, 8}, std::array<int, 2>{4, 8},
                                           std::array<int, 2>{1, 16}, std::array<int, 2>{4, 16}));

TEST(ImageIo, ValueScalesToUnitRange) {
  Image image;
  image.width = 2;
  image.height = 1;
  image.channels = 3;
  image.pixels = {0, 51, 255, 255, 102, 0};
  EXPECT_FLOAT_EQ(image.value(0, 0, 1), 0.2f);
  EXPECT_FLOAT_EQ(image.value(0, 0, 2), 1.0f);
  EXPECT_FLOAT_EQ(image.value(1, 0, 1), 0.4f);
  Image deep;
  deep.width = 1;
  deep.height = 2;
  deep.channels = 1;
  deep.bit_depth = 16;
  deep.pixels16 = {0, 65535};
  EXPECT_FLOAT_EQ(deep.value(0, 0, 0), 0.0f);
  EXPECT_FLOAT_EQ(deep.value(0, 1, 0), 1.0f);
}

TEST(ImageIo, Reads16BitSamplesInNativeOrder) {
  const auto dir = varmesh::testing::scratch_dir("image_io_png16");
  RawPng png{3, 1, 16, 0, 16, "", {0x1234, 0xfe01, 0x00ff}};
  const auto path = dir / "g16.png";
  write_bytes(path, encode_png(png, false));
  const Image image = read_png(path.string());
  EXPECT_EQ(image.bit_depth, 16);
  EXPECT_EQ(image.channels, 1);
  EXPECT_TRUE(image.pixels.empty());
  EXPECT_EQ(image.pixels16, (std::vector<std::uint16_t>{0x1234, 0xfe01, 0x00ff}));
}

TEST(ImageIo, ExpandsPaletteToRgbAndTransparencyToAlpha) {
  const auto dir = varmesh::testing::scratch_dir("image_io_palette");
  const std::string palette("\x0a\x14\x1e" "\xff\x00\x00" "\x00\xff\x00" "\x01\x02\x03", 12);
  RawPng png{5, 3, 2, 3, 2, png_chunk("PLTE", palette), {}};
  for (std::uint64_t i = 0; i < 15; ++i) png.pixels.push_back((i * 7 + 1) % 4);
  write_bytes(dir / "p.png", encode_png(png, false));
  const Image rgb = read_png((dir / "p.png").string());
  ASSERT_EQ(rgb.channels, 3);
  ASSERT_EQ(rgb.bit_depth, 8);
  ASSERT_EQ(rgb.pixels.size(), 45u);
  for (std::size_t i = 0; i < 15; ++i) {
    for (std::size_t c = 0; c < 3; ++c) {
      EXPECT_EQ(rgb.pixels[3 * i + c], static_cast<unsigned char>(palette[3 * png.pixels[i] + c])) << i;
    }
  }
  png.extra_chunks += png_chunk("tRNS", std::string("\x80\xff", 2));  // entry 0 half, 1 opaque, rest opaque
  write_bytes(dir / "pt.png", encode_png(png, false));
  const Image rgba = read_png((dir / "pt.png").string());
  ASSERT_EQ(rgba.channels, 4);
  for (std::size_t i = 0; i < 15; ++i) {
    EXPECT_EQ(rgba.pixels[4 * i + 3], png.pixels[i] == 0 ? 0x80 : 0xff) << i;
    EXPECT_EQ(rgba.pixels[4 * i], rgb.pixels[3 * i]) << i;
  }
}

TEST(ImageIo, ExpandsOneBitGrayToEightBits) {
  const auto dir = varmesh::testing::scratch_dir("image_io_1bit");
  RawPng png{10, 2, 1, 0, 1, "", {}};
  for (std::uint64_t i = 0; i < 20; ++i) png.pixels.push_back(i % 3 == 0 ? 1 : 0);
  write_bytes(dir / "b.png", encode_png(png, false));
  const Image image = read_png((dir / "b.png").string());
  ASSERT_EQ(image.channels, 1);
  ASSERT_EQ(image.pixels.size(), 20u);
  for (std::size_t i = 0; i < 20; ++i) EXPECT_EQ(image.pixels[i], png.pixels[i] ? 255 : 0) << i;
}

TEST(ImageIo, InterlacedPngMatchesProgressive) {
  const auto dir = varmesh::testing::scratch_dir("image_io_interlaced");
  RawPng png{11, 9, 8, 2, 24, "", {}};
  for (std::uint64_t i = 0; i < 99; ++i) png.pixels.push_back((i * 2654435761u) & 0xffffff);
  write_bytes(dir / "plain.png", encode_png(png, false));
  write_bytes(dir / "adam7.png", encode_png(png, true));
  const Image plain = read_png((dir / "plain.png").string());
  ASSERT_EQ(plain.pixels.size(), 99u * 3);
  EXPECT_EQ(plain.pixels[3 * 5 + 1], (png.pixels[5] >> 8) & 0xff);
  expect_same(read_png((dir / "adam7.png").string()), plain);
}

TEST(ImageIo, ReadsBinaryPgm8And16Bit) {
  const auto dir = varmesh::testing::scratch_dir("image_io_pgm_binary");
  write_bytes(dir / "a.pgm", std::string("P5\n# a comment\n3 2 # trailing\n200\n") + std::string("\x00\x01\x02\xc8\x10\x20", 6));
  const Image a = read_pgm((dir / "a.pgm").string());
  EXPECT_EQ(a.width, 3u);
  EXPECT_EQ(a.height, 2u);
  EXPECT_EQ(a.channels, 1);
  EXPECT_EQ(a.bit_depth, 8);
  EXPECT_EQ(a.pixels, (std::vector<std::uint8_t>{0, 1, 2, 200, 16, 32}));

  write_bytes(dir / "b.pgm", std::string("P5 2 2 65535 ") + std::string("\x12\x34\xff\xff\x00\x00\x01\x00", 8));
  const Image b = read_pgm((dir / "b.pgm").string());
  EXPECT_EQ(b.bit_depth, 16);
  EXPECT_EQ(b.pixels16, (std::vector<std::uint16_t>{0x1234, 0xffff, 0, 256}));

  // maxval 1000: samples kept as stored, still 16-bit and big endian.
  write_bytes(dir / "c.pgm", std::string("P5\n1 2\n1000\n") + std::string("\x03\xe8\x00\x07", 4));
  EXPECT_EQ(read_pgm((dir / "c.pgm").string()).pixels16, (std::vector<std::uint16_t>{1000, 7}));
}

TEST(ImageIo, ReadsAsciiPgm) {
  const auto dir = varmesh::testing::scratch_dir("image_io_pgm_ascii");
  write_bytes(dir / "a.pgm", "P2\n# made by hand\n4 2\n15\n0 1 2 3\n 15 14\n13\n12\n");
  const Image a = read_pgm((dir / "a.pgm").string());
  EXPECT_EQ(a.width, 4u);
  EXPECT_EQ(a.height, 2u);
  EXPECT_EQ(a.bit_depth, 8);
  EXPECT_EQ(a.pixels, (std::vector<std::uint8_t>{0, 1, 2, 3, 15, 14, 13, 12}));
  write_bytes(dir / "b.pgm", "P2 2 1 60000 59999 300");
  const Image b = read_pgm((dir / "b.pgm").string());
  EXPECT_EQ(b.bit_depth, 16);
  EXPECT_EQ(b.pixels16, (std::vector<std::uint16_t>{59999, 300}));
}

TEST(ImageIo, AsciiAndBinaryPgmOfTheSamePixelsAgree) {
  const auto dir = varmesh::testing::scratch_dir("image_io_pgm_p2_p5");
  const Image image = random_image(13, 7, 1, 8, 7);
  std::string p2 = "P2\n13 7\n255\n";
  std::string p5 = "P5\n13 7\n255\n";
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    p2 += std::to_string(image.pixels[i]) + (i % 13 == 12 ? "\n" : " ");
    p5.push_back(static_cast<char>(image.pixels[i]));
  }
  write_bytes(dir / "a.pgm", p2);
  write_bytes(dir / "b.pgm", p5);
  expect_same(read_pgm((dir / "a.pgm").string()), image);
  expect_same(read_pgm((dir / "b.pgm").string()), image);
}

// Every fixture tests/data/bad/<prefix>* must fail with an IoError naming the file, a reason and a position.
void expect_all_bad(const std::string& prefix, Image (*reader)(const std::string&), int minimum_count) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(varmesh::testing::test_data("bad"))) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    ++count;
    const std::string path = entry.path().string();
    try {
      reader(path);
      ADD_FAILURE() << name << " was accepted";
    } catch (const IoError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_FALSE(e.reason().empty()) << name;
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_TRUE(e.line() != IoError::kNoLine || e.byte_offset() != IoError::kNoOffset) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << " threw a non-IoError: " << e.what();
    }
  }
  EXPECT_GE(count, minimum_count) << "fixtures missing for prefix " << prefix;
}

TEST(ImageIo, EveryBadPngFixtureThrowsIoError) { expect_all_bad("png_", read_png, 12); }
TEST(ImageIo, EveryBadPgmFixtureThrowsIoError) { expect_all_bad("pgm_", read_pgm, 17); }

IoError error_of(Image (*reader)(const std::string&), const std::string& fixture) {
  try {
    reader(varmesh::testing::test_data("bad/" + fixture));
  } catch (const IoError& e) {
    return e;
  }
  ADD_FAILURE() << fixture << " was accepted";
  return IoError("", "");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(ImageIo, BadPgmErrorsGiveReasonAndPosition) {
  const IoError truncated = error_of(read_pgm, "pgm_truncated.pgm");
  EXPECT_TRUE(contains(truncated.reason(), "truncated")) << truncated.what();
  EXPECT_EQ(truncated.byte_offset(), 21u);
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_truncated_16bit.pgm").reason(), "truncated"));
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_huge_dims.pgm").reason(), "absurd size"));
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_ascii_huge_dims.pgm").reason(), "truncated"));
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_maxval_zero.pgm").reason(), "maxval 0"));
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_maxval_too_big.pgm").reason(), "maxval 70000"));
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_overflow_width.pgm").reason(), "too large"));
  const IoError bad_number = error_of(read_pgm, "pgm_bad_number.pgm");
  EXPECT_EQ(bad_number.line(), 3u);
  EXPECT_TRUE(contains(bad_number.reason(), "4x")) << bad_number.what();
  EXPECT_EQ(error_of(read_pgm, "pgm_negative_sample.pgm").line(), 5u);
  const IoError above = error_of(read_pgm, "pgm_ascii_above_maxval.pgm");
  EXPECT_EQ(above.line(), 5u);
  EXPECT_TRUE(contains(above.reason(), "300")) << above.what();
  EXPECT_EQ(error_of(read_pgm, "pgm_ascii_truncated.pgm").line(), 5u);
  const IoError binary_above = error_of(read_pgm, "pgm_binary_above_maxval.pgm");
  EXPECT_EQ(binary_above.byte_offset(), 13u);
  EXPECT_TRUE(contains(error_of(read_pgm, "pgm_bad_magic.pgm").reason(), "magic"));
}

TEST(ImageIo, BadPngErrorsGiveReasonAndPosition) {
  EXPECT_TRUE(contains(error_of(read_png, "png_corrupt_crc.png").reason(), "CRC"));
  EXPECT_TRUE(contains(error_of(read_png, "png_huge_dims.png").reason(), "absurd size"));
  EXPECT_TRUE(contains(error_of(read_png, "png_idat_too_small.png").reason(), "cannot hold"));
  EXPECT_EQ(error_of(read_png, "png_bad_signature.png").byte_offset(), 0u);
  const auto truncated_size = fs::file_size(varmesh::testing::test_data("bad/png_truncated.png"));
  EXPECT_EQ(error_of(read_png, "png_truncated.png").byte_offset(), truncated_size);
}

TEST(ImageIo, MissingFileThrowsIoError) {
  EXPECT_THROW(read_png("/nonexistent/varmesh/x.png"), IoError);
  EXPECT_THROW(read_pgm("/nonexistent/varmesh/x.pgm"), IoError);
}

TEST(ImageIo, FailedWriteLeavesNoFile) {
  const auto dir = varmesh::testing::scratch_dir("image_io_failed_write");
  const auto path = dir / "missing_folder" / "x.png";
  EXPECT_THROW(write_png(path.string(), random_image(4, 4, 3, 8, 1)), IoError);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(dir / "missing_folder"));
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(ImageIo, WriteRejectsInconsistentImages) {
  const auto dir = varmesh::testing::scratch_dir("image_io_inconsistent");
  const std::string path = (dir / "x.png").string();
  Image short_buffer = random_image(4, 4, 3, 8, 1);
  short_buffer.pixels.pop_back();
  EXPECT_THROW(write_png(path, short_buffer), InvalidInput);
  Image wrong_buffer = random_image(4, 4, 1, 8, 1);
  wrong_buffer.bit_depth = 16;  // pixels16 is empty
  EXPECT_THROW(write_png(path, wrong_buffer), InvalidInput);
  Image five = random_image(2, 2, 4, 8, 1);
  five.channels = 5;
  EXPECT_THROW(write_png(path, five), InvalidInput);
  EXPECT_THROW(write_png(path, Image{}), InvalidInput);
  EXPECT_FALSE(fs::exists(path));
}

TEST(ImageIo, OverwritesAnExistingFile) {
  const auto dir = varmesh::testing::scratch_dir("image_io_overwrite");
  const std::string path = (dir / "x.png").string();
  write_png(path, random_image(5, 5, 1, 8, 1));
  const Image second = random_image(3, 2, 3, 8, 2);
  write_png(path, second);
  expect_same(read_png(path), second);
}

TEST(ImageIo, CameramanPngAndPgmAgree) {
  VARMESH_REQUIRE_SHARED(png_path, "images/cameraman_256_gray.png");
  VARMESH_REQUIRE_SHARED(pgm_path, "images/cameraman_256_gray.pgm");
  const Image png = read_png(png_path);
  const Image pgm = read_pgm(pgm_path);
  EXPECT_EQ(png.width, 256u);
  EXPECT_EQ(png.height, 256u);
  EXPECT_EQ(png.channels, 1);
  expect_same(png, pgm);
}

TEST(ImageIo, SharedGrayImagesPngAndPgmAgree) {
  for (const char* name : {"mandrill_256_gray", "peppers_256_gray", "skimage_camera_512_gray_cc0"}) {
    const std::string png_path = varmesh::testing::shared_data(std::string("images/") + name + ".png");
    const std::string pgm_path = varmesh::testing::shared_data(std::string("images/") + name + ".pgm");
    if (!fs::exists(png_path) || !fs::exists(pgm_path)) GTEST_SKIP() << "shared test data missing: " << png_path;
    const Image png = read_png(png_path);
    const Image pgm = read_pgm(pgm_path);
    SCOPED_TRACE(name);
    expect_same(png, pgm);
    // Round trip of real photographic data through the writer.
    const auto dir = varmesh::testing::scratch_dir(std::string("image_io_shared_") + name);
    write_png((dir / "copy.png").string(), png);
    expect_same(read_png((dir / "copy.png").string()), png);
  }
}

}  // namespace
}  // namespace varmesh
