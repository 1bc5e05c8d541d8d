// Lossy bakes (docs/lossy.md): the bound every node keeps, the next-surface layer they read, and the tool's
// promises (smaller, deterministic, the same answers on surfaces at 0, every reader unchanged).
#include <gtest/gtest.h>

#include <bit>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/dag/leaf_table.h"
#include "libcpvs/raster/next_surface.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::tempDir;
using test::toolPath;

// A synthetic region with a next surface behind every texel that meets something: past its exit, often within
// a few slices (leaf on leaf), sometimes nowhere (N).
DepthRegion syntheticWithNext(uint32_t n, uint32_t seed) {
  DepthRegion depth = test::syntheticDepth(n, seed);
  std::mt19937 rng(seed * 7919u + 1u);
  depth.next.resize(depth.enter.size());
  for (size_t at = 0; at < depth.enter.size(); ++at) {
    const uint32_t x = depth.exit[at];
    const uint32_t kind = rng() % 4;
    depth.next[at] = x >= n || kind == 0 ? n : std::min(n, x + uint32_t(kind == 1 ? rng() % 4 : rng() % (n - x + 1)));
  }
  return depth;
}

// Every voxel of random nodes of a lossy DAG, against the rule of its texel: lit up to the first surface,
// shadowed from max(exit, next - guard, enter + 1 + D) on, and at most D voxels per texel column that a receiver
// could sit in (at or past max(exit, next - guard)) answered differently from the lossless DAG.
TEST(LossyChains, EveryNodeStaysWithinTheBound) {
  const uint32_t n = 64, levels = uint32_t(std::countr_zero(n)) - 3;
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const DepthRegion depth = syntheticWithNext(n, seed);
    const ShadowDag lossless = buildDag(buildTileChains(depth, UndefinedMode::Kampe), true);
    for (uint32_t maxError : {0u, 3u, 16u}) {
      const TileChains chains = buildTileChains(depth, UndefinedMode::Kampe, 2, maxError);
      const ShadowDag lossy = buildDag(chains, true);
      const DagView a = lossy.view(), b = lossless.view();
      std::mt19937 rng(seed + 100 * maxError);
      uint64_t broken = 0, overBound = 0;
      for (int node = 0; node < 200; ++node) {
        const uint32_t level = rng() % (levels + 1), size = n >> level, cells = n / size;
        const uint32_t x0 = (rng() % cells) * size, y0 = (rng() % cells) * size, z0 = (rng() % cells) * size;
        uint64_t changedOnReceivers = 0;
        for (uint32_t y = y0; y < y0 + size; ++y)
          for (uint32_t x = x0; x < x0 + size; ++x) {
            const size_t at = size_t(y) * n + x;
            const uint32_t e = depth.enter[at], exit = depth.exit[at], next = depth.next[at];
            const uint32_t freeEnd = std::max(exit, next > kNextSurfaceGuard ? next - kNextSurfaceGuard : 0);
            const uint32_t end = e >= n ? n : std::min(n, std::max(freeEnd, e + 1 + maxError));
            for (uint32_t z = z0; z < z0 + size; ++z) {
              const bool shadowed = a.shadowed(x, y, z);
              broken += (z <= e && shadowed) || (z >= end && !shadowed);
              changedOnReceivers += z >= freeEnd && shadowed != b.shadowed(x, y, z);
            }
          }
        overBound += changedOnReceivers > uint64_t(maxError) * size * size;
      }
      EXPECT_EQ(broken, 0u) << "seed " << seed << " D " << maxError;
      EXPECT_EQ(overBound, 0u) << "seed " << seed << " D " << maxError;
    }
  }
}

// The report's counts are what the chains leave lit; the DAG may shadow more (past every darkFrom of a
// footprint), never less, so counted over the whole grid they bound what the file answers.
TEST(LossyChains, ReportedVoxelsBoundWhatTheDagLeavesLit) {
  const uint32_t n = 64;
  const DepthRegion depth = syntheticWithNext(n, 5);
  const TileChains chains = buildTileChains(depth, UndefinedMode::Kampe, 1, 4u);
  const ShadowDag lossy = buildDag(chains, true);
  const DagView dag = lossy.view();
  uint64_t freeLit = 0, delayed = 0;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      const size_t at = size_t(y) * n + x;
      const uint32_t e = depth.enter[at], exit = depth.exit[at], next = depth.next[at];
      if (e >= n) continue;
      const uint32_t freeEnd = std::max(exit, next > kNextSurfaceGuard ? next - kNextSurfaceGuard : 0);
      for (uint32_t z = exit; z < n; ++z)
        if (!dag.shadowed(x, y, z)) (z < freeEnd ? freeLit : delayed) += 1;
    }
  EXPECT_GT(freeLit, 0u);
  EXPECT_GT(delayed, 0u);
  EXPECT_LE(freeLit, chains.freeVoxelsLit);
  EXPECT_LE(delayed, chains.voxelsDelayed);
  EXPECT_LE(chains.voxelsDelayed, 4u * n * n);
}

