// The CPU rasteriser's uniform tiles (docs/depth-maps.md, "Uniform tiles") against its per-texel path: every
// region of every view is rendered both ways and each tile's chain compared, on the shipped scenes, the
// compressed dioramas, a ground sheet, generated cities and forests, and random triangle soups; and whole bakes
// give the same bytes either way.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/bake/cone_crop.h"
#include "libcpvs/raster/cpu_depth_renderer.h"
#include "libcpvs/tiles/tile_masks.h"
#include "libcpvs/views/view_fitting.h"
#include "libcpvs/views/view_geometry.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

struct Totals {
  uint64_t regions = 0, tiles = 0, uniform = 0, summarized = 0, earlyStops = 0, wideRegions = 0;
};

// Renders every region of every view of `light` with and without uniform tiles, as a bake does (cone crop
// included), and checks that the two give the same tile chains in `modes`, the same texels wherever the fast
// path wrote texels, and the same peel counts. Where the CPU has AVX2, the rasteriser's AVX2 copy renders both
// ways too and must give the baseline's texels and summaries exactly.
void compareLight(const WorldGeometry& world, const Light& light, uint32_t n, uint32_t regionSize,
                  const PeelSettings& peel, const std::string& what, Totals& totals) {
  const std::unique_ptr<DepthRenderer> renderer = createCpuDepthRenderer(CpuPeel::Replay, RasterIsa::Baseline);
  // The CPU decides, not CPVS_RASTER_ISA (which lowers only bestRasterIsa's choice).
  const std::unique_ptr<DepthRenderer> wide =
#if defined(__x86_64__) && defined(__GNUC__)
      __builtin_cpu_supports("avx2") ? createCpuDepthRenderer(CpuPeel::Replay, RasterIsa::Avx2) :
#endif
                                     nullptr;
  for (const LightView& view : makeLightViews(light, world, n)) {
    if (view.empty) continue;
    const ViewGeometry geometry = gatherViewGeometry(world, view);
    const ConeCrop crop = coneCropOf(light, view);
    for (const RegionRect& rect : splitIntoRegions(n, regionSize)) {
      if (crop.regionOutside(view, rect)) continue;
      const RowSpans inside = crop.inside(view, rect);
      const RowSpans* needed = crop.active ? &inside : nullptr;
      RenderStats perTexelStats, uniformStats;
      DepthRegion perTexel = renderer->render(geometry, view, rect, peel, &perTexelStats, needed, false);
      DepthRegion uniform = renderer->render(geometry, view, rect, peel, &uniformStats, needed, true);
      const std::string where = what + " view " + std::to_string(view.face) + " region " + std::to_string(rect.x0) +
                                "," + std::to_string(rect.y0);
      if (wide) {
        RenderStats widePerTexelStats, wideUniformStats;
        const DepthRegion widePerTexel = wide->render(geometry, view, rect, peel, &widePerTexelStats, needed, false);
        const DepthRegion wideUniform = wide->render(geometry, view, rect, peel, &wideUniformStats, needed, true);
        ASSERT_TRUE(widePerTexel.enter == perTexel.enter && widePerTexel.exit == perTexel.exit) << where << " (AVX2)";
        ASSERT_EQ(widePerTexelStats.peelIterations, perTexelStats.peelIterations) << where << " (AVX2)";
        ASSERT_EQ(widePerTexelStats.texelsAtPeelCap, perTexelStats.texelsAtPeelCap) << where << " (AVX2)";
        ASSERT_EQ(wideUniformStats.uniformTiles, uniformStats.uniformTiles) << where << " (AVX2)";
        ASSERT_EQ(wideUniform.tiles.size(), uniform.tiles.size()) << where << " (AVX2)";
        for (size_t t = 0; t < uniform.tiles.size(); ++t) {
          ASSERT_EQ(wideUniform.tiles[t].summarized, uniform.tiles[t].summarized) << where << " tile " << t;
          ASSERT_EQ(wideUniform.tiles[t].maxEnter, uniform.tiles[t].maxEnter) << where << " tile " << t;
          ASSERT_EQ(wideUniform.tiles[t].minExit, uniform.tiles[t].minExit) << where << " tile " << t;
          if (uniform.tiles[t].summarized) continue;  // else every texel was written: compare them
          const uint32_t tx = uint32_t(t % (rect.width / 8)), ty = uint32_t(t / (rect.width / 8));
          for (uint32_t y = ty * 8; y < ty * 8 + 8; ++y)
            for (uint32_t x = tx * 8; x < tx * 8 + 8; ++x)
              ASSERT_TRUE(wideUniform.enterAt(x, y) == uniform.enterAt(x, y) &&
                          wideUniform.exitAt(x, y) == uniform.exitAt(x, y))
                  << where << " texel " << x << "," << y << " (AVX2)";
        }
        ++totals.wideRegions;
      }
      ConeCrop::freeOutside(inside, perTexel);
      ConeCrop::freeOutside(inside, uniform);
      ASSERT_TRUE(perTexel.tiles.empty()) << where;
      ASSERT_EQ(perTexelStats.peelIterations, uniformStats.peelIterations) << where;
      ASSERT_EQ(perTexelStats.texelsAtPeelCap, uniformStats.texelsAtPeelCap) << where;
      const uint32_t tilesX = rect.width / 8;
      for (size_t t = 0; t < uniform.tiles.size(); ++t) {
        const uint32_t tx = uint32_t(t % tilesX), ty = uint32_t(t / tilesX);
        if (uniform.tiles[t].summarized) {  // its two values are exactly the per-texel maps' extremes
          uint32_t maxEnter = 0, minExit = n;
          for (uint32_t y = ty * 8; y < ty * 8 + 8; ++y)
            for (uint32_t x = tx * 8; x < tx * 8 + 8; ++x) {
              maxEnter = std::max(maxEnter, perTexel.enterAt(x, y));
              minExit = std::min(minExit, perTexel.exitAt(x, y));
            }
          ASSERT_EQ(uniform.tiles[t].maxEnter, maxEnter) << where << " tile " << tx << "," << ty;
          ASSERT_EQ(uniform.tiles[t].minExit, minExit) << where << " tile " << tx << "," << ty;
          continue;
        }
        for (uint32_t y = ty * 8; y < ty * 8 + 8; ++y)
          for (uint32_t x = tx * 8; x < tx * 8 + 8; ++x) {
            ASSERT_EQ(perTexel.enterAt(x, y), uniform.enterAt(x, y)) << where << " texel " << x << "," << y;
            ASSERT_EQ(perTexel.exitAt(x, y), uniform.exitAt(x, y)) << where << " texel " << x << "," << y;
          }
      }
      for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn}) {
        const TileChains a = buildTileChains(perTexel, mode), b = buildTileChains(uniform, mode);
        ASSERT_EQ(a.first, b.first) << where << " " << undefinedModeName(mode);
        ASSERT_EQ(a.start, b.start) << where << " " << undefinedModeName(mode);
        ASSERT_EQ(a.mask, b.mask) << where << " " << undefinedModeName(mode);
        ASSERT_EQ(a.litUntil, b.litUntil) << where << " " << undefinedModeName(mode);
        ASSERT_EQ(a.darkFrom, b.darkFrom) << where << " " << undefinedModeName(mode);
      }
      ++totals.regions;
      totals.tiles += uint64_t(tilesX) * (rect.height / 8);
      totals.uniform += uniformStats.uniformTiles;
      totals.summarized += uniformStats.summarizedTiles;
      totals.earlyStops += uniformStats.peelIterations < peel.maxPeels && uniformStats.texelsAtPeelCap > 0;
    }
  }
}

