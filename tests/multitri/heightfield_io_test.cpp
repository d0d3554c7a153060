#include "multitri/heightfield.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "multitri/errors.hpp"
#include "multitri/image.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace fs = std::filesystem;

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

HeightField random_field(std::size_t width, std::size_t height, float lo, float hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> dist(lo, hi);
  HeightField field;
  field.width = width;
  field.height = height;
  field.z.resize(width * height);
  for (float& z : field.z) z = dist(rng);
  return field;
}

float terrain_rgb_height(std::uint32_t code) { return static_cast<float>(-10000.0 + code * 0.1); }

TEST(HeightFieldIo, RawRoundTripIsBitExact) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_raw");
  HeightField field = random_field(7, 5, -500.0f, 9000.0f, 3);
  field.z[0] = -0.0f;
  field.z[1] = std::numeric_limits<float>::denorm_min();
  field.z[2] = std::numeric_limits<float>::max();
  field.z[3] = -std::numeric_limits<float>::max();
  for (const char* name : {"f.raw", "f.f32", "F.RAW"}) {
    const std::string path = (dir / name).string();
    write_heightfield_raw(path, field);
    EXPECT_EQ(fs::file_size(path), 7u * 5u * 4u);
    HeightFieldReadOptions options;
    options.raw_width = 7;
    options.raw_height = 5;
    const HeightField back = read_heightfield(path, options);
    ASSERT_EQ(back.width, 7u);
    ASSERT_EQ(back.height, 5u);
    ASSERT_EQ(back.z.size(), field.z.size());
    for (std::size_t i = 0; i < field.z.size(); ++i) {
      EXPECT_EQ(std::bit_cast<std::uint32_t>(back.z[i]), std::bit_cast<std::uint32_t>(field.z[i])) << i;
    }
  }
}

TEST(HeightFieldIo, RawIsLittleEndianRowMajor) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_raw_layout");
  HeightField field;
  field.width = 2;
  field.height = 1;
  field.z = {1.0f, -2.5f};  // 0x3f800000, 0xc0200000
  const std::string path = (dir / "f.raw").string();
  write_heightfield_raw(path, field);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes, std::string("\x00\x00\x80\x3f\x00\x00\x20\xc0", 8));
}

TEST(HeightFieldIo, Pgm16RoundTripWithinQuantizationStep) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_pgm16");
  const HeightField field = random_field(31, 17, -120.0f, 3000.0f, 5);
  const std::string path = (dir / "f.pgm").string();
  write_heightfield_pgm16(path, field);
  const HeightField back = read_heightfield(path);
  ASSERT_EQ(back.width, 31u);
  ASSERT_EQ(back.height, 17u);
  const auto [lo, hi] = std::minmax_element(field.z.begin(), field.z.end());
  const double half_step = (double{*hi} - *lo) / 65535.0 / 2.0;
  for (std::size_t i = 0; i < field.z.size(); ++i) {
    EXPECT_NEAR(back.z[i], field.z[i], half_step + 1e-6 * std::abs(field.z[i]) + 1e-6) << i;
  }
  EXPECT_EQ(*std::min_element(back.z.begin(), back.z.end()), *lo);
  EXPECT_EQ(*std::max_element(back.z.begin(), back.z.end()), *hi);

  // The file is a plain 16-bit PGM for other tools: min maps to 0 and max to 65535.
  const Image image = read_pgm(path);
  EXPECT_EQ(image.bit_depth, 16);
  EXPECT_EQ(*std::min_element(image.pixels16.begin(), image.pixels16.end()), 0);
  EXPECT_EQ(*std::max_element(image.pixels16.begin(), image.pixels16.end()), 65535);

  // z_scale applies on top of the restored heights.
  HeightFieldReadOptions options;
  options.z_scale = 2.0f;
  const HeightField doubled = read_heightfield(path, options);
  for (std::size_t i = 0; i < field.z.size(); ++i) EXPECT_FLOAT_EQ(doubled.z[i], 2.0f * back.z[i]) << i;
}

TEST(HeightFieldIo, Pgm16FlatFieldRoundTrips) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_pgm16_flat");
  HeightField field;
  field.width = 3;
  field.height = 2;
  field.z.assign(6, 42.25f);
  const std::string path = (dir / "flat.pgm").string();
  write_heightfield_pgm16(path, field);
  EXPECT_EQ(read_heightfield(path).z, field.z);
}

