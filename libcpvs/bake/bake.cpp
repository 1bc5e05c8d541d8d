#include "libcpvs/bake/bake.h"

#include <algorithm>
#include <optional>

#include <nlohmann/json.hpp>
#include <xxhash.h>

#include "libcpvs/bake/bake_cache.h"
#include "libcpvs/bake/cone_crop.h"
#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/peak_memory.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/version.h"
#include "libcpvs/views/view_geometry.h"
#include "libcpvs/views/view_fitting.h"

namespace cpvs {
namespace {

ShadowDag allLitDag(uint32_t resolution) {
  ShadowDag dag;
  dag.resolution = resolution;
  dag.rootCode = ChildCode::Lit;
  const uint32_t levels = DagView{resolution, ChildCode::Lit, {}, {}}.levels();
  dag.nodesPerLevel.assign(levels, 0);
  dag.levelOffsets.assign(levels, 0);
  return dag;
}

std::string settingsJson(const BakeSettings& settings, uint64_t inputHash, const std::vector<uint32_t>& part,
                         size_t sceneLights) {
  // Only what determines the bytes of the result: no timestamps, no thread count, no paths.
  nlohmann::json j = {{"tool", "cpvs-bake"},
                      {"tool_version", kVersion},
                      {"resolution", settings.resolution},
                      {"undefined", undefinedModeName(settings.undefinedMode)},
                      {"node_reuse", settings.nodeReuse},
                      {"max_peels", settings.peel.maxPeels},
                      {"region", std::min(settings.regionSize, settings.resolution)},
                      {"ground", groundSheetsName(settings.ground)},
                      {"input_hash", hex64(inputHash)}};
  if (settings.voxelSize > 0) j["voxel_size"] = settings.voxelSize;
  j["crop_to_cone"] = settings.cropToCone;
  // The rasterisers agree on all but a few texels, not on every byte.
  j["backend"] = rasterBackendName(settings.backend);
  // A run that bakes only some lights says which: cpvs-merge checks and drops this key.
  if (part.size() != sceneLights) j["part"] = {{"lights", formatLightList(part)}, {"of", sceneLights}};
  return j.dump();
}

}  // namespace

uint64_t bakeInputHash(const WorldGeometry& world, const std::vector<Light>& lights, const BakeSettings& settings) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  XXH3_64bits_update(state, world.positions.data(), world.positions.size() * sizeof(glm::dvec3));
  XXH3_64bits_update(state, world.indices.data(), world.indices.size() * sizeof(uint32_t));
  const uint64_t closed = world.closedTriangleCount;
  XXH3_64bits_update(state, &closed, sizeof closed);
  if (world.masked.count()) {  // what the alpha test reads: which triangles, their coordinates, the masks' bits
    const uint64_t begin = world.masked.begin;
    XXH3_64bits_update(state, &begin, sizeof begin);
    XXH3_64bits_update(state, world.masked.maskOf.data(), world.masked.maskOf.size() * sizeof(uint32_t));
    XXH3_64bits_update(state, world.masked.uvs.data(), world.masked.uvs.size() * sizeof(glm::vec2));
    for (const CoverageMask& mask : world.masked.masks) {
      const uint64_t h = mask.hash();
      XXH3_64bits_update(state, &h, sizeof h);
    }
  }
  for (const Light& l : lights) {
    XXH3_64bits_update(state, l.name.data(), l.name.size());
    const double values[] = {double(l.type), l.color.r, l.color.g, l.color.b, l.intensity, l.range,
                             l.innerConeAngle, l.outerConeAngle, l.position.x, l.position.y, l.position.z,
                             l.direction.x, l.direction.y, l.direction.z};
    XXH3_64bits_update(state, values, sizeof values);
  }
  // The region size orders the nodes within each level, so it is part of what the bytes depend on.
  const uint64_t s[] = {settings.resolution, uint64_t(settings.undefinedMode), settings.nodeReuse,
                        settings.peel.maxPeels, std::min(settings.regionSize, settings.resolution),
                        uint64_t(settings.ground)};
  XXH3_64bits_update(state, s, sizeof s);
  if (settings.voxelSize > 0) XXH3_64bits_update(state, &settings.voxelSize, sizeof settings.voxelSize);
  const uint64_t more[] = {uint64_t(settings.cropToCone), uint64_t(settings.backend)};
  XXH3_64bits_update(state, more, sizeof more);
  const uint64_t hash = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return hash;
}

uint64_t sceneInputHash(const Scene& scene, const BakeSettings& requested) {
  BakeSettings settings = requested;
  settings.regionSize = regionSizeWithinBudget(requested);
  return bakeInputHash(flatten(scene, settings.ground), scene.lights, settings);
}

