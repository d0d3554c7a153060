#pragma once
// Timing shared by the benchmark programs: wall time and the CPU time of the process (all its threads). On a
// shared 2-core machine the CPU time leaves out the time other processes held the cores, which wall time
// does not. The benchmark programs run no threads of their own, so for the single-threaded code timed here it
// is the calling thread's CPU time (which this header measured until 2026-11-24); a parallel analysis
// (QemOptions::threads) counts the CPU time of all its threads.
#include <time.h>

#include <chrono>

namespace varmesh::bench {

using Clock = std::chrono::steady_clock;

inline double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The calling thread's CPU time (bench/subdiv_bench.cpp's phase breakdown).
inline double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

inline double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Lap {
  double wall = 0.0, cpu = 0.0;  // seconds
};

/// Wall and process CPU time since construction.
class Stopwatch {
 public:
  Stopwatch() : wall_(Clock::now()), cpu_(process_cpu_seconds()) {}
  Lap lap() const { return {seconds_since(wall_), process_cpu_seconds() - cpu_}; }

 private:
  Clock::time_point wall_;
  double cpu_;
};

}  // namespace varmesh::bench
