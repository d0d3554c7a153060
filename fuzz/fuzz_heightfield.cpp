// Height field readers (multitri/heightfield.hpp: PGM, PNG, raw float32) and through them read_png and
// read_pgm. The readers take a path only, so the harness writes each input to a file in /dev/shm (memory)
// named by its process. Input: byte 0 chooses the format (low two bits: .pgm, .png, .raw, .png with
// Terrain-RGB decoding); for .raw, bytes 1 and 2 are the width and height; the rest is the file. Only
// IoError (and InvalidInput, for the option combinations the header lists) may escape; an accepted field
// must pass HeightField::validate() and hold width * height samples.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>

#include "fuzz_support.hpp"
#include "multitri/heightfield.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace varmesh;
  if (size < 3) return 0;
  static const char* const kExtensions[] = {".pgm", ".png", ".raw", ".png"};
  const int format = data[0] & 3;
  const std::string path = "/dev/shm/varmesh_fuzz_" + std::to_string(::getpid()) + kExtensions[format];
  HeightFieldReadOptions options;
  if (format == 3) options.decoding = PixelDecoding::kTerrainRgb;
  if (format == 2) {
    options.raw_width = data[1];
    options.raw_height = data[2];
  }
  if (std::FILE* f = std::fopen(path.c_str(), "wb")) {
    const bool ok = std::fwrite(data + 3, 1, size - 3, f) == size - 3;
    if (std::fclose(f) != 0 || !ok) return 0;
  } else {
    return 0;
  }
  HeightField field;
  const bool accepted = fuzz::run_expecting_only_documented_errors([&] { field = read_heightfield(path, options); });
  std::remove(path.c_str());
  if (!accepted) return 0;
  fuzz::run_expecting_no_error([&] { field.validate(); });
  VARMESH_FUZZ_CHECK(field.z.size() == field.width * field.height && field.width > 0 && field.height > 0);
  return 0;
}
