#pragma once
// The one clock every phase timing, throughput figure and report uses: monotonic wall time. Beside it, CPU time
// (of this thread, or of the whole process) for the work a bake reports.
#include <chrono>
#include <ctime>

namespace cpvs {

class Stopwatch {
public:
  using Clock = std::chrono::steady_clock;
  Stopwatch() : start_(Clock::now()) {}
  void restart() { start_ = Clock::now(); }
  double ms() const { return std::chrono::duration<double, std::milli>(Clock::now() - start_).count(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

private:
  Clock::time_point start_;
};

// CPU time of a clock (CLOCK_THREAD_CPUTIME_ID: the calling thread; CLOCK_PROCESS_CPUTIME_ID: every thread of
// the process), in milliseconds.
inline double cpuClockMs(clockid_t clock) {
  timespec t{};
  ::clock_gettime(clock, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}
inline double threadCpuMs() { return cpuClockMs(CLOCK_THREAD_CPUTIME_ID); }
inline double processCpuMs() { return cpuClockMs(CLOCK_PROCESS_CPUTIME_ID); }

}  // namespace cpvs
