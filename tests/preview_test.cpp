// cpvs-view's renderer (libcpvs/preview): the GPU's lookups against the CPU runtime on every (pixel, light)
// pair, the tile light lists against brute force, reference images per shadow mode and overlay, and the tool.
// Skipped where no OpenGL 4.5 context with compute shaders exists (OSMesa's llvmpipe has one).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/base/error.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/preview/light_lists.h"
#include "libcpvs/preview/preview_renderer.h"
#include "libcpvs/preview/shadow_pass.h"
#include "libcpvs/runtime/file_shadows.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::sourcePath;
using test::toolPath;

// A scene, its bake (kept in memory as a file) and a renderer over it; never destroyed (Mesa tears its state
// down in its own exit handlers), but kept reachable from keptBakes() so LeakSanitizer does not report it.
struct Baked {
  std::string name;
  Scene scene;
  std::unique_ptr<CpvsFile> file;
  PreviewRenderer* renderer = nullptr;
  std::string unavailable;
};

std::vector<Baked*>& keptBakes() {
  static auto* kept = new std::vector<Baked*>;  // never destroyed either: a static vector is freed before the leak check
  return *kept;
}

Baked* bake(const std::string& name, Scene scene, uint32_t resolution, uint16_t formatMajor = 2) {
  auto* b = keptBakes().emplace_back(new Baked);
  b->name = name;
  b->scene = std::move(scene);
  BakeSettings settings;
  settings.resolution = resolution;
  settings.threads = 2;
  const std::string bytes = writeCpvs(bakeScene(b->scene, settings), formatMajor);
  b->file = orThrow(CpvsFile::fromBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, name));
  std::vector<LightShadow> lights;
  for (const CpvsFile::LightEntry& e : b->file->lights()) lights.push_back(orThrow(lightShadowOf(e)));
  try {
    b->renderer = new PreviewRenderer(b->scene, std::move(lights), RasterBackend::OSMesa, 2);
  } catch (const Error& e) {
    if (e.category() != ErrorCategory::NotSupported) throw;
    b->unavailable = e.what();
  }
  return b;
}

