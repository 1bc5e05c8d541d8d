// The culling demo's per-frame shadow maps (cpvs-view --shadows shadowmap / lightcluster): the conservative
// caster culling changes no lookup (and frustum culling no texel) while drawing fewer triangles, the GPU's
// shadow-map lookups equal eval/shadow_map.h's CPU lookup on the maps it drew, and LightCluster draws fewer
// maps. A generated city with spot lights, a point light and a sun; skipped without a GL 4.5 context.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/base/error.h"
#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/caster_culling.h"
#include "libcpvs/preview/light_clusters.h"
#include "libcpvs/preview/many_psm_plan.h"
#include "libcpvs/preview/preview_renderer.h"
#include "libcpvs/runtime/file_shadows.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

struct City {
  Scene scene;
  std::unique_ptr<CpvsFile> file;
  PreviewRenderer* renderer = nullptr;  // never destroyed (Mesa's exit handlers tear its state down)
  std::string unavailable;
};

City* bakeCity(Scene scene) {
  auto* c = new City;
  c->scene = std::move(scene);
  {
    BakeSettings settings;
    settings.resolution = 256;
    const std::string bytes = writeCpvs(bakeScene(c->scene, settings));
    c->file = orThrow(CpvsFile::fromBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, "city"));
    std::vector<LightShadow> lights;
    for (const CpvsFile::LightEntry& e : c->file->lights()) lights.push_back(orThrow(lightShadowOf(e)));
    try {
      c->renderer = new PreviewRenderer(c->scene, std::move(lights), RasterBackend::OSMesa, 2);
    } catch (const Error& e) {
      if (e.category() != ErrorCategory::NotSupported) throw;
      c->unavailable = e.what();
    }
  }
  return c;
}

City& city() {
  static City* c = [] {
    const std::string path = test::tempDir() + "/culling_city.glb";
    const test::ToolResult r =
        test::runTool(test::toolPath("cpvs-scenegen") + " city-spots --triangles 8000 --lights 12 -o " + path);
    if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen failed: " + r.output);
    Scene scene = importGltf(path);
    scene.lights.push_back(test::sunLight("sun", {0.4, -1.0, 0.3}));
    scene.lights.push_back(test::pointLight("point", {-60, 50, 40}, 300));
    return bakeCity(std::move(scene));
  }();
  return *c;
}

// Casters far from what they shadow: small blocks floating high above a ground square, lit from above, so that the
// voxel grid must follow the lines from the ground's cells up to the light to keep them.
City& floating() {
  static City* c = [] {
    Scene scene;
    test::addQuad(scene, "ground", {-50, 0, -50}, {-50, 0, 50}, {50, 0, 50}, {50, 0, -50});
    // Small enough (2 x 1 x 2 against cells of about 3 x 2 x 3) not to land on the grid's never-culled list.
    for (int i = 0; i < 16; ++i) {
      const glm::dvec3 at(-30.0 + 20 * (i % 4), 60, -30.0 + 20 * (i / 4));
      test::addBox(scene, "block" + std::to_string(i), at, at + glm::dvec3(2, 1, 2));
    }
    test::classifyMeshes(scene);
    scene.lights = {test::spotLight("spot", {0, 95, 0}, {0, -1, 0}, 0.75, 200), test::sunLight("sun", {0.2, -1, 0.1})};
    return bakeCity(std::move(scene));
  }();
  return *c;
}

// Two views: over the scene, and down a street into the first spot's pool of light.
std::vector<PreviewCamera> cameras(const City& c) {
  PreviewCamera street;
  const Light& spot = c.scene.lights.front();
  street.target = spot.position + spot.direction * (spot.position.y / -spot.direction.y);
  street.eye = street.target + glm::dvec3(90, 45, 70);
  return {defaultCamera(sceneBounds(c.scene), 1.5), street};
}

// A small frame with 5 x 5 PCF whose maps are kept for the tests.
FrameSettings testFrame(ShadowMode mode, uint32_t size) {
  FrameSettings settings;
  settings.width = 192;
  settings.height = 128;
  settings.pcfKernel = 5;
  settings.shadows = mode;
  settings.shadowMaps.size = size;
  settings.shadowMaps.keepMaps = true;
  return settings;
}

Frame render(City& c, const PreviewCamera& camera, ShadowMode mode, CasterCulling culling,
             ReceiverMaskVariant variant = ReceiverMaskVariant::Fragments, uint32_t clusters = 2, uint32_t size = 256) {
  FrameSettings settings = testFrame(mode, size);
  settings.shadowMaps.casterCulling = culling;
  settings.shadowMaps.maskVariant = variant;
  settings.shadowMaps.clusters = clusters;
  return c.renderer->render(camera, settings);
}