void report(const char* what, const Totals& t) {
  std::printf("[ uniform  ] %s: %llu regions, %llu tiles, %llu uniform, %llu summarised, %llu early stops, %llu "
              "regions also rendered by the AVX2 copy\n",
              what, (unsigned long long)t.regions, (unsigned long long)t.tiles, (unsigned long long)t.uniform,
              (unsigned long long)t.summarized, (unsigned long long)t.earlyStops, (unsigned long long)t.wideRegions);
}

std::vector<Light> sunAndSpot(const WorldGeometry& world) {
  const glm::dvec3 c = world.bounds.center();
  const double r = 0.5 * glm::length(world.bounds.extent());
  return {test::sunLight("sun", {0.3, -1.0, 0.2}),
          test::spotLight("spot", c + glm::dvec3(0.35 * r, 1.6 * r, 0.2 * r), -glm::dvec3(0.35, 1.6, 0.2), 0.5,
                          10 * r)};
}

// The shipped scenes: closed meshes, open ones, a ground sheet (Terrain), two compressed dioramas with
// alpha-tested materials, each under a sun and a spot, at several peel caps and early stops.
TEST(UniformTiles, ChainsEqualThePerTexelPathOnTheShippedScenes) {
  Totals totals;
  const char* scenes[] = {"data/scenes/Tiny/tiny.gltf",
                          "data/scenes/TorusKnot/torusknot.gltf",
                          "data/scenes/Terrain/terrain.gltf",
                          "data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf",
                          "data/scenes/FlightHelmet/FlightHelmet.gltf",
                          "data/scenes/JapaneseTemple/scene.gltf",
                          "data/scenes/MacrossCityDiorama/scene.glb",
                          "data/scenes/JapaneseBridgeGarden/scene.glb"};
  for (const char* path : scenes) {
    const WorldGeometry world = flatten(importGltf(test::sourcePath(path)));
    for (const Light& light : sunAndSpot(world)) {
      compareLight(world, light, 1024, 512, PeelSettings{}, std::string(path) + " " + light.name, totals);
      compareLight(world, light, 512, 512, PeelSettings{3, 20000}, std::string(path) + " " + light.name, totals);
      compareLight(world, light, 256, 128, PeelSettings{1, 0}, std::string(path) + " " + light.name, totals);
    }
  }
  report("shipped scenes", totals);
  // Both paths must have been taken, or the comparison proves little.
  EXPECT_GT(totals.summarized, totals.tiles / 4);
  EXPECT_GT(totals.uniform, totals.summarized);
  EXPECT_LT(totals.uniform, totals.tiles);
}

