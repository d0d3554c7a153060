#pragma once
/// Whole-file reading and atomic writing, shared by every reader and writer.
#include <string>

namespace varmesh {

/// Reads a whole file into memory. Throws IoError (a folder, or a file that cannot be opened or read).
std::string read_file(const std::string& path);

/// Writes `contents` to `path` atomically: a temporary file in the same folder, flushed, then renamed over
/// `path`. On any failure the temporary file is removed and IoError is thrown; `path` is left untouched.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace varmesh
