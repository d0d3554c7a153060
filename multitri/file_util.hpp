#pragma once
/// Whole-file reading and atomic writing, shared by every reader and writer.
#include <filesystem>
#include <string>

namespace varmesh {

/// Reads a whole file into memory. Throws IoError (a folder, a FIFO, a device or a socket, which are refused
/// before they are opened; or a file that cannot be opened or read).
std::string read_file(const std::string& path);

/// Where a write to `path` lands, by the output policy of every writer: `path` itself when it is a regular
/// file or does not exist; when it is a symbolic link (chains followed, relative targets taken from the
/// link's folder), the file the link points to, which need not exist (a dangling link is written through
/// and stays a link). Throws IoError naming `path` when the file it would replace is a folder or not a
/// regular file (a FIFO, a device, a socket: writing over one would replace it by a regular file), or when
/// the links loop. A path whose type cannot be read (e.g. a folder without search permission) is returned
/// as it is: the write then fails and says why.
std::filesystem::path resolve_output_path(const std::string& path);

/// `prefix` + `name` + `suffix` as one file name of at most 255 bytes (NAME_MAX of Linux file systems), `name`
/// cut to fit. Temporary files are named after the file they replace: a name near the limit is valid, and
/// its temporary name must be too (a 250-byte output name failed with "File name too long").
std::string bounded_file_name(const std::string& prefix, const std::string& name, const std::string& suffix);

/// Writes `contents` to `path` atomically: a temporary file in the folder of resolve_output_path(path),
/// flushed, then renamed over that file (so a symbolic link at `path` keeps pointing to the new file). On
/// any failure the temporary file is removed and IoError naming `path` is thrown; `path` is left untouched.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace varmesh