Frame renderManyPsm(City& c, const PreviewCamera& camera, uint32_t size, uint32_t minSize) {
  FrameSettings settings = testFrame(ShadowMode::ManyPsm, size);
  settings.shadowMaps.minSize = minSize;
  return c.renderer->render(camera, settings);
}

TEST(Culling, ConservativeCullingChangesNoLookupAndDrawsFewerTriangles) {
  for (City* scene : {&city(), &floating()})
    for (const PreviewCamera& camera : cameras(*scene)) {
    City& c = *scene;
    if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
    const Frame all = render(c, camera, ShadowMode::ShadowMap, CasterCulling::None);
    ASSERT_FALSE(all.shadowMaps.views.empty());
    size_t shadowed = 0;
    for (float v : all.visibility) shadowed += v < 1.0f;
    ASSERT_GT(shadowed, 100u) << "the frame shows too few shadows to test anything";
    struct Case {
      CasterCulling culling;
      ReceiverMaskVariant variant;
    };
    for (const Case& k : {Case{CasterCulling::Frustum, ReceiverMaskVariant::Fragments},
                          Case{CasterCulling::VoxelGrid, ReceiverMaskVariant::Fragments},
                          Case{CasterCulling::ReceiverMask, ReceiverMaskVariant::Fragments},
                          Case{CasterCulling::ReceiverMask, ReceiverMaskVariant::BoundingVolumes}}) {
      const Frame culled = render(c, camera, ShadowMode::ShadowMap, k.culling, k.variant);
      const std::string name = std::string(casterCullingName(k.culling)) +
                               (k.culling == CasterCulling::ReceiverMask ? std::string(" ") + receiverMaskVariantName(k.variant) : "");
      ASSERT_EQ(culled.lists.lights, all.lists.lights) << name;
      ASSERT_EQ(culled.visibility.size(), all.visibility.size()) << name;
      size_t differing = 0;
      for (size_t i = 0; i < all.visibility.size(); ++i) differing += culled.visibility[i] != all.visibility[i];
      EXPECT_EQ(differing, 0u) << name << ": lookups that culling changed, of " << all.visibility.size();
      // Frustum culling leaves out only what the rasteriser would clip: every texel of every map is the same.
      if (k.culling == CasterCulling::Frustum) {
        EXPECT_EQ(culled.shadowMaps.texels, all.shadowMaps.texels);
      }
      std::printf("[ culling  ] %-18s %8llu of %8llu triangles drawn into %zu maps\n", name.c_str(),
                  (unsigned long long)culled.shadowMaps.trianglesDrawn(), (unsigned long long)all.shadowMaps.trianglesDrawn(),
                  culled.shadowMaps.views.size());
      // Fewer triangles on the city (frustum culling may keep all where every light sees the whole scene; the
      // floating blocks are there for the lookups).
      if (k.culling == CasterCulling::Frustum || scene != &city()) {
        EXPECT_LE(culled.shadowMaps.trianglesDrawn(), all.shadowMaps.trianglesDrawn()) << name;
      } else {
        EXPECT_LT(culled.shadowMaps.trianglesDrawn(), all.shadowMaps.trianglesDrawn()) << name;
      }
    }
  }
}

