#pragma once
// The one way cpvs runs work in parallel: TBB. Results never depend on how the work was split or scheduled
// (callers write to disjoint, pre-sized outputs or concatenate parts in order), so bytes do not depend on
// the thread count.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include "libcpvs/base/stopwatch.h"

namespace cpvs {

// What a thread spent inside parallel loops it called (its own share of their work, and whatever it picked up
// while waiting in them), so that the rest of its CPU time is the work that ran on one thread: what a bake's
// span counts (SerialCpuTimer).
struct ParallelLoopClock {
  // This thread's CPU ms inside parallel loops it called, so far (nested loops counted once).
  static double& spentMs() {
    thread_local double ms = 0;
    return ms;
  }
};

// Counts the calling thread's CPU time in a parallel loop as the loop's (RAII). A loop inside it (its own, or
// one of a task it picked up while waiting) has counted its part already: only the rest is added.
class InParallelLoop {
public:
  InParallelLoop() : cpu_(threadCpuMs()), counted_(ParallelLoopClock::spentMs()) {}
  ~InParallelLoop() {
    double& spent = ParallelLoopClock::spentMs();
    spent += (threadCpuMs() - cpu_) - (spent - counted_);
  }
  InParallelLoop(const InParallelLoop&) = delete;
  InParallelLoop& operator=(const InParallelLoop&) = delete;

private:
  double cpu_, counted_;
};

// The calling thread's CPU time since construction less what it spent in parallel loops: the part of a section
// that ran on this thread alone. Read it on the thread that made it.
class SerialCpuTimer {
public:
  SerialCpuTimer() : cpu_(threadCpuMs()), inLoops_(ParallelLoopClock::spentMs()) {}
  double ms() const { return (threadCpuMs() - cpu_) - (ParallelLoopClock::spentMs() - inLoops_); }

private:
  double cpu_, inLoops_;
};

// fn(i) for every i in [0, count), in parallel; `grain` indices at least per task.
template <class Fn>
void parallelFor(size_t count, Fn&& fn, size_t grain = 256) {
  const InParallelLoop counted;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, count, std::max<size_t>(1, grain)),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i != r.end(); ++i) fn(i);
                    });
}

// fn(part, begin, end) for `parts` contiguous, equal ranges of [0, count) (part p covers
// [count p / parts, count (p + 1) / parts)), in parallel, one task per part (so on at most `parts` threads). A
// fixed split: callers that concatenate per-part results in part order get the same result for any scheduling.
// No task arena of its own: making one per call (a region's tile chains, 65,536 times at 256k) had the two
// threads spinning in TBB's arena set-up for most of a 256k bake.
template <class Fn>
void parallelParts(size_t count, unsigned parts, Fn&& fn) {
  const InParallelLoop counted;  // one part or several: with more threads it would be parallel work
  parts = std::max(1u, parts);
  if (parts == 1) {
    fn(0u, size_t(0), count);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<unsigned>(0, parts, 1), [&](const tbb::blocked_range<unsigned>& r) {
    for (unsigned p = r.begin(); p != r.end(); ++p) fn(p, count * p / parts, count * (p + 1) / parts);
  }, tbb::simple_partitioner());
}

// fn(lane, i) for every i in [0, count), in index order as lanes free up, at most `lanes` calls at a time (lane
// in [0, lanes): what a call may own, such as a renderer). Each call runs isolated: a thread waiting inside one
// call's parallel loops helps only that call, so no call ends up suspended under another's stack.
template <class Fn>
void parallelLanes(size_t count, unsigned lanes, Fn&& fn) {
  lanes = unsigned(std::clamp<size_t>(lanes, 1, std::max<size_t>(1, count)));
  if (lanes == 1) {
    for (size_t i = 0; i < count; ++i) fn(0u, i);
    return;
  }
  std::atomic<size_t> next{0};
  tbb::parallel_for(tbb::blocked_range<unsigned>(0, lanes, 1), [&](const tbb::blocked_range<unsigned>& r) {
    for (unsigned lane = r.begin(); lane != r.end(); ++lane)
      for (size_t i = next++; i < count; i = next++) tbb::this_task_arena::isolate([&] { fn(lane, i); });
  }, tbb::simple_partitioner());
}

// One piece of work running beside the calling thread (e.g. tile masks and DAG building while the caller
// renders the next region). wait() rethrows what the work threw.
class BackgroundWork {
public:
  ~BackgroundWork() {
    try {
      group_.wait();
    } catch (...) {  // the caller is already unwinding from its own error
    }
  }
  template <class Fn>
  void start(Fn&& fn) {
    wait();
    // Work beside the caller, not the caller's own: whichever thread runs it (the caller too, while it waits)
    // counts its CPU time as it counts a parallel loop's.
    group_.run([fn = std::forward<Fn>(fn)]() {
      const InParallelLoop beside;
      fn();
    });
    running_ = true;
  }
  void wait() {
    if (!running_) return;
    running_ = false;
    const InParallelLoop waiting;  // waiting (and the work it may run meanwhile) is not the caller's own work
    group_.wait();
  }

private:
  tbb::task_group group_;
  bool running_ = false;
};

}  // namespace cpvs
