#pragma once
/// Reading one file out of a tar archive, plain or gzip-compressed, without unpacking the rest: how the
/// tool takes models from Debian packages that ship them inside a .tar.gz (libcgal-demo's data.tar.gz holds
/// the cow and a bunny).
///
/// Formats read: POSIX ustar and the older v7 headers, with the GNU long-name entry ('L') and the pax
/// extended header's `path` record for names over 100 characters, sizes in octal or GNU base-256. Member
/// names match exactly or with a leading "./". Only regular files are returned.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace varmesh {

/// Reads the member `member` of the tar archive `archive` (gzip-compressed or not: zlib tells them apart).
/// Returns std::nullopt when the archive ends without a regular file of that name. Reads the archive once,
/// front to back, decompressing but not keeping the members before the one asked for.
/// Throws IoError naming the archive and the byte offset in the uncompressed stream: the file cannot be
/// opened, a header fails its checksum or has a malformed size, the archive or its compressed stream ends
/// early or is corrupt, or the member is larger than `max_bytes`.
std::optional<std::string> read_tar_member(const std::string& archive, std::string_view member,
                                           std::uint64_t max_bytes = std::uint64_t{1} << 30);

}  // namespace varmesh