TEST(LossyChains, LosslessChainsIgnoreTheNextLayerAndOtherModesRefuseTheBound) {
  const DepthRegion depth = syntheticWithNext(64, 2);
  DepthRegion without = depth;
  without.next.clear();
  const TileChains a = buildTileChains(depth, UndefinedMode::Kampe), b = buildTileChains(without, UndefinedMode::Kampe);
  EXPECT_EQ(a.start, b.start);
  EXPECT_EQ(a.mask, b.mask);
  EXPECT_THROW(buildTileChains(depth, UndefinedMode::Sintorn, 1, 2u), Error);
  EXPECT_THROW(buildTileChains(depth, UndefinedMode::None, 1, 0u), Error);
}

TEST(LeafTable, EdgeTexelsAreThoseWithADifferentNeighbour) {
  const uint64_t leftHalf = 0x0f0f0f0f0f0f0f0full;  // columns 0-3 shadowed
  EXPECT_EQ(edgeTexels(leftHalf), 0x1818181818181818ull);
  EXPECT_EQ(edgeTexels(0xffffull), 0xffff00ull);  // rows 0-1 shadowed: rows 1 and 2
  EXPECT_EQ(edgeTexels(0), 0u);
  EXPECT_EQ(edgeTexels(~uint64_t(0)), 0u);
  EXPECT_EQ(edgeTexels(uint64_t(1) << 9), 0x20702ull);  // texel (1, 1) and its four neighbours
}

TEST(LeafTable, AnswersWithinTheBoundFewestFlipsFirstAndAlwaysTheSame) {
  const auto bit = [](int i) { return uint64_t(1) << i; };
  const uint64_t a = 0x0f0f0f0f0f0f0f0full;
  const uint64_t oneOff = a ^ bit(4);             // texel (4, 0): on the edge
  const uint64_t twoOff = a ^ bit(4) ^ bit(27);   // and (3, 3)
  LeafTable lossless;
  EXPECT_EQ(lossless.intern(a), 0u);
  EXPECT_EQ(lossless.intern(oneOff), 1u);
  LeafTable one(1);
  EXPECT_EQ(one.intern(a), 0u);
  EXPECT_EQ(one.intern(oneOff), 0u);
  EXPECT_EQ(one.intern(oneOff), 0u);
  EXPECT_EQ(one.intern(twoOff), 1u);  // two flips: a leaf of its own
  EXPECT_EQ(one.intern(0xff00ff00ff00ff00ull), 2u);
  EXPECT_EQ(one.merged(), 1u);
  LeafTable two(2);
  EXPECT_EQ(two.intern(a), 0u);
  EXPECT_EQ(two.intern(twoOff), 0u);
  // c is three flips from a (stored), q two from a and one from c: the one-flip answer wins.
  const uint64_t c = a ^ bit(4) ^ bit(12) ^ bit(20), q = a ^ bit(4) ^ bit(12);
  EXPECT_EQ(two.intern(c), 1u);
  EXPECT_EQ(two.intern(q), 1u);
  EXPECT_EQ(two.merged(), 2u);
  EXPECT_EQ(two.flipped(), 3u);
  EXPECT_THROW(LeafTable(3), Error);
}

// Every 8x8 slice of a DAG built with edge merging differs from the lossless one in at most K texels, each on
// a shadow edge of the lossless slice; node reuse changes nothing with it either.
TEST(LossyChains, EdgeMergingKeepsEverySliceWithinTheBound) {
  const uint32_t n = 64;
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const TileChains chains = buildTileChains(syntheticWithNext(n, seed), UndefinedMode::Kampe, 1, 4u);
    const ShadowDag exact = buildDag(chains, true);
    for (uint32_t k : {1u, 2u}) {
      DagBuildStats stats;
      const ShadowDag merged = buildDag(chains, true, &stats, k);
      const ShadowDag mergedWithoutReuse = buildDag(chains, false, nullptr, k);
      EXPECT_EQ(merged.nodes, mergedWithoutReuse.nodes);
      EXPECT_EQ(merged.leaves, mergedWithoutReuse.leaves);
      EXPECT_GT(stats.leavesMerged, 0u) << seed;
      const DagView a = merged.view(), b = exact.view();
      uint64_t overBound = 0, offEdge = 0;
      for (uint32_t z = 0; z < n; ++z)
        for (uint32_t ty = 0; ty < n / 8; ++ty)
          for (uint32_t tx = 0; tx < n / 8; ++tx) {
            uint64_t lossless = 0, lossy = 0;
            for (uint32_t j = 0; j < 64; ++j) {
              const uint32_t x = tx * 8 + (j & 7), y = ty * 8 + (j >> 3);
              lossless |= uint64_t(b.shadowed(x, y, z)) << j;
              lossy |= uint64_t(a.shadowed(x, y, z)) << j;
            }
            overBound += std::popcount(lossless ^ lossy) > int(k);
            offEdge += ((lossless ^ lossy) & ~edgeTexels(lossless)) != 0;
          }
      EXPECT_EQ(overBound, 0u) << seed;
      EXPECT_EQ(offEdge, 0u) << seed;
    }
  }
}

