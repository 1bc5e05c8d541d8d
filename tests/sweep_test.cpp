// The equal-bytes 16-bit shadow map baseline (libcpvs/eval/shadow_map.h) and the speed-vs-error sweep
// (libcpvs/eval/sweep.h) on tiny scenes: sizes, quantisation, agreement with Embree, Embree vs GL depth,
// and a whole sweep whose rows are consistent.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/eval/sweep.h"
#include "libcpvs/base/error.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// A 20 x 20 ground quad facing up and a closed box floating above it (no contact: no leak at a base).
Scene floatingBox() {
  Scene scene;
  test::addQuad(scene, "ground", {-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
  test::addBox(scene, "box", {-2, 3, -1.5}, {1.5, 4.5, 2});
  test::classifyMeshes(scene);
  Light sun;
  sun.name = "sun";
  sun.direction = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
  scene.lights.push_back(sun);
  return scene;
}

TEST(ShadowMapBaseline, EqualBytesSize) {
  EXPECT_EQ(equalBytesShadowMapSize(0), 1u);
  EXPECT_EQ(equalBytesShadowMapSize(1), 1u);
  for (uint64_t m : {1ull, 2ull, 7ull, 300ull, 4096ull, 46341ull}) {
    EXPECT_EQ(equalBytesShadowMapSize(2 * m * m), m);
    EXPECT_EQ(equalBytesShadowMapSize(2 * m * m + 1), m);
    EXPECT_EQ(equalBytesShadowMapSize(2 * (m + 1) * (m + 1) - 1), m);
  }
}

TEST(ShadowMapBaseline, QuantizeSlice) {
  for (uint32_t m : {1u, 100u, 4096u, 65536u}) {
    EXPECT_EQ(quantizeSlice(0.0, m), 0);
    EXPECT_EQ(quantizeSlice(-3.0, m), 0);
    EXPECT_EQ(quantizeSlice(double(m), m), ShadowMap16::kFar);
    EXPECT_EQ(quantizeSlice(double(m) * 0.5, m), 32768);
    EXPECT_EQ(quantizeSlice(std::nan(""), m), 0);
    uint16_t last = 0;
    for (int i = 0; i <= 1000; ++i) {  // monotone
      const uint16_t q = quantizeSlice(double(m) * i / 1000.0, m);
      EXPECT_GE(q, last);
      last = q;
    }
  }
  // At resolution 65536 the 16-bit value is the integer slice.
  EXPECT_EQ(quantizeSlice(1234.75, 65536), 1234);
}

TEST(ShadowMapBaseline, AgreesWithEmbreeAwayFromShadowEdges) {
  const Scene scene = floatingBox();
  const WorldGeometry world = flatten(scene);
  const EmbreeScene embree(world);
  const Light& sun = scene.lights[0];
  const std::vector<LightView> views = makeLightViews(sun, world, 256);
  const ShadowMap16 map = buildShadowMapEmbree(embree, views[0], 200);
  ASSERT_EQ(map.size(), 200u);
  ASSERT_EQ(map.bytes(), 200u * 200u * 2u);
  const ShadowMapLight light(sun, {map});
  const ShadowReference reference(world);
  const LookupOptions options{1, NormalOrientation::AsGiven};

  // The ground's shadow of the box, analytically: a ground point p is shadowed when the ray p - t d hits the box.
  const glm::dvec3 d = sun.direction;
  auto inShadow = [&](const glm::dvec3& p) {
    double t0 = 0, t1 = 1e30;
    const glm::dvec3 lo(-2, 3, -1.5), hi(1.5, 4.5, 2);
    for (int a = 0; a < 3; ++a) {
      const double ta = (lo[a] - p[a]) / -d[a], tb = (hi[a] - p[a]) / -d[a];
      t0 = std::max(t0, std::min(ta, tb));
      t1 = std::min(t1, std::max(ta, tb));
    }
    return t0 <= t1;
  };
  // Texel size on the ground is about 20 / 200 = 0.1; skip points within 0.5 of the shadow's edge.
  auto nearEdge = [&](const glm::dvec3& p) {
    const bool s = inShadow(p);
    for (double dx : {-0.5, 0.0, 0.5})
      for (double dz : {-0.5, 0.0, 0.5})
        if (inShadow(p + glm::dvec3(dx, 0, dz)) != s) return true;
    return false;
  };
  size_t checked = 0, shadowed = 0;
  for (double x = -9.5; x <= 9.5; x += 0.173) {
    for (double z = -9.5; z <= 9.5; z += 0.191) {
      const glm::dvec3 p(x, 0, z), n(0, 1, 0);
      if (nearEdge(p)) continue;
      const bool expectLit = !inShadow(p);
      ASSERT_EQ(reference.visibility(sun, {p, n}), expectLit ? 1 : 0) << x << " " << z;
      ASSERT_EQ(light.visibility(p, n, options), expectLit ? 1.0f : 0.0f) << x << " " << z;
      ++checked;
      shadowed += !expectLit;
    }
  }
  EXPECT_GT(checked, 9000u);
  EXPECT_GT(shadowed, 200u);
  // The box's own top faces the sun and is lit; its bottom faces away: 0 without a lookup.
  EXPECT_EQ(light.visibility({0, 4.5, 0}, {0, 1, 0}, options), 1.0f);
  EXPECT_EQ(light.visibility({0, 3, 0}, {0, -1, 0}, options), 0.0f);
  // PCF at a lit point far from any edge is 1, inside the shadow 0.
  EXPECT_EQ(light.visibility({8, 0, 8}, {0, 1, 0}, {5, NormalOrientation::AsGiven}), 1.0f);
}

TEST(ShadowMapBaseline, SpotOutsideInfluenceIsZero) {
  Scene scene = floatingBox();
  Light spot;
  spot.name = "spot";
  spot.type = LightType::Spot;
  spot.position = {0, 8, 0};
  spot.direction = {0, -1, 0};
  spot.outerConeAngle = 0.5;
  spot.range = 20;
  scene.lights = {spot};
  const WorldGeometry world = flatten(scene);
  const EmbreeScene embree(world);
  const std::vector<LightView> views = makeLightViews(spot, world, 128);
  const ShadowMapLight light(spot, {buildShadowMapEmbree(embree, views[0], 100)});
  const LookupOptions options{1, NormalOrientation::AsGiven};
  EXPECT_EQ(light.visibility({9, 0, 9}, {0, 1, 0}, options), 0.0f);     // outside the cone
  EXPECT_EQ(light.visibility({0, 4.5, 0}, {0, 1, 0}, options), 1.0f);   // the box top, facing the spot
  EXPECT_EQ(light.visibility({0.2, 0, 0.1}, {0, 1, 0}, options), 0.0f); // under the box
}

TEST(ShadowMapBaseline, RasterDepthMatchesEmbreeDepth) {
  const Scene scene = floatingBox();
  const WorldGeometry world = flatten(scene);
  const EmbreeScene embree(world);
  std::unique_ptr<DepthRenderer> renderer;
  SKIP_WITHOUT_OSMESA(renderer = DepthRenderer::create(RasterBackend::OSMesa));
  for (const Light& light : {scene.lights[0]}) {
    const std::vector<LightView> views = makeLightViews(light, world, 512);
    const ShadowMap16 a = buildShadowMapEmbree(embree, views[0], 300);
    const ShadowMap16 b = buildShadowMapRaster(*renderer, world, views[0], 300);
    ASSERT_EQ(a.depth.size(), b.depth.size());
    size_t close = 0;
    for (size_t i = 0; i < a.depth.size(); ++i) close += std::abs(int(a.depth[i]) - int(b.depth[i])) <= 1;
    // Everything but texels on a silhouette (where the rasteriser's coverage rule and the ray may differ).
    EXPECT_GE(double(close) / double(a.depth.size()), 0.995);
  }
}

TEST(Sweep, SamplesInsideClosedSolidsAreDropped) {
  // Two overlapping closed boxes and an open quad that passes through both: the parts of each surface inside
  // the other box (or inside either box, for the quad) are hidden and dropped.
  Scene scene;
  test::addBox(scene, "a", {0, 0, 0}, {2, 2, 2});
  test::addBox(scene, "b", {1, 1, 1}, {3, 3, 3});
  test::addQuad(scene, "sheet", {-1, 1.5, -1}, {-1, 1.5, 4}, {4, 1.5, 4}, {4, 1.5, -1});
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene);
  const ShadowReference reference(world);
  const auto drawn = sampleSurfaces(world, 20000, 3);
  const auto kept = exteriorSamples(reference, drawn);
  auto strictlyInside = [](const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi) {
    const double m = 1e-3;
    return p.x > lo.x + m && p.y > lo.y + m && p.z > lo.z + m && p.x < hi.x - m && p.y < hi.y - m && p.z < hi.z - m;
  };
  auto hidden = [&](const glm::dvec3& p) {
    return strictlyInside(p, {0, 0, 0}, {2, 2, 2}) || strictlyInside(p, {1, 1, 1}, {3, 3, 3});
  };
  size_t expectHidden = 0, clear = 0;
  for (const SurfaceSample& s : drawn) {
    const bool h = hidden(s.position);
    expectHidden += h;
    // Points on a boundary (within 1e-3 of a face of the other box) may go either way.
    bool nearBoundary = false;
    for (int a = 0; a < 3; ++a)
      for (double f : {0.0, 1.0, 2.0, 3.0}) nearBoundary = nearBoundary || std::abs(s.position[a] - f) < 1e-3;
    if (!nearBoundary) ++clear;
  }
  EXPECT_GT(expectHidden, 2000u);
  size_t keptHidden = 0;
  for (const SurfaceSample& s : kept) keptHidden += hidden(s.position);
  EXPECT_EQ(keptHidden, 0u);
  // Everything dropped was hidden (up to the points on a box face lying in the other box's face plane).
  EXPECT_NEAR(double(drawn.size() - kept.size()), double(expectHidden), 0.01 * double(drawn.size()));
  EXPECT_GT(clear, 0u);
}

TEST(Sweep, RowsOnATinyScene) {
  Scene scene = floatingBox();
  scene.lights.push_back(test::spotLight("spot", {3, 9, 2}, {-0.3, -1, -0.2}, 0.7, 30));
  SweepSettings settings;
  settings.resolutions = {64, 128, 256};
  settings.samples = 6000;
  settings.timingSeconds = 0.01;
  settings.bake.threads = 2;
  std::vector<SweepRow> rows;
  SKIP_WITHOUT_OSMESA(rows = runSweep(scene, settings));
  ASSERT_EQ(rows.size(), 6u);
  const WorldGeometry world = flatten(scene);
  const ShadowReference reference(world);
  const auto drawn = sampleSurfaces(world, settings.samples, settings.seed);
  const auto samples = exteriorSamples(reference, drawn);
  EXPECT_EQ(samples.size(), drawn.size());  // nothing is inside the box here
  for (size_t i = 0; i < rows.size(); ++i) {
    const SweepRow& r = rows[i];
    EXPECT_EQ(r.resolution, settings.resolutions[i / 2]);
    EXPECT_EQ(r.light, i % 2);
    EXPECT_EQ(r.points, sweepPoints(scene.lights[r.light], samples, false).size());
    EXPECT_GT(r.points, 1000u);
    EXPECT_GT(r.referenceLit, 0u);
    EXPECT_LT(r.referenceLit, r.points);  // the box shadows part of the ground for both lights
    EXPECT_GT(r.bytes, 0u);
    EXPECT_GE(r.fileBytes, r.bytes);
    // Equal bytes: the largest square 16-bit map that fits.
    EXPECT_LE(r.smBytes, r.bytes);
    EXPECT_GT(2ull * (r.smSize + 1) * (r.smSize + 1), r.bytes);
    EXPECT_LE(r.uniform, r.points);
    EXPECT_LE(r.misclassifiedUniform, r.misclassified);
    EXPECT_LE(r.misclassified, r.points / 20);  // a few percent at most, even at 64
    EXPECT_GT(r.lookupsPerS, 0.0);
    EXPECT_GT(r.raysPerS, 0.0);
    EXPECT_GT(r.smLookupsPerS, 0.0);
  }
  // Finer resolution, no more errors (allowing a point of noise), for both lights.
  for (size_t l = 0; l < 2; ++l) EXPECT_LE(rows[4 + l].misclassified, rows[l].misclassified + 1);
  // The CPVS at 256 beats the shadow map of the same bytes.
  for (size_t l = 0; l < 2; ++l) EXPECT_LE(rows[4 + l].misclassified, rows[4 + l].smMisclassified);
}

// A narrow spot over the scene keeps few of the samples; --min-light-points tops it up from further rounds,
// and leaves the other light's points as they were.
TEST(Sweep, ANarrowSpotIsToppedUpToTheMinimum) {
  Scene scene = floatingBox();
  const Light spot = test::spotLight("narrow", {3, 9, 2}, {-0.3, -1, -0.2}, 0.12, 30);
  scene.lights.push_back(spot);
  SweepSettings settings;
  settings.resolutions = {64};
  settings.samples = 3000;
  settings.timingSeconds = 0.01;
  settings.minLightPoints = 2500;
  const WorldGeometry world = flatten(scene);
  const auto base = sampleSurfaces(world, settings.samples, settings.seed);
  const size_t narrowBase = sweepPoints(spot, base, false).size();
  ASSERT_LT(narrowBase, 500u) << "the spot should keep few points";
  ASSERT_GT(sweepPoints(scene.lights[0], base, false).size(), settings.minLightPoints);
  std::vector<SweepRow> rows;
  SKIP_WITHOUT_OSMESA(rows = runSweep(scene, settings));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].points, sweepPoints(scene.lights[0], base, false).size());  // untouched
  EXPECT_EQ(rows[1].points, settings.minLightPoints);
  EXPECT_GT(rows[1].referenceLit, 0u);
}