TEST(HeightFieldIo, GrayDecodingUsesRawSamplesTimesScale) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_gray");
  HeightFieldReadOptions options;
  options.z_scale = 0.5f;

  write_bytes(dir / "a.pgm", "P2\n3 1\n1000\n0 999 1000\n");
  EXPECT_EQ(read_heightfield((dir / "a.pgm").string(), options).z, (std::vector<float>{0.0f, 499.5f, 500.0f}));

  Image gray8;
  gray8.width = 2;
  gray8.height = 2;
  gray8.channels = 2;  // gray + alpha: the alpha channel is ignored
  gray8.pixels = {0, 9, 255, 9, 10, 9, 128, 9};
  write_png((dir / "g8.png").string(), gray8);
  const HeightField f8 = read_heightfield((dir / "g8.png").string(), options);
  EXPECT_EQ(f8.z, (std::vector<float>{0.0f, 127.5f, 5.0f, 64.0f}));
  EXPECT_FLOAT_EQ(f8.at(1, 1), 64.0f);
  EXPECT_EQ(f8.to_world(1, 1), glm::vec3(1.0f, 1.0f, 64.0f));

  Image gray16;
  gray16.width = 3;
  gray16.height = 1;
  gray16.channels = 1;
  gray16.bit_depth = 16;
  gray16.pixels16 = {0, 1000, 65535};
  write_png((dir / "g16.png").string(), gray16);
  EXPECT_EQ(read_heightfield((dir / "g16.png").string(), options).z, (std::vector<float>{0.0f, 500.0f, 32767.5f}));

  Image rgb;
  rgb.width = 2;
  rgb.height = 1;
  rgb.channels = 3;
  rgb.pixels = {100, 100, 100, 255, 0, 0};
  write_png((dir / "rgb.png").string(), rgb);
  const HeightField luma = read_heightfield((dir / "rgb.png").string());
  EXPECT_NEAR(luma.z[0], 100.0f, 1e-4f);
  EXPECT_NEAR(luma.z[1], 0.299f * 255.0f, 1e-3f);
}

TEST(HeightFieldIo, TerrainRgbDecodesExactly) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_terrain_rgb");
  const std::vector<std::uint32_t> codes = {0, 100000, 100137, 137510, 0xffffff, 0x0186a1, 0x123456, 0xabcdef};
  for (int channels : {3, 4}) {
    Image image;
    image.width = 4;
    image.height = 2;  // row 0 holds codes 0..3, row 1 codes 4..7
    image.channels = channels;
    for (std::uint32_t code : codes) {
      image.pixels.push_back(static_cast<std::uint8_t>(code >> 16));
      image.pixels.push_back(static_cast<std::uint8_t>((code >> 8) & 0xff));
      image.pixels.push_back(static_cast<std::uint8_t>(code & 0xff));
      if (channels == 4) image.pixels.push_back(255);
    }
    const std::string path = (dir / ("t" + std::to_string(channels) + ".png")).string();
    write_png(path, image);
    HeightFieldReadOptions options;
    options.decoding = PixelDecoding::kTerrainRgb;
    const HeightField field = read_heightfield(path, options);
    ASSERT_EQ(field.width, 4u);
    ASSERT_EQ(field.height, 2u);
    for (std::size_t i = 0; i < codes.size(); ++i) EXPECT_EQ(field.z[i], terrain_rgb_height(codes[i])) << i;
    EXPECT_EQ(field.at(1, 0), 0.0f);
    EXPECT_EQ(field.at(2, 0), 13.7f);
    EXPECT_EQ(field.at(3, 0), 3751.0f);
    EXPECT_EQ(field.at(0, 1), terrain_rgb_height(0xffffff));
  }
}

TEST(HeightFieldIo, TerrainRgbRejectsNonRgbImagesAndNonPngFiles) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_terrain_rgb_bad");
  HeightFieldReadOptions options;
  options.decoding = PixelDecoding::kTerrainRgb;
  Image gray;
  gray.width = 2;
  gray.height = 2;
  gray.channels = 1;
  gray.pixels = {1, 2, 3, 4};
  const std::string gray_path = (dir / "gray.png").string();
  write_png(gray_path, gray);
  try {
    read_heightfield(gray_path, options);
    ADD_FAILURE() << "gray Terrain-RGB accepted";
  } catch (const IoError& e) {
    EXPECT_EQ(e.file(), gray_path);
    EXPECT_NE(e.reason().find("Terrain-RGB"), std::string::npos) << e.what();
  }
  Image rgb16;
  rgb16.width = 1;
  rgb16.height = 1;
  rgb16.channels = 3;
  rgb16.bit_depth = 16;
  rgb16.pixels16 = {1, 2, 3};
  write_png((dir / "rgb16.png").string(), rgb16);
  EXPECT_THROW(read_heightfield((dir / "rgb16.png").string(), options), IoError);
  write_bytes(dir / "a.pgm", "P2 1 1 255 7");
  EXPECT_THROW(read_heightfield((dir / "a.pgm").string(), options), InvalidInput);
}

