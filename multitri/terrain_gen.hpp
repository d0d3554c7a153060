#pragma once
/// Generated height fields for tests, demos and benchmarks (no data files needed).
#include <cstddef>
#include <cstdint>

#include "multitri/heightfield.hpp"

namespace varmesh {

/// Fractal terrain: fractional Brownian motion of value noise (octaves of smoothly interpolated lattice
/// noise, each twice the frequency and `persistence` times the amplitude of the previous one) with a ridge
/// transform. Heights in [0, amplitude] (all 0 when the noise is flat); deterministic for a seed. Spacing 1.
/// Throws InvalidInput unless 2 <= width, height <= 32768, 1 <= octaves <= 20, amplitude is finite and
/// >= 0, and persistence is finite and small enough for the octave sum to stay finite (|persistence| to
/// the power octaves - 1 below about 1e38). O(width * height * octaves).
HeightField make_fractal_terrain(std::size_t width, std::size_t height, std::uint32_t seed, float amplitude = 100.0f,
                                 int octaves = 8, float persistence = 0.5f);

}  // namespace varmesh
