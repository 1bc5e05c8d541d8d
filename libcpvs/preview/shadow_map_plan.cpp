#include "libcpvs/preview/shadow_map_plan.h"

#include <algorithm>
#include <map>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/eval/shadow_map.h"

namespace cpvs {

namespace {

// Per file light: the receivers its lookups will be at (covered pixels of the tiles listing it) and the boxes
// of those tiles.
std::vector<LightReceivers> receiversOf(const Frame& f, size_t lightCount, double reach) {
  std::vector<LightReceivers> receivers(lightCount);
  for (LightReceivers& r : receivers) r.reachTexels = reach;
  for (uint32_t ty = 0; ty < f.lists.tilesY; ++ty)
    for (uint32_t tx = 0; tx < f.lists.tilesX; ++tx) {
      const size_t tile = size_t(ty) * f.lists.tilesX + tx;
      if (f.lists.offsets[tile] == f.lists.offsets[tile + 1]) continue;
      std::vector<glm::vec3> points;
      glm::vec3 lo(3e38f), hi(-3e38f);
      for (uint32_t y = ty * kTileSize; y < std::min(f.height, (ty + 1) * kTileSize); ++y)
        for (uint32_t x = tx * kTileSize; x < std::min(f.width, (tx + 1) * kTileSize); ++x) {
          const glm::vec4& p = f.positions[f.pixel(x, y)];
          if (p.w == 0.0f) continue;
          points.emplace_back(p);
          lo = glm::min(lo, glm::vec3(p));
          hi = glm::max(hi, glm::vec3(p));
        }
      for (uint32_t i = f.lists.offsets[tile]; i < f.lists.offsets[tile + 1]; ++i) {
        LightReceivers& r = receivers[f.lists.lights[i]];
        r.points.insert(r.points.end(), points.begin(), points.end());
        r.boxes.push_back(lo);
        r.boxes.push_back(hi);
      }
    }
  return receivers;
}

LightReceivers merged(const std::vector<LightReceivers>& parts, double reach) {
  LightReceivers r;
  r.reachTexels = reach;
  for (const LightReceivers& p : parts) {
    r.points.insert(r.points.end(), p.points.begin(), p.points.end());
    r.boxes.insert(r.boxes.end(), p.boxes.begin(), p.boxes.end());
  }
  return r;
}

}  // namespace

ShadowMapPlan planShadowMaps(const ShadowMapScene& scene, const Frame& frame, const FrameSettings& settings,
                             bool clustered) {
  const std::vector<LightShadow>& lights = *scene.lights;
  const uint32_t m = settings.shadowMaps.size;
  ShadowMapPlan plan;
  // Records: every file light with its views at the map size, then every cluster's cube.
  std::vector<std::vector<LightView>> recordViews;
  for (const LightShadow& l : lights) {
    std::vector<LightView> views;
    for (const LightView& v : l.views()) views.push_back(shadowMapView(v, m));
    recordViews.push_back(views);
    orThrow(appendLightRecords(plan.records, l.light(), views, nullptr));
  }
  if (clustered)
    for (size_t c = 0; c < scene.clusters->lights.size(); ++c) {
      std::vector<LightView> views;
      for (const LightView& v : (*scene.clusterViews)[c]) views.push_back(shadowMapView(v, m));
      recordViews.push_back(views);
      orThrow(appendLightRecords(plan.records, scene.clusters->lights[c], views, nullptr));
    }
  auto shadowRecordOf = [&](uint32_t light) {
    if (!clustered || scene.clusters->clusterOf[light] == LightClusters::kAlone) return light;
    return uint32_t(lights.size()) + scene.clusters->clusterOf[light];
  };
  for (uint32_t l = 0; l < lights.size(); ++l)
    plan.records.lightWords[size_t(l) * gpu_layout::kLightWords + gpu_layout::kLightShadowLight] = shadowRecordOf(l);

  // The records some tile's light needs maps of, and the receivers of each.
  const double reach = lookupReachTexels(settings.pcfKernel, settings.biasMargin);
  const std::vector<LightReceivers> receivers = receiversOf(frame, lights.size(), reach);
  std::map<uint32_t, std::vector<uint32_t>> usersOfRecord;  // record -> file lights whose lookups read it
  for (uint32_t l : frame.lists.lights) usersOfRecord[shadowRecordOf(l)].push_back(l);
  for (auto& [record, users] : usersOfRecord) {
    std::sort(users.begin(), users.end());
    users.erase(std::unique(users.begin(), users.end()), users.end());
    for (uint32_t v = 0; v < recordViews[record].size(); ++v) {
      MapView mv;
      mv.shadowLight = record;
      mv.view = v;
      mv.mapView = recordViews[record][v];
      plan.views.push_back(std::move(mv));
    }
  }
  // Culling, view by view in parallel.
  std::vector<LightReceivers> recordReceivers(recordViews.size());
  for (const auto& [record, users] : usersOfRecord) {
    std::vector<LightReceivers> parts;
    for (uint32_t l : users) parts.push_back(receivers[l]);
    recordReceivers[record] = merged(parts, reach);
  }
  std::vector<std::vector<uint32_t>> gridCasters(recordViews.size());
  const auto recordLight = [&](uint32_t record) -> const Light& {
    return record < lights.size() ? lights[record].light() : scene.clusters->lights[record - lights.size()];
  };
  if (settings.shadowMaps.casterCulling == CasterCulling::VoxelGrid) {
    std::vector<uint32_t> records;
    for (const auto& entry : usersOfRecord) records.push_back(entry.first);
    parallelFor(records.size(), [&](size_t i) {
      const uint32_t r = records[i];
      gridCasters[r] = scene.grid->casters(recordLight(r), recordViews[r], recordReceivers[r]);
    }, 1);
  }
  parallelFor(plan.views.size(), [&](size_t i) {
    MapView& mv = plan.views[i];
    switch (settings.shadowMaps.casterCulling) {
      case CasterCulling::None: mv.drawAll = true; break;
      case CasterCulling::Frustum: mv.triangles = frustumCull(*scene.triangles, mv.mapView, nullptr); break;
      case CasterCulling::VoxelGrid: mv.triangles = frustumCull(*scene.triangles, mv.mapView, &gridCasters[mv.shadowLight]); break;
      case CasterCulling::ReceiverMask:
        mv.triangles = receiverMaskCull(*scene.triangles, mv.mapView, recordReceivers[mv.shadowLight], settings.shadowMaps.maskVariant);
        break;
    }
  }, 1);
  for (uint32_t layer = 0; layer < plan.views.size(); ++layer) {
    const MapView& mv = plan.views[layer];
    const size_t firstView = plan.records.lightWords[size_t(mv.shadowLight) * gpu_layout::kLightWords + gpu_layout::kLightFirstView];
    plan.records.viewWords[(firstView + mv.view) * gpu_layout::kViewWords + gpu_layout::kViewLayer] = layer;
  }
  // Triangles per file light: those drawn into every map its lookups read.
  plan.trianglesPerLight.assign(lights.size(), 0);
  for (const auto& [record, users] : usersOfRecord)
    for (const MapView& mv : plan.views)
      if (mv.shadowLight == record)
        for (uint32_t l : users) plan.trianglesPerLight[l] += mv.drawAll ? scene.triangles->count() : mv.triangles.size();
  return plan;
}

}  // namespace cpvs