// The TorusKnot under a sun, a spot and a point light.
Baked& torusKnot() {
  static Baked* b = [] {
    Scene scene = importGltf(sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
    scene.lights = {test::sunLight("sun", {0.3, -1.0, 0.2}), test::spotLight("spot", {5, 60, 0}, {0, -1, 0}, 0.6, 150),
                    test::pointLight("point", {20, 25, 15}, 120)};
    return bake("TorusKnot", std::move(scene), 256);
  }();
  return *b;
}

// The shipped SubpassSceneOpaque (-Y up: arcades, vaults, a dome, a Menger sponge) under a sun and a spot.
Baked& subpass() {
  static Baked* b = [] {
    Scene scene = importGltf(sourcePath("data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf"));
    scene.lights = {test::sunLight("sun", {0.35, 1, 0.25}), test::spotLight("spot", {0, -8, 0}, {0.2, 1, 0.1}, 0.7, 30)};
    return bake("Subpass", std::move(scene), 256);
  }();
  return *b;
}

// A generated city (cpvs-scenegen city-spots: 9 spot lights) with a sun and a point light added, as a 3.0 file:
// its views read one pool, which the GPU records hold once (gpu_records.cpp).
Baked& city() {
  static Baked* b = [] {
    const std::string path = test::tempDir() + "/preview_city.glb";
    const test::ToolResult r = runTool(toolPath("cpvs-scenegen") + " city-spots --triangles 5000 --lights 9 -o " + path);
    if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen failed: " + r.output);
    Scene scene = importGltf(path);
    // A dim sun and a point light as bright as the spots, so that every kind shows in the images.
    scene.lights.push_back(test::sunLight("sun", {0.4, -1.0, 0.3}));
    scene.lights.back().intensity = 0.01f;
    scene.lights.push_back(test::pointLight("point", {-60, 50, 40}, 300));
    scene.lights.back().intensity = 1500.0f;
    return bake("city", std::move(scene), 256, 3);
  }();
  return *b;
}

// The shipped two-light scene, for the reference images.
Baked& tiny() {
  static Baked* b = bake("Tiny", importGltf(sourcePath("data/scenes/Tiny/tiny.gltf")), 256);
  return *b;
}

std::vector<Light> lightsOf(const Baked& b) {
  std::vector<Light> lights;
  for (const LightShadow& l : b.renderer->lights()) lights.push_back(l.light());
  return lights;
}

#define REQUIRE_RENDERER(b)                                                        \
  if (!(b).unavailable.empty()) GTEST_SKIP() << "no GL compute context: " << (b).unavailable

// ---- GPU = CPU ------------------------------------------------------------------------------------------

// Every (pixel, listed light) pair: the GPU's verdict and voxel against the CPU's lookupCell on the same
// G-buffer point; the GPU's count against the CPU's walk of the GPU's voxel; the visibility against the
// CPU runtime's batch answer.
void checkGpuEqualsCpu(Baked& b, const PreviewCamera& camera, int pcf) {
  FrameSettings settings;
  settings.width = 192;
  settings.height = 128;
  settings.pcfKernel = pcf;
  settings.recordCells = true;
  const Frame gpu = b.renderer->render(camera, settings);
  settings.recordCells = false;
  settings.shadows = ShadowMode::Cpu;
  const Frame cpu = b.renderer->render(camera, settings);
  ASSERT_EQ(gpu.lists.lights, cpu.lists.lights) << "the same view twice gave other light lists";
  // llvmpipe rounds double division and square root correctly: there the voxels must be the CPU's exactly.
  const bool exactGpu = b.renderer->contextDescription().find("llvmpipe") != std::string::npos;
  LookupOptions options;
  options.pcfKernel = pcf;
  const auto& lights = b.renderer->lights();
  size_t pairs = 0, voxelPairs = 0, sameVoxel = 0, offByOne = 0, countChecked = 0, sameVisibility = 0;
  std::map<int, size_t> verdicts;
  for (uint32_t y = 0; y < gpu.height; ++y)
    for (uint32_t x = 0; x < gpu.width; ++x) {
      const size_t i = gpu.pixel(x, y);
      if (gpu.positions[i].w == 0.0f) continue;
      const glm::dvec3 p(glm::vec3(gpu.positions[i])), n(glm::vec3(gpu.normals[i]));
      const size_t tile = gpu.tileOf(x, y);
      for (uint32_t slot = 0; slot < gpu.lists.offsets[tile + 1] - gpu.lists.offsets[tile]; ++slot) {
        const LightShadow& light = lights[gpu.lists.lights[gpu.lists.offsets[tile] + slot]];
        const size_t pair = gpu.pairIndex(x, y, slot);
        const PairCell& g = gpu.cells[pair];
        const int verdict = g.verdictAndCount & 3;
        ++pairs;
        ++verdicts[verdict];
        const bool sameAnswer = gpu.visibility[pair] == cpu.visibility[pair];
        sameVisibility += sameAnswer;
        const int view = light.viewIndex(p);
        int expected = 0;
        LookupCell cell;
        if (view >= 0) {
          cell = lookupCell(ViewMapping(light.views()[size_t(view)]), p, n, options);
          // A view without casters answers lit before any other rule, as the runtime's batch does (a DAG
          // without a grid only occurs in an empty view: the reader rejects it elsewhere).
          if (light.views()[size_t(view)].empty || light.dags()[size_t(view)].resolution < 8)
            cell.kind = LookupCell::Kind::Lit;
          expected = cell.kind == LookupCell::Kind::Voxel ? 2 : cell.kind == LookupCell::Kind::Lit ? 1 : 0;
        }
        ASSERT_EQ(verdict, expected) << b.name << " pixel " << x << "," << y << " light " << light.light().name;
        if (verdict != 2) {
          ASSERT_TRUE(sameAnswer) << b.name << " pixel " << x << "," << y << " light " << light.light().name;
          continue;
        }
        ++voxelPairs;
        const int dx = std::abs(g.x - cell.x), dy = std::abs(g.y - cell.y), dz = std::abs(g.z - cell.z);
        if (dx == 0 && dy == 0 && dz == 0) {
          ++sameVoxel;
          ASSERT_TRUE(sameAnswer) << b.name << " pixel " << x << "," << y << ": the same voxel, another answer";
        } else {
          ++offByOne;
        }
        ASSERT_LE(std::max({dx, dy, dz}), 1) << b.name << " pixel " << x << "," << y << " light " << light.light().name;
        // The walk: the CPU's count over the GPU's own voxel.
        const uint32_t count = shadowedTexels(light.dags()[size_t(view)], g.x, g.y, uint32_t(g.z), pcf);
        ASSERT_EQ(uint32_t(g.verdictAndCount >> 2), count) << b.name << " pixel " << x << "," << y;
        ++countChecked;
      }
    }
  std::printf("[ pairs    ] %s K=%d: %zu pairs (%zu zero, %zu lit, %zu voxel), voxel equal on %zu, one off on %zu, "
              "visibility equal on %zu\n",
              b.name.c_str(), pcf, pairs, verdicts[0], verdicts[1], verdicts[2], sameVoxel, offByOne, sameVisibility);
  EXPECT_GT(voxelPairs, pairs / 10) << "too few lookups reach a DAG to test anything";
  EXPECT_GE(double(sameVoxel), 0.9999 * double(voxelPairs));
  if (exactGpu) {
    EXPECT_EQ(offByOne, 0u) << "llvmpipe's voxels must be the CPU's exactly";
  }
  EXPECT_EQ(countChecked, voxelPairs);
}

// The record layout the C++ writes (gpu_records.h) is the one the shaders read (lookup_records.glsl).
TEST(Preview, RecordLayoutEqualsTheShadersDefines) {
  std::map<std::string, uint32_t> defines;
  std::istringstream text(glsl::lookup_records_glsl);
  for (std::string line; std::getline(text, line);) {
    std::istringstream words(line);
    std::string directive, name, value;
    if (words >> directive >> name >> value && directive == "#define") defines[name] = uint32_t(std::stoul(value));
  }
  using namespace gpu_layout;
  const std::pair<const char*, uint32_t> expected[] = {
      {"CPVS_MAP_ROW", kMapRow}, {"CPVS_MAP_XMIN", kMapXMin}, {"CPVS_MAP_YMIN", kMapYMin},
      {"CPVS_MAP_USCALE", kMapUScale}, {"CPVS_MAP_VSCALE", kMapVScale}, {"CPVS_MAP_USTEP", kMapUStep},
      {"CPVS_MAP_VSTEP", kMapVStep}, {"CPVS_MAP_NEAR", kMapNear}, {"CPVS_MAP_INVNEAR", kMapInvNear},
      {"CPVS_MAP_SSCALE", kMapSScale}, {"CPVS_MAP_INVDS", kMapInvDs},
      {"CPVS_MAP_RESOLUTION", kMapResolution}, {"CPVS_MAP_REALS", kMapReals},
      {"CPVS_FLAG_ORTHOGRAPHIC", kFlagOrthographic}, {"CPVS_FLAG_LINEAR", kFlagLinear}, {"CPVS_FLAG_EMPTY", kFlagEmpty},
      {"CPVS_LIGHT_POSITION", kLightPosition}, {"CPVS_LIGHT_DIRECTION", kLightDirection}, {"CPVS_LIGHT_RANGE", kLightRange},
      {"CPVS_LIGHT_COS_OUTER", kLightCosOuter}, {"CPVS_LIGHT_SIN_OUTER", kLightSinOuter},
      {"CPVS_LIGHT_COS_INNER", kLightCosInner}, {"CPVS_LIGHT_COLOR", kLightColor}, {"CPVS_LIGHT_INTENSITY", kLightIntensity},
      {"CPVS_LIGHT_REALS", kLightReals}, {"CPVS_LIGHT_TYPE", kLightType}, {"CPVS_LIGHT_FIRST_VIEW", kLightFirstView},
      {"CPVS_LIGHT_VIEW_COUNT", kLightViewCount}, {"CPVS_LIGHT_DISABLED", kLightDisabled},
      {"CPVS_LIGHT_FACE_VIEW", kLightFaceView}, {"CPVS_LIGHT_SHADOW_LIGHT", kLightShadowLight},
      {"CPVS_LIGHT_SHAPE", kLightShape},
      {"CPVS_LIGHT_WORDS", kLightWords}, {"CPVS_VIEW_FLAGS", kViewFlags}, {"CPVS_VIEW_NODE_BASE", kViewNodeBase},
      {"CPVS_VIEW_LEAF_BASE", kViewLeafBase}, {"CPVS_VIEW_ROOT_CODE", kViewRootCode},
      {"CPVS_VIEW_RESOLUTION", kViewResolution}, {"CPVS_VIEW_LAYER", kViewLayer},
      {"CPVS_VIEW_ATLAS_X", kViewAtlasX}, {"CPVS_VIEW_ATLAS_Y", kViewAtlasY},
      {"CPVS_VIEW_CHILD_BASE", kViewChildBase}, {"CPVS_VIEW_WORDS", kViewWords}};
  for (const auto& [name, value] : expected) {
    ASSERT_TRUE(defines.count(name)) << name << " is not defined in lookup_records.glsl";
    EXPECT_EQ(defines[name], value) << name;
  }
  EXPECT_EQ(defines.size(), std::size(expected)) << "a #define without its C++ twin in gpu_layout";
}

TEST(Preview, GpuLookupsEqualTheCpuRuntimeOnTheTorusKnot) {
  Baked& b = torusKnot();
  REQUIRE_RENDERER(b);
  const Bounds bounds = sceneBounds(b.scene);
  checkGpuEqualsCpu(b, defaultCamera(bounds, 1.5), 9);
  checkGpuEqualsCpu(b, defaultCamera(bounds, 1.5, {0, 1, 0}, 0.5), 1);
}

TEST(Preview, GpuLookupsEqualTheCpuRuntimeOnSubpassScene) {
  Baked& b = subpass();
  REQUIRE_RENDERER(b);
  checkGpuEqualsCpu(b, defaultCamera(sceneBounds(b.scene), 1.5, {0, -1, 0}), 9);
  checkGpuEqualsCpu(b, defaultCamera(sceneBounds(b.scene), 1.5, {0, -1, 0}, 0.4), 5);
}

TEST(Preview, GpuLookupsEqualTheCpuRuntimeOnAGeneratedCity) {
  Baked& b = city();
  REQUIRE_RENDERER(b);
  // Down a street into the first spot light's pool of light, then the whole city.
  const Light& spot = b.scene.lights.front();
  PreviewCamera street;
  street.target = spot.position + spot.direction * (spot.position.y / -spot.direction.y);
  street.eye = street.target + glm::dvec3(90, 45, 70);
  checkGpuEqualsCpu(b, street, 9);
  checkGpuEqualsCpu(b, defaultCamera(sceneBounds(b.scene), 1.5), 3);
  // The 3.0 file's pool is in the GPU's node buffer once, not once per view.
  std::span<const uint16_t> pool;
  for (const CpvsFile::LightEntry& light : b.file->lights())
    for (const CpvsFile::View& view : light.views)
      if (!view.dag.sharedNodes.empty()) pool = view.dag.sharedNodes;
  ASSERT_FALSE(pool.empty());
  EXPECT_EQ(orThrow(packGpuScene(b.renderer->lights())).nodes.size(), (pool.size() + 1) / 2);
}

// ---- light lists ----------------------------------------------------------------------------------------

void checkLightLists(Baked& b, const PreviewCamera& camera) {
  FrameSettings settings;
  settings.width = 200;  // not a multiple of 8: partial tiles at the edges
  settings.height = 150;
  settings.shadows = ShadowMode::None;
  const Frame f = b.renderer->render(camera, settings);
  const std::vector<Light> lights = lightsOf(b);
  const TileLists brute = bruteForceLightLists(f.positions, f.width, f.height, lights);
  ASSERT_EQ(f.lists.offsets, brute.offsets) << b.name;
  ASSERT_EQ(f.lists.lights, brute.lights) << b.name;
  const auto missing = missingLights(f.positions, f.width, f.height, f.lists, lights);
  ASSERT_TRUE(missing.empty()) << b.name << ": pixel " << missing.front().first << " misses light "
                               << lights[missing.front().second].name;
  const LightListStats stats = lightListStats(f, lights.size());
  std::printf("[ lists    ] %s: %zu covered tiles, %.2f lights per tile (max %u), %llu pairs culled of %llu\n",
              b.name.c_str(), stats.coveredTiles, stats.meanLightsPerTile, stats.maxLightsPerTile,
              (unsigned long long)stats.pairsCulled, (unsigned long long)(stats.pairsCulled + stats.pairsListed));
  if (lights.size() > 3) {
    EXPECT_GT(stats.pairsCulled, 0u) << "the culling culls nothing";
  }
}

TEST(Preview, LightListsEqualBruteForceAndMissNoLight) {
  for (Baked* b : {&city(), &torusKnot()}) {
    REQUIRE_RENDERER(*b);
    const Bounds bounds = sceneBounds(b->scene);
    checkLightLists(*b, defaultCamera(bounds, 200.0 / 150.0));
    PreviewCamera low = defaultCamera(bounds, 200.0 / 150.0, {0, 1, 0}, 1.2);
    low.eye = bounds.center() + glm::dvec3(0.3, 0.05, 0.2) * glm::length(bounds.extent());
    checkLightLists(*b, low);
  }
}

// ---- reference images -----------------------------------------------------------------------------------

// Rendered the way cpvs-view writes a PNG by default: the camera on the side the strongest light lights, the
// automatic exposure with the default fill, the overlay drawn over the tone-mapped image.
// The references were rewritten on purpose when the fill (a sky over a grey ground and a light at the eye, 0.15
// of the base colour, in place of a flat 4 %) and that camera came: every image changed, the Tiny scene's now
// seen from its lit side, the shade in each showing its colours and forms.
RgbImage renderImage(Baked& b, ShadowMode mode, Overlay overlay) {
  FrameSettings settings;
  settings.width = settings.height = 256;
  settings.pcfKernel = 5;
  settings.shadows = mode;
  settings.compareWithRays = overlay == Overlay::Difference;
  settings.shadowMaps.size = 256;
  settings.shadowMaps.casterCulling = CasterCulling::VoxelGrid;  // changes no pixel (tests/culling_test.cpp)
  settings.shadowMaps.clusters = 3;
  std::vector<Light> lights;
  for (const LightShadow& light : b.renderer->lights()) lights.push_back(light.light());
  const Bounds bounds = sceneBounds(b.scene);
  const PreviewCamera camera = defaultCamera(bounds, 1.0, {0, 1, 0}, PreviewCamera{}.yfov, litSide(lights, bounds));
  const Frame f = b.renderer->render(camera, settings);
  const ExposedFrame exposed = autoExposed(f, f.radiance, Fill{});
  return withOverlay(f, toneMapped(f, f.radiance, exposed.exposure, exposed.fill), overlay);
}

// Compares with tests/golden/preview/NAME.png: at most 0.5 % of the pixels may differ by more than 4 of 255 in
// a channel (rasterisation ties and float rounding in another Mesa; the same Mesa gives the same bytes). With
// CPVS_UPDATE_REFERENCE_IMAGES=1 the reference is rewritten instead (a renderer change that alters images
// commits them with it). The image and its difference go to the build folder for a look.
void compareWithReference(const RgbImage& image, const std::string& name) {
  const std::string reference = sourcePath("tests/golden/preview/" + name + ".png");
  const std::string outDir = std::string(CPVS_BINARY_DIR) + "/preview-images";
  std::filesystem::create_directories(outDir);
  std::ofstream(outDir + "/" + name + ".png", std::ios::binary) << encodePng(image);
  if (const char* update = std::getenv("CPVS_UPDATE_REFERENCE_IMAGES"); update && std::string(update) == "1") {
    std::filesystem::create_directories(std::filesystem::path(reference).parent_path());
    std::ofstream(reference, std::ios::binary) << encodePng(image);
    return;
  }
  const RgbImage expected = readPng(reference);
  ASSERT_EQ(expected.width, image.width);
  ASSERT_EQ(expected.height, image.height);
  RgbImage difference = image;
  size_t differing = 0;
  int largest = 0;
  for (size_t i = 0; i < image.pixels.size(); i += 3) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(image.pixels[i + c]) - int(expected.pixels[i + c])));
    differing += d > 4;
    largest = std::max(largest, d);
    for (int c = 0; c < 3; ++c) difference.pixels[i + c] = uint8_t(std::min(255, d * 8));
  }
  std::ofstream(outDir + "/" + name + ".difference.png", std::ios::binary) << encodePng(difference);
  const double percent = 100.0 * double(differing) / double(image.width * image.height);
  std::printf("[ image    ] %s: %.3f %% of pixels differ by > 4, largest difference %d\n", name.c_str(), percent, largest);
  EXPECT_LE(percent, 0.5) << name << ": see " << outDir;
}

