// cpvs-bake end to end: every required voxel of the baked DAGs agrees with the depth maps they were
// built from, in every mode and with and without node reuse; regions and thread counts change no byte; the tool
// writes atomically, reports what pipelines read, and exits with its documented codes.
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "tools/common/exit_codes.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::sourcePath;
using test::tempDir;
using test::toolPath;

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Closed boxes on a closed ground slab, an open roof quad over one of them, and an open wall: free voxels
// inside the solids, open casters in the air, shadows over both.
Scene mixedScene() {
  Scene scene;
  test::addBox(scene, "ground", {-10, -1, -10}, {10, 0, 10});
  test::addBox(scene, "tower", {-3, 0, -2}, {-1, 6, 0});
  test::addBox(scene, "block", {2, 0, 1}, {5, 2, 4});
  test::addBox(scene, "inner", {2.5, 0.5, 1.5}, {4.5, 1.5, 3.5});  // nested inside "block"
  test::addQuad(scene, "roof", {1, 4, 0}, {6, 4, 0}, {6, 4, 5}, {1, 4, 5});
  test::addQuad(scene, "wall", {-6, 0, 4}, {-2, 0, 4}, {-2, 3, 4}, {-6, 3, 4});
  test::classifyMeshes(scene);
  scene.lights = {test::sunLight("sun", {0.35, -1.0, 0.25}), test::spotLight("spot", {0, 12, 0}, {0, -1, 0}, 0.7, 40)};
  return scene;
}

