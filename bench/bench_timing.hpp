#pragma once
// Timing shared by the benchmark programs: wall time and the CPU time of the process (all its threads). On a
// shared 2-core machine the CPU time leaves out the time other processes held the cores, which wall time
// does not. The benchmark programs run no threads of their own, so for the single-threaded code timed here it
// is the calling thread's CPU time (which this header measured until 2026-11-24); a parallel analysis
// (QemOptions::threads) counts the CPU time of all its threads.
// The medians and percentiles that the programs print from repeated laps are defined once here, quantile().
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <utility>
#include <vector>

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

/// The q-quantile (q in [0, 1], clamped) of the samples, 0 for none. Definition: sort, take the position
/// q (n - 1) among the order statistics and interpolate linearly between the two around it (Hyndman and
/// Fan's definition 7, the default of R and NumPy). The benchmarks' tables say "median", and a reader expects
/// the mean of the two middle values for an even count, which this gives; q = 0 and 1 give the minimum and
/// maximum. With 21 runs or fewer the 95th percentile lies between the two slowest.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double h = std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(h);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (h - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

inline double median(std::vector<double> v) { return quantile(std::move(v), 0.5); }

/// The laps of repeated runs of one thing, in run order; the tables print their medians and 95th percentiles.
struct Laps {
  std::vector<double> wall, cpu;  // seconds
  void add(const Lap& l) {
    wall.push_back(l.wall);
    cpu.push_back(l.cpu);
  }
  std::size_t size() const { return cpu.size(); }
  Lap quantile(double q) const { return {bench::quantile(wall, q), bench::quantile(cpu, q)}; }
  Lap med() const { return quantile(0.5); }
  Lap p95() const { return quantile(0.95); }
};

}  // namespace varmesh::bench