// The shipped Tiny scene (a sun and a spot) and the generated city (spots, a point light, a dim sun).
TEST(PreviewImages, EveryShadowModeMatchesItsReference) {
  for (Baked* b : {&tiny(), &city()}) {
    REQUIRE_RENDERER(*b);
    for (ShadowMode mode : {ShadowMode::Gpu, ShadowMode::Cpu, ShadowMode::RayTraced, ShadowMode::None,
                            ShadowMode::ShadowMap, ShadowMode::LightCluster, ShadowMode::ManyPsm})
      compareWithReference(renderImage(*b, mode, Overlay::None), b->name + "_" + shadowModeName(mode));
  }
}

TEST(PreviewImages, EveryOverlayMatchesItsReference) {
  for (Baked* b : {&tiny(), &city()}) {
    REQUIRE_RENDERER(*b);
    for (Overlay overlay : {Overlay::LightsPerTile, Overlay::Difference, Overlay::ShadowCount})
      compareWithReference(renderImage(*b, ShadowMode::Gpu, overlay), b->name + "_" + overlayName(overlay));
  }
}

TEST(PreviewImages, ShadowsChangeTheImage) {
  // The reference comparison must be able to fail: lighting without shadows is not the shadowed image.
  Baked& b = tiny();
  REQUIRE_RENDERER(b);
  const RgbImage shadowed = renderImage(b, ShadowMode::Gpu, Overlay::None), unshadowed = renderImage(b, ShadowMode::None, Overlay::None);
  size_t differing = 0;
  for (size_t i = 0; i < shadowed.pixels.size(); ++i) differing += std::abs(int(shadowed.pixels[i]) - int(unshadowed.pixels[i])) > 16;
  EXPECT_GT(differing, shadowed.pixels.size() / 1000);  // the tiny scene's two shadows: about 0.4 % of the values
}

