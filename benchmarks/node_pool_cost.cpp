// What pooling costs a bake: the time and memory of the library's NodePool (libcpvs/dag/node_pool.h) adding every
// view of a baked .cpvs one after the other, as a 3.0 bake adds each light as it finishes (cpvs_writer.cpp, without
// per-node view counts), then laying the pool out. The histogram of how many views reach each node comes from
// one more pool, with the counts, outside the timings.
//
// Memory: the resident set before the first add (the file mapped and validated, every DAG touched) and after
// the layout; the pool's share is the difference (the tables' index, the build-form nodes, the laid-out bytes).
// Time: wall clock of the adds and of the layout, best of --rounds (fresh pools), with the load average.
//
//   node_pool_cost FILE.cpvs [--rounds R]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <xxhash.h>

#include "benchmarks/load_average.h"
#include "libcpvs/base/error.h"
#include "libcpvs/base/peak_memory.h"
#include "libcpvs/dag/node_pool.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using cpvs::study::loadAverage;
using Clock = std::chrono::steady_clock;


double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

int run(const char* path, int rounds) {
  const auto file = orThrow(CpvsFile::open(path));
  uint64_t stored = 0, views = 0;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) {
      stored += v.dag.nodes.size() * 2 + v.dag.leaves.size() * 8;
      ++views;
    }
  const std::string loadBefore = loadAverage();
  const uint64_t rssBefore = currentRssBytes();
  double bestAdd = 1e30, bestLayOut = 1e30;
  uint64_t pooledBytes = 0, rssAfter = 0, nodes = 0, layoutHash = 0;
  std::vector<uint64_t> sharing;
  NodePool::BuildFormBytes buildForm;
  for (int r = 0; r < rounds; ++r) {
    NodePool pool(LeafShape::Slices, /*countViews=*/false);
    const auto t0 = Clock::now();
    for (const CpvsFile::LightEntry& light : file->lights())
      for (const CpvsFile::View& v : light.views) pool.add(v.dag);
    const auto t1 = Clock::now();
    buildForm = pool.buildFormBytes();
    pool.releaseIndexes();
    const LaidOutPool laid = pool.layOut();
    const auto t2 = Clock::now();
    bestAdd = std::min(bestAdd, seconds(t0, t1));
    bestLayOut = std::min(bestLayOut, seconds(t1, t2));
    pooledBytes = laid.leaves.size() * 8;
    // A hash of everything laid out, so that two builds of NodePool can be shown to lay out the same bytes.
    layoutHash = XXH3_64bits(laid.leaves.data(), laid.leaves.size() * 8);
    for (const PooledLevel& level : laid.levels) {
      pooledBytes += level.bytes.size();
      layoutHash = XXH3_64bits_withSeed(level.bytes.data(), level.bytes.size(), layoutHash);
    }
    for (const LaidOutPool::Root& root : laid.roots)
      layoutHash = XXH3_64bits_withSeed(&root.offset, sizeof root.offset, layoutHash);
    nodes = pool.nodes();
    rssAfter = std::max(rssAfter, currentRssBytes());
  }
  {
    NodePool counted(LeafShape::Slices, /*countViews=*/true);
    for (const CpvsFile::LightEntry& light : file->lights())
      for (const CpvsFile::View& v : light.views) counted.add(v.dag);
    sharing = counted.nodesByViewsReaching();
  }
  std::printf("%s: %llu views, DAGs %.2f MB as stored, pooled %.2f MB (%llu nodes, layout XXH3 %016llx); adding every "
              "view %.2f s, laying out %.2f s (best of %d); resident %.0f MB before, %.0f MB with the pool (+%.0f MB), "
              "peak %.0f MB; load %s -> %s\n",
              path, (unsigned long long)views, double(stored) / 1e6, double(pooledBytes) / 1e6,
              (unsigned long long)nodes, (unsigned long long)layoutHash, bestAdd, bestLayOut, rounds, double(rssBefore) / 1e6, double(rssAfter) / 1e6,
              double(rssAfter - std::min(rssAfter, rssBefore)) / 1e6, double(peakRssBytes()) / 1e6,
              loadBefore.c_str(), loadAverage().c_str());
  const auto mb = [](uint64_t bytes) { return double(bytes) / 1e6; };
  std::printf("  build form once every view is in: %.1f MB (nodes %.1f, leaf parents %.1f, indexes %.1f, "
              "node starts %.1f, leaves %.1f, leaf index %.1f)\n",
              mb(buildForm.total()), mb(buildForm.nodes), mb(buildForm.leafParents), mb(buildForm.indexes),
              mb(buildForm.starts), mb(buildForm.leaves), mb(buildForm.leafIndex));
  std::printf("  nodes by the views that reach them:");
  for (size_t k = 0; k < sharing.size(); ++k) {
    const uint64_t low = k == 0 ? 1 : (uint64_t(1) << (k - 1)) + 1, high = uint64_t(1) << k;
    const std::string views = low == high ? std::to_string(low) : std::to_string(low) + "-" + std::to_string(high);
    std::printf("%s %s: %llu (%.1f %%)", k ? ";" : "", views.c_str(), (unsigned long long)sharing[k],
                100.0 * double(sharing[k]) / double(nodes ? nodes : 1));
  }
  std::printf("\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: node_pool_cost FILE.cpvs [--rounds R]\n");
    return 1;
  }
  int rounds = 3;
  if (argc >= 4 && std::strcmp(argv[2], "--rounds") == 0) rounds = std::max(1, std::atoi(argv[3]));
  try {
    return run(argv[1], rounds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "node_pool_cost: %s\n", e.what());
    return 2;
  }
}
