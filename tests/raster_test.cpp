// Enter / exit depth maps from OpenGL (OSMesa and EGL) against Embree ground truth (docs/depth-maps.md §Tests).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>

#include <tbb/parallel_for.h>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/raster/depth_maps.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/raster/cpu_depth_renderer.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/views/view_geometry.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// ------------------------------------------------------------------------------------------- fixtures

// One renderer per backend per process (context creation and shader compilation are not free); nullptr with
// the reason when the backend cannot open a context here.
DepthRenderer* renderer(RasterBackend backend, std::string* why = nullptr) {
  // Deliberately never destroyed: Mesa tears its state down in its own exit handlers, which run before the
  // destructors of statics constructed earlier than the library was loaded.
  static std::mutex mutex;
  static auto& renderers = *new std::map<RasterBackend, std::unique_ptr<DepthRenderer>>;
  static std::map<RasterBackend, std::string> failures;
  std::lock_guard<std::mutex> lock(mutex);
  if (!renderers.count(backend) && !failures.count(backend)) {
    try {
      renderers[backend] = DepthRenderer::create(backend);
      std::printf("[ backend  ] %s: %s\n", rasterBackendName(backend), renderers[backend]->description().c_str());
    } catch (const Error& e) {
      failures[backend] = e.what();
    }
  }
  if (failures.count(backend)) {
    if (why) *why = failures[backend];
    return nullptr;
  }
  return renderers[backend].get();
}

