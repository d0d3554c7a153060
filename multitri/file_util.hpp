#pragma once
/// Whole-file reading and atomic writing, shared by every reader and writer.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace varmesh {

/// A whole file's bytes, as read_file_bytes() read them (an uninitialised buffer the reads fill: nothing is
/// zeroed first, which took a third of the time of reading an 89 MB hierarchy file).
class FileBytes {
 public:
  FileBytes() = default;
  const char* data() const noexcept { return bytes_.get(); }
  std::size_t size() const noexcept { return size_; }
  std::string_view view() const noexcept { return {bytes_.get(), size_}; }
  operator std::string_view() const noexcept { return view(); }

 private:
  friend FileBytes read_file_bytes(const std::string& path);
  std::unique_ptr<char[]> bytes_;
  std::size_t size_ = 0;
};

/// Reads a whole file into memory. Throws IoError (a folder, a FIFO, a device or a socket, which are refused
/// before they are opened; or a file that cannot be opened or read, or that shrinks while it is read). A file
/// of kParallelReadBytes or more is read as two halves at once (two threads: the copy out of the page cache
/// is the cost, and it halves).
FileBytes read_file_bytes(const std::string& path);
inline constexpr std::size_t kParallelReadBytes = std::size_t{16} << 20;

/// read_file_bytes() as a string.
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

/// Files and folders to remove if the process is interrupted before it removes or renames them itself: the
/// temporary files of write_file_atomically() and, in the command line tool, its staging folders. An entry
/// holds its own copy of the path (at most kMaxPath bytes; longer paths and entries beyond kMaxEntries are
/// not recorded, the cleanup being best effort). Registering and forgetting take a lock-free slot and may be
/// called from any thread.
class InterruptCleanup {
 public:
  static constexpr std::size_t kMaxEntries = 128, kMaxPath = 1024;
  /// Records `path` (a file to unlink, or an empty folder to remove); returns its slot, or -1 when it was not
  /// recorded.
  static int add(const std::string& path, bool folder);
  /// Forgets the entry of slot `slot` (nothing for -1).
  static void forget(int slot);
  /// Entries recorded now (for tests).
  static std::size_t pending();
  /// Installs handlers of SIGINT, SIGTERM, SIGHUP and SIGPIPE that remove the recorded files, then the
  /// recorded folders (those left empty), and then end the process by the same signal with its default
  /// action (the exit status still says which signal ended it). Only async-signal-safe calls are made in
  /// the handler (unlink, rmdir, signal, raise).
  static void install_handlers();
  /// What the handlers do before the signal's default action (for tests): removes what is recorded.
  static void remove_recorded();
};

/// An entry of InterruptCleanup for the life of the object.
class CleanupGuard {
 public:
  CleanupGuard(const std::string& path, bool folder) : slot_(InterruptCleanup::add(path, folder)) {}
  ~CleanupGuard() { InterruptCleanup::forget(slot_); }
  CleanupGuard(const CleanupGuard&) = delete;
  CleanupGuard& operator=(const CleanupGuard&) = delete;

 private:
  int slot_;
};

/// Writes `contents` to `path` atomically: a temporary file in the folder of resolve_output_path(path),
/// flushed, then renamed over that file (so a symbolic link at `path` keeps pointing to the new file). On
/// any failure the temporary file is removed and IoError naming `path` is thrown; `path` is left untouched.
/// The temporary file is recorded in InterruptCleanup while it exists.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace varmesh
