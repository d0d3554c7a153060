// Vertex hierarchy files (pm/hierarchy_io.hpp). The fuzzer cannot forge a CRC-32, so the harness seals
// every input first, as an editor that re-seals a file would: the size field (bytes 16..23) is set to the
// input's size and the CRC of every byte before the last four is written into them. The decoder then
// reaches the array checks, VertexHierarchyBuilder::finish and VertexHierarchy::validate(). Only IoError may
// escape decoding; an accepted hierarchy must re-encode to the same bytes and survive an SrMesh round (refine
// everything, coarsen everything) under one of the three schemes with its invariants intact.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <vector>

#include <zlib.h>

#include "fuzz_support.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/sr_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace varmesh;
  std::vector<std::uint8_t> bytes(data, data + size);
  if (size >= 24) fuzz::put_le(bytes.data() + 16, size, 8);
  std::uint32_t crc = 0;
  if (size >= 4) {
    crc = static_cast<std::uint32_t>(::crc32_z(::crc32_z(0L, Z_NULL, 0), bytes.data(), size - 4));
    fuzz::put_le(bytes.data() + size - 4, crc, 4);
  }
  VertexHierarchy h;
  try {
    h = decode_vertex_hierarchy(bytes, "fuzz.vmh");
  } catch (const IoError&) {
    return 0;
  } catch (const std::exception& e) {
    fuzz::finding("decode threw something other than IoError:", e.what());
  }
  try {
    h.validate();
    VARMESH_FUZZ_CHECK(encode_vertex_hierarchy(h) == bytes);
    const RefinementScheme schemes[] = {RefinementScheme::kKimLee, RefinementScheme::kHoppe97,
                                        RefinementScheme::kXiaVarshney};
    SrMesh sr(h, schemes[crc % 3]);
    sr.validate();
    VARMESH_FUZZ_CHECK(sr.num_active_vertices() == h.num_roots());
    sr.refine_all();
    sr.validate();
    VARMESH_FUZZ_CHECK(sr.num_active_vertices() == h.num_leaves());
    VARMESH_FUZZ_CHECK(sr.num_faces() == h.num_faces());
    sr.to_mesh().validate();
    sr.coarsen_all();
    sr.validate();
    VARMESH_FUZZ_CHECK(sr.num_active_vertices() == h.num_roots());
  } catch (const std::exception& e) {
    fuzz::finding("an accepted hierarchy broke:", e.what());
  }
  return 0;
}