uint64_t regionMemoryBytes(uint32_t regionSize) {
  // llvmpipe's colour, depth and stencil targets and read-back (about 40 bytes a texel, docs/depth-maps.md),
  // the enter/exit maps (8) and tile chains (up to about 16).
  constexpr uint64_t kBytesPerTexel = 64;
  return uint64_t(regionSize) * regionSize * kBytesPerTexel;
}

uint32_t regionSizeWithinBudget(const BakeSettings& settings) {
  uint32_t size = settings.regionSize;
  if (settings.maxMemoryBytes == 0) return size;
  while (size > 64 && regionMemoryBytes(size) > settings.maxMemoryBytes / 4) size /= 2;
  return size;
}

namespace {

// Per view of a light: its triangles (view space) and the estimated cost of baking it: the texels of the
// regions its triangles overlap plus a weight per triangle and region drawn.
struct LightGeometry {
  std::vector<ViewGeometry> views;
  double cost = 0;
  bool reachesGeometry = false;
};

LightGeometry gatherLightGeometry(const WorldGeometry& world, const std::vector<LightView>& views, uint32_t regionSize) {
  constexpr double kTexelsPerTriangleDraw = 64;
  LightGeometry out;
  for (const LightView& view : views) {
    out.views.push_back(view.empty ? ViewGeometry{} : gatherViewGeometry(world, view));
    const ViewGeometry& g = out.views.back();
    if (g.triangleCount() == 0) continue;
    out.reachesGeometry = true;
    const uint32_t size = std::min(regionSize, view.resolution);
    const uint32_t perSide = (view.resolution + size - 1) / size;
    std::vector<uint8_t> occupied(size_t(perSide) * perSide, 0);
    uint64_t draws = 0;
    for (const glm::vec4& b : g.gridBounds) {
      const auto cell = [&](float t) { return uint32_t(std::clamp(std::floor(t / float(size)), 0.0f, float(perSide - 1))); };
      for (uint32_t y = cell(b.z); y <= cell(b.w); ++y)
        for (uint32_t x = cell(b.x); x <= cell(b.y); ++x) {
          occupied[size_t(y) * perSide + x] = 1;
          ++draws;
        }
    }
    const double regions = double(std::count(occupied.begin(), occupied.end(), uint8_t(1)));
    out.cost += regions * double(size) * double(size) + kTexelsPerTriangleDraw * double(draws);
  }
  return out;
}

std::vector<std::vector<LightView>> viewsOfLights(const Scene& scene, const WorldGeometry& world,
                                                  const BakeSettings& settings) {
  std::vector<std::vector<LightView>> views;
  for (const Light& light : scene.lights) {
    views.push_back(makeLightViews(light, world, settings.resolution));
    if (settings.voxelSize <= 0) continue;
    uint32_t n = resolutionForVoxelSize(views.back(), settings.voxelSize, settings.resolution);
    // The estimate scales the fit at the largest N; the fit's padding grows at small N, so check and double.
    while (n < settings.resolution) {
      std::vector<LightView> fitted = makeLightViews(light, world, n);
      double largest = 0;
      for (const LightView& v : fitted)
        if (!v.empty) largest = std::max(largest, largestVoxelSize(v));
      if (largest <= settings.voxelSize) {
        views.back() = std::move(fitted);
        break;
      }
      n *= 2;
    }
  }
  return views;
}

// settings.lights (or every light), then its shard, balanced by each light's estimated cost: every light index
// ends in exactly one shard.
std::vector<uint32_t> selectLights(const Scene& scene, const BakeSettings& settings, const WorldGeometry& world,
                                   const std::vector<std::vector<LightView>>& views) {
  std::vector<uint32_t> chosen = settings.lights;
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  if (chosen.empty())
    for (uint32_t i = 0; i < scene.lights.size(); ++i) chosen.push_back(i);
  for (const uint32_t i : chosen)
    if (i >= scene.lights.size())
      throw Error(ErrorCategory::InvalidArgument, "light index " + std::to_string(i) + " is out of range: the scene has " +
                                                      std::to_string(scene.lights.size()) + " light(s)");
  if (settings.shard.count <= 1) return chosen;
  std::vector<double> cost(scene.lights.size(), 0.0);
  for (const uint32_t i : chosen) cost[i] = gatherLightGeometry(world, views[i], settings.regionSize).cost;
  return shardLights(chosen, cost, settings.shard);
}

// Lights whose range is tiny against the scene usually mean a unit mismatch (a level in centimetres, lights in
// metres): every shadow would be baked into a speck.
void warnAboutRanges(const Scene& scene, const WorldGeometry& world, std::vector<std::string>& warnings) {
  if (world.bounds.empty()) return;
  const double diagonal = glm::length(world.bounds.extent());
  // The largest range of the spot and point lights (infinite when one is unlimited; -1 when there are none).
  double largest = -1;
  for (const Light& l : scene.lights)
    if (l.type != LightType::Directional) largest = std::max(largest, l.range);
  constexpr double kTinyFraction = 0.01;
  if (largest >= 0 && largest < kTinyFraction * diagonal) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "every spot and point light's range is under 1 %% of the scene's size (largest range %.4g, scene "
                  "diagonal %.4g): are the lights and the geometry in the same units (a level authored in "
                  "centimetres with ranges in metres)?",
                  largest, diagonal);
    warnings.emplace_back(text);
  }
}

