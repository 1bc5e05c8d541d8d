// What the 3.0 candidates cost a lookup: the scalar walk of format 2.0 (DagView::shadowed over the file's own
// DAGs) against the runtime's byte walk (libcpvs/runtime/byte_dag.h) over the same DAGs in place, and over the
// whole file's pool as the library's NodePool lays it out: slice or octant leaves, without or with hot tables;
// on the same voxels, alternating. Besides single voxels, 8x8 tile masks at a slice, what a PCF footprint reads: one leaf with
// slices, rows of four octants with octant leaves. A study for a format 3.0, not a format: the runtime's batch
// walks (AVX-512 gathers) are not ported, so this weighs the decoding's cost, not the tools' throughput.
//
// Voxels are drawn at random (fixed seed) over the views, in two sets: uniform over each view's grid, and only
// voxels whose walk reaches a leaf (the deepest walks, where a lookup spends most). Every answer of the byte
// walk is checked against the 2.0 walk's before anything is timed.
//
//   level_width_walk FILE.cpvs [--lookups N] [--rounds R]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "libcpvs/dag/node_pool.h"
#include "libcpvs/runtime/byte_dag.h"
#include "benchmarks/load_average.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using cpvs::study::loadAverage;

struct Lookup {
  uint32_t view, x, y, z;
};

// The 2.0 walk of voxel (x, y, z) down to its leaf parent: code 2 and its unit in `offset`, or the code of the
// homogeneous node above.
uint32_t toLeafParent(const DagView& dag, uint32_t x, uint32_t y, uint32_t z, uint32_t& offset) {
  uint32_t code = uint32_t(dag.rootCode);
  offset = 0;
  for (uint32_t half = dag.resolution >> 1; half >= 8 && code == uint32_t(ChildCode::Ref); half >>= 1) {
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = dag.nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = dag.child(offset, header, c, half * 2);
  }
  return code;
}
// Whether the 2.0 walk of voxel (x, y, z) ends at a leaf (not at a homogeneous node above).
bool reachesLeaf(const DagView& dag, uint32_t x, uint32_t y, uint32_t z) {
  uint32_t offset;
  return toLeafParent(dag, x, y, z, offset) == uint32_t(ChildCode::Ref) &&
         childCodeOf(dag.nodes[offset], z & 7u) == uint32_t(ChildCode::Ref);
}
// The 2.0 tile mask: the 8x8 slice holding (x, y) at depth z, as a PCF footprint reads it. Written here, as
// DagView::shadowed walks, rather than taken from the GPU walk's C++ twin (gpu::DagWalk, bounds-checked and not
// written for speed): it is the baseline the timings divide by.
uint64_t tileMask(const DagView& dag, uint32_t x, uint32_t y, uint32_t z) {
  uint32_t offset;
  const uint32_t code = toLeafParent(dag, x, y, z, offset);
  if (code != uint32_t(ChildCode::Ref)) return 0 - uint64_t(code == uint32_t(ChildCode::Shadowed));
  const uint32_t header = dag.nodes[offset];
  const uint32_t leafCode = childCodeOf(header, z & 7u);
  return leafCode == uint32_t(ChildCode::Ref) ? dag.leaves[dag.child(offset, header, z & 7u, 8)] : 0 - uint64_t(leafCode);
}

std::vector<Lookup> drawLookups(const std::vector<const DagView*>& views, size_t count, bool deepOnly, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Lookup> out;
  size_t tries = 0;
  while (out.size() < count && tries < count * 2000) {
    ++tries;
    const uint32_t v = uint32_t(rng() % views.size());
    const uint32_t n = views[v]->resolution;
    const Lookup l{v, uint32_t(rng() % n), uint32_t(rng() % n), uint32_t(rng() % n)};
    if (!deepOnly || reachesLeaf(*views[v], l.x, l.y, l.z)) out.push_back(l);
  }
  return out;
}

// A walk answers a lookup with a 64-bit value: a voxel's bit, or a tile's mask. Sums of answers (a hash for the
// masks) must agree between walks; they also keep the compiler from dropping a loop.
using Walk = std::function<uint64_t(const Lookup&)>;
double nanosecondsPerLookup(const std::vector<Lookup>& lookups, const Walk& walk, uint64_t& sum) {
  const auto start = std::chrono::steady_clock::now();
  uint64_t s = 0;
  for (const Lookup& l : lookups) s = s * 31 + walk(l);
  const auto end = std::chrono::steady_clock::now();
  sum = s;
  return std::chrono::duration<double, std::nano>(end - start).count() / double(lookups.size());
}


