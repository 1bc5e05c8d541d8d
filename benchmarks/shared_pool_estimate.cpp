// What one node pool shared by every view of a .cpvs would weigh: each distinct subtree (the same child codes
// over the same distinct children, at the same node size) and each distinct leaf mask stored once for the
// whole file instead of once per view. A study, not a format. Two estimates bracket what a format would get:
// each shared node keeps the unit count it has in its own view (header plus its 1- or 2-unit references: the
// optimistic one), or every reference is 2 units wide (a pool too large for 16-bit references anywhere: the
// pessimistic one).
//
//   shared_pool_estimate FILE.cpvs...      prints per file: bytes as stored, pooled (both), saving
#include <cstdint>
#include <cstdio>

#include "benchmarks/node_pool.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;

int run(const char* path) {
  const auto file = orThrow(CpvsFile::open(path));
  const study::Pool pool = study::poolOf(*file);
  uint64_t pooledUnits = 0, pooledWideUnits = 0;
  for (const study::PooledNode& n : pool.nodes) {
    pooledUnits += n.ownUnits;
    pooledWideUnits += 1 + 2 * n.children.size();
  }
  const uint64_t storedBytes = pool.storedBytes, views = pool.views;
  const uint64_t pooledBytes = pooledUnits * 2 + pool.leaves * 8;
  const uint64_t pooledWideBytes = pooledWideUnits * 2 + pool.leaves * 8;
  const auto saving = [&](uint64_t b) { return 100.0 * (1.0 - double(b) / double(storedBytes ? storedBytes : 1)); };
  std::printf("| %s | %llu | %llu | %llu / %llu | %.1f %% / %.1f %% |\n", path, (unsigned long long)views,
              (unsigned long long)storedBytes, (unsigned long long)pooledBytes,
              (unsigned long long)pooledWideBytes, saving(pooledBytes), saving(pooledWideBytes));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: shared_pool_estimate FILE.cpvs...\n");
    return 1;
  }
  std::printf("| file | views | DAG bytes as stored | one shared pool: own widths / all wide | saving |\n"
              "|---|---|---|---|---|\n");
  try {
    for (int i = 1; i < argc; ++i) run(argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shared_pool_estimate: %s\n", e.what());
    return 2;
  }
  return 0;
}
