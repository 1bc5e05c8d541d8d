#include "libcpvs/preview/many_psm_plan.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "libcpvs/base/error.h"
#include "libcpvs/eval/shadow_map.h"

namespace cpvs {

namespace {

// The bits of z at even positions: the x (or, shifted by one, y) of a Morton-ordered index.
uint32_t evenBits(uint64_t z) {
  uint32_t out = 0;
  for (uint32_t bit = 0; bit < 32; ++bit) out |= uint32_t((z >> (2 * bit)) & 1u) << bit;
  return out;
}

}  // namespace

uint32_t manyPsmResolution(const Light& light, const glm::dvec3& eye, const ShadowMapSettings& settings) {
  const uint32_t largest = settings.size, smallest = std::min(settings.minSize, settings.size);
  if (!std::isfinite(influenceRange(light))) return largest;
  const double distance = glm::length(eye - light.position);
  if (!(distance > light.range)) return largest;
  const double wanted = double(largest) * light.range / distance;
  const uint32_t size = std::bit_ceil(uint32_t(std::clamp(std::ceil(wanted), 1.0, double(largest))));
  return std::clamp(size, smallest, largest);
}

ManyPsmPlan planManyPsms(const std::vector<LightShadow>& lights, const Frame& frame, const glm::dvec3& eye,
                         const ShadowMapSettings& settings) {
  ManyPsmPlan plan;
  plan.layerSize = settings.size;
  std::vector<uint8_t> listed(lights.size(), 0);
  for (uint32_t l : frame.lists.lights) listed[l] = 1;
  std::vector<uint32_t> size(lights.size(), settings.size);
  for (uint32_t l = 0; l < lights.size(); ++l) {
    if (!listed[l]) continue;
    size[l] = manyPsmResolution(lights[l].light(), eye, settings);
    for (uint32_t v = 0; v < lights[l].views().size(); ++v)
      plan.views.push_back({l, v, shadowMapView(lights[l].views()[v], size[l]), 0, 0, 0});
  }
  // Largest first, so that each view starts on a multiple of its own area along a Morton curve through the
  // layer: every place is an aligned square and the layers fill without gaps.
  std::stable_sort(plan.views.begin(), plan.views.end(),
                   [](const AtlasView& a, const AtlasView& b) { return a.mapView.resolution > b.mapView.resolution; });
  const uint64_t layerTexels = uint64_t(plan.layerSize) * plan.layerSize;
  uint64_t used = 0;
  for (AtlasView& v : plan.views) {
    const uint64_t area = uint64_t(v.mapView.resolution) * v.mapView.resolution;
    if (used + area > layerTexels) {
      ++plan.layers;
      used = 0;
    }
    v.layer = plan.layers;
    v.x = evenBits(used);
    v.y = evenBits(used >> 1);
    used += area;
  }
  if (!plan.views.empty()) ++plan.layers;
  // Records: every file light with its views at its resolution; the atlas places of the drawn ones.
  for (uint32_t l = 0; l < lights.size(); ++l) {
    std::vector<LightView> views;
    for (const LightView& v : lights[l].views()) views.push_back(shadowMapView(v, size[l]));
    orThrow(appendLightRecords(plan.records, lights[l].light(), views, nullptr));
  }
  for (const AtlasView& v : plan.views) {
    const size_t first = plan.records.lightWords[size_t(v.light) * gpu_layout::kLightWords + gpu_layout::kLightFirstView];
    uint32_t* words = &plan.records.viewWords[(first + v.view) * gpu_layout::kViewWords];
    words[gpu_layout::kViewLayer] = v.layer;
    words[gpu_layout::kViewAtlasX] = v.x;
    words[gpu_layout::kViewAtlasY] = v.y;
  }
  return plan;
}

}  // namespace cpvs