// The GPU's lookups of the maps it drew equal eval/shadow_map.h's CPU lookup of the read-back maps.
// The maps' work counters: every texel a map holds took at least one fragment that passed the depth test, so
// the fragments a layer counts are at least its written texels; frustum culling drops only triangles outside
// a map's view, which make no fragment, so it counts the same fragments as drawing everything; every layer is
// cleared once.
TEST(Culling, MapWorkCountersBoundTheMapsAndFollowTheCulling) {
  City& c = city();
  if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
  const PreviewCamera camera = cameras(c).front();
  const Frame all = render(c, camera, ShadowMode::ShadowMap, CasterCulling::None);
  const Frame frustum = render(c, camera, ShadowMode::ShadowMap, CasterCulling::Frustum);
  const ShadowMapFrame& maps = all.shadowMaps;
  const size_t layers = maps.views.size(), texels = size_t(maps.size) * maps.size;
  ASSERT_GT(layers, 0u);
  ASSERT_EQ(maps.fragments.size(), layers);
  EXPECT_EQ(maps.texelsCleared, uint64_t(layers) * texels);
  EXPECT_GT(maps.drawCalls, 0u);
  EXPECT_LE(maps.drawCalls, layers);
  uint64_t written = 0;
  for (size_t layer = 0; layer < layers; ++layer) {
    uint64_t layerWritten = 0;
    for (size_t t = 0; t < texels; ++t) layerWritten += maps.texels[layer * texels + t] < ShadowMap16::kFar;
    EXPECT_GE(maps.fragments[layer], layerWritten) << "layer " << layer;
    written += layerWritten;
  }
  EXPECT_GT(written, 0u);
  EXPECT_EQ(frustum.shadowMaps.fragmentsDrawn(), maps.fragmentsDrawn());
  EXPECT_LT(frustum.shadowMaps.trianglesDrawn(), maps.trianglesDrawn());
  // The lookups' bytes: 4 per texel read, at most K^2 texels per listed pair, none for a pair whose verdict
  // needs no map (lit or zero); CPVS counts its DAG reads.
  size_t pairs = 0;
  all.forEachPair([&](uint32_t, uint32_t, size_t, uint32_t, size_t) { ++pairs; });
  ASSERT_TRUE(all.lookupBytesCounted);
  EXPECT_GT(all.lookupBytes, 0u);
  EXPECT_EQ(all.lookupBytes % 4, 0u);
  EXPECT_LE(all.lookupBytes, uint64_t(pairs) * 25 * 4);
  EXPECT_EQ(frustum.lookupBytes, all.lookupBytes);
  const Frame cpvs = render(c, camera, ShadowMode::Gpu, CasterCulling::None);
  ASSERT_TRUE(cpvs.lookupBytesCounted);
  EXPECT_GT(cpvs.lookupBytes, 0u);
  // Per light: the frame's bytes split by the light each lookup was for; a light no tile lists read nothing.
  std::vector<uint8_t> listed(c.renderer->lights().size(), 0);
  for (uint32_t l : all.lists.lights) listed[l] = 1;
  for (const Frame* f : {&all, &cpvs}) {
    ASSERT_EQ(f->lookupBytesPerLight.size(), listed.size());
    uint64_t sum = 0;
    for (size_t l = 0; l < listed.size(); ++l) {
      sum += f->lookupBytesPerLight[l];
      if (!listed[l]) {
        EXPECT_EQ(f->lookupBytesPerLight[l], 0u) << "light " << l;
      }
    }
    EXPECT_EQ(sum, f->lookupBytes);
  }
  std::printf("[ lookups  ] %zu pairs: the maps' lookups read %llu bytes, CPVS's %llu\n", pairs,
              (unsigned long long)all.lookupBytes, (unsigned long long)cpvs.lookupBytes);
}

TEST(Culling, GpuShadowMapLookupsEqualTheCpuRule) {
  City& c = city();
  if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
  const Frame f = render(c, cameras(c)[1], ShadowMode::ShadowMap, CasterCulling::None);
  const auto& lights = c.renderer->lights();
  const uint32_t m = f.shadowMaps.size;
  // The maps of each light, by view, as ShadowMap16s.
  std::vector<std::vector<ShadowMap16>> maps(lights.size());
  for (size_t layer = 0; layer < f.shadowMaps.views.size(); ++layer) {
    ShadowMap16 map;
    map.view = f.shadowMaps.views[layer];
    map.depth.assign(f.shadowMaps.texels.begin() + std::ptrdiff_t(layer * m * m),
                     f.shadowMaps.texels.begin() + std::ptrdiff_t((layer + 1) * m * m));
    maps[f.shadowMaps.shadowLight[layer]].push_back(std::move(map));
  }
  LookupOptions options;
  options.pcfKernel = 5;
  size_t pairs = 0, partial = 0;
  for (uint32_t y = 0; y < f.height; ++y)
    for (uint32_t x = 0; x < f.width; ++x) {
      const size_t i = f.pixel(x, y);
      if (f.positions[i].w == 0.0f) continue;
      const size_t tile = f.tileOf(x, y);
      for (uint32_t slot = 0; slot < f.lists.offsets[tile + 1] - f.lists.offsets[tile]; ++slot) {
        const uint32_t l = f.lists.lights[f.lists.offsets[tile] + slot];
        ASSERT_EQ(maps[l].size(), lights[l].views().size()) << "light " << l << " lacks maps";
        const ShadowMapLight cpu(lights[l].light(), maps[l]);
        const float want = cpu.visibility(glm::dvec3(glm::vec3(f.positions[i])), glm::dvec3(glm::vec3(f.normals[i])), options);
        ASSERT_EQ(f.visibility[f.pairIndex(x, y, slot)], want) << "pixel " << x << "," << y << " light " << l;
        ++pairs;
        partial += want > 0.0f && want < 1.0f;
      }
    }
  std::printf("[ lookups  ] %zu pairs equal to the CPU rule (%zu in a penumbra)\n", pairs, partial);
  EXPECT_GT(partial, 10u);
}