#define REQUIRE_RENDERER(var, backend)                                                        \
  std::string why_##var;                                                                      \
  DepthRenderer* var = renderer(backend, &why_##var);                                         \
  if (!var) GTEST_SKIP() << rasterBackendName(backend) << " not available here: " << why_##var

enum class SceneId { Boxes, Quads, TorusKnot, Terrain, Nested, Overlapping, OpenBoxOverBox, QuadOverBox, Coplanar };
enum class LightId { Directional, Spot };

const char* sceneName(SceneId s) {
  switch (s) {
    case SceneId::Boxes: return "Boxes";
    case SceneId::Quads: return "Quads";
    case SceneId::TorusKnot: return "TorusKnot";
    case SceneId::Terrain: return "Terrain";
    case SceneId::Nested: return "Nested";
    case SceneId::Overlapping: return "Overlapping";
    case SceneId::OpenBoxOverBox: return "OpenBoxOverBox";
    case SceneId::QuadOverBox: return "QuadOverBox";
    case SceneId::Coplanar: return "Coplanar";
  }
  return "?";
}

// An open quad facing +y (CCW seen from above) at height y.
void addGroundQuad(Scene& s, const std::string& name, double x0, double z0, double x1, double z1, double y) {
  test::addQuad(s, name, {x0, y, z1}, {x1, y, z1}, {x1, y, z0}, {x0, y, z0});
}

Scene buildScene(SceneId id) {
  Scene s;
  switch (id) {
    case SceneId::Boxes:  // closed only: a slab with boxes standing on it (coincident faces) and one floating
      test::addBox(s, "slab", {-10, -1, -10}, {10, 0, 10});
      test::addBox(s, "a", {-6, 0, -6}, {-2, 4, -2});
      test::addBox(s, "b", {1, 0, 1}, {5, 2, 6});
      test::addBox(s, "tall", {3, 0, -7}, {4, 8, -5});
      test::addBox(s, "floating", {-3.3, 3, 2.1}, {0.2, 5, 4.4});
      break;
    case SceneId::Quads:  // open only: a ground quad, tilted quads, one facing away from the lights
      addGroundQuad(s, "ground", -10, -10, 10, 10, 0);
      test::addQuad(s, "tilted", {-6, 2, 2}, {-1, 4, 2}, {-1, 4, -3}, {-6, 2, -3});
      test::addQuad(s, "away", {1, 6, -4}, {1, 6, 1}, {6, 5, 1}, {6, 5, -4});  // normal points down
      test::addQuad(s, "wall", {2, 0, 5}, {7, 0, 5}, {7, 5, 5}, {2, 5, 5});
      break;
    case SceneId::TorusKnot:
      s = importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
      break;
    case SceneId::Terrain:
      s = importGltf(test::sourcePath("data/scenes/Terrain/terrain.gltf"));
      break;
    case SceneId::Nested:  // a box inside a box, over a floor slab
      test::addBox(s, "floor", {-10, -3, -10}, {10, -2, 10});
      test::addBox(s, "outer", {-5, 0, -5}, {5, 6, 5});
      test::addBox(s, "inner", {-2.5, 1.5, -2.5}, {2.5, 4.5, 2.5});
      break;
    case SceneId::Overlapping:  // the union of two intersecting boxes
      test::addBox(s, "floor", {-10, -3, -10}, {10, -2, 10});
      test::addBox(s, "a", {-5, 0, -4}, {2, 4, 4});
      test::addBox(s, "b", {-1.5, 2, -2.5}, {5.5, 7, 2.5});
      break;
    case SceneId::OpenBoxOverBox: {  // an open box (no bottom) above half of a closed box
      test::addBox(s, "closed", {-3, 0, -3}, {3, 3, 3});
      const double x0 = -5, x1 = 0.5, y0 = 5, y1 = 7, z0 = -5, z1 = 5;
      addGroundQuad(s, "top", x0, z0, x1, z1, y1);
      test::addQuad(s, "side-x0", {x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0});
      test::addQuad(s, "side-x1", {x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1});
      test::addQuad(s, "side-z0", {x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0});
      test::addQuad(s, "side-z1", {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});
      break;
    }
    case SceneId::Coplanar:  // solids sharing faces: two overlapping boxes with one top and one bottom plane, and a
                             // third inside both standing on that bottom (coincident front and back layers)
      test::addBox(s, "floor", {-10, -3, -10}, {10, -2, 10});
      test::addBox(s, "a", {-5, 0, -4}, {2, 4, 4});
      test::addBox(s, "b", {-1, 0, -2}, {5, 4, 2});
      test::addBox(s, "inside", {-0.5, 0, -1}, {1.5, 2, 1});
      break;
    case SceneId::QuadOverBox:  // a closed box, half of it behind an open quad
      test::addBox(s, "closed", {-3, 0, -3}, {3, 3, 3});
      addGroundQuad(s, "roof", -6, -6, 0.3, 6, 5);
      break;
  }
  test::classifyMeshes(s);
  return s;
}

Light makeLight(LightId id, const WorldGeometry& world) {
  const glm::dvec3 c = world.bounds.center();
  const double r = 0.5 * glm::length(world.bounds.extent());
  Light light;
  if (id == LightId::Directional) {
    light.type = LightType::Directional;
    light.direction = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
  } else {
    light.type = LightType::Spot;
    light.position = c + glm::dvec3(0.35 * r, 1.6 * r, 0.2 * r);
    light.direction = glm::normalize(c - light.position);
    light.outerConeAngle = std::atan(0.75);
  }
  return light;
}

struct ViewSetup {
  WorldGeometry world;
  LightView view;
  ViewGeometry geometry;
  std::shared_ptr<EmbreeScene> embree;
};

const ViewSetup& setup(SceneId scene, LightId light, uint32_t n) {
  static std::mutex mutex;
  static std::map<std::tuple<int, int, uint32_t>, std::unique_ptr<ViewSetup>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[{int(scene), int(light), n}];
  if (!slot) {
    slot = std::make_unique<ViewSetup>();
    slot->world = flatten(buildScene(scene));
    const std::vector<LightView> views = makeLightViews(makeLight(light, slot->world), slot->world, n);
    slot->view = views.at(0);
    slot->geometry = gatherViewGeometry(slot->world, slot->view);
    slot->embree = std::make_shared<EmbreeScene>(slot->world);
  }
  return *slot;
}

// ---------------------------------------------------------------------------------------- reference

// Embree along the ray through every texel centre of the view.
struct Reference {
  uint32_t n = 0;
  // exit: the walk that takes back faces first where surfaces meet at one depth (touching solids exit between
  // them); exitLate: front faces first (touching solids merge). UINT32_MAX where the walk never leaves.
  std::vector<uint32_t> enter, exit, exitLate;
  std::vector<double> enterSlice;     // continuous slice of the first hit (NaN: miss)
  uint32_t e(uint32_t x, uint32_t y) const { return enter[size_t(y) * n + x]; }
  uint32_t xo(uint32_t x, uint32_t y) const { return exit[size_t(y) * n + x]; }
};

Reference reference(const ViewSetup& s) {
  const LightView& view = s.view;
  const uint32_t n = view.resolution;
  Reference ref;
  ref.n = n;
  ref.enter.assign(size_t(n) * n, n);
  ref.exit.assign(size_t(n) * n, n);
  ref.exitLate.assign(size_t(n) * n, n);
  ref.enterSlice.assign(size_t(n) * n, std::nan(""));
  const double tieTolerance = 1e-6 * glm::length(s.world.bounds.extent());
  tbb::parallel_for(uint32_t(0), n, [&](uint32_t y) {
    for (uint32_t x = 0; x < n; ++x) {
      const size_t i = size_t(y) * n + x;
      const Ray ray = texelRay(view, x + 0.5, y + 0.5);
      const std::optional<RayHit> hit = s.embree->firstHit(ray);
      if (!hit) continue;
      auto sliceAt = [&](double t) { return toGrid(view, ray.origin + t * ray.direction).uvs.z; };
      const double se = sliceAt(hit->t);
      const uint32_t e = uint32_t(toVoxel(view, {0, 0, se}).z);
      ref.enter[i] = e;
      ref.enterSlice[i] = se;
      ref.exit[i] = ref.exitLate[i] = e + 1;
      if (!hit->closed || !hit->frontFacing) continue;
      // Walk the closed surfaces from the enter with count 1.
      std::vector<RayHit> hits = s.embree->allHits(ray, 0.0, EmbreeScene::kInfinity, true);
      std::vector<std::pair<double, int>> events;  // (t, +1 front / -1 back)
      bool skippedEnter = false;
      for (const RayHit& h : hits) {
        if (h.t < hit->t - tieTolerance) continue;
        if (!skippedEnter && h.frontFacing && h.t <= hit->t + tieTolerance) {
          skippedEnter = true;
          continue;
        }
        events.emplace_back(h.t, h.frontFacing ? 1 : -1);
      }
      for (int order : {-1, 1}) {  // -1: back faces first at ties, +1: front faces first
        std::sort(events.begin(), events.end(), [&](const auto& a, const auto& b) {
          if (std::abs(a.first - b.first) > tieTolerance) return a.first < b.first;
          return order < 0 ? a.second < b.second : a.second > b.second;
        });
        int count = 1;
        double exitT = -1;
        for (const auto& [t, delta] : events) {
          count += delta;
          if (count <= 0) {
            exitT = t;
            break;
          }
        }
        uint32_t& out = order < 0 ? ref.exit[i] : ref.exitLate[i];
        if (exitT < 0) {
          out = UINT32_MAX;
          continue;
        }
        const double sx = std::floor(sliceAt(exitT));
        out = uint32_t(std::clamp<double>(std::max<double>(e + 1, sx), e + 1, n));
      }
    }
  });
  return ref;
}

// Whether a texel lies next to a depth discontinuity of the reference (a neighbour within one texel whose
// enter or exit differs by more than 2 slices, or a hit / miss change).
bool nearDiscontinuity(const Reference& ref, uint32_t x, uint32_t y) {
  const int64_t n = ref.n;
  const uint32_t e = ref.e(x, y), xo = ref.xo(x, y);
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int64_t nx = int64_t(x) + dx, ny = int64_t(y) + dy;
      if (nx < 0 || ny < 0 || nx >= n || ny >= n) continue;
      const uint32_t e2 = ref.e(uint32_t(nx), uint32_t(ny)), x2 = ref.xo(uint32_t(nx), uint32_t(ny));
      if ((e == ref.n) != (e2 == ref.n)) return true;
      if (std::abs(int64_t(e) - int64_t(e2)) > 2) return true;
      if ((xo == UINT32_MAX) != (x2 == UINT32_MAX)) return true;
      if (xo != UINT32_MAX && std::abs(int64_t(xo) - int64_t(x2)) > 2) return true;
    }
  return false;
}

