#pragma once
// Timing shared by the benchmark programs: wall time and the CPU time of the calling thread. On a shared
// 2-core machine the thread's CPU time leaves out the time other processes held the core, which wall time
// does not; every timed piece of code in bench/ is single-threaded.
#include <time.h>

#include <chrono>

namespace varmesh::bench {

using Clock = std::chrono::steady_clock;

inline double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

inline double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Lap {
  double wall = 0.0, cpu = 0.0;  // seconds
};

/// Wall and thread-CPU time since construction.
class Stopwatch {
 public:
  Stopwatch() : wall_(Clock::now()), cpu_(thread_cpu_seconds()) {}
  Lap lap() const { return {seconds_since(wall_), thread_cpu_seconds() - cpu_}; }

 private:
  Clock::time_point wall_;
  double cpu_;
};

}  // namespace varmesh::bench
