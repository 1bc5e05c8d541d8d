// End-to-end golden bytes: cpvs-bake on the shipped Tiny scene at N = 64, with a sun and a spot given
// on the command line (so the result does not depend on the scene's own lights) and every setting spelled out
// (so it does not depend on the tool's defaults), must reproduce
// tests/golden/tiny_scene_bake64_v2.cpvs (OpenGL on OSMesa) and tests/golden/tiny_scene_bake64_v2_cpu.cpvs
// (the CPU rasteriser) byte for byte — with one thread and with two. This pins the whole pipeline (import,
// views, depth rendering, masks, DAG, container) where format_test pins the container alone with synthetic
// content. tests/golden/alpha_test_bake128_v2{,_cpu}.cpvs pin the alpha-tested casters the same way (the
// `cpvs-scenegen alpha-test` scene at N = 128; docs/alpha.md), per rasteriser.
//
// The bytes change when the pipeline's output legitimately changes (a DAG construction change, a new format
// version) and also when the tool version changes (it is recorded in the BAKE block). After checking that the
// change is intended (cpvs-info on old and new file shows what moved), regenerate with:
//   CPVS_UPDATE_GOLDEN=1 build/bin/golden_test
// and commit the new tests/golden/tiny_scene_bake64_v2*.cpvs and alpha_test_bake128_v2*.cpvs. A change in the container layout must also bump
// the format version (libcpvs/runtime/cpvs_file.h) and update formats/cpvs/format.md and formats/cpvs/golden/tiny_v2.cpvs.
// tests/golden/tiny_scene_bake64_v1.cpvs is the same bake by cpvs 0.1 in format 1.0, and
// tests/golden/tiny_scene_bake64_v2_cpvs-bake-0.2.0.cpvs the same DAGs by cpvs 0.2 in format 2.0 (before
// cpvs 0.3 placed Kampe's mask changes differently); both stay, to show that 1.x files open, convert to
// exactly the writer's 2.0 units and decode to the same voxels.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/version.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using Bytes = std::vector<uint8_t>;
using test::runTool;
using test::sourcePath;
using test::tempDir;
using test::toolPath;

// Every setting that the bytes depend on is spelled out, so that a change of a default does not move them.
constexpr const char* kBakeArguments =
    " --resolution 64 --undefined kampe --max-peels 16 --ground auto --quiet"
    " --sun 0.3,-1,0.2 --spot 0,5,0,0,-1,0,0.6,20";

// One golden file per rasteriser: OpenGL on llvmpipe and the CPU rasteriser (the default).
const std::string& goldenPath(const std::string& backend = "osmesa") {
  static const std::string gl = sourcePath("tests/golden/tiny_scene_bake64_v2.cpvs");
  static const std::string cpu = sourcePath("tests/golden/tiny_scene_bake64_v2_cpu.cpvs");
  return backend == "cpu" ? cpu : gl;
}

Bytes readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The alpha-tested casters' pin: `cpvs-scenegen alpha-test` (a checkerboard MASK card, a clear BLEND pane, an
// OPAQUE card) at N = 128 with its own sun, one golden file per rasteriser.
constexpr const char* kAlphaBakeArguments =
    " --resolution 128 --undefined kampe --max-peels 16 --ground auto --alpha-test on --transparent clip --quiet";
const std::string& alphaGoldenPath(const std::string& backend) {
  static const std::string gl = sourcePath("tests/golden/alpha_test_bake128_v2.cpvs");
  static const std::string cpu = sourcePath("tests/golden/alpha_test_bake128_v2_cpu.cpvs");
  return backend == "cpu" ? cpu : gl;
}
const std::string& alphaScene() {
  static const std::string path = [] {
    const std::string p = tempDir() + "/alpha-test.glb";
    const auto r = runTool(toolPath("cpvs-scenegen") + " alpha-test -o " + p);
    if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen alpha-test: " + r.output);
    return p;
  }();
  return path;
}

// Bakes the golden scene into `dir` and returns the file's bytes.
Bytes bake(const std::string& dir, const std::string& extra, bool alpha = false) {
  const std::string out = dir + (alpha ? "/alpha128" : "/tiny64") + std::to_string(std::hash<std::string>()(extra) % 1000) + ".cpvs";
  const auto r = runTool(toolPath("cpvs-bake") + " " + (alpha ? alphaScene() : sourcePath("data/scenes/Tiny/tiny.gltf")) +
                         " -o " + out + (alpha ? kAlphaBakeArguments : kBakeArguments) + extra);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  return readFile(out);
}