DepthRegion renderWhole(DepthRenderer& r, const ViewSetup& s, const PeelSettings& peel = {}, RenderStats* stats = nullptr) {
  const uint32_t n = s.view.resolution;
  return r.render(s.geometry, s.view, {0, 0, n, n}, peel, stats);
}

// ------------------------------------------------------------------------------------------ enter

struct EnterCase {
  RasterBackend backend;
  SceneId scene;
  LightId light;
};

class EnterDepth : public ::testing::TestWithParam<EnterCase> {};

TEST_P(EnterDepth, MatchesEmbreeThroughTexelCentres) {
  const EnterCase c = GetParam();
  REQUIRE_RENDERER(r, c.backend);
  const uint32_t n = 512;
  const ViewSetup& s = setup(c.scene, c.light, n);
  RenderStats stats;
  const DepthRegion d = renderWhole(*r, s, {}, &stats);
  const Reference ref = reference(s);
  size_t equal = 0, hits = 0, rounding = 0, unexplained = 0;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      const uint32_t e = d.enterAt(x, y), er = ref.e(x, y);
      hits += er < n;
      if (e == er) {
        ++equal;
        continue;
      }
      if (nearDiscontinuity(ref, x, y)) continue;
      // Float rounding: one slice off where the exact slice coordinate is within 0.01 of a slice boundary.
      const double se = ref.enterSlice[size_t(y) * n + x];
      if (er < n && e < n && std::abs(int64_t(e) - int64_t(er)) == 1 &&
          std::abs(se - std::round(se)) < 0.01) {
        ++rounding;
        continue;
      }
      if (unexplained < 5)
        ADD_FAILURE() << "texel (" << x << ", " << y << "): GL enter " << e << ", Embree " << er << " (slice " << se
                      << ")";
      ++unexplained;
    }
  const double agreement = 100.0 * double(equal) / double(size_t(n) * n);
  std::printf("[ enter    ] %s %s %s: %.4f%% equal, %zu hit texels, %zu rounding, %zu unexplained; enter %.1f ms, "
              "peel %.1f ms, %u peels, %llu triangles\n",
              rasterBackendName(c.backend), sceneName(c.scene), c.light == LightId::Spot ? "spot" : "directional",
              agreement, hits, rounding, unexplained, stats.enterMs, stats.peelMs, stats.peelIterations,
              (unsigned long long)stats.trianglesSubmitted);
  RecordProperty("agreement_percent", std::to_string(agreement));
  EXPECT_GT(hits, size_t(n) * n / 20) << "the view should see the scene";
  EXPECT_GE(agreement, 99.9);
  EXPECT_EQ(unexplained, 0u);
  EXPECT_EQ(stats.trianglesSubmitted, s.geometry.triangleCount());
}

std::vector<EnterCase> enterCases() {
  std::vector<EnterCase> cases;
  for (RasterBackend b : {RasterBackend::OSMesa, RasterBackend::EGL, RasterBackend::Cpu})
    for (SceneId s : {SceneId::Boxes, SceneId::Quads, SceneId::TorusKnot, SceneId::Terrain})
      for (LightId l : {LightId::Directional, LightId::Spot}) cases.push_back({b, s, l});
  return cases;
}

std::string caseName(RasterBackend b, SceneId s, LightId l) {
  return std::string(b == RasterBackend::EGL ? "EGL" : b == RasterBackend::Cpu ? "CPU" : "OSMesa") + "_" + sceneName(s) + "_" +
         (l == LightId::Spot ? "Spot" : "Directional");
}

INSTANTIATE_TEST_SUITE_P(Scenes, EnterDepth, ::testing::ValuesIn(enterCases()),
                         [](const auto& info) { return caseName(info.param.backend, info.param.scene, info.param.light); });

// ------------------------------------------------------------------------------------------- exit

struct ExitCheck {
  size_t columns = 0, freeSamples = 0, straddling = 0, outside = 0;
  size_t exitCompared = 0, exitWithinOne = 0, exitLater = 0;
};

