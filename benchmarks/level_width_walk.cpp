// What the per-level reference widths cost a lookup: the scalar walk of format 2.0 (DagView::shadowed over the
// file's own DAGs) against the same walk over the whole file's pool as the library's NodePool lays it out
// (benchmarks/level_widths.h reads it), without and with hot tables, on the same voxels, alternating. A study for a format 3.0, not a format: the runtime's batch
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
#include <random>
#include <string>
#include <vector>

#include "benchmarks/level_widths.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using namespace cpvs::study;

struct Lookup {
  uint32_t view, x, y, z;
};

// Whether the 2.0 walk of voxel (x, y, z) ends at a leaf (not at a homogeneous node above).
bool reachesLeaf(const DagView& dag, uint32_t x, uint32_t y, uint32_t z) {
  uint32_t code = uint32_t(dag.rootCode), offset = 0;
  for (uint32_t half = dag.resolution >> 1; half >= 8; half >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return false;
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = dag.nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = dag.child(offset, header, c, half * 2);
  }
  return code == uint32_t(ChildCode::Ref) && childCodeOf(dag.nodes[offset], z & 7u) == uint32_t(ChildCode::Ref);
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

template <class Walk>
double nanosecondsPerLookup(const std::vector<Lookup>& lookups, Walk&& shadowed, uint64_t& sum) {
  const auto start = std::chrono::steady_clock::now();
  uint64_t s = 0;
  for (const Lookup& l : lookups) s += shadowed(l) ? 1 : 0;
  const auto end = std::chrono::steady_clock::now();
  sum = s;
  return std::chrono::duration<double, std::nano>(end - start).count() / double(lookups.size());
}

std::string loadAverage() {
  char text[128] = {};
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (!std::fgets(text, sizeof text, f)) text[0] = 0;
    std::fclose(f);
  }
  std::string s(text);
  return s.substr(0, s.find(' ', s.find(' ', s.find(' ') + 1) + 1));
}

int run(const char* path, size_t count, int rounds) {
  const auto file = orThrow(CpvsFile::open(path));
  std::vector<const DagView*> views;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) views.push_back(&v.dag);
  NodePool pool;
  for (const DagView* v : views) pool.add(*v);
  const LaidOutPool laidOut = pool.layOut(), laidOutHot = pool.layOut(true);
  const ByteDag laid(laidOut), laidHot(laidOutHot);
  std::vector<ByteDagView> byteViews, hotViews;
  for (const LaidOutPool::Root& r : laidOut.roots) byteViews.push_back(ByteDagView::of(laid, r));
  for (const LaidOutPool::Root& r : laidOutHot.roots) hotViews.push_back(ByteDagView::of(laidHot, r));
  uint64_t stored = 0;
  for (const DagView* v : views) stored += v->nodes.size() * 2 + v->leaves.size() * 8;
  std::printf("%s: %zu views, 2.0 DAGs %.2f MB, pooled byte form %.2f MB, with hot tables %.2f MB; load %s\n", path,
              views.size(), double(stored) / 1e6, double(laid.nodeBytes() + laid.leaves.size() * 8) / 1e6,
              double(laidHot.nodeBytes() + laidHot.tableBytes() + laidHot.leaves.size() * 8) / 1e6, loadAverage().c_str());
  const auto old = [&](const Lookup& l) { return views[l.view]->shadowed(l.x, l.y, l.z); };
  const auto pooled = [&](const Lookup& l) { return byteViews[l.view].shadowed(l.x, l.y, l.z); };
  const auto hot = [&](const Lookup& l) { return hotViews[l.view].shadowed(l.x, l.y, l.z); };
  for (const bool deep : {false, true}) {
    const std::vector<Lookup> lookups = drawLookups(views, count, deep, deep ? 2 : 1);
    size_t mismatches = 0;
    for (const Lookup& l : lookups) mismatches += (old(l) != pooled(l)) + (old(l) != hot(l));
    if (mismatches) {
      std::fprintf(stderr, "level_width_walk: %s: %zu of %zu answers differ\n", path, mismatches, lookups.size());
      return 3;
    }
    std::vector<double> a, b, h, ratio, ratioHot;
    uint64_t sumA = 0, sumB = 0, sumH = 0;
    for (int r = 0; r < rounds; ++r) {
      a.push_back(nanosecondsPerLookup(lookups, old, sumA));
      b.push_back(nanosecondsPerLookup(lookups, pooled, sumB));
      h.push_back(nanosecondsPerLookup(lookups, hot, sumH));
      ratio.push_back(b.back() / a.back());
      ratioHot.push_back(h.back() / a.back());
      if (sumA != sumB || sumA != sumH) {  // also keeps the compiler from dropping any loop
        std::fprintf(stderr, "level_width_walk: %s: %llu vs %llu vs %llu shadowed\n", path, (unsigned long long)sumA,
                     (unsigned long long)sumB, (unsigned long long)sumH);
        return 3;
      }
    }
    for (auto* v : {&a, &b, &h, &ratio, &ratioHot}) std::sort(v->begin(), v->end());
    std::printf("  %s voxels (%zu, all answers equal, %llu shadowed), ns per lookup best / median: 2.0 walk %.1f / "
                "%.1f; pooled %.1f / %.1f (ratio per round %.3f..%.3f, median %.3f); pooled with hot tables %.1f / "
                "%.1f (ratio %.3f..%.3f, median %.3f)\n",
                deep ? "deep" : "uniform", lookups.size(), (unsigned long long)sumA, a.front(), a[a.size() / 2],
                b.front(), b[b.size() / 2], ratio.front(), ratio.back(), ratio[ratio.size() / 2], h.front(),
                h[h.size() / 2], ratioHot.front(), ratioHot.back(), ratioHot[ratioHot.size() / 2]);
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