// Where two files first differ, in terms of the golden file's sections.
std::string firstDifference(const Bytes& golden, const Bytes& baked) {
  size_t at = 0;
  while (at < golden.size() && at < baked.size() && golden[at] == baked[at]) ++at;
  std::string where = "sizes " + std::to_string(golden.size()) + " (golden) and " + std::to_string(baked.size()) +
                      " (baked); first difference at byte " + std::to_string(at);
  try {
    const auto file = orThrow(CpvsFile::fromBytes(golden, "golden"));
    if (at < 64) return where + ", in the header";
    for (size_t i = 0; i < file->sections().size(); ++i) {
      const auto& s = file->sections()[i];
      if (at >= s.offset && at < s.offset + s.size)
        return where + ", in section " + std::to_string(i) + " '" + s.type + "' at +" + std::to_string(at - s.offset);
    }
    return where + ", in the section table or padding";
  } catch (const std::exception& e) {
    return where + " (the golden file does not read: " + e.what() + ")";
  }
}

void expectPinnedBytes(const std::string& backend, bool alpha = false) {
  const std::string dir = tempDir();
  const std::string path = alpha ? alphaGoldenPath(backend) : goldenPath(backend);
  const Bytes baked = bake(dir, " --threads 2 --backend " + backend, alpha);
  ASSERT_FALSE(baked.empty());
  if (const char* update = std::getenv("CPVS_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(baked.data()), std::streamsize(baked.size()));
    GTEST_SKIP() << "wrote " << path << " (" << baked.size() << " bytes)";
  }
  const Bytes golden = readFile(path);
  ASSERT_FALSE(golden.empty()) << path << " is missing; run with CPVS_UPDATE_GOLDEN=1 to create it";
  EXPECT_TRUE(baked == golden) << "cpvs-bake no longer reproduces " << path << ": " << firstDifference(golden, baked)
                               << ". If the change is intended, regenerate it (see the top of golden_test.cpp).";
  // One thread gives the same bytes.
  EXPECT_TRUE(bake(dir, " --threads 1 --backend " + backend, alpha) == golden) << "--threads 1 differs from " << path;
}

TEST(GoldenBake, TinySceneAt64ReproducesThePinnedBytes) { expectPinnedBytes("osmesa"); }

TEST(GoldenBake, TinySceneAt64ReproducesThePinnedBytesOnTheCpuRasteriser) { expectPinnedBytes("cpu"); }

TEST(GoldenBake, AlphaTestSceneAt128ReproducesThePinnedBytes) { expectPinnedBytes("osmesa", true); }

TEST(GoldenBake, AlphaTestSceneAt128ReproducesThePinnedBytesOnTheCpuRasteriser) { expectPinnedBytes("cpu", true); }

// The two rasterisers cut the alpha-tested card alike: the pinned files differ in their settings block only.
TEST(GoldenBake, BothRasterisersPinTheSameAlphaTestedDags) {
  const auto gl = orThrow(CpvsFile::open(alphaGoldenPath("osmesa")));
  const auto cpu = orThrow(CpvsFile::open(alphaGoldenPath("cpu")));
  ASSERT_EQ(gl->lights().size(), 1u);
  ASSERT_EQ(cpu->lights().size(), 1u);
  const CpvsFile::View& a = gl->lights()[0].views[0];
  const CpvsFile::View& b = cpu->lights()[0].views[0];
  EXPECT_TRUE(std::ranges::equal(a.dag.nodes, b.dag.nodes));
  EXPECT_TRUE(std::ranges::equal(a.dag.leaves, b.dag.leaves));
  EXPECT_GT(a.dag.leaves.size(), 1u);  // the checkerboard is there, not a uniform shadow
}

TEST(GoldenBake, TheFormat1BakeOfCpvs01DecodesToTheSameVoxels) {
  const auto current = orThrow(CpvsFile::open(sourcePath("tests/golden/tiny_scene_bake64_v2_cpvs-bake-0.2.0.cpvs")));
  const auto old = orThrow(CpvsFile::open(sourcePath("tests/golden/tiny_scene_bake64_v1.cpvs")));
  EXPECT_EQ(old->majorVersion(), 1);
  ASSERT_EQ(old->lights().size(), current->lights().size());
  uint64_t shadowed = 0;
  for (size_t li = 0; li < old->lights().size(); ++li) {
    const CpvsFile::View& a = old->lights()[li].views[0];
    const CpvsFile::View& b = current->lights()[li].views[0];
    EXPECT_EQ(a.nodesPerLevel, b.nodesPerLevel);
    EXPECT_TRUE(std::ranges::equal(a.dag.leaves, b.dag.leaves));
    // The conversion is the writer's encoding: the same units, which in the file are half the bytes or less.
    EXPECT_TRUE(std::ranges::equal(a.dag.nodes, b.dag.nodes));
    EXPECT_LE(2 * b.nodeBytes, a.nodeBytes);
    const uint32_t n = a.view.resolution;
    uint64_t differences = 0;
    for (uint32_t z = 0; z < n; ++z)
      for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x) {
          differences += a.dag.shadowed(x, y, z) != b.dag.shadowed(x, y, z);
          shadowed += b.dag.shadowed(x, y, z);
        }
    EXPECT_EQ(differences, 0u) << "light " << li;
  }
  EXPECT_GT(shadowed, 0u);
}

