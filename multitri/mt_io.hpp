#pragma once
/// Multi-Triangulation files (.vrm): any Mt (regular 4-8, semi-regular, adaptive, simplification-based)
/// saved as a versioned little-endian binary with a checksum, and loaded back through MtBuilder so that the
/// MT definition is re-checked and the bounds are recomputed exactly as when it was built.
///
/// Layout (version 1), all integers little-endian:
///   magic "VMSHMT\r\n" (8 bytes; the CR LF catches text-mode transfers), u32 version = 1,
///   u32 num_vertices V, u32 num_faces F, u32 num_nodes N (source included),
///   V x (f32 x, y, z), F x (u32 a, b, c),
///   u32 size of the source's image (the base faces are faces 0 .. size-1),
///   for nodes 1 .. N-1: u8 kind, f32 error, u32 removed count R, R x u32 removed face, u32 image size
///     (faces are numbered by creator, so node n's image is the next `image size` faces),
///   u64 FNV-1a 64 checksum of all preceding bytes.
#include <cstdint>
#include <string>
#include <string_view>

#include "multitri/mt.hpp"

namespace varmesh {

/// Encodes `mt` (O(size)). Throws InvalidInput for an Mt with no node (default-constructed or moved-from:
/// it has no source, and MtBuilder never builds one).
std::string encode_mt(const Mt& mt);
/// Decodes; `name` is used in error messages. Throws IoError (name, byte offset, reason) on a bad magic,
/// an unsupported version, a truncated file, counts larger than the file can hold (checked before any
/// allocation), non-finite numbers, a checksum mismatch, or an MT that MtBuilder rejects.
Mt decode_mt(std::string_view bytes, const std::string& name);

/// Writes atomically (temporary file + rename): a failure leaves no file. Throws InvalidInput as encode_mt
/// does (before touching the file system) and IoError.
void write_mt(const std::string& path, const Mt& mt);
/// Reads and decodes. Throws IoError as decode_mt does (and when the file cannot be read).
Mt read_mt(const std::string& path);

}  // namespace varmesh
