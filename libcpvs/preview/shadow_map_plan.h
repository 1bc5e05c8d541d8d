#pragma once
// What a frame of cpvs-view's shadow-map modes draws (the culling demo, docs/culling-demo.md): which light
// views get a map this frame (only those of lights some tile lists), at what size, in which layer, with which
// triangles (caster_culling.h), and the light records the lookups read (lookup_records.glsl: each light's
// CPVS_LIGHT_SHADOW_LIGHT names the record whose views hold its maps: its own, or its LightCluster cluster's).
#include <cstdint>
#include <vector>

#include "libcpvs/preview/caster_culling.h"
#include "libcpvs/preview/frame.h"
#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/preview/light_clusters.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

struct MapView {
  uint32_t shadowLight = 0;  // record index: a file light, or lights.size() + cluster
  uint32_t view = 0;         // the view of that record
  LightView mapView;         // at the map's size
  bool drawAll = false;      // culling none: every triangle (no index list)
  std::vector<uint32_t> triangles;
};

struct ShadowMapPlan {
  std::vector<MapView> views;   // one layer each, in layer order
  GpuSceneRecords records;      // the file's lights, then the clusters', views at the map size, layers set
  std::vector<uint64_t> trianglesPerLight;  // per file light: triangles drawn into the maps its lookups read
};

// Everything the culling needs that does not change between frames.
struct ShadowMapScene {
  const std::vector<LightShadow>* lights = nullptr;
  const CasterTriangles* triangles = nullptr;
  const CasterGrid* grid = nullptr;  // voxel-grid culling
  const LightClusters* clusters = nullptr;                       // lightcluster mode
  const std::vector<std::vector<LightView>>* clusterViews = nullptr;  // per cluster, the cube's views (any size)
};

// Plans a frame from its G-buffer and light lists. `threads` bounds the culling's parallel loop.
ShadowMapPlan planShadowMaps(const ShadowMapScene& scene, const Frame& frame, const FrameSettings& settings,
                             bool clustered);

}  // namespace cpvs
