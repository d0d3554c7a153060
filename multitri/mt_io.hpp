#pragma once
/// Multi-Triangulation files (.vrm): any Mt (regular 4-8, semi-regular, adaptive, simplification-based)
/// saved as a versioned little-endian binary with checksums, and loaded back through MtBuilder so that the
/// MT definition is re-checked and the bounds are recomputed exactly as when it was built.
///
/// Layout, format version 2. Every integer is little-endian and unsigned; f32 is IEEE-754 binary32.
///
///     offset  size
///     0       8          magic "VMSHMT\r\n" (the CR LF catches text-mode transfers)
///     8       4   u32    format version (2)
///     12      4   u32    V  vertices
///     16      4   u32    F  faces
///     20      4   u32    N  nodes, the source included
///     24      8   u64    total file size in bytes, checksum included
///     32      8   u64    header checksum: FNV-1a 64 of bytes 0 .. 31
///     40                 V x (f32 x, y, z)
///                        F x (u32 a, b, c)
///                        u32 size of the source's image (the base faces are faces 0 .. size-1)
///                        for nodes 1 .. N-1: u8 kind, f32 error, u32 removed count R, R x u32 removed face,
///                          u32 image size (faces are numbered by creator, so node n's image is the next
///                          `image size` faces)
///     size-8  8   u64    FNV-1a 64 of every byte before it
///
/// Version 1 (still read, no longer written) is the same without the bytes 24 .. 39: the positions start at
/// byte 24.
///
/// Reading checks, in this order, before allocating anything: the magic, the version (below), that the header
/// is complete, the header checksum, the declared size against the real size, the header's counts against the
/// size, then the checksum of the whole file; then it parses (non-finite numbers, unknown node kinds,
/// negative errors, indices and counts out of range are refused with their byte offset) and hands the MT to
/// MtBuilder. Because the header carries its own checksum, a file shorter than it declares is reported as
/// "truncated" (with the byte count it has, the count it should have, and the element where the data
/// stops), and damage that keeps the length as "checksum mismatch". A version-1 file does not record its
/// size: a cut one is reported as "truncated, or a count is damaged".
///
/// The checksums cover the version field, so a version field that does not read 2 is judged by them: the
/// file is "corrupt" (the version field is damaged) when the header checksum matches with the field read as
/// 2, or, for a field that reads neither 1 nor 2, when the whole file's checksum matches with it read as 1,
/// or when the file is laid out as version 2 (its size field holds its size) but its header checksum fails.
/// It is of an "unsupported MT file version" when the header checksum matches the field as it is (an intact
/// header of another version) or when no checksum matches at all (a newer layout, or worse damage). A field
/// that reads 1 is read as version 1 unless the first test says otherwise.
#include <cstdint>
#include <string>
#include <string_view>

#include "multitri/mt.hpp"

namespace varmesh {

/// Format version written by encode_mt; decode_mt reads this version and version 1.
inline constexpr std::uint32_t kMtFormatVersion = 2;

/// Encodes `mt` in the layout above (O(size)). Throws InvalidInput for an Mt with no node
/// (default-constructed or moved-from: it has no source, and MtBuilder never builds one).
std::string encode_mt(const Mt& mt);
/// Decodes; `name` is the file name in error messages. Throws IoError (name, byte offset, reason) on a bad
/// magic, an unsupported or damaged version field, a truncated file, a checksum mismatch, counts larger than
/// the file can hold, non-finite numbers, or an MT that MtBuilder rejects (see above for the order). Never
/// allocates more than a small multiple of bytes.size(), whatever the counts say.
Mt decode_mt(std::string_view bytes, const std::string& name);

/// Writes atomically (temporary file + rename): a failure leaves no file. Throws InvalidInput as encode_mt
/// does (before touching the file system) and IoError.
void write_mt(const std::string& path, const Mt& mt);
/// Reads and decodes. Throws IoError as decode_mt does (and when the file cannot be read).
Mt read_mt(const std::string& path);

}  // namespace varmesh
