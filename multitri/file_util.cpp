#include "multitri/file_util.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "multitri/errors.hpp"

namespace varmesh {

std::string read_file(const std::string& path) {
  // A folder opens as a stream on Linux, and seeking to its end reports a size of up to 2^63 bytes.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw IoError(path, "cannot read: it is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
  std::string data;
  in.seekg(0, std::ios::end);
  const auto size = in.tellg();
  if (size < 0) throw IoError(path, "cannot determine the file size");
  data.resize(static_cast<std::size_t>(size));
  in.seekg(0, std::ios::beg);
  if (size > 0 && !in.read(data.data(), size)) throw IoError(path, "read failed");
  return data;
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (target.filename().empty()) throw IoError(path, "not a file name");
  // A unique temporary name next to the target keeps the rename on one file system.
  std::random_device rd;
  const fs::path tmp = target.parent_path() / (".tmp." + target.filename().string() + "." + std::to_string(rd()));
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw IoError(path, std::string("cannot create a temporary file: ") + std::strerror(errno));
    const bool ok = std::fwrite(contents.data(), 1, contents.size(), f) == contents.size() && std::fflush(f) == 0;
    const bool closed = std::fclose(f) == 0;
    if (!ok || !closed) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw IoError(path, "write failed (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw IoError(path, "cannot rename the temporary file into place: " + ec.message());
  }
}

}  // namespace varmesh