Scene torusKnotScene() {
  Scene scene = importGltf(sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
  scene.lights = {test::sunLight("sun", {0.3, -1.0, 0.2})};
  return scene;
}

// The open terrain with a low sun and a spot: its sheet is closed into solid ground (libcpvs/scene/ground_sheet.h).
Scene terrainScene() {
  Scene scene = importGltf(sourcePath("data/scenes/Terrain/terrain.gltf"));
  scene.lights = {test::sunLight("sun", {0.6, -0.5, 0.3}),
                  test::spotLight("spot", {1.5, 1.5, 1}, {-0.6396, -0.6396, -0.4264}, 0.7, 10)};
  return scene;
}

// Depth maps of every region, captured during the bake: key (light, view).
using CapturedDepth = std::map<std::pair<size_t, size_t>, std::vector<DepthRegion>>;

struct Bake {
  CpvsContent content;
  CapturedDepth depth;
  BakeReport report;
};

Bake bake(const Scene& scene, const BakeSettings& settings) {
  Bake b;
  std::mutex mutex;
  BakeCallbacks callbacks;
  callbacks.depthRegion = [&](size_t light, size_t view, const LightView&, const DepthRegion& region) {
    std::lock_guard<std::mutex> lock(mutex);
    b.depth[{light, view}].push_back(region);
  };
  try {
    b.content = bakeScene(scene, settings, &b.report, callbacks);
  } catch (const Error& e) {
    if (e.category() == ErrorCategory::NotSupported) throw;
    ADD_FAILURE() << e.what();
  }
  return b;
}

DagView viewOf(const ShadowDag& dag) { return dag.view(); }

// Voxels that contradict the depth maps: lit where z >= exit, shadowed where z <= enter. Every `stride`-th
// column is checked (1 = all).
uint64_t contradictions(const DagView& dag, const std::vector<DepthRegion>& regions, uint32_t stride = 1) {
  uint64_t errors = 0;
  for (const DepthRegion& d : regions) {
    const uint32_t n = d.resolution;
    for (uint32_t y = 0; y < d.rect.height; ++y)
      for (uint32_t x = (y % stride); x < d.rect.width; x += stride) {
        const uint32_t e = d.enterAt(x, y), exit = d.exitAt(x, y);
        for (uint32_t z = 0; z < n; ++z) {
          const bool shadowed = dag.shadowed(d.rect.x0 + x, d.rect.y0 + y, z);
          if ((z <= e && shadowed) || (z >= exit && !shadowed)) ++errors;
        }
      }
  }
  return errors;
}

// Voxels decoded differently by two DAGs of the same view.
uint64_t differences(const DagView& a, const DagView& b, uint32_t n) {
  uint64_t count = 0;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      for (uint32_t z = 0; z < n; ++z) count += a.shadowed(x, y, z) != b.shadowed(x, y, z);
  return count;
}

// Free voxels (neither required lit nor required shadowed) over all texels.
uint64_t freeVoxels(const std::vector<DepthRegion>& regions) {
  uint64_t count = 0;
  for (const DepthRegion& d : regions)
    for (size_t i = 0; i < d.enter.size(); ++i)
      if (d.exit[i] > d.enter[i] + 1) count += d.exit[i] - d.enter[i] - 1;
  return count;
}

struct ExactCase {
  const char* scene;
  uint32_t resolution;
};

class Exactness : public ::testing::TestWithParam<ExactCase> {};

TEST_P(Exactness, EveryRequiredVoxelInEveryModeAndReuseChangesNoVoxel) {
  const ExactCase c = GetParam();
  const std::string name = c.scene;
  const Scene scene = name == "mixed" ? mixedScene() : name == "terrain" ? terrainScene() : torusKnotScene();
  // Full checks up to 256; at 512 every 7th column (the grid has 134M voxels per view).
  const uint32_t stride = c.resolution > 256 ? 7 : 1;
  for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn, UndefinedMode::None}) {
    BakeSettings settings;
    settings.resolution = c.resolution;
    settings.undefinedMode = mode;
    Bake reuse, noReuse;
    SKIP_WITHOUT_OSMESA(reuse = bake(scene, settings));
    settings.nodeReuse = false;
    noReuse = bake(scene, settings);
    ASSERT_EQ(reuse.content.lights.size(), scene.lights.size());
    uint64_t free = 0;
    for (size_t li = 0; li < reuse.content.lights.size(); ++li) {
      const auto& views = reuse.content.lights[li].views;
      for (size_t vi = 0; vi < views.size(); ++vi) {
        const auto it = reuse.depth.find({li, vi});
        if (it == reuse.depth.end()) continue;  // a view with no caster: all lit, nothing rendered
        free += freeVoxels(it->second);
        const DagView a = viewOf(views[vi].dag), b = viewOf(noReuse.content.lights[li].views[vi].dag);
        EXPECT_EQ(contradictions(a, it->second, stride), 0u)
            << c.scene << " N=" << c.resolution << " " << undefinedModeName(mode) << " light " << li << " view " << vi;
        EXPECT_EQ(contradictions(b, it->second, stride), 0u) << "without node reuse";
        if (c.resolution <= 256) {
          EXPECT_EQ(differences(a, b, c.resolution), 0u) << "node reuse changed the decoded grid";
        }
        // Reuse only skips building nodes it would have built identically.
        EXPECT_EQ(views[vi].dag.nodes, noReuse.content.lights[li].views[vi].dag.nodes);
        EXPECT_EQ(views[vi].dag.leaves, noReuse.content.lights[li].views[vi].dag.leaves);
      }
    }
    // The test means something: closed solids leave free voxels to decide.
    EXPECT_GT(free, 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, Exactness,
                         ::testing::Values(ExactCase{"mixed", 64}, ExactCase{"mixed", 128}, ExactCase{"mixed", 256},
                                           ExactCase{"torusknot", 128}, ExactCase{"terrain", 256},
                                           ExactCase{"mixed", 512}),
                         [](const auto& info) {
                           return std::string(info.param.scene) + "_" + std::to_string(info.param.resolution);
                         });

// The ground under the terrain is free: the same required voxels (Exactness above), a far smaller DAG, and
// the report names the sheet.
TEST(Bake, GroundSheetShrinksTheTerrain) {
  const Scene scene = terrainScene();
  BakeSettings settings;
  settings.resolution = 512;
  Bake ground, open;
  SKIP_WITHOUT_OSMESA(ground = bake(scene, settings));
  settings.ground = GroundSheets::Off;
  open = bake(scene, settings);
  ASSERT_EQ(ground.report.groundSheets.size(), 1u);
  EXPECT_TRUE(ground.report.groundSheets[0].used);
  EXPECT_TRUE(open.report.groundSheets.empty());
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    const uint64_t withGround = ground.report.lights[li].views[0].bytes, without = open.report.lights[li].views[0].bytes;
    std::printf("[ ground   ] terrain %s at 512: %llu bytes with the ground solid, %llu without\n",
                scene.lights[li].name.c_str(), (unsigned long long)withGround, (unsigned long long)without);
    EXPECT_LT(3 * withGround, without) << scene.lights[li].name;  // 4.9x at 512; more at higher N
  }
  EXPECT_NE(ground.report.inputHash, open.report.inputHash);
  EXPECT_NE(ground.content.settingsJson, open.content.settingsJson);
}