TEST(SweepTool, QuietWithAnOutputFolderWritesOnlyTheFiles) {
  // Pipelines run the sweep with -q --out-dir: the table goes to the files, nothing to the terminal.
  const std::string dir = test::tempDir();
  const std::string base = test::toolPath("cpvs-sweep") + " '" + test::sourcePath("data/scenes/Tiny/tiny.gltf") +
                           "' --resolutions 64 --points 2000 --timing 0.01 --name tiny";
  const auto quiet = test::runTool(base + " -q --out-dir '" + dir + "'");
  if (quiet.exitCode != 0 && quiet.output.find("OSMesa") != std::string::npos) GTEST_SKIP() << quiet.output;
  ASSERT_EQ(quiet.exitCode, 0) << quiet.output;
  EXPECT_EQ(quiet.output, "");
  for (const char* ext : {".md", ".svg", ".json"}) EXPECT_TRUE(std::filesystem::exists(dir + "/tiny" + ext)) << ext;
  // Without an output folder the table is the output, quiet or not.
  const auto table = test::runTool(base + " -q");
  ASSERT_EQ(table.exitCode, 0) << table.output;
  EXPECT_NE(table.output.find("| 64 |"), std::string::npos) << table.output;
  // The reference's offset is checked as cpvs-query checks it, before any work.
  for (const char* bad : {" --reference-epsilon 0", " --reference-epsilon 0.5"}) {
    const auto r = test::runTool(base + " -q" + bad);
    EXPECT_EQ(r.exitCode, 1) << bad;
    EXPECT_NE(r.output.find("--reference-epsilon: reference ray offset"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace cpvs
