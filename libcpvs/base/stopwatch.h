#pragma once
// The one clock every phase timing, throughput figure and report uses: monotonic wall time.
#include <chrono>

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

}  // namespace cpvs