TEST(Bake, ModesOrderBySize) {
  const Scene scene = mixedScene();
  BakeSettings settings;
  settings.resolution = 256;
  std::map<UndefinedMode, uint64_t> bytes;
  for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn, UndefinedMode::None}) {
    settings.undefinedMode = mode;
    Bake b;
    SKIP_WITHOUT_OSMESA(b = bake(scene, settings));
    for (const BakedLight& l : b.content.lights)
      for (const BakedView& v : l.views) bytes[mode] += v.dag.bytes();
  }
  EXPECT_LE(bytes[UndefinedMode::Kampe], bytes[UndefinedMode::Sintorn]);
  EXPECT_LE(bytes[UndefinedMode::Sintorn], bytes[UndefinedMode::None]);
}

TEST(Bake, RegionsChangeNoVoxelAndThreadsNoByte) {
  const Scene scene = mixedScene();
  BakeSettings settings;
  settings.resolution = 256;
  Bake whole;
  SKIP_WITHOUT_OSMESA(whole = bake(scene, settings));
  for (uint32_t region : {64u, 128u}) {
    std::string reference;
    for (unsigned threads : {1u, 2u}) {
      settings.regionSize = region;
      settings.threads = threads;
      const Bake split = bake(scene, settings);
      EXPECT_EQ(split.report.lights[0].views[0].regions, (256 / region) * (256 / region));
      // Regions are built in a different order than one piece, so node order (bytes) may differ; the voxels
      // may not.
      for (size_t li = 0; li < scene.lights.size(); ++li)
        EXPECT_EQ(differences(viewOf(split.content.lights[li].views[0].dag),
                              viewOf(whole.content.lights[li].views[0].dag), 256),
                  0u)
            << "region " << region << ", light " << li;
      const std::string bytes = writeCpvs(split.content);
      if (reference.empty())
        reference = bytes;
      else
        EXPECT_TRUE(bytes == reference) << "region " << region << ": --threads changed the bytes";
    }
  }
}

// Baking straight into the file, light by light as lights finish (on several lanes), writes exactly the bytes of
// the bake written at once: for several lights of every kind, 1, 2 and 4 threads, and lights taken from a cache.
TEST(Bake, WrittenAsLightsFinishEqualsWrittenAtOnce) {
  Scene scene = mixedScene();
  Light point;
  point.type = LightType::Point;
  point.name = "bulb";
  point.position = {0, 5, 6};
  point.range = 30;
  scene.lights.push_back(point);
  scene.lights.push_back(test::spotLight("second spot", {4, 9, -3}, {-0.2, -1, 0.1}, 0.5, 30));
  BakeSettings settings;
  settings.resolution = 128;
  settings.regionSize = 64;
  const std::string whole = writeCpvs(bakeScene(scene, settings));
  const std::string cache = test::tempDir() + "/cache";
  for (const unsigned threads : {1u, 2u, 4u})
    for (const bool cached : {false, true, true}) {
      settings.threads = threads;
      settings.cacheFolder = cached ? cache : "";
      std::string streamed;
      std::vector<uint8_t> timesWritten;  // every byte exactly once: a file sink must not rely on holes
      size_t writes = 0;
      BakeReport report;
      const uint64_t size = bakeSceneTo(scene, settings, [&](uint64_t at, const char* data, size_t n) {
        if (streamed.size() < at + n) {
          streamed.resize(size_t(at + n), '\0');
          timesWritten.resize(size_t(at + n), 0);
        }
        std::memcpy(streamed.data() + at, data, n);
        for (size_t i = 0; i < n; ++i) ++timesWritten[at + i];
        ++writes;
      }, &report);
      EXPECT_EQ(size, whole.size());
      EXPECT_EQ(std::count(timesWritten.begin(), timesWritten.end(), uint8_t(1)), ptrdiff_t(timesWritten.size()));
      EXPECT_GT(writes, 2 * scene.lights.size()) << "written in pieces";
      EXPECT_TRUE(streamed == whole) << threads << " thread(s), cache " << cached;
      ASSERT_EQ(report.lights.size(), scene.lights.size());
      for (size_t i = 0; i < report.lights.size(); ++i) EXPECT_EQ(report.lights[i].index, i) << "in light order";
    }
}