// Two open quads under a sun straight down, the upper one smaller, over nothing: behind the upper quad the next
// surface is the lower one (its own enter slice where it is seen), behind the lower one and beside both there
// is none. Sloped planes count from their near side (the steep ridge of the ground-and-ridge world).
TEST(NextSurface, FindsTheSurfaceBehindTheFirst) {
  Scene scene;
  test::addQuad(scene, "lower", {-4, 0, 4}, {4, 0, 4}, {4, 0, -4}, {-4, 0, -4});
  test::addQuad(scene, "upper", {-2, 2, 2}, {2, 2, 2}, {2, 2, -2}, {-2, 2, -2});
  test::classifyMeshes(scene);
  scene.lights.push_back(test::sunLight("sun", {0, -1, 0}));
  BakeSettings settings;
  settings.resolution = 256;
  settings.maxVoxelError = 0;
  settings.threads = 1;
  std::vector<DepthRegion> regions;
  BakeCallbacks callbacks;
  callbacks.depthRegion = [&](size_t, size_t, const LightView&, const DepthRegion& d) { regions.push_back(d); };
  bakeSceneTo(scene, settings, [](uint64_t, const char*, size_t) {}, nullptr, callbacks);
  ASSERT_EQ(regions.size(), 1u);
  const DepthRegion& d = regions[0];
  const uint32_t n = d.resolution, w = d.rect.width;
  ASSERT_EQ(d.next.size(), d.enter.size());
  // The lower quad's slice where it is the first surface, and the upper one's.
  uint32_t lowerSlice = n, upperSlice = n;
  uint64_t behindUpper = 0, behindLower = 0, nothing = 0;
  for (size_t at = 0; at < d.enter.size(); ++at) {
    if (d.enter[at] >= n) continue;
    lowerSlice = lowerSlice == n ? d.enter[at] : std::max(lowerSlice, d.enter[at]);
    upperSlice = std::min(upperSlice, d.enter[at]);
  }
  ASSERT_LT(upperSlice, lowerSlice);
  for (uint32_t y = 1; y + 1 < d.rect.height; ++y)
    for (uint32_t x = 1; x + 1 < w; ++x) {
      const size_t at = size_t(y) * w + x;
      if (d.enter[at] == upperSlice) {
        EXPECT_EQ(d.next[at], lowerSlice) << x << "," << y;
        ++behindUpper;
      } else if (d.enter[at] == lowerSlice) {
        EXPECT_EQ(d.next[at], n) << x << "," << y;
        ++behindLower;
      } else {
        EXPECT_EQ(d.next[at], n);
        ++nothing;
      }
    }
  EXPECT_GT(behindUpper, 1000u);
  EXPECT_GT(behindLower, 1000u);
}

// The tool on a small forest: lossless, then lossy at 0 and 8. Lossy is smaller, repeats its bytes with any
// thread count, is read by cpvs-info as any 2.0 file, records its bound, and at 0 answers as lossless does on
// sampled surface points.
class LossyBake : public ::testing::Test {
protected:
  static std::string scene() {
    static const std::string path = [] {
      const std::string p = tempDir() + "/forest.glb";
      const test::ToolResult r = runTool(toolPath("cpvs-scenegen") + " foliage --triangles 20000 -o " + p);
      if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen foliage failed: " + r.output);
      return p;
    }();
    return path;
  }
  static std::string bake(const std::string& name, const std::string& extra) {
    const std::string out = tempDir() + "/" + name + ".cpvs";
    const test::ToolResult r = runTool(toolPath("cpvs-bake") + " " + scene() + " -o " + out +
                                       " -r 2k --lights sun --quiet --report " + out + ".json" + extra);
    if (r.exitCode != 0) throw std::runtime_error("cpvs-bake failed: " + r.output);
    return out;
  }
  static std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  static std::vector<std::string> answers(const std::string& cpvs, const std::string& points) {
    const std::string out = cpvs + ".csv";
    const test::ToolResult r =
        runTool(toolPath("cpvs-query") + " " + cpvs + " --points " + points + " -o " + out + " --quiet");
    if (r.exitCode != 0) throw std::runtime_error("cpvs-query failed: " + r.output);
    std::ifstream in(out);
    std::vector<std::string> rows;
    for (std::string line; std::getline(in, line);) rows.push_back(line);
    return rows;
  }
};

