#pragma once
/// Saving and loading a VertexHierarchy (vertex_hierarchy.hpp) as a versioned binary file with a checksum.
///
/// The file holds only the arrays the analysis produced; the loader hands them to
/// VertexHierarchyBuilder::finish, which recomputes the derived arrays (parents, face creators, roots, base
/// faces, node keys) and re-validates the whole hierarchy, the replay of every collapse on the original
/// faces included (VertexHierarchy::validate), so a loaded hierarchy is as trustworthy as a freshly built
/// one even when the file was edited and re-sealed. That replay is most of the load time; on a large
/// hierarchy validate() splits it over two threads, and the checksum and the untrusted checks run beside
/// the parse and the derivation (the 437k-vertex dragon's 89 MB file: 0.48 s with two free cores, 0.78 s
/// all on one thread as before; a busy second core takes the gain back, the split costing a tenth more
/// processor time). Re-encoding a loaded hierarchy gives the same bytes.
///
/// Layout, format version 1. Every field is little-endian whatever the host; f32 is IEEE-754 binary32, u32
/// and u64 are unsigned. N = L + C nodes; an array is present only where its condition says so.
///
///     offset  size                field
///     0       8                   magic "VMPMHIER"
///     8       4     u32           format version (1)
///     12      4     u32           flags: bit 0 colours present, bit 1 locked flags present; other bits 0
///     16      8     u64           total file size in bytes, checksum included
///     24      8     u64           L  leaves
///     32      8     u64           C  collapses
///     40      8     u64           F  original faces
///     48      8     u64           R  stored ring items
///     56            arrays, back to back:
///                   N x 3 f32     positions
///                   N x 3 f32     colours                 (flag bit 0)
///                   C x 10 u32    collapse records: vt, vu, vl_hat, vr_hat, fl_hat, fr_hat, fn[0..3]
///                   F x 3 u32     face corners (leaves)
///                   N x 9 f32     bounds: centre xyz, radius, error, cone axis xyz, cone cos_half_angle
///                   (C+1) x u32   stored ring offsets (0, non-decreasing, last = R)
///                   R x u32       stored ring items
///                   L x u32       leaf_to_input
///                   F x u32       face_to_input
///                   L x u8        locked, 0 or 1          (flag bit 1)
///                   9 x u64       repair report: input_vertices, input_faces, unreferenced_vertices,
///                                 degenerate_faces, duplicate_faces, nonmanifold_edge_faces,
///                                 nonmanifold_vertices, added_vertex_copies, locked_vertices
///     size-4  4     u32           CRC-32 (ISO-HDLC, the one of zlib's crc32()) of every byte before it
///
/// Reading checks, in this order, before allocating anything: the magic, the version, the flags, the
/// declared size against the real size (a shorter file is "truncated" at the byte where it ends), every
/// count against the format's 32-bit indices and against the file size, then the checksum (on a file of
/// 4 MiB or more, computed on a second thread while the arrays are parsed; a mismatch is still the error
/// reported, whatever the parse finds); then it parses
/// (non-finite floats, locked flags other than 0/1 and decreasing ring offsets are rejected with their byte
/// offset) and runs VertexHierarchyBuilder::finish. Every failure is an IoError carrying the file name, the
/// byte offset when there is one (IoError::byte_offset()) and the reason; finish's complaints (InvalidInput,
/// or std::logic_error from validate()) come back as IoError with the file name and their message.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

/// Current format version written by encode_vertex_hierarchy; the reader accepts exactly this version.
inline constexpr std::uint32_t kVertexHierarchyFormatVersion = 1;

/// The file image of `h` in the layout above. Throws InvalidInput for a hierarchy that could not be read
/// back: never built (no leaf: a default-constructed VertexHierarchy), or with a colour outside [0, 1] (from
/// an input mesh with such colours). O(size of h).
std::vector<std::uint8_t> encode_vertex_hierarchy(const VertexHierarchy& h);

/// Rebuilds a hierarchy from a file image. `name_for_errors` is the file name IoError reports. Throws
/// IoError as described above; never allocates more than a small multiple of bytes.size(), whatever the
/// counts say. O(bytes.size()).
VertexHierarchy decode_vertex_hierarchy(std::span<const std::uint8_t> bytes, const std::string& name_for_errors);

/// Writes encode_vertex_hierarchy(h) to `path` atomically (temporary file + rename): on failure IoError is
/// thrown and `path` is left as it was. Throws InvalidInput, before touching the file system, as encode does.
void write_vertex_hierarchy(const std::string& path, const VertexHierarchy& h);

/// Reads a file written by write_vertex_hierarchy. Throws IoError when the file cannot be read or is not a
/// valid hierarchy file of this version (see above), naming `path`.
VertexHierarchy read_vertex_hierarchy(const std::string& path);

}  // namespace varmesh
