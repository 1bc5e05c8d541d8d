// The DAG phase alone, on the depth maps of a real bake, without rendering: the builder with and without node
// reuse (Kämpe et al. 2015, §3.2) and the parts that do not depend on reuse (the min-max hierarchies, the final
// relocation). docs/benchmarks.md quotes it to show where the reuse build's time goes.
//
//   build-bench/bin/cpvs-bake out/bench/scenes/city-t100000-s1.glb --resolution 16k --sun 0.4,-1,0.3
//       --dump-depth out/bench/depth16k --quiet
//   CPVS_DEPTH_DIR=out/bench/depth16k build-bench/bin/dag_build_bench
//
// The folder holds light0_view0_region<x0>_<y0>.exr files (channels enter, exit); N is taken from the regions'
// extent. Tile chains are built once, with --undefined kampe, before anything is timed.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <stdexcept>

#include "libcpvs/io/exr_image.h"
#include "libcpvs/dag/dag_builder.h"

namespace cpvs {
namespace {

struct Regions {
  uint32_t resolution = 0, regionSize = 0;
  std::vector<TileChains> chains;  // in splitIntoRegions order (row-major by y0, then x0)
};

const Regions& regions() {
  static const Regions loaded = [] {
    const char* dir = std::getenv("CPVS_DEPTH_DIR");
    if (!dir) throw std::runtime_error("set CPVS_DEPTH_DIR to a folder written by cpvs-bake --dump-depth");
    std::vector<std::pair<std::pair<uint32_t, uint32_t>, std::string>> files;  // ((y0, x0), path)
    const std::regex name("light0_view0_region(\\d+)_(\\d+)\\.exr");
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      std::smatch m;
      const std::string file = entry.path().filename().string();
      if (std::regex_match(file, m, name)) files.push_back({{std::stoul(m[2]), std::stoul(m[1])}, entry.path().string()});
    }
    if (files.empty()) throw std::runtime_error(std::string(dir) + ": no light0_view0_region*.exr files");
    std::sort(files.begin(), files.end());
    Regions r;
    std::vector<DepthRegion> depths;
    for (const auto& [origin, path] : files) {
      const ExrImage image = readExr(path, {"enter", "exit"});
      DepthRegion d;
      d.rect = {origin.second, origin.first, image.width, image.height};
      d.enter.resize(size_t(image.width) * image.height);
      d.exit.resize(d.enter.size());
      for (size_t i = 0; i < d.enter.size(); ++i) {
        d.enter[i] = uint32_t(image.pixels[2 * i]);
        d.exit[i] = uint32_t(image.pixels[2 * i + 1]);
      }
      r.regionSize = image.width;
      r.resolution = std::max(r.resolution, d.rect.x0 + d.rect.width);
      depths.push_back(std::move(d));
    }
    for (DepthRegion& d : depths) {
      d.resolution = r.resolution;
      r.chains.push_back(buildTileChains(d, UndefinedMode::Kampe, 1));
    }
    return r;
  }();
  return loaded;
}

void dagBuild(benchmark::State& state) {
  const Regions& r = regions();
  const bool reuse = state.range(0) != 0;
  DagBuildStats stats;
  double finishMs = 0;
  for (auto _ : state) {
    DagBuilder builder(r.resolution, r.regionSize, reuse);
    for (const TileChains& c : r.chains) builder.addRegion(c);
    const auto t0 = std::chrono::steady_clock::now();
    ShadowDag dag = builder.finish();
    finishMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(dag.nodes.data());
    stats = builder.stats();
  }
  state.counters["nodes_built"] = double(stats.nodesBuilt);
  state.counters["nodes_reused"] = double(stats.nodesReused);
  state.counters["homogeneous"] = double(stats.homogeneous);
  state.counters["finish_ms"] = finishMs;  // the relocation into one array (part of the time above)
}
BENCHMARK(dagBuild)->ArgName("reuse")->Arg(0)->Arg(1)->Iterations(2)->Unit(benchmark::kMillisecond);

// The min-max hierarchies of every region (built inside addRegion, the same with and without reuse).
void tileHierarchies(benchmark::State& state) {
  const Regions& r = regions();
  for (auto _ : state)
    for (const TileChains& c : r.chains) {
      TileHierarchy h(c);
      benchmark::DoNotOptimize(h.size.data());
    }
}
BENCHMARK(tileHierarchies)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cpvs
