#pragma once
// Throughput measured the one way every report of cpvs measures it: single-threaded work items per second,
// each method repeated for a minimum time per round, the methods interleaved round by round so that a change
// in the machine's load hits all of them alike; the best round (the least disturbed) is the figure, the
// median is kept beside it.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "libcpvs/base/stopwatch.h"

namespace cpvs {

// Work items per second of `pass` (which does `workPerPass` items), repeated for at least `seconds`.
template <class Fn>
double perSecond(size_t workPerPass, double seconds, Fn&& pass) {
  if (workPerPass == 0) return 0.0;
  uint64_t work = 0;
  const Stopwatch clock;
  double elapsed = 0;
  do {
    pass();
    work += workPerPass;
    elapsed = clock.seconds();
  } while (elapsed < seconds);
  return double(work) / elapsed;
}

// Keeps timed loops from being optimised away: each pass stores a value that depends on its results.
void consume(float value);

class Throughput {
public:
  using Method = std::function<double()>;  // one round: items per second
  void add(const std::string& name, Method method);
  // One warm-up pass of every method (caches, page faults), then `rounds` rounds.
  void run(int rounds);
  double best(const std::string& name) const;
  double median(const std::string& name) const;

private:
  struct Entry {
    std::string name;
    Method method;
    std::vector<double> samples;
  };
  const Entry& find(const std::string& name) const;
  std::vector<Entry> methods_;
};

}  // namespace cpvs