void describeDag(const ShadowDag& dag, ViewReport& vr) {
  vr.nodesPerLevel = dag.nodesPerLevel;
  vr.uniqueLeaves = dag.leaves.size();
  vr.bytes = dag.bytes();
}

CpvsContent bakeSceneHere(const Scene& scene, const BakeSettings& requested, BakeReport* report,
                          const BakeCallbacks& callbacks) {
  BakeSettings settings = requested;
  settings.regionSize = regionSizeWithinBudget(requested);
  const WorldGeometry world = flatten(scene, settings.ground);
  const uint64_t inputHash = bakeInputHash(world, scene.lights, settings);
  const std::vector<std::vector<LightView>> allViews = viewsOfLights(scene, world, settings);
  const std::vector<uint32_t> chosen = selectLights(scene, settings, world, allViews);
  CpvsContent content;
  content.settingsJson = settingsJson(settings, inputHash, chosen, scene.lights.size());

  std::unique_ptr<DepthRenderer> renderer;  // opened on first use: scenes without geometry need none
  BakeReport localReport;
  BakeReport& rep = report ? *report : localReport;
  rep.inputHash = inputHash;
  rep.groundSheets = world.groundSheets;
  rep.sceneTriangles = world.sceneTriangleCount();
  rep.sceneLights = scene.lights.size();
  warnAboutRanges(scene, world, rep.warnings);
  std::optional<BakeCache> cache;
  if (!settings.cacheFolder.empty()) cache.emplace(settings.cacheFolder);

  // Progress counts views, weighted equally.
  size_t totalViews = 0, doneViews = 0;
  for (const uint32_t li : chosen) totalViews += allViews[li].size();

  for (size_t done = 0; done < chosen.size(); ++done) {
    const uint32_t li = chosen[done];
    const Stopwatch lightTime;
    BakedLight baked;
    baked.light = scene.lights[li];
    if (callbacks.lightStarted) callbacks.lightStarted(baked.light.name);
    LightReport lightReport;
    lightReport.name = baked.light.name;
    lightReport.index = li;
    lightReport.type = baked.light.type;
    const LightGeometry lightGeometry = gatherLightGeometry(world, allViews[li], settings.regionSize);
    lightReport.estimatedCost = lightGeometry.cost;
    lightReport.reachesGeometry = lightGeometry.reachesGeometry;
    if (!lightGeometry.reachesGeometry)
      rep.warnings.push_back("light '" + baked.light.name + "' (index " + std::to_string(li) +
                             ") reaches no geometry: every voxel of its views is lit (check its position, direction "
                             "and range)");
    uint64_t cacheKey = 0;
    if (cache) {
      cacheKey = lightBakeKey(settings, baked.light, allViews[li], lightGeometry.views);
      std::string problem;
      if (std::optional<BakedLight> hit = cache->find(cacheKey, baked.light, &problem)) {
        if (hit->views.size() == allViews[li].size()) {
          baked = std::move(*hit);
          lightReport.cache = LightReport::Cache::Hit;
        } else {
          problem = cache->pathOf(cacheKey) + ": holds " + std::to_string(hit->views.size()) + " view(s), expected " +
                    std::to_string(allViews[li].size());
        }
      }
      if (!problem.empty()) rep.warnings.push_back("bake cache entry ignored and baked again: " + problem);
      if (lightReport.cache != LightReport::Cache::Hit) lightReport.cache = LightReport::Cache::Miss;
    }
    const bool fromCache = lightReport.cache == LightReport::Cache::Hit;
    for (size_t vi = 0; vi < allViews[li].size(); ++vi) {
      const LightView& view = allViews[li][vi];
      ViewReport vr;
      vr.resolution = view.resolution;
      vr.face = view.face;
      vr.empty = view.empty;
      vr.shadowMapBytes = uint64_t(view.resolution) * view.resolution * 2;
      if (fromCache) {
        describeDag(baked.views[vi].dag, vr);
        lightReport.views.push_back(vr);
        ++doneViews;
        if (callbacks.progress) callbacks.progress(double(doneViews) / double(totalViews));
        continue;
      }
      BakedView bakedView{view, {}};
      const ViewGeometry& geometry = lightGeometry.views[vi];
      if (view.empty || geometry.triangleCount() == 0) {
        bakedView.dag = allLitDag(view.resolution);
      } else {
        if (!renderer) {
          renderer = DepthRenderer::create(settings.backend);
          rep.renderer = renderer->description();
        }
        const uint32_t regionSize =
            std::min({settings.regionSize, renderer->maxRegionSize(), view.resolution});
        const std::vector<RegionRect> regions = splitIntoRegions(view.resolution, regionSize);
        DagBuilder builder(view.resolution, regionSize, settings.nodeReuse);
        const ConeCrop crop = settings.cropToCone ? coneCropOf(baked.light, view) : ConeCrop{};
        vr.regions = uint32_t(regions.size());
        // Rendering stays on this thread (it owns the GL context); masks and DAG of the previous region run
        // beside it. The DAG still takes regions in order, so the bytes do not depend on the overlap.
        BackgroundWork pending;
        for (size_t ri = 0; ri < regions.size(); ++ri) {
          RenderStats stats;
          std::shared_ptr<DepthRegion> depth;
          if (crop.regionOutside(view, regions[ri])) {
            depth = std::make_shared<DepthRegion>(ConeCrop::freeRegion(view, regions[ri]));
            vr.texelsOutsideCone += depth->enter.size();
          } else {
            depth = std::make_shared<DepthRegion>(renderer->render(geometry, view, regions[ri], settings.peel, &stats));
            vr.texelsOutsideCone += crop.freeOutside(view, *depth);
          }
          vr.depthMs += stats.enterMs;
          vr.peelMs += stats.peelMs;
          vr.peelIterations = std::max(vr.peelIterations, stats.peelIterations);
          vr.texelsAtPeelCap += stats.texelsAtPeelCap;
          vr.trianglesSubmitted += stats.trianglesSubmitted;
          if (callbacks.depthRegion) callbacks.depthRegion(li, vi, view, *depth);
          if (settings.maxMemoryBytes && currentRssBytes() > settings.maxMemoryBytes)
            throw Error(ErrorCategory::RuntimeFailure,
                        "memory budget of " + std::to_string(settings.maxMemoryBytes >> 20) + " MiB exceeded (" +
                            std::to_string(currentRssBytes() >> 20) + " MiB resident) while baking light '" +
                            baked.light.name + "' view " + std::to_string(vi) + " at " +
                            std::to_string(view.resolution) + "^3: lower the resolution or raise the budget");
          pending.wait();
          auto work = [&, depth]() {
            Stopwatch masks;
            const TileChains chains = buildTileChains(*depth, settings.undefinedMode, std::max(1u, settings.threads));
            vr.masksMs += masks.ms();
            vr.tileMasks += chains.start.size();
            Stopwatch dag;
            builder.addRegion(chains);
            vr.dagMs += dag.ms();
          };
          if (settings.threads > 1)
            pending.start(work);
          else
            work();
          if (callbacks.progress)
            callbacks.progress((double(doneViews) + double(ri + 1) / double(regions.size())) / double(totalViews));
        }
        pending.wait();
        Stopwatch finish;
        bakedView.dag = builder.finish();
        vr.dagMs += finish.ms();
        vr.nodesBuilt = builder.stats().nodesBuilt;
        vr.nodesReused = builder.stats().nodesReused;
      }
      describeDag(bakedView.dag, vr);
      baked.views.push_back(std::move(bakedView));
      lightReport.views.push_back(vr);
      ++doneViews;
      if (callbacks.progress) callbacks.progress(double(doneViews) / double(totalViews));
    }
    if (cache && !fromCache) {
      try {
        cache->store(cacheKey, baked);
      } catch (const Error& e) {  // the bake itself is fine: only later runs lose the entry
        rep.warnings.push_back(std::string("bake cache entry not stored: ") + e.what());
      }
    }
    lightReport.ms = lightTime.ms();
    content.lights.push_back(std::move(baked));
    rep.lights.push_back(std::move(lightReport));
    if (callbacks.lightDone) callbacks.lightDone(rep.lights.back(), done + 1, chosen.size());
  }
  return content;
}

}  // namespace

CpvsContent bakeScene(const Scene& scene, const BakeSettings& settings, BakeReport* report,
                      const BakeCallbacks& callbacks) {
  // Every parallel loop of the bake (rasterising, tile masks, the DAG beside them) runs on `threads` threads.
  tbb::task_arena arena(int(std::clamp(settings.threads, 1u, 256u)));
  CpvsContent content;
  arena.execute([&] { content = bakeSceneHere(scene, settings, report, callbacks); });
  return content;
}

}  // namespace cpvs