// Every sampled free voxel (e < z < x) of every second texel column: its centre (on the texel's ray) must be
// inside a closed solid; when it is not, one of the six face centres of the voxel must be (the voxel straddles
// the boundary by less than one voxel: counted in `straddling`), else it is counted in `outside`. Exits are
// compared with the Embree walk where the enter slices agree and the texel is not next to a discontinuity.
ExitCheck checkExit(const ViewSetup& s, const DepthRegion& d, const Reference& ref) {
  const LightView& view = s.view;
  const uint32_t n = view.resolution;
  std::mutex mutex;
  ExitCheck total;
  tbb::parallel_for(uint32_t(0), n / 2, [&](uint32_t yy) {
    ExitCheck local;
    const uint32_t y = 2 * yy;
    for (uint32_t x = 0; x < n; x += 2) {
      const uint32_t e = d.enterAt(x, y), xo = d.exitAt(x, y);
      if (e >= n) continue;
      const size_t i = size_t(y) * n + x;
      if (ref.e(x, y) == e && ref.exitLate[i] != UINT32_MAX && !nearDiscontinuity(ref, x, y)) {
        ++local.exitCompared;
        const bool within = xo + 1 >= ref.exit[i] && xo <= ref.exitLate[i] + 1;
        local.exitWithinOne += within;
        local.exitLater += xo > ref.exitLate[i] + 1;
        if (!within && local.exitCompared - local.exitWithinOne <= 2) {
          std::lock_guard<std::mutex> lock(mutex);
          std::printf("[ exit     ]   texel (%u, %u): enter %u, exit %u, Embree exit %u..%u\n", x, y, e, xo,
                      ref.exit[i], ref.exitLate[i]);
        }
      }
      if (xo <= e + 1) continue;
      ++local.columns;
      std::vector<uint32_t> zs = {e + 1, xo - 1};
      for (int k = 1; k <= 4; ++k) zs.push_back(e + 1 + uint32_t(uint64_t(xo - e - 2) * k / 5));
      std::sort(zs.begin(), zs.end());
      zs.erase(std::unique(zs.begin(), zs.end()), zs.end());
      for (uint32_t z : zs) {
        ++local.freeSamples;
        const glm::dvec3 centre(x + 0.5, y + 0.5, z + 0.5);
        if (s.embree->isInsideClosedSolid(gridToWorld(view, centre))) continue;
        bool straddles = false;
        for (int axis = 0; axis < 3 && !straddles; ++axis)
          for (double sign : {-0.5, 0.5}) {
            glm::dvec3 p = centre;
            p[axis] += sign;
            if (s.embree->isInsideClosedSolid(gridToWorld(view, p))) {
              straddles = true;
              break;
            }
          }
        (straddles ? local.straddling : local.outside) += 1;
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    total.columns += local.columns;
    total.freeSamples += local.freeSamples;
    total.straddling += local.straddling;
    total.outside += local.outside;
    total.exitCompared += local.exitCompared;
    total.exitWithinOne += local.exitWithinOne;
    total.exitLater += local.exitLater;
  });
  return total;
}

struct ExitCase {
  RasterBackend backend;
  SceneId scene;
  LightId light;
};

class ExitDepth : public ::testing::TestWithParam<ExitCase> {};

TEST_P(ExitDepth, FreeVoxelsAreInsideClosedSolidsAndExitsAreExact) {
  const ExitCase c = GetParam();
  REQUIRE_RENDERER(r, c.backend);
  const uint32_t n = 256;
  const ViewSetup& s = setup(c.scene, c.light, n);
  RenderStats stats;
  const DepthRegion d = renderWhole(*r, s, PeelSettings{16, 0}, &stats);  // every texel peeled to its exit
  const Reference ref = reference(s);
  const ExitCheck k = checkExit(s, d, ref);
  const double exact = k.exitCompared ? 100.0 * double(k.exitWithinOne) / double(k.exitCompared) : 100.0;
  std::printf("[ exit     ] %s %s %s: %zu free columns, %zu samples, %zu straddling, %zu outside; exit within 1 "
              "slice on %.3f%% of %zu texels (%zu later); %u peels, %llu capped\n",
              rasterBackendName(c.backend), sceneName(c.scene), c.light == LightId::Spot ? "spot" : "directional",
              k.columns, k.freeSamples, k.straddling, k.outside, exact, k.exitCompared, k.exitLater,
              stats.peelIterations, (unsigned long long)stats.texelsAtPeelCap);
  EXPECT_GT(k.columns, 100u) << "nothing to check";
  EXPECT_EQ(k.outside, 0u);
  EXPECT_LE(k.straddling, k.freeSamples / 100);
  EXPECT_EQ(stats.texelsAtPeelCap, 0u);
  // Exits may come early (never late) where a ray grazes an edge of an inner solid: rasterisation and Embree
  // decide coverage on the edge differently. That costs a few undefined voxels, never a wrong one.
  EXPECT_GE(exact, 99.9);
  EXPECT_EQ(k.exitLater, 0u);
  // Invariants of every texel.
  for (uint32_t i = 0; i < n * n; ++i) {
    ASSERT_LE(d.enter[i], n);
    ASSERT_LE(d.exit[i], n);
    if (d.enter[i] == n) {
      ASSERT_EQ(d.exit[i], n);
    } else {
      ASSERT_GT(d.exit[i], d.enter[i]);
    }
  }
}

std::vector<ExitCase> exitCases() {
  std::vector<ExitCase> cases;
  // Terrain and Quads: open ground sheets closed into solids (libcpvs/scene/ground_sheet.h).
  for (SceneId s : {SceneId::Nested, SceneId::Overlapping, SceneId::OpenBoxOverBox, SceneId::QuadOverBox,
                    SceneId::Boxes, SceneId::TorusKnot, SceneId::Terrain, SceneId::Quads})
    for (LightId l : {LightId::Directional, LightId::Spot})
      for (RasterBackend b : {RasterBackend::OSMesa, RasterBackend::Cpu}) cases.push_back({b, s, l});
  cases.push_back({RasterBackend::EGL, SceneId::Nested, LightId::Spot});
  cases.push_back({RasterBackend::EGL, SceneId::TorusKnot, LightId::Directional});
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Scenes, ExitDepth, ::testing::ValuesIn(exitCases()),
                         [](const auto& info) { return caseName(info.param.backend, info.param.scene, info.param.light); });

TEST(ExitRules, OpenOrBackFacingFirstSurfaceExitsRightAfterIt) {
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  for (SceneId scene : {SceneId::QuadOverBox, SceneId::OpenBoxOverBox}) {
  const ViewSetup& s = setup(scene, LightId::Directional, 256);
  const DepthRegion d = renderWhole(*r, s);
  size_t open = 0, closed = 0;
  for (uint32_t y = 0; y < 256; ++y)
    for (uint32_t x = 0; x < 256; ++x) {
      const uint32_t e = d.enterAt(x, y);
      if (e == 256) continue;
      const std::optional<RayHit> hit = s.embree->firstHit(texelRay(s.view, x + 0.5, y + 0.5));
      if (!hit) continue;
      if (!hit->closed) {
        ++open;
        EXPECT_EQ(d.exitAt(x, y), e + 1) << x << "," << y;
      } else if (d.exitAt(x, y) > e + 2) {
        ++closed;
      }
    }
  EXPECT_GT(open, 1000u);
  EXPECT_GT(closed, 1000u);
  }
}

// A region without closed triangles takes the renderer's open-only path (no peel state, enter slices read
// back alone). Its maps must be those the full path gives wherever the first surface is open.
TEST(ExitRules, OpenOnlyRegionsMatchTheFullPath) {
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  const uint32_t n = 256;
  const ViewSetup& s = setup(SceneId::QuadOverBox, LightId::Directional, n);
  ViewGeometry openOnly = s.geometry;
  const size_t closedTriangles = openOnly.closedIndices.size() / 3;
  ASSERT_GT(closedTriangles, 0u);
  ASSERT_GT(openOnly.openIndices.size(), 0u);
  openOnly.closedIndices.clear();
  openOnly.gridBounds.erase(openOnly.gridBounds.begin(), openOnly.gridBounds.begin() + ptrdiff_t(closedTriangles));
  const DepthRegion full = renderWhole(*r, s);
  const DepthRegion open = r->render(openOnly, s.view, {0, 0, n, n}, {});
  size_t compared = 0, empty = 0;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      const uint32_t e = open.enterAt(x, y);
      ASSERT_EQ(open.exitAt(x, y), e == n ? n : e + 1) << x << "," << y;
      empty += e == n;
      const std::optional<RayHit> hit = s.embree->firstHit(texelRay(s.view, x + 0.5, y + 0.5));
      if (!hit || hit->closed || full.exitAt(x, y) != full.enterAt(x, y) + 1) continue;
      EXPECT_EQ(e, full.enterAt(x, y)) << x << "," << y;
      ++compared;
    }
  EXPECT_GT(compared, 1000u);
  EXPECT_GT(empty, 0u);
}

TEST(ExitRules, PeelCapIsConservative) {
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  for (SceneId scene : {SceneId::Nested, SceneId::TorusKnot}) {
    const ViewSetup& s = setup(scene, LightId::Spot, 256);
    RenderStats full, capped;
    const DepthRegion a = renderWhole(*r, s, PeelSettings{16}, &full);
    const DepthRegion b = renderWhole(*r, s, PeelSettings{1}, &capped);
    EXPECT_EQ(capped.peelIterations, 1u);
    // Nested solids need several peels, so one peel caps many texels; the torus knot's first span ends at its
    // first back face, which one peel finds: the cap must then change nothing.
    if (scene == SceneId::Nested) {
      EXPECT_GT(capped.texelsAtPeelCap, 100u) << sceneName(scene);
    }
    size_t earlier = 0;
    for (size_t i = 0; i < a.exit.size(); ++i) {
      ASSERT_EQ(a.enter[i], b.enter[i]);
      ASSERT_LE(b.exit[i], a.exit[i]) << "capped exit later than the full one at texel " << i;
      if (b.enter[i] < 256) {
        ASSERT_GT(b.exit[i], b.enter[i]);
      }
      earlier += b.exit[i] < a.exit[i];
    }
    if (scene == SceneId::Nested) {
      EXPECT_GT(earlier, 100u);
    } else {
      EXPECT_EQ(earlier, 0u);
    }
    const ExitCheck k = checkExit(s, b, reference(s));
    EXPECT_EQ(k.outside, 0u);
    EXPECT_EQ(k.exitLater, 0u);
    std::printf("[ cap      ] %s: maxPeels=1: %llu texels capped, %zu exits earlier; full: %u peels\n",
                sceneName(scene), (unsigned long long)capped.texelsAtPeelCap, earlier, full.peelIterations);

    // Stopping once few texels are left (PeelSettings::stopBelowPerMillion) is the cap applied early: with
    // "few" = all of them it gives the one-peel maps exactly, and the default changes nothing here, where
    // hundreds of texels are still inside after each peel.
    RenderStats stopped;
    const DepthRegion early = renderWhole(*r, s, PeelSettings{16, 1000000}, &stopped);
    EXPECT_EQ(early.exit, b.exit) << sceneName(scene);
    EXPECT_EQ(stopped.texelsAtPeelCap, capped.texelsAtPeelCap) << sceneName(scene);
    EXPECT_EQ(stopped.peelIterations, 1u);
    EXPECT_EQ(renderWhole(*r, s, PeelSettings{16, 0}).exit, a.exit) << sceneName(scene);

    const DepthRegion none = renderWhole(*r, s, PeelSettings{0});
    for (size_t i = 0; i < none.exit.size(); ++i)
      if (none.enter[i] < 256) {
        ASSERT_EQ(none.exit[i], none.enter[i] + 1);
      }
  }
}

// ---------------------------------------------------------------------------------------- regions

TEST(Regions, SplitCoversTheViewOnce) {
  const std::pair<uint32_t, uint32_t> splits[] = {{512, 512}, {512, 256}, {512, 200}, {1, 8192}, {4096, 8192}};
  for (auto [n, size] : splits) {
    const std::vector<RegionRect> regions = splitIntoRegions(n, size);
    std::vector<uint8_t> covered(size_t(n) * n, 0);
    for (const RegionRect& r : regions) {
      ASSERT_LE(r.width, size);
      ASSERT_LE(r.height, size);
      ASSERT_LE(r.x0 + r.width, n);
      ASSERT_LE(r.y0 + r.height, n);
      for (uint32_t y = r.y0; y < r.y0 + r.height; ++y)
        for (uint32_t x = r.x0; x < r.x0 + r.width; ++x) ++covered[size_t(y) * n + x];
    }
    EXPECT_TRUE(std::all_of(covered.begin(), covered.end(), [](uint8_t c) { return c == 1; })) << n << " " << size;
    const uint32_t per = (n + size - 1) / size;
    EXPECT_EQ(regions.size(), size_t(per) * per);
  }
  EXPECT_TRUE(splitIntoRegions(0, 16).empty());
  EXPECT_THROW(splitIntoRegions(16, 0), Error);
}

class SplitRendering : public ::testing::TestWithParam<RasterBackend> {};

TEST_P(SplitRendering, GivesIdenticalSlices) {
  REQUIRE_RENDERER(r, GetParam());
  const std::pair<SceneId, LightId> cases[] = {{SceneId::TorusKnot, LightId::Spot}, {SceneId::Nested, LightId::Directional},
                                               {SceneId::Terrain, LightId::Spot}};
  for (auto [scene, light] : cases) {
    const ViewSetup& s = setup(scene, light, 512);
    RenderStats wholeStats;
    const DepthRegion whole = renderWhole(*r, s, {}, &wholeStats);
    for (uint32_t size : {256u, 200u}) {
      uint64_t submitted = 0;
      for (const RegionRect& rect : splitIntoRegions(512, size)) {
        RenderStats stats;
        const DepthRegion part = r->render(s.geometry, s.view, rect, {}, &stats);
        submitted += stats.trianglesSubmitted;
        ASSERT_EQ(part.rect.x0, rect.x0);
        ASSERT_EQ(part.enter.size(), size_t(rect.width) * rect.height);
        size_t differ = 0;
        for (uint32_t y = 0; y < rect.height; ++y)
          for (uint32_t x = 0; x < rect.width; ++x) {
            const uint32_t wx = rect.x0 + x, wy = rect.y0 + y;
            if (part.enterAt(x, y) == whole.enterAt(wx, wy) && part.exitAt(x, y) == whole.exitAt(wx, wy)) continue;
            if (++differ <= 3)
              ADD_FAILURE() << "texel (" << wx << ", " << wy << "): region enter/exit " << part.enterAt(x, y) << "/"
                            << part.exitAt(x, y) << ", whole " << whole.enterAt(wx, wy) << "/" << whole.exitAt(wx, wy);
          }
        EXPECT_EQ(differ, 0u) << sceneName(scene) << " region " << rect.x0 << "," << rect.y0 << " " << rect.width
                              << "x" << rect.height;
      }
      // Culling: each region gets only the triangles that overlap it.
      EXPECT_LT(submitted, wholeStats.trianglesSubmitted * (512 / size + 1) * (512 / size + 1));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Regions, SplitRendering, ::testing::Values(RasterBackend::OSMesa, RasterBackend::Cpu),
                         [](const auto& info) { return std::string(rasterBackendName(info.param)); });

TEST(Regions, RejectsRegionsOutsideTheViewOrTooLarge) {
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  const ViewSetup& s = setup(SceneId::Nested, LightId::Directional, 256);
  EXPECT_THROW(r->render(s.geometry, s.view, {200, 0, 100, 10}, {}), Error);
  EXPECT_THROW(r->render(s.geometry, s.view, {0, 0, 0, 10}, {}), Error);
  EXPECT_GE(r->maxRegionSize(), 1024u);
  EXPECT_LE(r->maxRegionSize(), 8192u);
}

TEST(Regions, EmptyGeometryIsAllLit) {
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  const ViewSetup& s = setup(SceneId::Nested, LightId::Directional, 256);
  const DepthRegion d = r->render(ViewGeometry{}, s.view, {0, 0, 64, 32}, {});
  ASSERT_EQ(d.enter.size(), 64u * 32u);
  for (size_t i = 0; i < d.enter.size(); ++i) {
    EXPECT_EQ(d.enter[i], 256u);
    EXPECT_EQ(d.exit[i], 256u);
  }
}

// --------------------------------------------------------------------------------------- backends

TEST(Backends, OSMesaAndEGLAgree) {
  REQUIRE_RENDERER(a, RasterBackend::OSMesa);
  REQUIRE_RENDERER(b, RasterBackend::EGL);
  const std::pair<SceneId, LightId> cases[] = {
      {SceneId::TorusKnot, LightId::Directional}, {SceneId::Terrain, LightId::Spot}, {SceneId::Overlapping, LightId::Spot}};
  for (auto [scene, light] : cases) {
    const ViewSetup& s = setup(scene, light, 512);
    // Interleave the two contexts in one process.
    const DepthRegion da = renderWhole(*a, s), db = renderWhole(*b, s), da2 = renderWhole(*a, s);
    size_t equal = 0;
    for (size_t i = 0; i < da.enter.size(); ++i) equal += da.enter[i] == db.enter[i] && da.exit[i] == db.exit[i];
    const double agreement = 100.0 * double(equal) / double(da.enter.size());
    std::printf("[ backends ] %s: OSMesa and EGL slices equal on %.4f%% of texels\n", sceneName(scene), agreement);
    EXPECT_GE(agreement, 99.99) << sceneName(scene);
    EXPECT_EQ(da.enter, da2.enter);
    EXPECT_EQ(da.exit, da2.exit);
  }
}

// The CPU rasteriser against llvmpipe on every test scene, both light kinds, with the default peel settings:
// the same snapped vertices, coverage rule and peeling give the same slices except where a depth lies within
// float rounding of a slice boundary (GL evaluates the plane and the logarithm in float, the CPU in double) and
// where solids touch (below).
TEST(Backends, CpuAndOSMesaAgree) {
  REQUIRE_RENDERER(gl, RasterBackend::OSMesa);
  REQUIRE_RENDERER(cpu, RasterBackend::Cpu);
  for (SceneId scene : {SceneId::Boxes, SceneId::Quads, SceneId::TorusKnot, SceneId::Terrain, SceneId::Nested,
                        SceneId::Overlapping, SceneId::OpenBoxOverBox, SceneId::QuadOverBox})
    for (LightId light : {LightId::Directional, LightId::Spot}) {
      const ViewSetup& s = setup(scene, light, 512);
      RenderStats glStats, cpuStats;
      const DepthRegion a = renderWhole(*gl, s, {}, &glStats), b = renderWhole(*cpu, s, {}, &cpuStats);
      size_t enterEqual = 0, exitEqual = 0, exitOffByMore = 0, exitLater = 0;
      for (size_t i = 0; i < a.enter.size(); ++i) {
        enterEqual += a.enter[i] == b.enter[i];
        exitEqual += a.exit[i] == b.exit[i];
        exitOffByMore += a.enter[i] == b.enter[i] && std::abs(int64_t(a.exit[i]) - int64_t(b.exit[i])) > 1;
        exitLater += a.enter[i] == b.enter[i] && b.exit[i] > a.exit[i] + 1;
      }
      const double texels = double(a.enter.size());
      std::printf("[ backends ] %s %s: CPU = OSMesa on %.4f%% of enters, %.4f%% of exits (%zu exits off by > 1); "
                  "%zu CPU exits later; peel iterations %u / %u, capped %llu / %llu\n",
                  sceneName(scene), light == LightId::Spot ? "spot" : "sun", 100.0 * double(enterEqual) / texels,
                  100.0 * double(exitEqual) / texels, exitOffByMore, exitLater, glStats.peelIterations, cpuStats.peelIterations,
                  (unsigned long long)glStats.texelsAtPeelCap, (unsigned long long)cpuStats.texelsAtPeelCap);
      EXPECT_GE(double(enterEqual) / texels, 0.9999) << sceneName(scene);
      // Boxes stand on their slab: where a box's bottom and the slab's top meet, each renderer's rounding decides
      // whether the ray leaves at the touching faces (a tie is an exit) or goes on through the slab; both are
      // right (ExitDepth checks every CPU exit of this scene against Embree), they just differ on ~3 % of texels.
      // Elsewhere the exits agree.
      EXPECT_GE(double(exitEqual) / texels, scene == SceneId::Boxes ? 0.97 : 0.9999) << sceneName(scene);
      if (scene != SceneId::Boxes) {
        EXPECT_EQ(exitLater, 0u) << sceneName(scene);
      }
    }
}

// The CPU rasteriser's peel replayed per texel from the crossings one pass keeps gives the maps, iteration
// counts and capped texels of the peel run pass by pass, on every test scene (nested and overlapping solids,
// touching boxes, open over closed, coincident layers), both light kinds, each cap the replay handles, with and without the early
// stop (including one that stops after the first iteration), for the whole view and for a region of it.
TEST(CpuPeel, ReplayGivesTheMapsOfPeelPasses) {
  const std::unique_ptr<DepthRenderer> replay = createCpuDepthRenderer(CpuPeel::Replay);
  const std::unique_ptr<DepthRenderer> passes = createCpuDepthRenderer(CpuPeel::Passes);
  size_t cases = 0, cappedCases = 0, earlyStops = 0;
  for (SceneId scene : {SceneId::Boxes, SceneId::Quads, SceneId::TorusKnot, SceneId::Terrain, SceneId::Nested,
                        SceneId::Overlapping, SceneId::OpenBoxOverBox, SceneId::QuadOverBox, SceneId::Coplanar})
    for (LightId light : {LightId::Directional, LightId::Spot}) {
      const ViewSetup& s = setup(scene, light, 256);
      for (uint32_t cap : {1u, 2u, 3u})
        for (uint32_t stop : {0u, 64u, 20000u, 1000000u})
          for (const RegionRect rect : {RegionRect{0, 0, 256, 256}, RegionRect{64, 128, 128, 64}}) {
            const PeelSettings peel{cap, stop};
            RenderStats a, b;
            const DepthRegion fromReplay = replay->render(s.geometry, s.view, rect, peel, &a);
            const DepthRegion fromPasses = passes->render(s.geometry, s.view, rect, peel, &b);
            const std::string what = std::string(sceneName(scene)) + (light == LightId::Spot ? " spot" : " sun") +
                                     " cap " + std::to_string(cap) + " stop " + std::to_string(stop) + " region " +
                                     std::to_string(rect.width);
            ASSERT_EQ(fromReplay.enter, fromPasses.enter) << what;
            ASSERT_EQ(fromReplay.exit, fromPasses.exit) << what;
            EXPECT_EQ(a.peelIterations, b.peelIterations) << what;
            EXPECT_EQ(a.texelsAtPeelCap, b.texelsAtPeelCap) << what;
            ++cases;
            cappedCases += b.texelsAtPeelCap > 0;
            earlyStops += b.peelIterations < cap && b.texelsAtPeelCap > 0;
          }
    }
  // The cases must exercise the cap and the early stop, or the comparison proves little.
  std::printf("[ replay   ] %zu cases equal; %zu with texels at the cap, %zu stopped early\n", cases, cappedCases,
              earlyStops);
  EXPECT_GT(cappedCases, 20u);
  EXPECT_GT(earlyStops, 5u);
}

TEST(Backends, NamesAndDescriptions) {
  EXPECT_EQ(parseRasterBackend("osmesa"), RasterBackend::OSMesa);
  EXPECT_EQ(parseRasterBackend("egl"), RasterBackend::EGL);
  EXPECT_EQ(parseRasterBackend("cpu"), RasterBackend::Cpu);
  try {
    parseRasterBackend("vulkan");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidArgument);
  }
  EXPECT_STREQ(rasterBackendName(RasterBackend::EGL), "egl");
  REQUIRE_RENDERER(r, RasterBackend::OSMesa);
  EXPECT_NE(r->description().find("OSMesa"), std::string::npos);
  EXPECT_NE(r->description().find("GL "), std::string::npos);
}

// -------------------------------------------------------------------------------------------- EXR

TEST(ExrImage, RoundTripsSingleAndMultiChannelFloat) {
  const std::string dir = test::tempDir();
  for (size_t channels : {size_t(1), size_t(2), size_t(4)}) {
    ExrImage image;
    image.width = 37;
    image.height = 11;
    const char* names[] = {"enter", "exit", "Z", "A"};
    for (size_t c = 0; c < channels; ++c) image.channels.push_back(names[c]);
    for (size_t i = 0; i < size_t(image.width) * image.height * channels; ++i)
      image.pixels.push_back(float(i) * 0.37f - 100.0f + (i % 7 == 0 ? 1e9f : 0.0f));
    const std::string path = dir + "/img" + std::to_string(channels) + ".exr";
    writeExr(path, image);
    const ExrImage back = readExr(path, image.channels);
    EXPECT_EQ(back.width, image.width);
    EXPECT_EQ(back.height, image.height);
    EXPECT_EQ(back.channels, image.channels);
    EXPECT_EQ(back.pixels, image.pixels);
    const ExrImage all = readExr(path);
    EXPECT_EQ(all.channels.size(), channels);  // in the file's (sorted) order
    for (size_t c = 0; c < channels; ++c) {
      const int k = all.channelIndex(image.channels[c]);
      ASSERT_GE(k, 0);
      EXPECT_EQ(all.at(5, 3, size_t(k)), image.at(5, 3, c));
    }
  }
  // Nothing but the final files is left behind.
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 3u);
}

TEST(ExrImage, ErrorsNameTheFile) {
  const std::string dir = test::tempDir();
  try {
    readExr(dir + "/missing.exr");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidInput);
    EXPECT_NE(std::string(e.what()).find("missing.exr"), std::string::npos);
  }
  {
    FILE* f = std::fopen((dir + "/bad.exr").c_str(), "wb");
    std::fputs("this is not an EXR file", f);
    std::fclose(f);
  }
  EXPECT_THROW(readExr(dir + "/bad.exr"), Error);
  ExrImage image;
  image.width = image.height = 2;
  image.channels = {"Y"};
  image.pixels = {1, 2, 3, 4};
  try {
    writeExr(dir + "/no/such/dir/out.exr", image);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::OutputFailed);
    EXPECT_NE(std::string(e.what()).find("out.exr"), std::string::npos);
  }
  writeExr(dir + "/ok.exr", image);
  try {
    readExr(dir + "/ok.exr", {"Y", "Q"});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidInput);
    EXPECT_NE(std::string(e.what()).find("'Q'"), std::string::npos);
  }
  image.pixels.pop_back();
  EXPECT_THROW(writeExr(dir + "/short.exr", image), Error);
}

}  // namespace
}  // namespace cpvs