// A technique of the test's own, behind the same interface as the built-in ones: every listed pair half lit.
// The renderer runs it knowing nothing of it, and the shading (linear in visibility) halves every pixel.
class HalfLit final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    ++runs;
    p.frame.visibility.assign(size_t(p.frame.lists.offsets.back()) * 64, 0.5f);
    return false;  // CPU-side: the renderer uploads it
  }
  int runs = 0;
};

TEST(Preview, AShadowTechniqueIsOneClassBehindShadowPass) {
  Baked& b = tiny();
  REQUIRE_RENDERER(b);
  FrameSettings settings;
  settings.width = 96;
  settings.height = 64;
  settings.shadows = ShadowMode::None;
  const PreviewCamera camera = defaultCamera(sceneBounds(b.scene), 1.5);
  const Frame lit = b.renderer->render(camera, settings);
  HalfLit half;
  const Frame halved = b.renderer->render(camera, settings, half);
  EXPECT_EQ(half.runs, 1);
  ASSERT_EQ(halved.radiance.size(), lit.radiance.size());
  size_t covered = 0;
  for (size_t i = 0; i < lit.radiance.size(); ++i) {
    if (lit.radiance[i].w == 0.0f) continue;
    ++covered;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(halved.radiance[i][c], 0.5f * lit.radiance[i][c], 1e-5f * (1.0f + lit.radiance[i][c])) << i;
  }
  EXPECT_GT(covered, halved.radiance.size() / 4);
  float brightest = 0.0f;
  for (const glm::vec4& c : lit.radiance) brightest = std::max(brightest, c.r + c.g + c.b);
  EXPECT_GT(brightest, 1e-3f) << "the lights reach the view";
  EXPECT_NE(halved.milliseconds("shading"), 0.0) << "the renderer's own passes still ran";
}

// The DAGs go to the GPU only when the GPU walk first runs: the CPU runtime, the rays and the shadow-map
// techniques never read them there, so a file larger than the GPU allows per buffer still previews with them.
TEST(Preview, TheDagsAreUploadedOnlyForTheGpuWalk) {
  Baked& b = *bake("TinyUploads", importGltf(sourcePath("data/scenes/Tiny/tiny.gltf")), 256);
  REQUIRE_RENDERER(b);
  const size_t before = b.renderer->staticUploadBytes();
  size_t dagBytes = 0;
  for (const LightShadow& l : b.renderer->lights())
    for (const DagView& v : l.dags()) dagBytes += (v.nodes.size() + 1) / 2 * 4 + v.leaves.size() * 8;
  ASSERT_GT(dagBytes, 0u);
  FrameSettings settings;
  settings.width = 64;
  settings.height = 48;
  const PreviewCamera camera = defaultCamera(sceneBounds(b.scene), 1.5);
  FrameSettings cpu;
  cpu.shadows = ShadowMode::Cpu;
  b.renderer->warmUp(cpu);
  for (ShadowMode mode : {ShadowMode::Cpu, ShadowMode::None}) {
    settings.shadows = mode;
    b.renderer->render(camera, settings);
    EXPECT_EQ(b.renderer->staticUploadBytes(), before) << shadowModeName(mode);
  }
  settings.shadows = ShadowMode::Gpu;
  b.renderer->render(camera, settings);
  const size_t withDags = b.renderer->staticUploadBytes();
  ASSERT_GT(withDags, before);
  EXPECT_GE(withDags - before, dagBytes) << "the walk's buffers hold the DAGs (two node units a word)";
  EXPECT_LE(withDags - before, dagBytes + 4096);
  b.renderer->render(camera, settings);
  EXPECT_EQ(b.renderer->staticUploadBytes(), withDags) << "once";
}

// The filtered reference (rays over each pair's PCF footprint) measures what 9 x 9 PCF estimates: the CPU
// runtime's filtered answers are closer to it than to one hard ray per pair, and more rays bring it closer.
TEST(Preview, FootprintRaysAreTheReferenceForFilteredLookups) {
  Baked& b = city();
  REQUIRE_RENDERER(b);
  FrameSettings settings;
  settings.width = 160;
  settings.height = 96;
  settings.pcfKernel = 9;
  settings.shadows = ShadowMode::Cpu;
  settings.compareWithRays = true;
  const PreviewCamera camera = defaultCamera(sceneBounds(b.scene), 160.0 / 96.0);
  double difference[3] = {};
  int i = 0;
  for (int raysPerSide : {1, 3, 9}) {
    settings.compareRaysPerSide = raysPerSide;
    const Frame f = b.renderer->render(camera, settings);
    const RayErrors e = errorsAgainstRays(f, 1.0);
    ASSERT_GT(e.pairs, 1000u);
    difference[i++] = e.meanAbsoluteDifference;
    // A filtered reference takes values between 0 and 1; one ray only 0 or 1.
    bool fractional = false;
    f.forEachPair([&](uint32_t, uint32_t, size_t, uint32_t, size_t p) {
      fractional |= f.rayVisibility[p] > 0.0f && f.rayVisibility[p] < 1.0f;
    });
    EXPECT_EQ(fractional, raysPerSide > 1) << raysPerSide;
  }
  EXPECT_LT(difference[2], 0.75 * difference[0]) << "81 rays " << difference[2] << ", one ray " << difference[0];
  EXPECT_LT(difference[2], difference[1] * 1.05) << "81 rays " << difference[2] << ", 9 rays " << difference[1];
}