TEST(Culling, LightClusterDrawsOneCubePerCluster) {
  City& c = city();
  if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
  const Frame perLight = render(c, cameras(c)[0], ShadowMode::ShadowMap, CasterCulling::None);
  const Frame clustered = render(c, cameras(c)[0], ShadowMode::LightCluster, CasterCulling::None);
  std::vector<Light> all;
  for (const LightShadow& l : c.renderer->lights()) all.push_back(l.light());
  const LightClusters clusters = clusterLights(all, 2);
  EXPECT_EQ(clusters.lights.size(), 2u);
  // At most 2 cubes of 6 faces and the sun's map, against a map per light view (12 spots, a sun, a cube).
  EXPECT_LE(clustered.shadowMaps.views.size(), 2u * 6u + 1u);
  EXPECT_LT(clustered.shadowMaps.views.size(), perLight.shadowMaps.views.size());
  size_t differing = 0;
  for (size_t i = 0; i < perLight.visibility.size(); ++i) differing += clustered.visibility[i] != perLight.visibility[i];
  std::printf("[ clusters ] %zu maps instead of %zu; %zu of %zu lookups differ from the per-light maps\n",
              clustered.shadowMaps.views.size(), perLight.shadowMaps.views.size(), differing, perLight.visibility.size());
  EXPECT_GT(differing, 0u) << "one map for many lights must be an approximation";
}

// ManyPSMs with every map at the largest size, where that size splats no node as a point (the floating blocks
// at 256^2; the city's facade details need 2048^2): its atlas then holds the per-light maps of frustum culling
// texel for texel (the traversal keeps every triangle that reaches a map, and a map as large as the layer is
// drawn with the per-light map's bits), so every lookup is theirs too.
TEST(Culling, ManyPsmEqualsThePerLightMapsWhereNoNodeIsSplatted) {
  struct Case {
    City* scene;
    uint32_t size;
    size_t cameras;
  };
  for (const Case& k : {Case{&floating(), 256, 2}, Case{&city(), 2048, 1}}) {
    City& c = *k.scene;
    if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
    for (size_t i = 0; i < k.cameras; ++i) {
      const PreviewCamera camera = cameras(c)[i];
      const Frame perLight = render(c, camera, ShadowMode::ShadowMap, CasterCulling::Frustum,
                                    ReceiverMaskVariant::Fragments, 2, k.size);
      const Frame many = renderManyPsm(c, camera, k.size, k.size);
      const ShadowMapFrame& a = perLight.shadowMaps;
      const ShadowMapFrame& b = many.shadowMaps;
      ASSERT_EQ(b.points, 0u) << "nodes were splatted as points: choose a larger size";
      ASSERT_EQ(b.views.size(), a.views.size());
      ASSERT_EQ(b.texels.size(), a.texels.size());
      for (size_t m = 0; m < b.views.size(); ++m) {
        ASSERT_EQ(b.shadowLight[m], a.shadowLight[m]) << "map " << m;
        ASSERT_EQ(b.views[m].resolution, k.size) << "map " << m;
      }
      size_t differing = 0, written = 0;
      for (size_t t = 0; t < a.texels.size(); ++t) {
        differing += a.texels[t] != b.texels[t];
        written += a.texels[t] < ShadowMap16::kFar;
      }
      EXPECT_EQ(differing, 0u) << "texels of " << a.texels.size() << " (" << written << " written)";
      EXPECT_GT(written, 1000u);
      EXPECT_EQ(many.visibility, perLight.visibility);
      EXPECT_EQ(many.lookupBytes, perLight.lookupBytes) << "the same lookups read the same texels";
      EXPECT_GT(b.nodesVisited, 0u);
      EXPECT_EQ(b.drawCalls, 2u);
      EXPECT_GE(b.fragmentsDrawn(), written);
      std::printf("[ manypsm  ] %zu maps of %u^2 in %u layers: %llu nodes visited, %llu triangles (frustum culling: "
                  "%llu), %zu of %zu texels differ\n", b.views.size(), k.size, b.atlasLayers, (unsigned long long)b.nodesVisited,
                  (unsigned long long)b.trianglesDrawn(), (unsigned long long)a.trianglesDrawn(), differing, a.texels.size());
    }
  }
}