TEST(GoldenBake, ThePinnedFileIsWhatItClaims) {
  const auto file = orThrow(CpvsFile::open(goldenPath()));
  EXPECT_EQ(file->majorVersion(), 2);
  EXPECT_EQ(file->minorVersion(), 0);
  // The BAKE block records what the bake depended on, and nothing about when or where it ran.
  const std::string& settings = file->settingsJson();
  for (const std::string s : {"\"tool\":\"cpvs-bake\"", "\"resolution\":64", "\"undefined\":\"kampe\"",
                              "\"node_reuse\":true", "\"region\":64", "\"input_hash\":\""})
    EXPECT_NE(settings.find(s), std::string::npos) << s << " in " << settings;
  EXPECT_EQ(settings.find("tiny.gltf"), std::string::npos) << settings;
  EXPECT_EQ(settings.find("threads"), std::string::npos) << settings;

  ASSERT_EQ(file->lights().size(), 2u);
  const auto& sun = file->lights()[0];
  EXPECT_EQ(sun.light.name, "sun0");
  EXPECT_EQ(sun.light.type, LightType::Directional);
  ASSERT_EQ(sun.views.size(), 1u);
  EXPECT_EQ(sun.views[0].view.projection, Projection::Orthographic);
  EXPECT_EQ(sun.views[0].view.mapping, DepthMapping::Linear);
  const auto& spot = file->lights()[1];
  EXPECT_EQ(spot.light.name, "spot0");
  EXPECT_EQ(spot.light.type, LightType::Spot);
  EXPECT_EQ(spot.light.range, 20.0);
  EXPECT_EQ(spot.light.outerConeAngle, 0.6);
  ASSERT_EQ(spot.views.size(), 1u);
  EXPECT_EQ(spot.views[0].view.projection, Projection::Perspective);
  EXPECT_EQ(spot.views[0].view.mapping, DepthMapping::Logarithmic);
  for (const auto& light : file->lights()) {
    const auto& v = light.views[0];
    EXPECT_EQ(v.view.resolution, 64u);
    EXPECT_FALSE(v.view.empty);
    EXPECT_EQ(v.dag.rootCode, ChildCode::Ref);  // real shadows: neither all lit nor all shadowed
    ASSERT_EQ(v.nodesPerLevel.size(), 4u);
    EXPECT_EQ(v.nodesPerLevel[0], 1u);
    EXPECT_GT(v.dag.leaves.size(), 0u);
  }
  // Hand-checked voxels (Tiny: box A spans x -2..-1, y 0..1, z -0.5..0.5; box B x 1..2, y 0..2; the open ground
  // quad lies at y = 0). Each point keeps at least half a texel laterally and several slices in depth from the
  // nearest edge, so the answer does not depend on rounding.
  auto shadowed = [](const CpvsFile::View& v, const glm::dvec3& p) {
    const GridPoint g = toGrid(v.view, p);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(g.uvs[k], 0.0) << "point outside the view";
      EXPECT_LT(g.uvs[k], double(v.view.resolution)) << "point outside the view";
    }
    const Voxel voxel = toVoxel(v.view, g.uvs);
    return v.dag.shadowed(uint32_t(voxel.x), uint32_t(voxel.y), uint32_t(voxel.z));
  };
  // Sun (travelling along (0.3, -1, 0.2)): box B's shadow on the ground beyond its +x face, and open air.
  EXPECT_TRUE(shadowed(sun.views[0], {2.3, 0.02, 0.0}));
  EXPECT_FALSE(shadowed(sun.views[0], {3.5, 0.3, 3.5}));
  // Spot at (0, 5, 0) looking down: box A's shadow beyond its -x face, and lit ground in front of the boxes.
  EXPECT_TRUE(shadowed(spot.views[0], {-2.25, 0.05, 0.0}));
  EXPECT_FALSE(shadowed(spot.views[0], {0.0, 0.3, 2.0}));

  // And cpvs-info reads it.
  const auto r = runTool(toolPath("cpvs-info") + " " + goldenPath());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("header ok, section table ok, 8 of 8 sections ok"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace cpvs