TEST_F(LossyBake, SmallerDeterministicReadableAndExactOnSurfacesAtZero) {
  const std::string lossless = bake("lossless", ""), zero = bake("zero", " --max-voxel-error 0");
  const std::string eight = bake("eight", " --max-voxel-error 8"), eightOne = bake("eight-j1", " --max-voxel-error 8 -j 1");
  const std::string edges = bake("edges", " --max-voxel-error 8 --max-edge-error 2");
  const std::string edgesOne = bake("edges-j1", " --max-voxel-error 8 --max-edge-error 2 -j 1");
  const std::string l = read(lossless), z = read(zero), e = read(eight), m = read(edges);
  EXPECT_LT(z.size(), l.size());
  EXPECT_LT(e.size(), z.size());
  EXPECT_LT(m.size(), e.size());
  EXPECT_EQ(e, read(eightOne));
  EXPECT_EQ(m, read(edgesOne));
  const nlohmann::json edgeReport = nlohmann::json::parse(read(edges + ".json"));
  const nlohmann::json& edgeView = edgeReport["lights"][0]["views"][0];
  EXPECT_GT(edgeView["leaves_merged"].get<uint64_t>(), 0u);
  EXPECT_GE(edgeView["edge_texels_flipped"].get<uint64_t>(), edgeView["leaves_merged"].get<uint64_t>());
  EXPECT_LE(edgeView["edge_texels_flipped"].get<uint64_t>(), 2 * edgeView["leaves_merged"].get<uint64_t>());
  EXPECT_EQ(nlohmann::json::parse(orThrow(CpvsFile::open(edges))->settingsJson()).at("max_edge_error").get<uint32_t>(), 2u);

  for (const std::string& file : {zero, eight}) {
    const test::ToolResult info = runTool(toolPath("cpvs-info") + " " + file + " --json");
    ASSERT_EQ(info.exitCode, 0) << info.output;
  }
  const auto file = orThrow(CpvsFile::open(eight));
  const nlohmann::json settings = nlohmann::json::parse(file->settingsJson());
  EXPECT_EQ(settings.at("max_voxel_error").get<uint32_t>(), 8u);
  EXPECT_FALSE(nlohmann::json::parse(orThrow(CpvsFile::open(lossless))->settingsJson()).contains("max_voxel_error"));

  const nlohmann::json report = nlohmann::json::parse(read(eight + ".json"));
  const nlohmann::json& view = report["lights"][0]["views"][0];
  EXPECT_GT(view["free_voxels_lit"].get<uint64_t>(), 0u);
  EXPECT_GT(view["voxels_delayed"].get<uint64_t>(), 0u);
  EXPECT_EQ(nlohmann::json::parse(read(zero + ".json"))["lights"][0]["views"][0]["voxels_delayed"].get<uint64_t>(), 0u);

  const std::string points = tempDir() + "/points.csv";
  const test::ToolResult sample = runTool(toolPath("cpvs-sample") + " " + scene() + " -o " + points + " -n 20000");
  ASSERT_EQ(sample.exitCode, 0) << sample.output;
  const std::vector<std::string> a = answers(lossless, points), b = answers(zero, points);
  ASSERT_EQ(a.size(), b.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
  // Exact up to the texel-centre sampling of the next surfaces (docs/lossy.md): at most 0.1 % of the points.
  EXPECT_LE(differ, a.size() / 1000) << differ << " of " << a.size();
}

TEST_F(LossyBake, RefusesABoundItCannotKeep) {
  for (const char* bad : {" --max-voxel-error -2", " --max-voxel-error 1e9", " --max-voxel-error 4 --undefined none",
                          " --max-edge-error 3", " --max-edge-error -1"}) {
    const std::string flag = std::string(bad).substr(1, std::string(bad).find(' ', 1) - 1);
    const test::ToolResult r =
        runTool(toolPath("cpvs-bake") + " " + scene() + " -o " + tempDir() + "/bad.cpvs -r 256 --quiet" + std::string(bad));
    EXPECT_EQ(r.exitCode, 1) << bad;
    EXPECT_NE(r.output.find(flag), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace cpvs