// A generated closed city (nested solids, ledges: the peel's cap and early stop), its open twin, and the forest
// level (instanced leaf cards with alpha masks over a ground sheet), by the scene generator.
TEST(UniformTiles, ChainsEqualThePerTexelPathOnGeneratedLevels) {
  const std::string dir = test::tempDir();
  Totals totals;
  for (const std::string kind : {"city --triangles 20000", "open-city --triangles 20000", "foliage --triangles 30000"}) {
    const std::string file = dir + "/level.glb";
    const test::ToolResult gen = test::runTool(test::toolPath("cpvs-scenegen") + " " + kind + " -o " + file);
    ASSERT_EQ(gen.exitCode, 0) << gen.output;
    const WorldGeometry world = flatten(importGltf(file));
    for (const Light& light : sunAndSpot(world)) {
      compareLight(world, light, 2048, 1024, PeelSettings{}, kind + " " + light.name, totals);
      compareLight(world, light, 1024, 256, PeelSettings{2, 20000}, kind + " " + light.name, totals);
    }
  }
  report("generated levels", totals);
  EXPECT_GT(totals.summarized, totals.tiles / 4);
  EXPECT_GT(totals.earlyStops, 0u);
}

// Random soups: rotated boxes that intersect and nest (closed), boxes sharing faces with a twin (coincident
// layers, ties), and open triangles of every size and slope, under suns and spots from many directions.
TEST(UniformTiles, ChainsEqualThePerTexelPathOnRandomSoups) {
  Totals totals;
  for (uint32_t seed = 1; seed <= 12; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const auto range = [&](double a, double b) { return a + (b - a) * unit(rng); };
    Scene scene;
    test::addBox(scene, "ground", {-20, -2, -20}, {20, 0, 20});
    for (int b = 0; b < 14; ++b) {
      const glm::dvec3 lo(range(-15, 10), range(-1, 6), range(-15, 10));
      const glm::dvec3 hi = lo + glm::dvec3(range(0.5, 8), range(0.5, 8), range(0.5, 8));
      test::addBox(scene, "box" + std::to_string(b), lo, hi);
      if (b % 3 == 0) {  // rotated about a random axis
        const glm::dvec3 axis = glm::normalize(glm::dvec3(range(-1, 1), range(0.1, 1), range(-1, 1)));
        scene.instances.back().worldFromLocal = glm::rotate(glm::dmat4(1.0), range(0, 3.1), axis);
      }
      if (b % 5 == 0)  // a twin sharing its bottom face and one side
        test::addBox(scene, "twin" + std::to_string(b), {lo.x, lo.y, lo.z}, {hi.x + 2, hi.y - 0.25, hi.z});
    }
    for (int t = 0; t < 30; ++t) {
      const glm::dvec3 a(range(-18, 18), range(0, 12), range(-18, 18));
      const double size = t % 4 == 0 ? 25 : 4;
      test::addQuad(scene, "tri" + std::to_string(t), a,
                    a + glm::dvec3(range(-size, size), range(-3, 3), range(-size, size)),
                    a + glm::dvec3(range(-size, size), range(-3, 3), range(-size, size)), a);
    }
    test::classifyMeshes(scene);
    const WorldGeometry world = flatten(scene);
    const glm::dvec3 direction(range(-1, 1), -range(0.2, 1), range(-1, 1));
    const std::vector<Light> lights = {
        test::sunLight("sun", direction),
        test::spotLight("spot", glm::dvec3(range(-10, 10), range(20, 40), range(-10, 10)), direction, range(0.2, 1.2),
                        200),
        test::pointLight("point", glm::dvec3(range(-5, 5), range(2, 10), range(-5, 5)), 100)};
    for (const Light& light : lights)
      compareLight(world, light, 512, seed % 2 ? 512 : 128, PeelSettings{uint32_t(1 + seed % 3), seed % 4 ? 64u : 20000u},
                   "soup " + std::to_string(seed) + " " + light.name, totals);
  }
  // Overlapping solids under a sun from straight above (their walls edge-on, not drawn): inside box A, box B's hidden top and bottom cross the
  // tiles along its sides while A's top covers them. Where B is, the ray leaves the union at B's bottom, beside
  // it at A's: a hidden crossing that covers part of a tile must keep the tile off the fast path.
  {
    Scene scene;
    test::addBox(scene, "a", {-4, 0, -4}, {4, 10, 4});
    test::addBox(scene, "b", {-1.3, -5, -1.3}, {6, 5, 6});
    test::classifyMeshes(scene);
    const WorldGeometry world = flatten(scene);
    for (uint32_t cap : {1u, 2u, 3u})
      compareLight(world, test::sunLight("sun", {0, -1, 0}), 512, 256, PeelSettings{cap, 0},
                   "overlapping boxes cap " + std::to_string(cap), totals);
  }
  report("random soups", totals);
  EXPECT_GT(totals.summarized, totals.tiles / 4);
  EXPECT_LT(totals.uniform, totals.tiles);
}