// A base-colour texture reaches the G-buffer decoded from sRGB, times the material's factor: a quad with a
// 2 x 2 texture (two sRGB colours) and a factor, seen from above.
// A 20 m quad with u along +x under `texture` (left half an sRGB colour, right half white), seen from above: the
// G-buffer's base colour near the texel centres u = 1/4 and 3/4 is the factor times the texel decoded from sRGB.
void expectTexturedQuadDecodedFromSrgb(const std::string& name, Texture texture) {
  Scene scene;
  test::addQuad(scene, "ground", {-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
  scene.meshes[0].uvs = {{0.0f, 0.0f}, {0.0f, 1.0f}, {1.0f, 1.0f}, {1.0f, 0.0f}};  // u along +x
  scene.meshes[0].baseColorTexture = 0;
  scene.meshes[0].baseColor = glm::vec4(0.5f, 1.0f, 1.0f, 1.0f);
  scene.textures.push_back(std::move(texture));
  test::classifyMeshes(scene);
  scene.lights = {test::sunLight("sun", {0.1, -1, 0.2})};
  Baked* b = bake(name, std::move(scene), 64);
  REQUIRE_RENDERER(*b);
  PreviewCamera camera;
  camera.eye = {0, 30, 0.001};
  camera.target = {0, 0, 0};
  FrameSettings settings;
  settings.width = settings.height = 64;
  settings.pcfKernel = 1;
  const Frame f = b->renderer->render(camera, settings);
  auto linear = [](double c) { c /= 255.0; return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  size_t left = 0, right = 0;
  for (uint32_t y = 16; y < 48; ++y)
    for (uint32_t x = 4; x < 60; ++x) {
      const glm::vec4 c = f.baseColors[f.pixel(x, y)];
      if (f.positions[f.pixel(x, y)].w == 0.0f) continue;
      // Near the texel centres (u = 1/4, 3/4): the linear filter blends in little of the other texel there.
      const double u = (f.positions[f.pixel(x, y)].x + 10.0) / 20.0;
      if (std::fabs(u - 0.25) < 0.02) {
        EXPECT_NEAR(c.r, 0.5 * linear(128), 0.02);
        EXPECT_NEAR(c.g, linear(64), 0.04);
        EXPECT_NEAR(c.b, 1.0, 0.01);
        ++left;
      } else if (std::fabs(u - 0.75) < 0.02) {
        EXPECT_NEAR(c.r, 0.5, 0.02);
        EXPECT_NEAR(c.g, 1.0, 0.04);
        ++right;
      }
    }
  EXPECT_GT(left, 20u);
  EXPECT_GT(right, 20u);
}

// Alpha-tested receivers are cut as the casters are: a card 1 m over the ground whose coverage mask blocks its
// left half and cuts its right half away, sun straight down, seen from above. Through the cut half the camera
// sees the ground, lit; under the kept half the ground is not seen, and the card is lit.
TEST(PreviewImages, AlphaTestedTexelsAreCutInTheGBufferAsInTheBake) {
  Scene scene;
  test::addQuad(scene, "ground", {-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
  test::addQuad(scene, "card", {-6, 1, -6}, {-6, 1, 6}, {6, 1, 6}, {6, 1, -6});
  Mesh& card = scene.meshes[1];
  card.maskUvs = {{0.0f, 0.0f}, {0.0f, 1.0f}, {1.0f, 1.0f}, {1.0f, 0.0f}};  // u along +x
  card.coverageMask = 0;
  CoverageMask mask;
  mask.width = 2;
  mask.blocks = {1, 0};  // x < 0 blocks light, x > 0 is cut away
  scene.coverageMasks.push_back(mask);
  test::classifyMeshes(scene);
  scene.lights = {test::sunLight("sun", {0.0, -1, 0.0})};
  // A second card that casts no shadow (an extras flag) is still cut as a receiver, and left out of the maps.
  const std::vector<glm::vec2> cardUvs = card.maskUvs;  // addQuad may move the meshes
  test::addQuad(scene, "shadowless card", {-6, 2, 7}, {-6, 2, 9}, {6, 2, 9}, {6, 2, 7});
  scene.meshes.back().maskUvs = cardUvs;
  scene.meshes.back().coverageMask = 0;
  scene.meshes.back().castsShadows = false;
  Baked* b = bake("alpha-tested card", std::move(scene), 256);
  REQUIRE_RENDERER(*b);
  PreviewCamera camera;
  camera.eye = {0, 30, 0.001};
  camera.target = {0, 0, 0};
  for (ShadowMode mode : {ShadowMode::Gpu, ShadowMode::ShadowMap}) {  // CPVS, and the culling demo's maps
  SCOPED_TRACE(mode == ShadowMode::Gpu ? "gpu" : "shadowmap");
  FrameSettings settings;
  settings.width = settings.height = 64;
  settings.pcfKernel = 1;
  settings.shadows = mode;
  const Frame f = b->renderer->render(camera, settings);
  size_t card1 = 0, ground = 0, shadowlessKept = 0;
  for (uint32_t y = 0; y < f.height; ++y)
    for (uint32_t x = 0; x < f.width; ++x) {
      const glm::vec4 p = f.positions[f.pixel(x, y)];
      if (p.w != 0.0f && std::fabs(p.y - 2.0f) < 1e-3f) {  // the shadowless card: only its kept half is drawn
        EXPECT_LT(p.x, 0.05f) << "shadowless card drawn on a cut texel at " << x << "," << y;
        ++shadowlessKept;
        continue;
      }
      if (p.w == 0.0f || std::fabs(p.z) > 5.0f || std::fabs(p.x) > 5.0f || std::fabs(p.x) < 0.5f) continue;
      if (p.x < 0) {  // the kept half: the card itself
        EXPECT_NEAR(p.y, 1.0f, 1e-3f) << x << "," << y;
        ++card1;
      } else {  // the cut half: the ground below, lit through the gap (the sun listed, and not shadowing it)
        EXPECT_NEAR(p.y, 0.0f, 1e-3f) << x << "," << y;
        EXPECT_EQ(f.stats[f.pixel(x, y)], glm::uvec2(1, 0)) << x << "," << y;
        ++ground;
      }
    }
  EXPECT_GT(card1, 100u);
  EXPECT_GT(ground, 100u);
  EXPECT_GT(shadowlessKept, 10u);
  }
}

TEST(PreviewImages, BaseColourTexturesAreDecodedFromSrgb) {
  Texture texture;
  texture.width = 2;
  texture.height = 2;  // both rows alike: an sRGB colour on the left, white on the right
  texture.rgba = {128, 64, 255, 255, 255, 255, 255, 255, 128, 64, 255, 255, 255, 255, 255, 255};
  expectTexturedQuadDecodedFromSrgb("textured quad", std::move(texture));
}

TEST(PreviewImages, NonSquareTexturesAreResampledInSrgb) {
  // 2x1 goes through the resampler to the array's 2x2 layer (rows repeated, columns kept): the texels must land
  // where they were, still decoded from sRGB. (Columns are not rescaled here, so this does not tell an
  // sRGB-aware filter from one on the encoded bytes.)
  Texture texture;
  texture.width = 2;
  texture.height = 1;
  texture.rgba = {128, 64, 255, 255, 255, 255, 255, 255};
  expectTexturedQuadDecodedFromSrgb("resampled textured quad", std::move(texture));
}

TEST(PreviewImages, AutoExposureExposesMiddleGreyAndKeepsTheBrightestOffWhite) {
  const auto grey = [](float l) { return glm::vec4(l, l, l, 1.0f); };
  // Evenly lit: the log average goes to middle grey.
  EXPECT_NEAR(autoExposure(std::vector<glm::vec4>(100, grey(0.5f))), 0.18 / 0.5, 1e-6);
  // Half in shadow, lit only by a far light's tail: the shadowed pixels count as 1/1000 of the bright ones and
  // the brightest 1 % are exposed to at most kBrightestAfterExposure (the plain log average, 0.18 / sqrt(1e-9),
  // would expose them 2 800 times past that).
  std::vector<glm::vec4> halfShadowed(100, grey(1.0f));
  std::fill(halfShadowed.begin(), halfShadowed.begin() + 50, grey(1e-9f));
  const double exposure = autoExposure(halfShadowed);
  EXPECT_NEAR(exposure, std::min(0.18 / std::sqrt(1e-3), kBrightestAfterExposure), 1e-6);
  // Uncovered and unlit pixels do not count; nothing lit: 1.
  std::vector<glm::vec4> withBackground(10, grey(0.5f));
  withBackground.push_back(glm::vec4(100.0f, 100.0f, 100.0f, 0.0f));
  withBackground.push_back(grey(0.0f));
  EXPECT_NEAR(autoExposure(withBackground), 0.18 / 0.5, 1e-6);
  EXPECT_EQ(autoExposure(std::vector<glm::vec4>(4, grey(0.0f))), 1.0);
}

// Three pixels in the shade (no light reaches them): facing up, facing down and a wall facing the eye.
Frame shadedPixels() {
  Frame f;
  f.width = 3;
  f.height = 1;
  f.eye = glm::dvec3(0.0, 0.0, 10.0);
  f.positions.assign(3, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
  f.normals = {glm::vec4(0, 1, 0, 0), glm::vec4(0, -1, 0, 0), glm::vec4(0, 0, 1, 0)};
  f.baseColors.assign(3, glm::vec4(0.5f, 0.25f, 1.0f, 1.0f));
  f.radiance.assign(3, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
  return f;
}

TEST(PreviewImages, TheFillKeepsTheShadeReadableAndShowsItsForm) {
  const Frame f = shadedPixels();
  const Fill fill;  // the default: 0.15, +Y up
  const glm::dvec3 colour(0.5, 0.25, 1.0);
  // Facing up: the whole sky, the eye at 90 degrees; facing down: the ground; the wall: half of each, and the eye.
  const glm::dvec3 up = fillRadiance(f, 0, fill), down = fillRadiance(f, 1, fill), wall = fillRadiance(f, 2, fill);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(up[c], 0.15 * kSkyShare * colour[c], 1e-12);
    EXPECT_NEAR(down[c], 0.15 * kSkyShare * kGroundShade * colour[c], 1e-12);
    EXPECT_NEAR(wall[c], 0.15 * (kSkyShare * (0.5 + 0.5 * kGroundShade) + (1 - kSkyShare)) * colour[c], 1e-12);
  }
  // The image: with the fill the three differ and none is black; without it all three are black.
  const RgbImage filled = toneMapped(f, f.radiance, 1.0, fill), dark = toneMapped(f, f.radiance, 1.0, Fill{0.0});
  for (uint32_t x = 0; x < 3; ++x) {
    EXPECT_EQ(dark.at(x, 0)[2], 0) << x;
    EXPECT_GT(filled.at(x, 0)[2], 30) << x;  // the blue channel of a blue-ish surface in the shade
  }
  EXPECT_NE(filled.at(0, 0)[2], filled.at(1, 0)[2]);
  EXPECT_NE(filled.at(0, 0)[2], filled.at(2, 0)[2]);
  // The background gets none.
  Frame background = f;
  background.positions[0].w = 0.0f;
  EXPECT_EQ(fillRadiance(background, 0, fill), glm::dvec3(0.0));
}

TEST(PreviewImages, AutoExposureWithTheFillKeepsItsRatioToTheLights) {
  Frame f = shadedPixels();
  f.radiance[0] = glm::vec4(2.0f, 2.0f, 2.0f, 1.0f);  // the one lit pixel
  // Without a fill: the exposure of the lights alone, as before the fill existed.
  const ExposedFrame none = autoExposed(f, f.radiance, Fill{0.0}, 1.0);
  EXPECT_EQ(none.exposure, autoExposure(f.radiance) * 2.0);
  EXPECT_EQ(none.fill.strength, 0.0);
  // With one: lights and fill scaled alike, so the shade stays the same fraction of the lit.
  const Fill fill;
  const ExposedFrame with = autoExposed(f, f.radiance, fill, 0.0);
  EXPECT_NEAR(with.fill.strength / with.exposure, fill.strength / autoExposure(f.radiance), 1e-12);
  // The image with its fill is exposed as a whole: exposing it again changes nothing.
  std::vector<glm::vec4> exposedImage(f.radiance.size());
  for (size_t i = 0; i < exposedImage.size(); ++i)
    exposedImage[i] = glm::vec4(glm::dvec3(f.radiance[i]) * with.exposure + fillRadiance(f, i, with.fill), 1.0);
  EXPECT_NEAR(autoExposure(exposedImage), 1.0, 1e-6);
}

// ---- framing --------------------------------------------------------------------------------------------

TEST(PreviewCamera, DefaultFramingFitsTheBoxCentredAndTight) {
  // A flat city, a tall tower, a deep corridor and a cube, each under both up conventions and two aspects.
  const Bounds boxes[] = {{{-50, 0, -50}, {50, 8, 50}}, {{-2, 0, -2}, {2, 60, 2}}, {{-1, 0, -40}, {1, 3, 40}},
                          {{10, 10, 10}, {11, 11, 11}}};
  for (const Bounds& box : boxes)
    for (const glm::dvec3 up : {glm::dvec3(0, 1, 0), glm::dvec3(0, -1, 0)})
      for (const double aspect : {16.0 / 9.0, 0.75}) {
        const PreviewCamera camera = withClipPlanes(defaultCamera(box, aspect, up), box);
        checkCamera(camera);
        const glm::dmat4 clip = clipFromWorld(camera, aspect);
        glm::dvec2 low(INFINITY), high(-INFINITY);
        for (int i = 0; i < 8; ++i) {
          const glm::dvec4 p = clip * glm::dvec4((i & 1) ? box.max.x : box.min.x, (i & 2) ? box.max.y : box.min.y,
                                                 (i & 4) ? box.max.z : box.min.z, 1.0);
          ASSERT_GT(p.w, 0.0);
          low = glm::min(low, glm::dvec2(p) / p.w);
          high = glm::max(high, glm::dvec2(p) / p.w);
        }
        SCOPED_TRACE(testing::Message() << "box " << box.min.x << ".." << box.max.x << " aspect " << aspect);
        // Inside the frame less its margin, touching the margin across one axis, centred across both.
        const double margin = 1.0 / 1.05;
        EXPECT_LE(std::max({-low.x, -low.y, high.x, high.y}), margin + 1e-9);
        EXPECT_NEAR(std::max(high.x - low.x, high.y - low.y), 2.0 * margin, 1e-9);
        EXPECT_NEAR(low.y + high.y, 0.0, 1e-9);
        EXPECT_NEAR(low.x + high.x, 0.0, 1e-9);
      }
}

TEST(PreviewCamera, TheDefaultCameraLooksFromTheSideTheStrongestLightLights) {
  const Bounds box{{-10, 0, -10}, {10, 4, 10}};
  const glm::dvec3 up(0, 1, 0);
  Light sun;  // travels toward -X and down: lights the +X side
  sun.direction = glm::normalize(glm::dvec3(-1, -1, 0));
  sun.intensity = 2.0f;
  // Toward the light (+X), turned 90 degrees counter-clockwise seen from above: -Z, across the light.
  const glm::dvec3 side = litSide(std::vector<Light>{sun}, box, up);
  EXPECT_NEAR(side.x, 0.0, 1e-12);
  EXPECT_NEAR(side.y, 0.0, 1e-12);
  EXPECT_NEAR(side.z, -1.0, 1e-12);
  EXPECT_EQ(strongestLight(std::vector<Light>{sun}, box), std::optional<size_t>(0));
  EXPECT_EQ(strongestLight({}, box), std::nullopt);
  const PreviewCamera camera = defaultCamera(box, 1.5, up, 0.8, side);
  EXPECT_GT(glm::dot(camera.eye - box.center(), side), 0.0);
  EXPECT_GT(glm::dot(camera.eye - box.center(), up), 0.0);
  // No light, or the strongest straight above: the default side.
  EXPECT_EQ(litSide({}, box, up), kDefaultSide);
  Light overhead = sun;
  overhead.direction = glm::normalize(glm::dvec3(0.1, -1, 0));
  EXPECT_EQ(litSide(std::vector<Light>{overhead}, box, up), kDefaultSide);
  // A point light giving more illuminance at the centre wins over the sun (5 cd at 1 m: 5 lux against 2).
  Light point;
  point.type = LightType::Point;
  point.position = box.center() + glm::dvec3(0, 0, 1);  // +Z of the centre
  point.intensity = 5.0f;
  const glm::dvec3 pointSide = litSide(std::vector<Light>{sun, point}, box, up);
  EXPECT_NEAR(pointSide.x, 1.0, 1e-12);  // +Z turned to +X
  EXPECT_NEAR(pointSide.z, 0.0, 1e-12);
  EXPECT_EQ(strongestLight(std::vector<Light>{sun, point}, box), std::optional<size_t>(1));
  // ... but not beyond its range, nor a spot whose cone misses the centre.
  point.range = 0.5;
  EXPECT_NEAR(litSide(std::vector<Light>{sun, point}, box, up).z, -1.0, 1e-12);
  Light spot = point;
  spot.type = LightType::Spot;
  spot.range = 100;
  spot.direction = glm::dvec3(0, 0, 1);  // away from the centre
  EXPECT_NEAR(litSide(std::vector<Light>{sun, spot}, box, up).z, -1.0, 1e-12);
  spot.direction = glm::dvec3(0, 0, -1);  // at it
  EXPECT_NEAR(litSide(std::vector<Light>{sun, spot}, box, up).x, 1.0, 1e-12);
}

TEST(PreviewCamera, TheDefaultViewShowsTheStrongestLightsShadows) {
  // The shipped Subpass scene under the demo's sun (and a spot), seen as cpvs-view sees it by default: across
  // the strongest light, from above. Between 15 and 50 % of the geometry's pixels lie in that light's shadow
  // and at most 30 % are near black (the fill keeps the shade readable). From the light's own side (the
  // default before) only about a tenth of the geometry shows shadow.
  Baked& b = subpass();
  REQUIRE_RENDERER(b);
  const glm::dvec3 up(0, -1, 0);
  const Bounds bounds = sceneBounds(b.scene);
  const std::vector<Light> lights = lightsOf(b);
  const std::optional<size_t> strongest = strongestLight(lights, bounds);
  ASSERT_TRUE(strongest);
  EXPECT_EQ(lights[*strongest].type, LightType::Directional);
  FrameSettings settings;
  settings.width = 480;
  settings.height = 270;
  settings.shadows = ShadowMode::Cpu;
  auto coverage = [&](const glm::dvec3& side) {
    const PreviewCamera camera = defaultCamera(bounds, 480.0 / 270.0, up, PreviewCamera{}.yfov, side);
    const Frame f = b.renderer->render(camera, settings);
    const Fill fill{Fill{}.strength, up};
    const ExposedFrame exposed = autoExposed(f, f.radiance, fill);
    return shadowCoverage(f, uint32_t(*strongest), toneMapped(f, f.radiance, exposed.exposure, exposed.fill));
  };
  const ShadowCoverage chosen = coverage(litSide(lights, bounds, up));
  std::printf("[ coverage ] Subpass: %.1f %% in the sun's shadow, %.1f %% near black, of %zu pixels\n",
              100 * chosen.inShadow, 100 * chosen.nearBlack, chosen.geometryPixels);
  EXPECT_GT(chosen.geometryPixels, size_t(480 * 270 / 10));
  EXPECT_GE(chosen.inShadow, 0.15);
  EXPECT_LE(chosen.inShadow, 0.50);
  EXPECT_LE(chosen.nearBlack, 0.30);
  // From the light's side the same measure sees less shadow (what the measure is for).
  const glm::dvec3 toLight = -lights[*strongest].direction;
  EXPECT_LT(coverage(toLight - glm::dot(toLight, up) * up).inShadow, chosen.inShadow);
}

TEST(Preview, AutomaticShadowsTakeTheCpuRuntimeOnASoftwareGl) {
  Baked& b = tiny();
  REQUIRE_RENDERER(b);
  const PreviewRenderer::ShadowChoice choice = b.renderer->automaticShadows();
  if (b.renderer->contextDescription().find("llvmpipe") == std::string::npos)
    GTEST_SKIP() << "not a software GL: " << b.renderer->contextDescription();
  EXPECT_EQ(choice.mode, ShadowMode::Cpu);
  EXPECT_NE(choice.reason.find("llvmpipe"), std::string::npos) << choice.reason;
}

// ---- against the rays -----------------------------------------------------------------------------------

TEST(Preview, CpvsAgreesWithEmbreeOnMostPixels) {
  Baked& b = torusKnot();
  REQUIRE_RENDERER(b);
  FrameSettings settings;
  settings.width = 160;
  settings.height = 120;
  settings.pcfKernel = 1;
  settings.compareWithRays = true;
  const Frame f = b.renderer->render(defaultCamera(sceneBounds(b.scene), 160.0 / 120.0), settings);
  const RayErrors e = errorsAgainstRays(f, autoExposure(f.radiance));
  std::printf("[ rays     ] TorusKnot at 256: %.3f %% wrong pixels, %llu of %llu pairs, RMSE %.4f\n", e.wrongPixelPercent(),
              (unsigned long long)e.wrongPairs, (unsigned long long)e.pairs, e.rmse);
  EXPECT_GT(e.coveredPixels, 1000u);
  EXPECT_LT(e.wrongPixelPercent(), 3.0);
  EXPECT_LT(e.rmse, 0.05);
}

// ---- the tool -------------------------------------------------------------------------------------------

// --help names every shadow technique, and each name --shadows takes is one of them.
TEST(PreviewTool, HelpListsEveryShadowTechnique) {
  const test::ToolResult help = runTool(toolPath("cpvs-view") + " --help");
  ASSERT_EQ(help.exitCode, 0) << help.output;
  for (ShadowMode mode : {ShadowMode::Gpu, ShadowMode::Cpu, ShadowMode::RayTraced, ShadowMode::None, ShadowMode::ShadowMap,
                          ShadowMode::LightCluster, ShadowMode::ManyPsm}) {
    EXPECT_NE(help.output.find(shadowModeName(mode)), std::string::npos) << shadowModeName(mode);
    EXPECT_EQ(parseShadowMode(shadowModeName(mode)), mode);
  }
  EXPECT_NE(help.output.find("--min-shadow-map-size"), std::string::npos);
}

TEST(PreviewTool, RendersABakeAndRefusesAnotherScene) {
  const std::string dir = test::tempDir() + "/preview_tool";
  std::filesystem::create_directories(dir);
  const std::string scene = sourcePath("data/scenes/Tiny/tiny.gltf");
  ASSERT_EQ(runTool(toolPath("cpvs-bake") + " " + scene + " --resolution 64 -q -o " + dir + "/tiny.cpvs").exitCode, 0);
  const test::ToolResult view = runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/tiny.cpvs -o " + dir +
                                        "/tiny.png --size 64x48 --pcf 3 --report " + dir + "/report.json");
  if (view.exitCode == 5) GTEST_SKIP() << view.output;
  ASSERT_EQ(view.exitCode, 0) << view.output;
  const RgbImage image = readPng(dir + "/tiny.png");
  EXPECT_EQ(image.width, 64u);
  EXPECT_EQ(image.height, 48u);
  std::ifstream report(dir + "/report.json");
  const std::string text((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
  for (const char* key : {"\"gbuffer\"", "\"tile_bounds\"", "\"light_lists\"", "\"shadows\"", "\"shading\"",
                          "\"mean_lights_per_tile\"", "\"uploaded_bytes\"", "\"matches\": true", "\"ambient\": 0.15",
                          "\"shadow_coverage\"", "\"in_shadow\"", "\"near_black\""})
    EXPECT_NE(text.find(key), std::string::npos) << key << " missing from the report:\n" << text;
  // No --shadows: auto, which takes the CPU runtime on llvmpipe and says so in one line and in the report.
  EXPECT_NE(view.output.find("cpvs-view: shadows cpu (auto: "), std::string::npos) << view.output;
  EXPECT_NE(text.find("\"shadows\": \"cpu\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"shadows_auto\": \"OSMesa"), std::string::npos) << text;
  EXPECT_NE(view.output.find("of the geometry's pixels in the shadow of '"), std::string::npos) << view.output;

  // Another scene: refused with exit code 2, naming both files; nothing written.
  const std::string other = sourcePath("data/scenes/TorusKnot/torusknot.gltf");
  const test::ToolResult refused = runTool(toolPath("cpvs-view") + " " + other + " " + dir + "/tiny.cpvs -o " + dir +
                                           "/other.png --size 64x48");
  EXPECT_EQ(refused.exitCode, 2) << refused.output;
  EXPECT_NE(refused.output.find("was not baked from"), std::string::npos) << refused.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/other.png"));
  // A bake without a mesh: the view must leave it out too (--exclude-mesh), else it is another scene.
  ASSERT_EQ(runTool(toolPath("cpvs-bake") + " " + scene + " --resolution 64 -q --exclude-mesh Box -o " + dir +
                    "/nobox.cpvs").exitCode, 0);
  EXPECT_EQ(runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/nobox.cpvs -q -o " + dir + "/nobox.png --size 32x32").exitCode, 2);
  const test::ToolResult excluded = runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/nobox.cpvs -q -o " + dir +
                                            "/nobox.png --size 32x32 --exclude-mesh Box");
  EXPECT_EQ(excluded.exitCode, 0) << excluded.output;
  // --ambient 0: the lights alone, so no pixel brighter than with the default fill and some darker.
  ASSERT_EQ(runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/tiny.cpvs -q -o " + dir +
                    "/dark.png --size 64x48 --pcf 3 --ambient 0 --exposure-scale 1").exitCode, 0);
  ASSERT_EQ(runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/tiny.cpvs -q -o " + dir +
                    "/filled.png --size 64x48 --pcf 3 --exposure-scale 1").exitCode, 0);
  const RgbImage dark = readPng(dir + "/dark.png"), filled = readPng(dir + "/filled.png");
  size_t darker = 0;
  for (size_t i = 0; i < dark.pixels.size(); ++i) {
    ASSERT_LE(dark.pixels[i], filled.pixels[i]) << i;
    darker += dark.pixels[i] < filled.pixels[i];
  }
  EXPECT_GT(darker, dark.pixels.size() / 10);
  // Usage errors: exit code 1.
  for (const char* args : {" --size 0x10", " --pcf 4", " --shadows fast", " --overlay heat", " -o x.jpg", " --ambient -1"}) {
    const test::ToolResult bad = runTool(toolPath("cpvs-view") + " " + scene + " " + dir + "/tiny.cpvs -o " + dir +
                                         "/bad.png" + args);
    EXPECT_EQ(bad.exitCode, 1) << args << ": " << bad.output;
  }
}

}  // namespace
}  // namespace cpvs
