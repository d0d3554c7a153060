#include "multitri/terrain_gen.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

// A small integer hash (Wang/Jenkins mix) turned into a value in [0, 1).
float lattice_value(std::int64_t x, std::int64_t y, std::uint32_t seed) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                    (std::uint64_t(seed) << 17);
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ull;
  h ^= h >> 33;
  return static_cast<float>(h >> 40) / static_cast<float>(1ull << 24);
}

float smooth(float t) { return t * t * (3.0f - 2.0f * t); }

float value_noise(float x, float y, std::uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const float tx = smooth(x - fx), ty = smooth(y - fy);
  const float a = lattice_value(ix, iy, seed), b = lattice_value(ix + 1, iy, seed);
  const float c = lattice_value(ix, iy + 1, seed), d = lattice_value(ix + 1, iy + 1, seed);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

}  // namespace

HeightField make_fractal_terrain(std::size_t width, std::size_t height, std::uint32_t seed, float amplitude,
                                 int octaves, float persistence) {
  if (width < 2 || height < 2 || width > (1u << 15) || height > (1u << 15))
    throw InvalidInput("make_fractal_terrain: sizes must be in [2, 32768]");
  if (octaves < 1 || octaves > 20) throw InvalidInput("make_fractal_terrain: octaves must be in [1, 20]");
  if (!std::isfinite(amplitude) || !(amplitude >= 0.0f))
    throw InvalidInput("make_fractal_terrain: amplitude " + std::to_string(amplitude) + " is not finite and >= 0");
  if (!std::isfinite(persistence))
    throw InvalidInput("make_fractal_terrain: persistence " + std::to_string(persistence) + " is not finite");
  HeightField f;
  f.width = width;
  f.height = height;
  f.z.resize(width * height);
  const float base = 4.0f / static_cast<float>(std::max(width, height));
  float lo = 1e30f, hi = -1e30f;
  for (std::size_t y = 0; y < height; ++y)
    for (std::size_t x = 0; x < width; ++x) {
      float sum = 0.0f, amp = 1.0f, freq = base;
      for (int o = 0; o < octaves; ++o) {
        // Ridged octaves for the first few (mountain crests), plain noise for the detail.
        float n = value_noise(static_cast<float>(x) * freq, static_cast<float>(y) * freq, seed + static_cast<std::uint32_t>(o));
        if (o < 3) n = 1.0f - std::abs(2.0f * n - 1.0f);
        sum += amp * n;
        amp *= persistence;
        freq *= 2.0f;
      }
      f.z[y * width + x] = sum;
      lo = std::min(lo, sum);
      hi = std::max(hi, sum);
    }
  if (!std::isfinite(lo) || !std::isfinite(hi) || !std::isfinite(hi - lo))
    throw InvalidInput("make_fractal_terrain: persistence " + std::to_string(persistence) +
                       " makes the octave sum overflow");
  const float scale = hi > lo ? amplitude / (hi - lo) : 0.0f;
  for (float& v : f.z) v = (v - lo) * scale;
  return f;
}

}  // namespace varmesh
