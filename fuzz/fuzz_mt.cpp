// Multi-Triangulation files (multitri/mt_io.hpp). The harness seals every input as an editor that re-seals
// a file would, so the fuzzer gets past the FNV-1a checksums: a version-2 header gets its size field (bytes
// 24..31) set to the input's size and its header checksum (bytes 32..39) recomputed; every input gets the
// whole-file checksum in its last eight bytes. Only IoError may escape decode_mt. An accepted Mt must pass
// Mt::validate(), re-encode to a file that decodes, and give a front through the query API (extract at an
// error threshold chosen from the input, then update to the full resolution and back to the coarsest) whose
// invariants hold and whose mesh passes TriMesh::validate().
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <string>
#include <string_view>

#include "fuzz_support.hpp"
#include "multitri/detail/binary_codec.hpp"
#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/mt_io.hpp"
#include "multitri/query.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace varmesh;
  std::string bytes(reinterpret_cast<const char*>(data), size);
  auto* b = reinterpret_cast<std::uint8_t*>(bytes.data());
  if (size >= 48 && fuzz::get_le(b + 8, 4) != 1) {
    fuzz::put_le(b + 24, size, 8);
    fuzz::put_le(b + 32, detail::fnv1a64(b, 32), 8);
  }
  if (size >= 8) fuzz::put_le(b + size - 8, detail::fnv1a64(b, size - 8), 8);
  Mt mt;
  try {
    mt = decode_mt(bytes, "fuzz.vrm");
  } catch (const IoError&) {
    return 0;
  } catch (const std::exception& e) {
    fuzz::finding("decode_mt threw something other than IoError:", e.what());
  }
  try {
    mt.validate();
    const Mt again = decode_mt(encode_mt(mt), "again.vrm");
    VARMESH_FUZZ_CHECK(again.num_nodes() == mt.num_nodes() && again.num_faces() == mt.num_faces());
    MtFront front(mt);
    Query q;
    // An error threshold from the first node's error scaled by an input byte (0: the full resolution).
    const float scale = static_cast<float>(data[size / 2]) / 64.0f;
    q.criterion = Criterion::object_error(mt.num_nodes() > 0 ? mt.bound(0).error * scale : 0.0f);
    extract(front, q);
    front.validate();
    front.to_mesh().validate();
    q.criterion = Criterion::object_error(0.0f);
    update(front, q);
    front.validate();
    front.to_mesh().validate();
    q.criterion = Criterion::object_error(std::numeric_limits<float>::infinity());
    update(front, q);
    front.validate();
    VARMESH_FUZZ_CHECK(front.num_faces() == mt.image_end(0) - mt.image_begin(0));
  } catch (const std::exception& e) {
    fuzz::finding("an accepted MT broke:", e.what());
  }
  return 0;
}