TEST(HeightFieldIo, OptionErrors) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_options");
  write_bytes(dir / "f.raw", std::string(16, '\0'));
  EXPECT_THROW(read_heightfield((dir / "f.raw").string()), InvalidInput);  // no raw size
  HeightFieldReadOptions options;
  options.raw_width = 2;
  options.raw_height = 2;
  EXPECT_EQ(read_heightfield((dir / "f.raw").string(), options).z, std::vector<float>(4, 0.0f));
  options.z_scale = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(read_heightfield((dir / "f.raw").string(), options), InvalidInput);
  options.z_scale = 1.0f;
  options.raw_width = 100000;
  options.raw_height = 100000;
  try {
    read_heightfield((dir / "f.raw").string(), options);
    ADD_FAILURE() << "absurd raw size accepted";
  } catch (const IoError& e) {
    EXPECT_NE(e.reason().find("absurd size"), std::string::npos) << e.what();
  }
  write_bytes(dir / "f.tif", "II*");
  try {
    read_heightfield((dir / "f.tif").string());
    ADD_FAILURE() << "unknown extension accepted";
  } catch (const IoError& e) {
    EXPECT_NE(e.reason().find(".tif"), std::string::npos) << e.what();
  }
}

TEST(HeightFieldIo, EveryBadRawFixtureThrowsIoError) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(varmesh::testing::test_data("bad"))) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("raw_", 0) != 0) continue;
    ++count;
    // raw_<what>_<W>x<H>.raw
    const std::string stem = entry.path().stem().string();
    const std::string dims = stem.substr(stem.rfind('_') + 1);
    HeightFieldReadOptions options;
    options.raw_width = std::stoul(dims.substr(0, dims.find('x')));
    options.raw_height = std::stoul(dims.substr(dims.find('x') + 1));
    const std::string path = entry.path().string();
    try {
      read_heightfield(path, options);
      ADD_FAILURE() << name << " was accepted";
    } catch (const IoError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_FALSE(e.reason().empty());
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(e.byte_offset(), IoError::kNoOffset) << e.what();
    }
  }
  EXPECT_GE(count, 5);
}

IoError raw_error(const std::string& fixture, std::size_t width, std::size_t height) {
  HeightFieldReadOptions options;
  options.raw_width = width;
  options.raw_height = height;
  try {
    read_heightfield(varmesh::testing::test_data("bad/" + fixture), options);
  } catch (const IoError& e) {
    return e;
  }
  ADD_FAILURE() << fixture << " was accepted";
  return IoError("", "");
}

TEST(HeightFieldIo, BadRawErrorsGiveReasonAndOffset) {
  const IoError short_file = raw_error("raw_size_mismatch_4x4.raw", 4, 4);
  EXPECT_EQ(short_file.byte_offset(), 60u);
  EXPECT_NE(short_file.reason().find("64"), std::string::npos) << short_file.what();
  EXPECT_EQ(raw_error("raw_too_long_2x2.raw", 2, 2).byte_offset(), 16u);
  const IoError nan = raw_error("raw_nan_2x2.raw", 2, 2);
  EXPECT_EQ(nan.byte_offset(), 8u);
  EXPECT_NE(nan.reason().find("NaN sample at (0, 1)"), std::string::npos) << nan.what();
  EXPECT_EQ(raw_error("raw_inf_3x1.raw", 3, 1).byte_offset(), 4u);
}

TEST(HeightFieldIo, BadPgmAndPngFixturesThrowIoErrorThroughTheFieldReader) {
  for (const char* fixture : {"pgm_truncated.pgm", "pgm_huge_dims.pgm", "pgm_maxval_zero.pgm",
                              "png_corrupt_crc.png", "png_huge_dims.png", "png_truncated.png"}) {
    EXPECT_THROW(read_heightfield(varmesh::testing::test_data(std::string("bad/") + fixture)), IoError) << fixture;
  }
}