// The writer refuses to write what it was not laid out for, naming the light.
TEST(Bake, CpvsWriterRefusesLightsItWasNotLaidOutFor) {
  const Scene scene = mixedScene();
  BakeSettings settings;
  settings.resolution = 64;
  const CpvsContent content = bakeScene(scene, settings);
  const auto sink = [](uint64_t, const char*, size_t) {};
  CpvsWriter swapped("{}", {scene.lights[1], scene.lights[0]}, {1, 1}, sink);
  try {
    swapped.add(content.lights[0]);
    FAIL() << "added the wrong light";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("laid out for 'spot'"), std::string::npos) << e.what();
  }
  CpvsWriter short_("{}", {scene.lights[0], scene.lights[1]}, {1, 1}, sink);
  short_.add(content.lights[0]);
  EXPECT_THROW(short_.finish(), Error);
  CpvsWriter views("{}", {scene.lights[0]}, {2}, sink);
  EXPECT_THROW(views.add(content.lights[0]), Error);
}

// Each light's DAG is validated where it lies, as a reader would validate it, before a byte of it is written.
TEST(Bake, CpvsWriterRefusesADagAReaderWouldReject) {
  const Scene scene = mixedScene();
  BakeSettings settings;
  settings.resolution = 64;
  CpvsContent content = bakeScene(scene, settings);
  ShadowDag& dag = content.lights[0].views[0].dag;
  ASSERT_FALSE(dag.leaves.empty());
  dag.leaves.pop_back();  // a leaf parent now references a leaf past the end
  size_t written = 0;
  CpvsWriter writer("{}", {scene.lights[0]}, {1}, [&](uint64_t, const char*, size_t n) { written += n; });
  const size_t before = written;
  try {
    writer.add(content.lights[0]);
    FAIL() << "wrote a DAG whose references leave it";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("references leaf"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("light 0 '" + scene.lights[0].name + "' view 0"), std::string::npos) << e.what();
  }
  EXPECT_EQ(written, before) << "nothing of the light was written";
}

TEST(Bake, ReportCountsWhatWasBuilt) {
  const Scene scene = mixedScene();
  BakeSettings settings;
  settings.resolution = 128;
  Bake b;
  SKIP_WITHOUT_OSMESA(b = bake(scene, settings));
  ASSERT_EQ(b.report.lights.size(), 2u);
  for (size_t li = 0; li < 2; ++li) {
    const ViewReport& v = b.report.lights[li].views[0];
    const ShadowDag& dag = b.content.lights[li].views[0].dag;
    EXPECT_EQ(v.bytes, dag.bytes());
    EXPECT_EQ(v.uniqueLeaves, dag.leaves.size());
    EXPECT_EQ(v.nodesPerLevel, dag.nodesPerLevel);
    EXPECT_EQ(v.shadowMapBytes, 128u * 128u * 2u);
    EXPECT_GT(v.nodesReused, 0u) << "no node was reused: the test scene has no repeated structure?";
  }
}