// With small maps ManyPSMs splats nodes as points, and only nodes at most a texel wide: each splatted node's
// box, its eight corners projected exactly (double) into its map, spans at most one texel either way. Each
// map has the resolution its light's distance asks for, and the atlas cells of a layer never overlap.
TEST(Culling, ManyPsmSplatsOnlyNodesAtMostATexelWide) {
  City& c = city();
  if (!c.unavailable.empty()) GTEST_SKIP() << c.unavailable;
  const PreviewCamera camera = cameras(c).front();
  const Frame many = renderManyPsm(c, camera, 64, 8);
  const ShadowMapFrame& maps = many.shadowMaps;
  ASSERT_GT(maps.points, 0u);
  ASSERT_EQ(maps.pointBoxes.size(), maps.points);
  double widest = 0;
  for (size_t i = 0; i < maps.pointBoxes.size(); ++i) {
    const LightView& view = maps.views[maps.pointMaps[i]];
    const auto& [lo, hi] = maps.pointBoxes[i];
    glm::dvec2 uvLo(1e300), uvHi(-1e300);
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 p(corner & 1 ? hi.x : lo.x, corner & 2 ? hi.y : lo.y, corner & 4 ? hi.z : lo.z);
      const GridPoint g = toGrid(view, p);
      ASSERT_TRUE(g.inFront) << "point " << i << " reaches behind its light";
      uvLo = glm::min(uvLo, glm::dvec2(g.uvs));
      uvHi = glm::max(uvHi, glm::dvec2(g.uvs));
    }
    widest = std::max({widest, uvHi.x - uvLo.x, uvHi.y - uvLo.y});
  }
  EXPECT_LE(widest, 1.0);
  uint64_t perMap = 0;
  for (uint64_t n : maps.pointsPerMap) perMap += n;
  EXPECT_EQ(perMap, maps.points);
  ShadowMapSettings settings;
  settings.size = 64;
  settings.minSize = 8;
  std::vector<std::vector<glm::uvec4>> cells(maps.atlasLayers);
  for (size_t m = 0; m < maps.views.size(); ++m) {
    const Light& light = c.renderer->lights()[maps.shadowLight[m]].light();
    EXPECT_EQ(maps.views[m].resolution, manyPsmResolution(light, many.eye, settings)) << light.name;
    const glm::uvec3 place = maps.atlasPlaces[m];
    const uint32_t res = maps.views[m].resolution;
    ASSERT_LT(place.x, maps.atlasLayers);
    EXPECT_LE(place.y + res, maps.size);
    EXPECT_LE(place.z + res, maps.size);
    for (const glm::uvec4& other : cells[place.x])
      EXPECT_TRUE(place.y + res <= other.x || other.x + other.z <= place.y || place.z + res <= other.y ||
                  other.y + other.z <= place.z) << "map " << m << " overlaps another";
    cells[place.x].push_back({place.y, place.z, res, 0});
  }
  std::printf("[ manypsm  ] 64^2 maps (8^2 at the least): %llu points, widest %.3f texels, %llu point fragments\n",
              (unsigned long long)maps.points, widest, (unsigned long long)(maps.fragments.size() > 1 ? maps.fragments[1] : 0));
}

TEST(Culling, ClustersMergeTheNearestLightsFirst) {
  std::vector<Light> lights = {test::pointLight("a", {0, 0, 0}, 10), test::pointLight("b", {1, 0, 0}, 10),
                               test::pointLight("c", {100, 0, 0}, 5), test::sunLight("sun", {0, -1, 0})};
  const LightClusters two = clusterLights(lights, 2);
  ASSERT_EQ(two.lights.size(), 2u);
  EXPECT_EQ(two.clusterOf[0], two.clusterOf[1]);
  EXPECT_NE(two.clusterOf[0], two.clusterOf[2]);
  EXPECT_EQ(two.clusterOf[3], LightClusters::kAlone);
  EXPECT_DOUBLE_EQ(two.lights[two.clusterOf[0]].position.x, 0.5);
  EXPECT_DOUBLE_EQ(two.lights[two.clusterOf[0]].range, 10.5);  // covers both members' ranges
  EXPECT_THROW(clusterLights(lights, 0), Error);
}

}  // namespace
}  // namespace cpvs
