#include "libcpvs/bake/cone_crop.h"

#include <algorithm>
#include <cmath>

namespace cpvs {

ConeCrop coneCropOf(const Light& light, const LightView& view) {
  ConeCrop crop;
  if (light.type != LightType::Spot || view.projection != Projection::Perspective || view.resolution == 0) return crop;
  // The runtime's cone (cell_lanes.h insideSpot) is the outer angle up to pi/2 (views stop at 85 degrees, so a
  // wider cone covers the whole view and nothing is cropped).
  const double kHalfPi = 1.57079632679489661923;
  if (!(light.outerConeAngle < kHalfPi)) return crop;
  const double texel = std::max(view.xMax - view.xMin, view.yMax - view.yMin) / view.resolution;
  crop.radius = std::tan(light.outerConeAngle) + kConeMarginTexels * texel;
  // Only worth it when some corner of the view lies outside.
  const double corner = std::hypot(std::max(std::abs(view.xMin), std::abs(view.xMax)),
                                   std::max(std::abs(view.yMin), std::abs(view.yMax)));
  crop.active = corner > crop.radius;
  return crop;
}

bool ConeCrop::regionOutside(const LightView& view, const RegionRect& rect) const {
  if (!active) return false;
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  // The region's texel centres span [a0, a1] x [b0, b1]; its point nearest the axis (a = b = 0).
  const double a0 = view.xMin + (rect.x0 + 0.5) * ex / n, a1 = view.xMin + (rect.x0 + rect.width - 0.5) * ex / n;
  const double b0 = view.yMin + (rect.y0 + 0.5) * ey / n, b1 = view.yMin + (rect.y0 + rect.height - 0.5) * ey / n;
  const double a = std::clamp(0.0, a0, a1), b = std::clamp(0.0, b0, b1);
  return a * a + b * b > radius * radius;
}

DepthRegion ConeCrop::freeRegion(const LightView& view, const RegionRect& rect) {
  DepthRegion region;
  region.rect = rect;
  region.resolution = view.resolution;
  region.enter.assign(size_t(rect.width) * rect.height, 0);
  region.exit.assign(region.enter.size(), view.resolution);
  return region;
}

uint64_t ConeCrop::freeOutside(const LightView& view, DepthRegion& region) const {
  if (!active) return 0;
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  const RegionRect& rect = region.rect;
  uint64_t freed = 0;
  for (uint32_t y = 0; y < rect.height; ++y) {
    const double b = view.yMin + (rect.y0 + y + 0.5) * ey / n;
    for (uint32_t x = 0; x < rect.width; ++x) {
      const double a = view.xMin + (rect.x0 + x + 0.5) * ex / n;
      if (a * a + b * b <= radius * radius) continue;
      const size_t i = size_t(y) * rect.width + x;
      region.enter[i] = 0;
      region.exit[i] = region.resolution;
      ++freed;
    }
  }
  return freed;
}

}  // namespace cpvs