// CPU time in a parallel loop, or in work beside the caller, is not the caller's serial work; the same spin
// outside them is.
TEST(Bake, SerialCpuLeavesParallelLoopsOut) {
  const auto spin = [](double ms) {
    const double until = threadCpuMs() + ms;
    volatile double x = 0;
    while (threadCpuMs() < until) x = x + 1;
  };
  const SerialCpuTimer inLoop;
  parallelFor(1, [&](size_t) { spin(60); });
  EXPECT_LT(inLoop.ms(), 20.0);
  BackgroundWork beside;
  beside.start([&] { spin(60); });
  beside.wait();  // the caller may run it itself while it waits
  EXPECT_LT(inLoop.ms(), 20.0);
  const SerialCpuTimer outside;
  spin(60);
  EXPECT_GE(outside.ms(), 55.0);
}

// The report's work and span: every view's serial parts measured, the span within the work, and about the same
// with one thread as with two (it counts what runs on one thread, whatever the cores).
TEST(Bake, ReportsWorkAndSpan) {
  const Scene scene = torusKnotScene();
  double spans[2];
  for (const unsigned threads : {1u, 2u}) {
    BakeSettings settings;
    settings.resolution = 1024;
    settings.threads = threads;
    Bake b;
    SKIP_WITHOUT_OSMESA(b = bake(scene, settings));
    const ViewReport& v = b.report.lights.at(0).views.at(0);
    EXPECT_GT(v.laneSerialMs, 0.0);
    EXPECT_GT(v.dagChainMs, 0.0);
    EXPECT_GT(v.encodeMs, 0.0);
    EXPECT_GT(b.report.setupSerialMs, 0.0);
    const double span = bakeSpanMs(b.report);
    EXPECT_GT(span, 0.0);
    EXPECT_LE(span, b.report.cpuMs * 1.02) << threads << " thread(s)";
    EXPECT_GE(span, std::max(v.laneSerialMs, v.dagChainMs) + v.encodeMs);
    // On one core the bake takes its whole work at least (the span is part of it), the span more at most.
    const WallBounds one = bakeWallBounds(b.report, 1);
    EXPECT_DOUBLE_EQ(one.atLeastMs, std::max(b.report.cpuMs, span));
    EXPECT_DOUBLE_EQ(one.atMostMs, b.report.cpuMs + span);
    EXPECT_LE(bakeWallBounds(b.report, 16).atLeastMs, one.atLeastMs);
    spans[threads - 1] = span;
  }
  EXPECT_LT(std::abs(spans[0] - spans[1]), 0.5 * std::max(spans[0], spans[1])) << spans[0] << " " << spans[1];
}

// ------------------------------------------------------------------------------------------------ the tool

std::string scenePath() { return sourcePath("data/scenes/TorusKnot/torusknot.gltf"); }

TEST(BakeTool, SameBytesTwiceAndForAnyThreadCount) {
  const std::string dir = tempDir();
  std::string first;
  for (const char* threads : {"1", "2", "2"}) {
    const std::string out = dir + "/t" + threads + ".cpvs";
    const auto r = runTool(toolPath("cpvs-bake") + " " + scenePath() + " -o " + out +
                           " --resolution 256 --sun 0.3,-1,0.2 --spot 0,4,0,0,-1,0,0.6,20 --quiet --threads " + threads);
    if (r.exitCode == int(tools::ExitCode::NotSupported)) GTEST_SKIP() << r.output;
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::string bytes = readFile(out);
    ASSERT_GT(bytes.size(), 1000u);
    if (first.empty())
      first = bytes;
    else
      EXPECT_TRUE(bytes == first) << "--threads " << threads;
  }
}

