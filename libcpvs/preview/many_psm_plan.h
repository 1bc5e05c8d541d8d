#pragma once
// What a ManyPSMs frame draws (cpvs-view --shadows manypsm, docs/culling-demo.md): every view of every light
// some tile lists, each at a resolution chosen by its light's distance to the camera, packed into an atlas of
// square layers, and the light records the lookups read (each view's layer and texel origin in the atlas).
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/preview/frame.h"
#include "libcpvs/runtime/gpu_records.h"

namespace cpvs {

struct AtlasView {
  uint32_t light = 0;     // file light
  uint32_t view = 0;      // of that light
  LightView mapView;      // at its resolution (mapView.resolution)
  uint32_t layer = 0, x = 0, y = 0;  // its resolution^2 texels in the atlas: [x, x + res) x [y, y + res) of layer
};

struct ManyPsmPlan {
  std::vector<AtlasView> views;  // largest first
  GpuSceneRecords records;       // the file's lights, views at their resolutions, atlas places set
  uint32_t layerSize = 0;        // the atlas layers' edge: the largest resolution allowed
  uint32_t layers = 0;
};

// The resolution of a light's maps: the largest (`settings.size`) when the camera is within the light's range
// (and always for a sun), else size x range / distance rounded up to a power of two, at least
// `settings.minSize` (the post's near views get more texels than far ones).
uint32_t manyPsmResolution(const Light& light, const glm::dvec3& eye, const ShadowMapSettings& settings);

// Plans a frame from its light lists and camera position.
ManyPsmPlan planManyPsms(const std::vector<LightShadow>& lights, const Frame& frame, const glm::dvec3& eye,
                         const ShadowMapSettings& settings);

}  // namespace cpvs
