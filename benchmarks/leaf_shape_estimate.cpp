// What a file's DAGs would weigh with 4x4x4 leaves instead of 8x8x1 slices: a study of the DAG's shape for a
// format 3.0 (docs/format-3-study.md), not a format. Today a leaf parent (an 8^3 block) splits z only, into
// eight 8x8x1 slices, each a 64-bit leaf; here it splits like every other node, into its eight 4^3 octants,
// each a 64-bit leaf (bit (z & 3) * 16 + (y & 3) * 4 + (x & 3)), homogeneous octants coded lit or shadowed.
// The levels above do not change (a block's octants tell it apart exactly as its slices do). Both shapes are
// pooled (benchmarks/node_pool.h) and laid out with widths per level (benchmarks/level_widths.h).
//
//   leaf_shape_estimate FILE.cpvs...      a markdown row per file
#include <cstdint>
#include <cstdio>
#include <vector>

#include "benchmarks/level_widths.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using namespace cpvs::study;

struct Weighed {
  uint64_t nodeBytes = 0, leafParentBytes = 0, leafParentReferences = 0, leaves = 0;
};
Weighed weigh(const Pool& pool) {
  const StudyLayout laid = layOut(pool);
  Weighed w;
  w.nodeBytes = laid.nodeBytes();
  w.leaves = pool.leaves;
  for (const PoolLevel& l : laid.levels)
    if (l.edge == 8) w.leafParentBytes = l.bytes, w.leafParentReferences = l.references;
  return w;
}

int run(const char* path) {
  const auto file = orThrow(CpvsFile::open(path));
  PoolBuilder whole;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) whole.add(v);
  const Pool& slices = whole.pool();
  const Pool cubes = withCubeLeaves(slices);
  const Weighed a = weigh(slices), b = weigh(cubes);
  const auto mb = [](uint64_t bytes) { return double(bytes) / 1e6; };
  const uint64_t totalA = a.nodeBytes + 8 * a.leaves, totalB = b.nodeBytes + 8 * b.leaves;
  std::printf("| %s | %.2f MB | %llu refs, %.2f MB; %llu leaves | %.2f MB | %llu refs, %.2f MB; %llu leaves | %.2f MB "
              "(%+.1f %%) |\n",
              path, mb(totalA), (unsigned long long)a.leafParentReferences, mb(a.leafParentBytes),
              (unsigned long long)a.leaves, mb(totalB), (unsigned long long)b.leafParentReferences,
              mb(b.leafParentBytes), (unsigned long long)b.leaves, mb(totalB),
              100.0 * (double(totalB) / double(totalA ? totalA : 1) - 1.0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: leaf_shape_estimate FILE.cpvs...\n");
    return 1;
  }
  std::printf("| file | pool, 8x8x1 leaves | its leaf parents; leaves | pool, 4x4x4 leaves | its leaf parents; leaves | "
              "change |\n|---|---|---|---|---|---|\n");
  try {
    for (int i = 1; i < argc; ++i) run(argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "leaf_shape_estimate: %s\n", e.what());
    return 2;
  }
  return 0;
}