TEST(BakeTool, LightIntensitiesFromTheCommandLineReachTheFileAndChangeNoVoxel) {
  const std::string dir = tempDir();
  const auto bake = [&](const std::string& name, const std::string& lights) {
    return runTool(toolPath("cpvs-bake") + " " + scenePath() + " -o " + dir + "/" + name + ".cpvs --resolution 64 --quiet " +
                   lights);
  };
  const auto plain = bake("plain", "--sun 0.3,-1,0.2 --spot 0,4,0,0,-1,0,0.6,20 --point 0,3,0,30");
  if (plain.exitCode == int(tools::ExitCode::NotSupported)) GTEST_SKIP() << plain.output;
  ASSERT_EQ(plain.exitCode, 0) << plain.output;
  const auto lit = bake("lit", "--sun 0.3,-1,0.2,3.5 --spot 0,4,0,0,-1,0,0.6,20,120 --point 0,3,0,30,0");
  ASSERT_EQ(lit.exitCode, 0) << lit.output;
  const auto plainFile = orThrow(CpvsFile::open(dir + "/plain.cpvs"));
  const auto litFile = orThrow(CpvsFile::open(dir + "/lit.cpvs"));
  ASSERT_EQ(litFile->lights().size(), 3u);
  const float expected[] = {3.5f, 120.0f, 0.0f};
  for (size_t l = 0; l < 3; ++l) {
    EXPECT_EQ(plainFile->lights()[l].light.intensity, 1.0f) << "the default, light " << l;
    EXPECT_EQ(litFile->lights()[l].light.intensity, expected[l]) << "light " << l;
    // Intensity shades; it shapes no voxel.
    ASSERT_EQ(litFile->lights()[l].views.size(), plainFile->lights()[l].views.size());
    for (size_t v = 0; v < litFile->lights()[l].views.size(); ++v) {
      const DagView &a = litFile->lights()[l].views[v].dag, &b = plainFile->lights()[l].views[v].dag;
      EXPECT_TRUE(std::equal(a.nodes.begin(), a.nodes.end(), b.nodes.begin(), b.nodes.end()) &&
                  std::equal(a.leaves.begin(), a.leaves.end(), b.leaves.begin(), b.leaves.end()))
          << "light " << l << " view " << v;
    }
  }
  // A negative or non-numeric intensity, or one value too many, is a usage error naming the option.
  for (const std::string bad : {"--spot 0,4,0,0,-1,0,0.6,20,-1", "--point 0,3,0,30,x", "--sun 0.3,-1,0.2,1,2"}) {
    const auto r = bake("bad", bad);
    EXPECT_EQ(r.exitCode, int(tools::ExitCode::Usage)) << bad << ": " << r.output;
    EXPECT_NE(r.output.find(bad.substr(0, bad.find(' '))), std::string::npos) << r.output;
  }
}

