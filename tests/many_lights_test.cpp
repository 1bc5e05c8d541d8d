// Many lights in one level: light lists and shards, parts merged into the file one run writes (byte for byte),
// the bake cache (a one-light change re-bakes one light, same bytes as a clean bake), and the warnings.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/bake_cache.h"
#include "libcpvs/bake/cone_crop.h"
#include "libcpvs/bake/light_subsets.h"
#include "libcpvs/bake/merge_parts.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::tempDir;
using test::toolPath;

// A ground slab with a row of blocks and six local lights: four spots along the row, a point light, and a spot
// pointing at the sky (it reaches no geometry).
Scene streetScene() {
  Scene scene;
  test::addBox(scene, "ground", {-30, -1, -6}, {30, 0, 6});
  for (int i = 0; i < 5; ++i)
    test::addBox(scene, "block" + std::to_string(i), {-26.0 + 12 * i, 0, -3}, {-22.0 + 12 * i, 3.0 + i, 1});
  test::classifyMeshes(scene);
  for (int i = 0; i < 4; ++i)
    scene.lights.push_back(test::spotLight("lamp" + std::to_string(i), {-24.0 + 14 * i, 9, 3}, {0.1, -1, -0.2}, 0.6, 20));
  scene.lights.push_back(test::pointLight("bulb", {5, 7, 2}, 15));
  scene.lights.push_back(test::spotLight("skyward", {0, 20, 0}, {0, 1, 0}, 0.5, 10));
  return scene;
}

BakeSettings smallSettings() {
  BakeSettings s;
  s.resolution = 128;
  s.regionSize = 64;  // several regions per view: node order depends on them
  return s;
}

std::string bakeBytes(const Scene& scene, const BakeSettings& settings, BakeReport* report = nullptr) {
  return writeCpvs(bakeScene(scene, settings, report));
}

std::unique_ptr<CpvsFile> openBytes(const std::string& bytes, const std::string& name) {
  auto file = CpvsFile::fromBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, name);
  if (!file.ok()) throw Error(file.outcome());
  return std::move(file).value();
}

