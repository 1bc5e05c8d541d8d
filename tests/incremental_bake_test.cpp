// Incremental bakes: with a cache, a re-bake after an edit renders only the regions the edit reaches and replays
// the others' DAG events; the file equals a clean bake of the edited scene byte for byte (moved, deleted and
// added meshes, a material's alpha mode), damaged region packs are ignored with a warning, and the folder keeps
// one version of each light.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/import/gltf_import.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::tempDir;
using test::toolPath;

// A scenegen scene, written once per test run.
std::string generated(const std::string& kind, const std::string& options) {
  const std::string path = tempDir() + "/" + kind + ".glb";
  if (std::filesystem::exists(path)) return path;
  const test::ToolResult r = runTool(toolPath("cpvs-scenegen") + " " + kind + " " + options + " -o " + path);
  if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen failed: " + r.output);
  return path;
}

// `source` edited by scripts/gltf_edit.py (`edit`: its action and arguments), as a new file.
std::string edited(const std::string& source, const std::string& name, const std::string& edit) {
  const std::string path = tempDir() + "/" + name + ".glb";
  const test::ToolResult r =
      runTool("python3 " + test::sourcePath("scripts/gltf_edit.py") + " " + source + " " + path + " " + edit);
  if (r.exitCode != 0) throw std::runtime_error("gltf_edit.py failed: " + r.output);
  return path;
}

// The city's sun, a spot over one block and a point light: a view per kind of mapping, and a cone crop.
Scene cityWithLights(const std::string& path) {
  Scene scene = importGltf(path);
  scene.lights.push_back(test::spotLight("spot", {-60, 90, -40}, {0.2, -1, 0.1}, 0.5, 300));
  scene.lights.push_back(test::pointLight("point", {100, 40, 120}, 200));
  return scene;
}

BakeSettings smallBake(const std::string& cache) {
  BakeSettings settings;
  settings.resolution = 512;
  settings.regionSize = 64;  // 64 regions a view: an edit reaches a few
  settings.threads = 2;
  settings.cacheFolder = cache;
  return settings;
}

std::string bakeBytes(const Scene& scene, const BakeSettings& settings, BakeReport* report = nullptr) {
  return writeCpvs(bakeScene(scene, settings, report));
}

struct Reuse {
  uint64_t regions = 0, reused = 0;
};
Reuse reuseOf(const BakeReport& report) {
  Reuse r;
  for (const LightReport& l : report.lights)
    for (const ViewReport& v : l.views) {
      r.regions += v.regions;
      r.reused += v.regionsReused;
    }
  return r;
}

size_t filesEndingWith(const std::string& folder, const std::string& suffix) {
  size_t n = 0;
  for (const auto& item : std::filesystem::directory_iterator(folder)) {
    const std::string name = item.path().filename().string();
    n += name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
  }
  return n;
}

TEST(IncrementalBake, EditedSceneBakesToTheBytesOfACleanBake) {
  const std::string city = generated("city", "--triangles 20000");
  const std::string cache = tempDir() + "/incremental-cache";
  std::filesystem::remove_all(cache);
  const BakeSettings cached = smallBake(cache), clean = smallBake("");
  BakeReport first;
  bakeBytes(cityWithLights(city), cached, &first);
  EXPECT_EQ(reuseOf(first).reused, 0u);
  const size_t views = filesEndingWith(cache, ".regions");
  EXPECT_GE(views, 3u);  // the sun's, the spot's and the point light's faces that see geometry

  // Each edit is baked with the cache the previous one left, as a level's saves are.
  const std::pair<const char*, std::string> edits[] = {
      {"moved", "move proto_gable_2.0 5 0 0"},
      {"deleted", "delete proto_round_1.0"},
      {"added", "copy proto_hip_1.0 30 0 12"},
  };
  std::string previous = city;
  for (const auto& [name, edit] : edits) {
    previous = edited(previous, name, edit);
    const Scene scene = cityWithLights(previous);
    BakeReport incremental;
    const std::string bytes = bakeBytes(scene, cached, &incremental);
    EXPECT_TRUE(bytes == bakeBytes(scene, clean)) << name << ": the incremental file differs from a clean bake";
    const Reuse reuse = reuseOf(incremental);
    // The edit reaches a few regions of the views that see it; the others are replayed. Lights whose views it
    // misses entirely come whole from the cache (no regions counted).
    EXPECT_GT(reuse.reused, 0u) << name;
    EXPECT_LT(reuse.reused, reuse.regions) << name;
    EXPECT_GT(reuse.reused * 4, reuse.regions * 3) << name << ": " << reuse.reused << " of " << reuse.regions;
    // One light entry per light, one region pack per view: the versions the edits replaced are gone.
    EXPECT_EQ(filesEndingWith(cache, ".cpvs"), scene.lights.size()) << name;
    EXPECT_EQ(filesEndingWith(cache, ".regions"), views) << name;
  }
}