int run(const char* path, size_t count, int rounds) {
  const auto file = orThrow(CpvsFile::open(path));
  std::vector<const DagView*> views;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) views.push_back(&v.dag);
  uint64_t stored = 0;
  for (const DagView* v : views) stored += v->nodes.size() * 2 + v->leaves.size() * 8;
  std::printf("%s: %zu views, 2.0 DAGs %.2f MB; load %s\n", path, views.size(), double(stored) / 1e6,
              loadAverage().c_str());

  // The byte walk over the 2.x views in place, then the pooled forms: slice and octant leaves, without and with
  // hot tables. Each is a set of runtime views (libcpvs/runtime/byte_dag.h).
  struct ByteWalk {
    std::string name;
    PooledDags pooled;               // empty for the views in place
    std::vector<ByteDagView> views;  // one per view of the file
  };
  std::vector<ByteWalk> byteWalks;
  byteWalks.push_back({"2.0 in place, byte walk", {}, {}});
  for (const DagView* v : views) byteWalks.back().views.push_back(ByteDagView::inPlace(*v));
  for (const LeafShape shape : {LeafShape::Slices, LeafShape::Octants}) {
    NodePool pool(shape);
    for (const DagView* v : views) pool.add(*v);
    pool.releaseIndexes();
    for (const bool hot : {false, true}) {
      ByteWalk w{std::string(shape == LeafShape::Slices ? "pooled" : "pooled octants") + (hot ? " + hot" : ""),
                 concatenate(pool.layOut(hot), shape), {}};
      w.views = w.pooled.views;
      uint64_t tables = 0;
      for (const auto& table : w.pooled.hot) tables += 4 * table.size();
      std::printf("  %s: %.2f MB\n", w.name.c_str(),
                  double(w.pooled.bytes.size() + tables + w.pooled.leaves.size() * 8) / 1e6);
      byteWalks.push_back(std::move(w));
    }
  }
  for (const int set : {0, 1, 2}) {  // uniform voxels, deep voxels, tiles at deep voxels
    const char* setName = set == 0 ? "uniform voxels" : set == 1 ? "deep voxels" : "tiles (8x8 masks at deep voxels)";
    const std::vector<Lookup> lookups = drawLookups(views, count, set > 0, set > 0 ? 2 : 1);
    std::vector<std::pair<std::string, Walk>> walks;
    const bool tiles = set == 2;
    walks.emplace_back("2.0", [&, tiles](const Lookup& l) -> uint64_t {
      return tiles ? tileMask(*views[l.view], l.x, l.y, l.z) : views[l.view]->shadowed(l.x, l.y, l.z);
    });
    for (const ByteWalk& b : byteWalks)
      walks.emplace_back(b.name, [&b, tiles](const Lookup& l) -> uint64_t {
        return tiles ? b.views[l.view].tileMask(l.x, l.y, l.z) : b.views[l.view].shadowed(l.x, l.y, l.z);
      });
    for (size_t w = 1; w < walks.size(); ++w) {
      size_t mismatches = 0;
      for (const Lookup& l : lookups) mismatches += walks[w].second(l) != walks[0].second(l);
      if (mismatches) {
        std::fprintf(stderr, "level_width_walk: %s: %s: %zu of %zu answers differ\n", path, walks[w].first.c_str(),
                     mismatches, lookups.size());
        return 3;
      }
    }
    std::vector<std::vector<double>> ns(walks.size()), ratio(walks.size());
    for (int r = 0; r < rounds; ++r) {
      uint64_t sum0 = 0;
      for (size_t w = 0; w < walks.size(); ++w) {
        uint64_t sum = 0;
        ns[w].push_back(nanosecondsPerLookup(lookups, walks[w].second, sum));
        ratio[w].push_back(ns[w].back() / ns[0].back());
        if (w == 0) sum0 = sum;
        else if (sum != sum0) return std::fprintf(stderr, "level_width_walk: %s: sums differ\n", path), 3;
      }
    }
    std::printf("  %s (%zu, every answer equal), ns per lookup best / median (ratio to 2.0, median of rounds):",
                setName, lookups.size());
    for (size_t w = 0; w < walks.size(); ++w) {
      std::sort(ns[w].begin(), ns[w].end());
      std::sort(ratio[w].begin(), ratio[w].end());
      std::printf("%s %s %.1f / %.1f (%.3f)", w ? ";" : "", walks[w].first.c_str(), ns[w].front(),
                  ns[w][ns[w].size() / 2], ratio[w][ratio[w].size() / 2]);
    }
    std::printf("\n");
  }
  std::printf("  load after %s\n", loadAverage().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: level_width_walk FILE.cpvs [--lookups N] [--rounds R]\n");
    return 1;
  }
  size_t count = 300000;
  int rounds = 5;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--lookups") == 0) count = std::strtoull(argv[i + 1], nullptr, 10);
    else if (std::strcmp(argv[i], "--rounds") == 0) rounds = std::atoi(argv[i + 1]);
  }
  try {
    return run(argv[1], count, rounds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "level_width_walk: %s\n", e.what());
    return 2;
  }
}