TEST(LightSubsets, ParsesIndicesRangesAndNames) {
  const Scene scene = streetScene();
  EXPECT_EQ(parseLightList("0", scene.lights), (std::vector<uint32_t>{0}));
  EXPECT_EQ(parseLightList("3,0-1,bulb,1", scene.lights), (std::vector<uint32_t>{0, 1, 3, 4}));
  EXPECT_EQ(parseLightList("skyward,2-3", scene.lights), (std::vector<uint32_t>{2, 3, 5}));
  EXPECT_EQ(formatLightList({0, 1, 2, 4, 6, 7}), "0-2,4,6-7");
  for (const char* bad : {"6", "0-6", "3-1", "lamp9", "0,,1", "", "1,", "-1"}) {
    try {
      parseLightList(bad, scene.lights);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::InvalidArgument);
      EXPECT_NE(std::string(e.what()).find("light list"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(parseShard("2/4").index, 2u);
  for (const char* bad : {"4/4", "0/0", "1", "a/b", "-1/4", "1/4/2"}) EXPECT_THROW(parseShard(bad), Error) << bad;
}

TEST(LightSubsets, ShardsHoldEveryLightOnceAndBalanceTheCost) {
  const std::vector<double> costs = {9, 1, 1, 1, 5, 4, 3, 3, 2, 8};
  std::vector<uint32_t> all(costs.size());
  for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  std::vector<int> seen(costs.size(), 0);
  double heaviest = 0, lightest = 1e9;
  for (uint32_t s = 0; s < 3; ++s) {
    double load = 0;
    for (const uint32_t light : shardLights(all, costs, {s, 3})) {
      ++seen[light];
      load += costs[light];
    }
    heaviest = std::max(heaviest, load);
    lightest = std::min(lightest, load);
  }
  for (const int n : seen) EXPECT_EQ(n, 1);
  EXPECT_LE(heaviest - lightest, 1.0);  // 37 in all: 13 / 12 / 12
  // More shards than lights: the extra shards are empty, none is lost.
  EXPECT_TRUE(shardLights({0, 1}, costs, {4, 5}).empty());
}

TEST(ManyLights, ShardsMergedEqualOneRun) {
  const Scene scene = streetScene();
  std::string whole;
  SKIP_WITHOUT_OSMESA(whole = bakeBytes(scene, smallSettings()));
  std::vector<std::string> partBytes;
  for (uint32_t s = 0; s < 3; ++s) {
    BakeSettings settings = smallSettings();
    settings.shard = {s, 3};
    settings.threads = 1 + s % 2;  // no byte depends on it
    partBytes.push_back(bakeBytes(scene, settings));
    EXPECT_NE(partBytes.back(), whole);
  }
  std::vector<std::unique_ptr<CpvsFile>> files;
  std::vector<NamedPart> parts;
  for (size_t i : {2, 0, 1}) {  // any order
    files.push_back(openBytes(partBytes[i], "part" + std::to_string(i)));
    parts.push_back({"part" + std::to_string(i), files.back().get()});
  }
  EXPECT_EQ(writeCpvs(mergeParts(parts)), whole);

  // A named list and its complement.
  BakeSettings first = smallSettings(), rest = smallSettings();
  first.lights = {0, 4};
  rest.lights = {1, 2, 3, 5};
  const std::string a = bakeBytes(scene, first), b = bakeBytes(scene, rest);
  const auto fa = openBytes(a, "a.cpvs"), fb = openBytes(b, "b.cpvs");
  EXPECT_EQ(fa->lights().size(), 2u);
  EXPECT_EQ(fa->lights()[1].light.name, "bulb");
  EXPECT_EQ(writeCpvs(mergeParts({{"b.cpvs", fb.get()}, {"a.cpvs", fa.get()}})), whole);

  // Refusals: a missing light, an overlap, parts of another bake.
  const auto expectRefusal = [](const std::vector<NamedPart>& p, const std::string& needle) {
    try {
      mergeParts(p);
      ADD_FAILURE() << "merged; expected a refusal mentioning '" << needle << "'";
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::InvalidInput);
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expectRefusal({{"a.cpvs", fa.get()}}, "missing: 1-3,5");
  expectRefusal({{"a.cpvs", fa.get()}, {"b.cpvs", fb.get()}, {"part0", files[1].get()}}, "is in both");
  BakeSettings other = smallSettings();
  other.lights = {1, 2, 3, 5};
  other.resolution = 64;
  const std::string c = bakeBytes(scene, other);
  const auto fc = openBytes(c, "c.cpvs");
  expectRefusal({{"a.cpvs", fa.get()}, {"c.cpvs", fc.get()}}, "differ in: input_hash, resolution");
}

TEST(ManyLights, CacheRebakesOnlyTheLightsAChangeReaches) {
  Scene scene = streetScene();
  const std::string folder = tempDir() + "/cache";
  BakeSettings settings = smallSettings();
  settings.cacheFolder = folder;
  BakeReport first;
  SKIP_WITHOUT_OSMESA(bakeBytes(scene, settings, &first));
  for (const LightReport& l : first.lights) EXPECT_EQ(l.cache, LightReport::Cache::Miss) << l.name;

  // Move one light: it alone is baked again, and the file equals a clean bake.
  scene.lights[1].position.x += 1.5;
  BakeReport second;
  const std::string cached = bakeBytes(scene, settings, &second);
  BakeSettings clean = smallSettings();
  EXPECT_EQ(cached, bakeBytes(scene, clean));
  for (const LightReport& l : second.lights)
    EXPECT_EQ(l.cache, l.index == 1 ? LightReport::Cache::Miss : LightReport::Cache::Hit) << l.name;

  // Raise one block (not above the tallest, so the scene's bounds stay): the lights that reach it are baked
  // again, the lamp at the far end of the street (14 units beyond its range) and the skyward spot are not.
  Mesh& block = scene.meshes[4];  // block3, x in [10, 14], 6 high
  for (glm::vec3& p : block.positions)
    if (p.y > 1) p.y += 0.5f;
  BakeReport third;
  EXPECT_EQ(bakeBytes(scene, settings, &third), bakeBytes(scene, clean));
  std::vector<uint32_t> missed;
  for (const LightReport& l : third.lights)
    if (l.cache == LightReport::Cache::Miss) missed.push_back(l.index);
  EXPECT_EQ(missed, (std::vector<uint32_t>{2, 3, 4}));

  // A damaged entry is baked again with a warning, never used.
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    std::fstream f(entry.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    f.put('\x5a');
  }
  BakeReport fourth;
  EXPECT_EQ(bakeBytes(scene, settings, &fourth), bakeBytes(scene, clean));
  size_t damaged = 0;
  for (const std::string& w : fourth.warnings) damaged += w.find("bake cache entry ignored") != std::string::npos;
  EXPECT_GT(damaged, 0u);
}

TEST(ManyLights, ABoundedCacheKeepsTheMostRecentlyUsedEntries) {
  Scene scene = streetScene();
  const std::string folder = tempDir() + "/bounded_cache";
  std::filesystem::remove_all(folder);
  BakeSettings settings = smallSettings();
  settings.cacheFolder = folder;
  BakeReport first;
  SKIP_WITHOUT_OSMESA(bakeBytes(scene, settings, &first));
  // This test is about light entries: the views' region packs (tests/incremental_bake_test.cpp) go.
  const auto removeRegionPacks = [&] {
    for (const auto& entry : std::filesystem::directory_iterator(folder))
      if (entry.path().extension() == ".regions") std::filesystem::remove(entry.path());
  };
  removeRegionPacks();
  std::map<std::string, uint64_t> sizes;  // every light's entry
  uint64_t total = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    total += sizes[entry.path().filename().string()] = entry.file_size();
  ASSERT_EQ(sizes.size(), first.lights.size());
  EXPECT_EQ(first.cacheEntriesRemoved, 0u);
  // A file that is not an entry is never counted nor removed.
  { std::ofstream(folder + "/notes.txt") << "kept"; }
  // Move light 1 and bake again: its new entry joins, the other lights' entries are used (found) again, the
  // moved light's old one is not. Bounded to what the entries this bake used take, the folder loses exactly
  // that old entry, the least recently used.
  scene.lights[1].position.x += 1.5;
  BakeReport second;
  const std::string bytes = bakeBytes(scene, settings, &second);
  BakeSettings clean = smallSettings();
  EXPECT_EQ(bytes, bakeBytes(scene, clean));
  removeRegionPacks();
  std::map<std::string, uint64_t> now;
  uint64_t nowTotal = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".cpvs") nowTotal += now[entry.path().filename().string()] = entry.file_size();
  ASSERT_EQ(now.size(), first.lights.size() + 1);
  EXPECT_EQ(second.lights[1].cache, LightReport::Cache::Miss);
  const BakeCache::Trimmed trimmed = BakeCache(folder).trim(nowTotal - 1);
  EXPECT_EQ(trimmed.removed, 1u);
  std::set<std::string> left;
  uint64_t leftBytes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".cpvs") left.insert(entry.path().filename().string()), leftBytes += entry.file_size();
  EXPECT_EQ(left.size(), first.lights.size());
  EXPECT_EQ(leftBytes, trimmed.bytesLeft);
  EXPECT_TRUE(std::filesystem::exists(folder + "/notes.txt"));
  // Every light of this bake is still there: a third bake of the same scene takes all from the cache.
  BakeReport third;
  EXPECT_EQ(bakeBytes(scene, settings, &third), bytes);
  for (const LightReport& l : third.lights) EXPECT_EQ(l.cache, LightReport::Cache::Hit) << l.name;
  // A bound below one entry leaves nothing.
  settings.cacheMaxBytes = 1;
  BakeReport fourth;
  bakeBytes(scene, settings, &fourth);
  EXPECT_EQ(fourth.cacheBytes, 0u);
  EXPECT_EQ(fourth.cacheEntriesRemoved, first.lights.size());
}

TEST(ManyLights, WarnsAboutALightThatReachesNothingAndTinyRanges) {
  Scene scene = streetScene();
  BakeReport report;
  SKIP_WITHOUT_OSMESA(bakeScene(scene, smallSettings(), &report));
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("'skyward' (index 5) reaches no geometry"), std::string::npos) << report.warnings[0];
  EXPECT_FALSE(report.lights[5].reachesGeometry);

  // The same level authored in centimetres with ranges left in metres.
  for (Mesh& m : scene.meshes)
    for (glm::vec3& p : m.positions) p *= 100.0f;
  for (Light& l : scene.lights) l.position *= 100.0;
  BakeReport centimetres;
  bakeScene(scene, smallSettings(), &centimetres);
  bool unitsWarned = false;
  for (const std::string& w : centimetres.warnings) unitsWarned |= w.find("same units") != std::string::npos;
  EXPECT_TRUE(unitsWarned);
}

TEST(ManyLights, VoxelSizeGivesEachLightTheResolutionItNeeds) {
  Scene scene = streetScene();
  scene.lights.push_back(test::spotLight("candle", {-24, 1.5, 2}, {0, -1, 0}, 0.5, 3));  // a small light
  BakeSettings settings = smallSettings();
  settings.resolution = 1024;  // the cap
  settings.voxelSize = 0.05;
  BakeReport report;
  CpvsContent content;
  SKIP_WITHOUT_OSMESA(content = bakeScene(scene, settings, &report));
  std::map<std::string, uint32_t> resolution;
  for (const BakedLight& l : content.lights)
    for (const BakedView& v : l.views) {
      EXPECT_EQ(v.view.resolution, l.views[0].view.resolution) << l.light.name;  // one N per light
      resolution[l.light.name] = v.view.resolution;
      if (v.view.empty) continue;
      // Small enough, and not more than twice smaller than asked: the smallest power of two that does.
      EXPECT_LE(largestVoxelSize(v.view), settings.voxelSize * 1.01) << l.light.name;
      if (v.view.resolution > 8 && v.view.resolution < settings.resolution) {
        EXPECT_GT(largestVoxelSize(v.view) * 2, settings.voxelSize * 0.99) << l.light.name;
      }
    }
  EXPECT_LT(resolution["candle"], resolution["lamp0"]);
  EXPECT_LE(resolution["lamp0"], 1024u);
  EXPECT_EQ(resolution["skyward"], 8u);  // reaches nothing
  // A voxel size too small for the cap: every light that reaches geometry gets the cap.
  settings.voxelSize = 1e-6;
  const CpvsContent capped = bakeScene(scene, settings);
  EXPECT_EQ(capped.lights[0].views[0].view.resolution, 1024u);
  // The setting is part of what the file says and hashes.
  EXPECT_NE(content.settingsJson.find("\"voxel_size\":0.05"), std::string::npos) << content.settingsJson;
  EXPECT_EQ(bakeScene(scene, smallSettings()).settingsJson.find("voxel_size"), std::string::npos);
}

// Outside a spot's cone the voxels are left free; every lookup inside the cone, PCF up to 33 x 33 at the cone's
// very edge included, answers as the uncropped bake does.
TEST(ManyLights, ConeCropChangesNoLookupAndSavesBytes) {
  Scene scene;
  test::addBox(scene, "ground", {-40, -1, -40}, {40, 0, 40});
  for (int i = 0; i < 6; ++i)
    test::addBox(scene, "post" + std::to_string(i), {-9.0 + 3 * i, 0, -1.0 + (i % 3)}, {-8.0 + 3 * i, 2.0 + i, 0.0 + (i % 3)});
  test::classifyMeshes(scene);
  scene.lights = {test::spotLight("lamp", {0, 12, 0}, {0.15, -1, 0.1}, 0.6, 40)};
  BakeSettings cropped = smallSettings(), whole = smallSettings();
  cropped.resolution = whole.resolution = 256;
  whole.cropToCone = false;
  BakeReport report;
  CpvsContent a, b;
  SKIP_WITHOUT_OSMESA(a = bakeScene(scene, cropped, &report));
  b = bakeScene(scene, whole);
  EXPECT_GT(report.lights[0].views[0].texelsOutsideCone, 0u);
  EXPECT_LT(a.lights[0].views[0].dag.bytes(), b.lights[0].views[0].dag.bytes());
  const Light& light = scene.lights[0];
  const LightView& view = a.lights[0].views[0].view;
  const DagView da = a.lights[0].views[0].dag.view(), db = b.lights[0].views[0].dag.view();
  size_t inside = 0, edge = 0;
  for (int k : {1, 9, 33})
    for (double x = -20; x <= 20; x += 0.173)
      for (double z = -20; z <= 20; z += 0.191) {
        const glm::dvec3 p(x, 0, z), up(0, 1, 0);
        if (!withinInfluence(light, p)) continue;
        ++inside;
        const glm::dvec3 d = glm::normalize(p - light.position);
        edge += glm::dot(d, glm::normalize(light.direction)) < std::cos(light.outerConeAngle) + 0.01;
        ASSERT_EQ(visibility(view, da, light, p, up, k), visibility(view, db, light, p, up, k))
            << "K " << k << " at " << x << "," << z;
      }
  EXPECT_GT(inside, 10000u);
  EXPECT_GT(edge, 100u);  // the cone's edge was sampled

  // A cone wider than the view's 85-degree cap covers the whole view: nothing may be cropped.
  for (const double outer : {1.50, 1.5707963267948966}) {
    Scene wide = scene;
    wide.lights = {test::spotLight("flood", {0, 3, 0}, {0, -1, 0}, outer, 40)};
    BakeReport wideReport;
    bakeScene(wide, cropped, &wideReport);
    EXPECT_EQ(wideReport.lights[0].views[0].texelsOutsideCone, 0u) << outer;
  }
}

// The renderer visits, and the bake keeps, exactly the texels whose centre lies within the crop radius: the
// spans found by bisection equal the per-texel test on every row of every region, for cones narrower than the
// view, off-axis views and regions that the cone's edge crosses, and a region wholly outside is all free.
TEST(ConeCrop, SpansHoldExactlyTheTexelsWithinTheRadius) {
  Scene scene;
  test::addBox(scene, "ground", {-40, -1, -40}, {40, 0, 40});
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene);
  size_t rows = 0, partialRows = 0, emptyRows = 0;
  for (const double outer : {0.3, 0.6, 0.9})
    for (const glm::dvec3 direction : {glm::dvec3(0, -1, 0), glm::dvec3(0.4, -1, 0.25)}) {
      const Light light = test::spotLight("lamp", {1, 12, -2}, direction, outer, 60);
      for (const uint32_t n : {256u, 1000u}) {
        const LightView view = makeLightViews(light, world, n).at(0);
        const ConeCrop crop = coneCropOf(light, view);
        ASSERT_TRUE(crop.active) << outer;
        const double ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
        for (const RegionRect rect : {RegionRect{0, 0, n, n}, RegionRect{0, 0, n / 4, n / 4},
                                      RegionRect{n / 4, n / 2, n / 4, n / 8}, RegionRect{n - 24, 0, 24, n}}) {
          const RowSpans spans = crop.inside(view, rect);
          DepthRegion region;
          region.rect = rect;
          region.resolution = n;
          region.enter.assign(size_t(rect.width) * rect.height, 7);
          region.exit.assign(region.enter.size(), 9);
          const uint64_t freed = ConeCrop::freeOutside(spans, region);
          uint64_t outside = 0;
          for (uint32_t y = 0; y < rect.height; ++y) {
            const double b = view.yMin + (rect.y0 + y + 0.5) * ey / n;
            ++rows;
            partialRows += spans.begin[y] > 0 || spans.end[y] < rect.width;
            emptyRows += spans.begin[y] >= spans.end[y];
            for (uint32_t x = 0; x < rect.width; ++x) {
              const double a = view.xMin + (rect.x0 + x + 0.5) * ex / n;
              const bool within = a * a + b * b <= crop.radius * crop.radius;
              ASSERT_EQ(within, x >= spans.begin[y] && x < spans.end[y])
                  << "texel " << x << "," << y << " of region " << rect.x0 << "," << rect.y0 << " (n " << n << ")";
              outside += !within;
              const size_t i = size_t(y) * rect.width + x;
              ASSERT_EQ(region.enter[i], within ? 7u : 0u);
              ASSERT_EQ(region.exit[i], within ? 9u : n);
            }
          }
          EXPECT_EQ(freed, outside);
          if (crop.regionOutside(view, rect)) {
            EXPECT_EQ(outside, uint64_t(rect.width) * rect.height);
          }
        }
      }
    }
  EXPECT_GT(partialRows, rows / 4);
  EXPECT_GT(emptyRows, 100u);
}