TEST(IncrementalBake, AlphaModeChangeReplaysTheRegionsItMisses) {
  const std::string scene = generated("alpha-test", "");
  const std::string cache = tempDir() + "/alpha-cache";
  std::filesystem::remove_all(cache);
  BakeSettings cached = smallBake(cache), clean = smallBake("");
  bakeBytes(importGltf(scene), cached);
  for (const auto& [name, edit] : {std::pair<const char*, const char*>{"leaf-opaque", "alpha LeafMask OPAQUE"},
                                   {"leaf-mask-again", "alpha LeafMask MASK 0.5"}}) {
    const Scene changed = importGltf(edited(scene, name, edit));
    BakeReport report;
    const std::string bytes = bakeBytes(changed, cached, &report);
    EXPECT_TRUE(bytes == bakeBytes(changed, clean)) << name;
    const Reuse reuse = reuseOf(report);
    EXPECT_GT(reuse.reused, 0u) << name;
    EXPECT_LT(reuse.reused, reuse.regions) << name;
  }
}

TEST(IncrementalBake, DamagedRegionPacksAreIgnoredWithAWarning) {
  const std::string city = generated("city", "--triangles 20000");
  const std::string cache = tempDir() + "/damaged-cache";
  std::filesystem::remove_all(cache);
  const BakeSettings cached = smallBake(cache);
  const Scene scene = cityWithLights(city);
  const std::string expected = bakeBytes(scene, cached);
  // One pack cut short: refused whole (its footer and index are gone). One byte changed in the middle of the
  // others: the region whose record holds it fails its hash and is rendered again.
  bool cut = false;
  for (const auto& item : std::filesystem::directory_iterator(cache)) {
    if (item.path().extension() != ".regions") continue;
    if (!cut) {
      std::filesystem::resize_file(item.path(), item.file_size() - 9);
      cut = true;
      continue;
    }
    std::fstream file(item.path(), std::ios::in | std::ios::out | std::ios::binary);
    file.seekg(std::streamoff(item.file_size() / 2));
    const char byte = char(file.get());
    file.seekp(std::streamoff(item.file_size() / 2));
    file.put(char(byte ^ 0x5a));
  }
  // The light entries would answer first: without them the packs are read.
  for (const auto& item : std::filesystem::directory_iterator(cache))
    if (item.path().extension() == ".cpvs") std::filesystem::remove(item.path());
  BakeReport report;
  EXPECT_TRUE(bakeBytes(scene, cached, &report) == expected);
  EXPECT_LT(reuseOf(report).reused, reuseOf(report).regions);
  bool packIgnored = false, regionIgnored = false;
  for (const std::string& w : report.warnings) {
    packIgnored = packIgnored || w.find("bake cache regions ignored") != std::string::npos;
    regionIgnored = regionIgnored || w.find("bake cache region ignored") != std::string::npos;
  }
  EXPECT_TRUE(packIgnored);
  EXPECT_TRUE(regionIgnored);
  // The packs stored by that bake are whole again: the next one replays every region.
  for (const auto& item : std::filesystem::directory_iterator(cache))
    if (item.path().extension() == ".cpvs") std::filesystem::remove(item.path());
  BakeReport again;
  EXPECT_TRUE(bakeBytes(scene, cached, &again) == expected);
  EXPECT_EQ(reuseOf(again).reused, reuseOf(again).regions);
}

// A bake stopped part way (here by its progress callback, as a cancel does) leaves the cache as it was: the
// entries of the lights it finished are not committed, and no temporary stays behind.
TEST(IncrementalBake, AStoppedBakeLeavesTheCacheAsItWas) {
  const std::string city = generated("city", "--triangles 20000");
  const std::string cache = tempDir() + "/stopped-cache";
  std::filesystem::remove_all(cache);
  const Scene scene = cityWithLights(city);
  BakeCallbacks stopLate;
  size_t calls = 0;
  stopLate.progress = [&](double done) {
    ++calls;
    if (done > 0.8) throw std::runtime_error("stopped");
  };
  EXPECT_THROW(bakeScene(scene, smallBake(cache), nullptr, stopLate), std::runtime_error);
  EXPECT_GT(calls, 10u);
  EXPECT_TRUE(std::filesystem::is_empty(cache));
  // A finished bake then fills it, and a stopped re-bake of an edit leaves that bake's entries untouched.
  bakeBytes(scene, smallBake(cache));
  std::vector<std::string> before;
  for (const auto& item : std::filesystem::directory_iterator(cache)) before.push_back(item.path().filename().string());
  const Scene moved = cityWithLights(edited(city, "stopped-moved", "move proto_gable_2.0 5 0 0"));
  EXPECT_THROW(bakeScene(moved, smallBake(cache), nullptr, stopLate), std::runtime_error);
  std::vector<std::string> after;
  for (const auto& item : std::filesystem::directory_iterator(cache)) after.push_back(item.path().filename().string());
  std::sort(before.begin(), before.end());
  std::sort(after.begin(), after.end());
  EXPECT_EQ(before, after);
}

}  // namespace
}  // namespace cpvs
