#include "multitri/file_util.hpp"

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <algorithm>
#include <system_error>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "multitri/errors.hpp"

namespace varmesh {

namespace {

std::string describe(std::filesystem::file_type type) {
  switch (type) {
    case std::filesystem::file_type::fifo: return "a named pipe (FIFO)";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::socket: return "a socket";
    default: return "not a regular file";
  }
}

// The recorded paths. A slot's state says what its buffer holds: a writer claims a free slot (kFree ->
// kWriting), copies the path in and publishes it (kFile or kFolder, release order); the signal handler reads
// only published slots. Forgetting a slot frees it. Static storage: nothing is allocated in a handler.
enum SlotState : int { kFree = 0, kWriting, kFile, kFolder };
struct CleanupSlot {
  std::atomic<int> state{kFree};
  std::array<char, InterruptCleanup::kMaxPath + 1> path{};
};
std::array<CleanupSlot, InterruptCleanup::kMaxEntries> g_cleanup;
static_assert(std::atomic<int>::is_always_lock_free, "the handler reads the slots' states");

extern "C" void cleanup_and_reraise(int sig) {
  InterruptCleanup::remove_recorded();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

int InterruptCleanup::add(const std::string& path, bool folder) {
  if (path.empty() || path.size() > kMaxPath) return -1;
  for (std::size_t i = 0; i < kMaxEntries; ++i) {
    int expected = kFree;
    CleanupSlot& s = g_cleanup[i];
    if (!s.state.compare_exchange_strong(expected, kWriting, std::memory_order_acquire)) continue;
    std::memcpy(s.path.data(), path.data(), path.size());
    s.path[path.size()] = '\0';
    s.state.store(folder ? kFolder : kFile, std::memory_order_release);
    return static_cast<int>(i);
  }
  return -1;
}

void InterruptCleanup::forget(int slot) {
  if (slot >= 0 && static_cast<std::size_t>(slot) < kMaxEntries)
    g_cleanup[static_cast<std::size_t>(slot)].state.store(kFree, std::memory_order_release);
}

std::size_t InterruptCleanup::pending() {
  std::size_t n = 0;
  for (const CleanupSlot& s : g_cleanup) n += s.state.load(std::memory_order_acquire) >= kFile;
  return n;
}

void InterruptCleanup::remove_recorded() {
  // Files first, then folders: a folder is removed only once empty, and a staging folder holds recorded
  // files and the folders made for it are nested, so the folders are tried until a round removes none.
  for (CleanupSlot& s : g_cleanup)
    if (s.state.load(std::memory_order_acquire) == kFile) ::unlink(s.path.data());
  for (bool removed = true; removed;) {
    removed = false;
    for (CleanupSlot& s : g_cleanup)
      if (s.state.load(std::memory_order_acquire) == kFolder && ::rmdir(s.path.data()) == 0) {
        s.state.store(kFree, std::memory_order_release);
        removed = true;
      }
  }
}

void InterruptCleanup::install_handlers() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) {
    struct sigaction sa {};
    sa.sa_handler = cleanup_and_reraise;
    sigemptyset(&sa.sa_mask);
    // The other signals wait while one runs the cleanup.
    for (const int other : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) sigaddset(&sa.sa_mask, other);
    sa.sa_flags = SA_RESETHAND;
    sigaction(sig, &sa, nullptr);
  }
}

FileBytes read_file_bytes(const std::string& path) {
  // A folder opens as a stream on Linux, and seeking to its end reports a size of up to 2^63 bytes. A FIFO
  // blocks the open until something writes to it (forever, with no writer), and a device reads as empty or
  // endless: none of them has a size to read, so only a regular file (links followed) is opened; fstat()
  // then checks the file that was opened.
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (std::filesystem::is_directory(st)) throw IoError(path, "cannot read: it is a folder, not a file");
  if (std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
    throw IoError(path, "cannot read: it is " + describe(st.type()) + ", not a regular file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat info {};
  if (::fstat(fd, &info) != 0) throw IoError(path, std::string("cannot determine the file size: ") + std::strerror(errno));
  if (!S_ISREG(info.st_mode)) throw IoError(path, "cannot read: it is not a regular file");
  if (info.st_size < 0) throw IoError(path, "cannot determine the file size");
  const auto size = static_cast<std::size_t>(info.st_size);
  FileBytes out;
  out.bytes_.reset(new char[size > 0 ? size : 1]);  // default-initialised: not zeroed
  out.size_ = size;
  // [lo, hi) by pread(); the error (errno) or -1 when the file ended first, 0 on success.
  auto read_range = [fd, buf = out.bytes_.get()](std::size_t lo, std::size_t hi) -> int {
    constexpr std::size_t kChunk = std::size_t{1} << 30;  // Linux moves at most ~2 GiB per call
    while (lo < hi) {
      const ssize_t got = ::pread(fd, buf + lo, std::min(hi - lo, kChunk), static_cast<off_t>(lo));
      if (got < 0) {
        if (errno == EINTR) continue;
        return errno;
      }
      if (got == 0) return -1;
      lo += static_cast<std::size_t>(got);
    }
    return 0;
  };
  int first = 0, second = 0;
  const std::size_t mid = size >= kParallelReadBytes ? size / 2 : size;
  std::thread other;
  if (mid < size) {
    try {
      other = std::thread([&] { second = read_range(mid, size); });
    } catch (const std::system_error&) {  // no thread to be had: read it all here
      second = read_range(mid, size);
    }
  }
  first = read_range(0, mid);
  if (other.joinable()) other.join();
  for (const int r : {first, second}) {
    if (r == -1) throw IoError(path, "read failed: the file became shorter while it was read");
    if (r != 0) throw IoError(path, std::string("read failed: ") + std::strerror(r));
  }
  return out;
}

std::string read_file(const std::string& path) { return std::string(read_file_bytes(path).view()); }

std::string bounded_file_name(const std::string& prefix, const std::string& name, const std::string& suffix) {
  constexpr std::size_t kNameMax = 255;
  const std::size_t fixed = prefix.size() + suffix.size();
  return prefix + name.substr(0, fixed < kNameMax ? kNameMax - fixed : 0) + suffix;
}

std::filesystem::path resolve_output_path(const std::string& path) {
  namespace fs = std::filesystem;
  // As many links as the kernel follows (MAXSYMLINKS on Linux).
  constexpr int kMaxLinks = 40;
  fs::path p(path);
  for (int links = 0;; ++links) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    const std::string via = links == 0 ? "" : " (the symbolic link's target " + p.string() + ")";
    switch (st.type()) {
      case fs::file_type::not_found:
      case fs::file_type::regular:
      case fs::file_type::none:  // unknown (ec set): the write itself reports why
        return p;
      case fs::file_type::directory:
        throw IoError(path, "is a folder" + via + ": the file cannot be put there");
      case fs::file_type::symlink: {
        if (links == kMaxLinks) throw IoError(path, "too many levels of symbolic links");
        const fs::path target = fs::read_symlink(p, ec);
        if (ec) throw IoError(path, "cannot read the symbolic link: " + ec.message());
        p = target.is_absolute() ? target : p.parent_path() / target;
        break;
      }
      default:
        throw IoError(path, "is " + describe(st.type()) + via +
                                ": only a regular file can be replaced by the output (nothing was written)");
    }
  }
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  namespace fs = std::filesystem;
  if (fs::path(path).filename().empty()) throw IoError(path, "not a file name");
  const fs::path target = resolve_output_path(path);
  // A unique temporary name next to the file replaced keeps the rename on one file system.
  std::random_device rd;
  const fs::path tmp =
      target.parent_path() / bounded_file_name(".tmp.", target.filename().string(), "." + std::to_string(rd()));
  const CleanupGuard cleanup(tmp.string(), false);
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw IoError(path, std::string("cannot create a temporary file: ") + std::strerror(errno));
    errno = 0;
    const bool ok = std::fwrite(contents.data(), 1, contents.size(), f) == contents.size() && std::fflush(f) == 0;
    const int write_errno = errno;
    const bool closed = std::fclose(f) == 0;
    if (!ok || !closed) {
      const int why = ok ? errno : write_errno;
      std::error_code ec;
      fs::remove(tmp, ec);
      throw IoError(path, "write failed" + (why ? ": " + std::string(std::strerror(why)) : std::string(" (disk full?)")));
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