// Whole bakes, uniform tiles against --per-texel: the same bytes, with the spots' cone crop, a point light's
// six views, several regions per view and both threads counts.
TEST(UniformTiles, BakesGiveTheBytesOfThePerTexelPath) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf"));
  const WorldGeometry world = flatten(scene);
  Scene lit = scene;
  lit.lights = sunAndSpot(world);
  lit.lights.push_back(test::pointLight("point", world.bounds.center() + glm::dvec3(0, 1, 0), 50));
  for (unsigned threads : {1u, 2u}) {
    BakeSettings settings;
    settings.resolution = 1024;
    settings.regionSize = 256;
    settings.threads = threads;
    BakeReport fastReport;
    const std::string fast = writeCpvs(bakeScene(lit, settings, &fastReport));
    settings.perTexel = true;
    BakeReport slowReport;
    const std::string slow = writeCpvs(bakeScene(lit, settings, &slowReport));
    EXPECT_EQ(fast, slow) << "threads " << threads;
    uint64_t uniform = 0, perTexelUniform = 0;
    for (size_t l = 0; l < fastReport.lights.size(); ++l)
      for (size_t v = 0; v < fastReport.lights[l].views.size(); ++v) {
        uniform += fastReport.lights[l].views[v].uniformTiles;
        perTexelUniform += slowReport.lights[l].views[v].uniformTiles;
      }
    EXPECT_GT(uniform, 0u);
    EXPECT_EQ(perTexelUniform, 0u);
  }
}

}  // namespace
}  // namespace cpvs