TEST(ManyLights, ToolsSplitMergeAndLogOneLinePerLight) {
  const std::string dir = tempDir();
  const std::string scene = dir + "/spots.glb";
  ASSERT_EQ(runTool(toolPath("cpvs-scenegen") + " city-spots --triangles 5000 --lights 7 -o " + scene).exitCode, 0);
  const std::string bake = toolPath("cpvs-bake") + " " + scene + " -r 64 --region 32";
  const test::ToolResult whole = runTool(bake + " -o " + dir + "/whole.cpvs --report " + dir + "/whole.json");
  ASSERT_EQ(whole.exitCode, 0) << whole.output;
  // stderr is not a terminal here: one line per finished light.
  EXPECT_NE(whole.output.find("cpvs-bake: light 7/7 'spot_6' (index 6): 1 view(s)"), std::string::npos) << whole.output;
  std::string parts;
  for (int s = 0; s < 3; ++s) {
    const std::string part = dir + "/part" + std::to_string(s) + ".cpvs";
    const test::ToolResult r = runTool(bake + " -q --shard " + std::to_string(s) + "/3 -o " + part);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(r.output, "");  // --quiet
    parts += " " + part;
  }
  const test::ToolResult merged = runTool(toolPath("cpvs-merge") + parts + " -o " + dir + "/merged.cpvs");
  ASSERT_EQ(merged.exitCode, 0) << merged.output;
  EXPECT_EQ(runTool("cmp " + dir + "/whole.cpvs " + dir + "/merged.cpvs").exitCode, 0);
  // A missing part: exit 2 (invalid input), nothing written.
  const test::ToolResult missing = runTool(toolPath("cpvs-merge") + " " + dir + "/part0.cpvs -o " + dir + "/half.cpvs");
  EXPECT_EQ(missing.exitCode, 2) << missing.output;
  EXPECT_NE(missing.output.find("missing:"), std::string::npos) << missing.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/half.cpvs"));
  // Bad flags name themselves.
  const test::ToolResult badShard = runTool(bake + " --shard 3/3 -o " + dir + "/x.cpvs");
  EXPECT_EQ(badShard.exitCode, 1) << badShard.output;
  EXPECT_NE(badShard.output.find("--shard"), std::string::npos) << badShard.output;
  const test::ToolResult badList = runTool(bake + " --lights 0,Nope -o " + dir + "/x.cpvs");
  EXPECT_NE(badList.exitCode, 0);
  EXPECT_NE(badList.output.find("--lights: light list '0,Nope': 'Nope'"), std::string::npos) << badList.output;
  // cpvs-info tells the input hash a bake with the same options writes, before baking.
  const test::ToolResult info = runTool(toolPath("cpvs-info") + " " + scene + " -r 64 --region 32 --json");
  ASSERT_EQ(info.exitCode, 0) << info.output;
  const auto file = CpvsFile::open(dir + "/whole.cpvs");
  ASSERT_TRUE(file.ok());
  const std::string hash = nlohmann::json::parse(file.value()->settingsJson())["input_hash"];
  EXPECT_EQ(nlohmann::json::parse(info.output)["input_hash"], hash);
  EXPECT_NE(nlohmann::json::parse(runTool(toolPath("cpvs-info") + " " + scene + " -r 128 --region 32 --json").output)
                ["input_hash"], hash);
  // The report says which lights a run baked and how.
  std::ifstream in(dir + "/whole.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["scene_lights"], 7);
  EXPECT_EQ(report["lights"][6]["index"], 6);
  EXPECT_EQ(report["lights"][6]["cache"], "off");
}

}  // namespace
}  // namespace cpvs
