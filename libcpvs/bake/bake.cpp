#include "libcpvs/bake/bake.h"

#include <algorithm>

#include <nlohmann/json.hpp>
#include <xxhash.h>

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

std::string settingsJson(const BakeSettings& settings, uint64_t inputHash) {
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(inputHash));
  // Only what determines the bytes of the result: no timestamps, no thread count, no paths.
  nlohmann::json j = {{"tool", "cpvs-bake"},
                      {"tool_version", kVersion},
                      {"resolution", settings.resolution},
                      {"undefined", undefinedModeName(settings.undefinedMode)},
                      {"node_reuse", settings.nodeReuse},
                      {"max_peels", settings.peel.maxPeels},
                      {"region", std::min(settings.regionSize, settings.resolution)},
                      {"ground", groundSheetsName(settings.ground)},
                      {"input_hash", hash}};
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
  const uint64_t hash = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return hash;
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

CpvsContent bakeScene(const Scene& scene, const BakeSettings& requested, BakeReport* report,
                      const BakeCallbacks& callbacks) {
  BakeSettings settings = requested;
  settings.regionSize = regionSizeWithinBudget(requested);
  const WorldGeometry world = flatten(scene, settings.ground);
  const uint64_t inputHash = bakeInputHash(world, scene.lights, settings);
  CpvsContent content;
  content.settingsJson = settingsJson(settings, inputHash);

  std::unique_ptr<DepthRenderer> renderer;  // opened on first use: scenes without geometry need none
  BakeReport localReport;
  BakeReport& rep = report ? *report : localReport;
  rep.inputHash = inputHash;
  rep.groundSheets = world.groundSheets;
  rep.sceneTriangles = world.sceneTriangleCount();

  // Progress counts views, weighted equally.
  std::vector<std::vector<LightView>> allViews;
  size_t totalViews = 0, doneViews = 0;
  for (const Light& light : scene.lights) {
    allViews.push_back(makeLightViews(light, world, settings.resolution));
    totalViews += allViews.back().size();
  }

  for (size_t li = 0; li < scene.lights.size(); ++li) {
    BakedLight baked;
    baked.light = scene.lights[li];
    LightReport lightReport;
    lightReport.name = baked.light.name;
    lightReport.type = baked.light.type;
    for (size_t vi = 0; vi < allViews[li].size(); ++vi) {
      const LightView& view = allViews[li][vi];
      ViewReport vr;
      vr.resolution = view.resolution;
      vr.face = view.face;
      vr.empty = view.empty;
      vr.shadowMapBytes = uint64_t(view.resolution) * view.resolution * 2;
      BakedView bakedView{view, {}};
      const ViewGeometry geometry = gatherViewGeometry(world, view);
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
        vr.regions = uint32_t(regions.size());
        // Rendering stays on this thread (it owns the GL context); masks and DAG of the previous region run
        // beside it. The DAG still takes regions in order, so the bytes do not depend on the overlap.
        BackgroundWork pending;
        for (size_t ri = 0; ri < regions.size(); ++ri) {
          RenderStats stats;
          auto depth = std::make_shared<DepthRegion>(renderer->render(geometry, view, regions[ri], settings.peel, &stats));
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
      vr.nodesPerLevel = bakedView.dag.nodesPerLevel;
      vr.uniqueLeaves = bakedView.dag.leaves.size();
      vr.bytes = bakedView.dag.bytes();
      baked.views.push_back(std::move(bakedView));
      lightReport.views.push_back(vr);
      ++doneViews;
      if (callbacks.progress) callbacks.progress(double(doneViews) / double(totalViews));
    }
    content.lights.push_back(std::move(baked));
    rep.lights.push_back(std::move(lightReport));
  }
  return content;
}

}  // namespace cpvs