TEST(BakeTool, ReportHasTheFieldsPipelinesRead) {
  const std::string dir = tempDir();
  const auto r = runTool(toolPath("cpvs-bake") + " " + scenePath() + " -o " + dir + "/o.cpvs --resolution 128 " +
                         "--sun 0.3,-1,0.2 --point 0,3,0,30 --quiet --report " + dir + "/r.json");
  if (r.exitCode == int(tools::ExitCode::NotSupported)) GTEST_SKIP() << r.output;
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(readFile(dir + "/r.json"));
  EXPECT_TRUE(j["version"].is_string());
  EXPECT_GT(j["total_ms"].get<double>(), 0.0);
  EXPECT_GT(j["load_ms"].get<double>(), 0.0);
  EXPECT_GT(j["setup_ms"].get<double>(), 0.0);
  EXPECT_LT(j["load_ms"].get<double>() + j["setup_ms"].get<double>(), j["total_ms"].get<double>());
  EXPECT_GT(j["peak_rss_bytes"].get<uint64_t>(), 0u);
  ASSERT_EQ(j["lights"].size(), 2u);
  EXPECT_EQ(j["lights"][0]["name"], "sun0");
  EXPECT_EQ(j["lights"][0]["views"].size(), 1u);
  EXPECT_EQ(j["lights"][1]["views"].size(), 6u) << "a point light has six cube faces";
  for (const auto& light : j["lights"])
    for (const auto& v : light["views"]) {
      EXPECT_EQ(v["resolution"], 128);
      for (const char* phase : {"depth", "peel", "masks", "dag", "write"})
        EXPECT_TRUE(v["phases_ms"][phase].is_number()) << phase;
      EXPECT_TRUE(v["nodes_per_level"].is_array());
      EXPECT_TRUE(v["unique_leaves"].is_number());
      EXPECT_TRUE(v["bytes"].is_number());
      EXPECT_EQ(v["shadow_map_bytes"], 128 * 128 * 2);
    }
  // The file holds what the report says.
  const auto file = orThrow(CpvsFile::open(dir + "/o.cpvs"));
  ASSERT_EQ(file->lights().size(), 2u);
  EXPECT_EQ(file->lights()[1].views.size(), 6u);
  EXPECT_EQ(j["file_bytes"].get<uint64_t>(), file->fileSize());
  EXPECT_EQ(j["settings"]["ground"], "auto");
  EXPECT_EQ(j["triangles"], 2880u);
  EXPECT_TRUE(j["ground_sheets"].is_array() && j["ground_sheets"].empty()) << "the torus knot has no ground";
  // Tiny's ground quad spans the scene: reported as used, with what closed it.
  const auto tiny = runTool(toolPath("cpvs-bake") + " " + sourcePath("data/scenes/Tiny/tiny.gltf") + " -o " + dir +
                            "/t.cpvs --resolution 64 --sun 0.3,-1,0.2 --quiet --report " + dir + "/t.json");
  ASSERT_EQ(tiny.exitCode, 0) << tiny.output;
  const nlohmann::json t = nlohmann::json::parse(readFile(dir + "/t.json"));
  EXPECT_EQ(t["triangles"], 26u) << "the scene's own: the ground's 12 closing triangles are not counted";
  ASSERT_EQ(t["ground_sheets"].size(), 1u);
  EXPECT_EQ(t["ground_sheets"][0]["mesh"], "Ground");
  EXPECT_EQ(t["ground_sheets"][0]["faces"], "+y");
  EXPECT_EQ(t["ground_sheets"][0]["used"], true);
  EXPECT_EQ(t["ground_sheets"][0]["closing_triangles"], 12u);  // 4 boundary edges: 4 x 2 wall + 4 bottom
  // cpvs-info describes the same sheet with the same keys.
  const auto info = runTool(toolPath("cpvs-info") + " " + sourcePath("data/scenes/Tiny/tiny.gltf") + " --json > " + dir +
                            "/info.json");
  ASSERT_EQ(info.exitCode, 0) << info.output;
  const nlohmann::json i = nlohmann::json::parse(readFile(dir + "/info.json"));
  ASSERT_EQ(i["groundSheets"].size(), 1u);
  EXPECT_EQ(i["groundSheets"][0], t["ground_sheets"][0]);
}

TEST(BakeTool, DumpDepthWritesEnterAndExitSlices) {
  const std::string dir = tempDir();
  const auto r = runTool(toolPath("cpvs-bake") + " " + scenePath() + " --dump-depth " + dir +
                         "/depth --resolution 64 --sun 0.3,-1,0.2 --quiet");
  if (r.exitCode == int(tools::ExitCode::NotSupported)) GTEST_SKIP() << r.output;
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const ExrImage image = readExr(dir + "/depth/light0_view0_region0_0.exr", {"enter", "exit"});
  ASSERT_EQ(image.width, 64u);
  ASSERT_EQ(image.height, 64u);
  size_t hits = 0, solid = 0;
  for (uint32_t y = 0; y < 64; ++y)
    for (uint32_t x = 0; x < 64; ++x) {
      const float e = image.at(x, y, 0), exit = image.at(x, y, 1);
      ASSERT_LE(e, 64.0f);
      ASSERT_LE(exit, 64.0f);
      if (e < 64) {
        ++hits;
        ASSERT_GT(exit, e);
        solid += exit > e + 1;
      }
    }
  EXPECT_GT(hits, 200u);
  EXPECT_GT(solid, 100u) << "the torus knot is closed: its texels have exits beyond the enter slice";
}