TEST(HeightFieldIo, ValidateNamesTheProblem) {
  HeightField field = random_field(4, 3, 0.0f, 1.0f, 1);
  EXPECT_NO_THROW(field.validate());
  field.z[7] = std::numeric_limits<float>::infinity();
  try {
    field.validate();
    ADD_FAILURE() << "infinite sample accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.element(), 7u);
    EXPECT_NE(std::string(e.what()).find("(3, 1)"), std::string::npos) << e.what();
  }
  field.z[7] = 0.0f;
  field.z.pop_back();
  EXPECT_THROW(field.validate(), InvalidInput);
  EXPECT_THROW(HeightField{}.validate(), InvalidInput);
  HeightField bad_spacing = random_field(2, 2, 0.0f, 1.0f, 1);
  bad_spacing.spacing_y = 0.0f;
  EXPECT_THROW(bad_spacing.validate(), InvalidInput);
}

TEST(HeightFieldIo, FailedOrRejectedWritesLeaveNoFile) {
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_failed_write");
  const HeightField field = random_field(4, 4, 0.0f, 10.0f, 2);
  const auto missing = dir / "missing_folder";
  EXPECT_THROW(write_heightfield_pgm16((missing / "f.pgm").string(), field), IoError);
  EXPECT_THROW(write_heightfield_raw((missing / "f.raw").string(), field), IoError);
  HeightField nan_field = field;
  nan_field.z[5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(write_heightfield_pgm16((dir / "n.pgm").string(), nan_field), InvalidInput);
  EXPECT_THROW(write_heightfield_raw((dir / "n.raw").string(), nan_field), InvalidInput);
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(HeightFieldIo, FujiTerrainRgbMatchesDecodedRaw) {
  VARMESH_REQUIRE_SHARED(png_path, "terrain/fuji_terrain_rgb_512.png");
  VARMESH_REQUIRE_SHARED(raw_path, "terrain/fuji_elevation_512_f32le.raw");
  HeightFieldReadOptions options;
  options.decoding = PixelDecoding::kTerrainRgb;
  const HeightField fuji = read_heightfield(png_path, options);
  ASSERT_EQ(fuji.width, 512u);
  ASSERT_EQ(fuji.height, 512u);
  const auto [lo, hi] = std::minmax_element(fuji.z.begin(), fuji.z.end());
  EXPECT_NEAR(*lo, 13.7, 0.05);
  EXPECT_NEAR(*hi, 3751.0, 0.05);
  double sum = 0.0;
  for (float z : fuji.z) sum += z;
  EXPECT_NEAR(sum / static_cast<double>(fuji.z.size()), 929.3, 0.05);

  HeightFieldReadOptions raw_options;
  raw_options.raw_width = 512;
  raw_options.raw_height = 512;
  const HeightField raw = read_heightfield(raw_path, raw_options);
  ASSERT_EQ(raw.z.size(), fuji.z.size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < raw.z.size(); ++i) {
    if (std::abs(raw.z[i] - fuji.z[i]) > 0.01f && ++mismatches <= 5) {
      ADD_FAILURE() << "sample (" << i % 512 << ", " << i / 512 << "): png " << fuji.z[i] << " raw " << raw.z[i];
    }
  }
  EXPECT_EQ(mismatches, 0u);
  // The summit is not symmetric: a flipped row order would move it.
  EXPECT_EQ(std::max_element(raw.z.begin(), raw.z.end()) - raw.z.begin(), hi - fuji.z.begin());
}

TEST(HeightFieldIo, JacksboroPgmKeepsMetres) {
  VARMESH_REQUIRE_SHARED(path, "terrain/jacksboro_fault_dem_403x344.pgm");
  const HeightField dem = read_heightfield(path);
  EXPECT_EQ(dem.width, 403u);
  EXPECT_EQ(dem.height, 344u);
  const auto [lo, hi] = std::minmax_element(dem.z.begin(), dem.z.end());
  EXPECT_EQ(*lo, 236.0f);
  EXPECT_EQ(*hi, 1076.0f);
  EXPECT_EQ(dem.at(0, 0), 483.0f);  // first big-endian sample of the file, 0x01e3
  EXPECT_EQ(dem.at(1, 0), 487.0f);

  // Round trip through the 16-bit writer stays within half a step.
  const auto dir = varmesh::testing::scratch_dir("heightfield_io_jacksboro");
  write_heightfield_pgm16((dir / "dem.pgm").string(), dem);
  const HeightField back = read_heightfield((dir / "dem.pgm").string());
  const float half_step = (1076.0f - 236.0f) / 65535.0f / 2.0f + 1e-4f;
  for (std::size_t i = 0; i < dem.z.size(); ++i) ASSERT_NEAR(back.z[i], dem.z[i], half_step) << i;
}

}  // namespace
}  // namespace varmesh