TEST(BakeTool, ExitCodesAndMessages) {
  const std::string dir = tempDir();
  const std::string bake = toolPath("cpvs-bake") + " ";
  auto help = runTool(bake + "--help");
  EXPECT_EQ(help.exitCode, 0);
  for (const char* text : {"--resolution", "--undefined", "--no-node-reuse", "--report", "Exit codes"})
    EXPECT_NE(help.output.find(text), std::string::npos) << text;
  EXPECT_EQ(runTool(bake + "--version").exitCode, 0);
  EXPECT_EQ(runTool(bake).exitCode, int(tools::ExitCode::Usage));
  EXPECT_EQ(runTool(bake + scenePath() + " -o " + dir + "/a.cpvs --resolution 3000 --sun 0,-1,0").exitCode,
            int(tools::ExitCode::Usage));
  EXPECT_EQ(runTool(bake + scenePath() + " -o " + dir + "/a.cpvs --undefined maybe --sun 0,-1,0").exitCode,
            int(tools::ExitCode::Usage));
  const auto unbounded = runTool(bake + scenePath() + " -o " + dir + "/a.cpvs --cache-max-size 1G --sun 0,-1,0");
  EXPECT_EQ(unbounded.exitCode, int(tools::ExitCode::Usage));
  EXPECT_NE(unbounded.output.find("--cache-max-size needs --cache DIR"), std::string::npos) << unbounded.output;
  EXPECT_EQ(runTool(bake + scenePath() + " -o " + dir + "/a.cpvs --cache " + dir + "/c --cache-max-size 12Q --sun 0,-1,0")
                .exitCode,
            int(tools::ExitCode::Usage));
  const auto missing = runTool(bake + dir + "/missing.gltf -o " + dir + "/a.cpvs --sun 0,-1,0");
  EXPECT_EQ(missing.exitCode, int(tools::ExitCode::InputInvalid));
  EXPECT_NE(missing.output.find("missing.gltf"), std::string::npos) << missing.output;
  const auto malformed = runTool(bake + "/usr/share/assimp/models/glTF2/IndexOutOfRange/IndexOutOfRange.gltf -o " +
                                 dir + "/a.cpvs --sun 0,-1,0");
  if (std::filesystem::exists("/usr/share/assimp/models/glTF2/IndexOutOfRange/IndexOutOfRange.gltf")) {
    EXPECT_EQ(malformed.exitCode, int(tools::ExitCode::InputInvalid)) << malformed.output;
  }
  const auto unwritable = runTool(bake + scenePath() + " -o " + dir + "/no/such/dir/a.cpvs --resolution 64 --sun 0,-1,0 -q");
  if (unwritable.exitCode != int(tools::ExitCode::NotSupported)) {
    EXPECT_EQ(unwritable.exitCode, int(tools::ExitCode::OutputFailed)) << unwritable.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.cpvs")) << "a failed run left an output file";
}

TEST(BakeTool, FailedOrInterruptedBakeLeavesNoPartialFile) {
  const std::string dir = tempDir();
  const std::string out = dir + "/keep.cpvs";
  { std::ofstream(out) << "previous contents"; }
  // A failing bake keeps the previous file untouched.
  EXPECT_EQ(runTool(toolPath("cpvs-bake") + " " + dir + "/missing.gltf -o " + out + " --sun 0,-1,0").exitCode,
            int(tools::ExitCode::InputInvalid));
  EXPECT_EQ(readFile(out), "previous contents");
  // Killed in the middle of a bake: the output path still holds the previous file, nothing half-written.
  const std::string fresh = dir + "/fresh.cpvs";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string tool = toolPath("cpvs-bake"), scene = scenePath();
    execl(tool.c_str(), tool.c_str(), scene.c_str(), "-o", fresh.c_str(), "--resolution", "16k", "--sun", "0.3,-1,0.2",
          "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_FALSE(std::filesystem::exists(fresh)) << "the bake finished before it was killed, or left a file";
}

}  // namespace
}  // namespace cpvs
