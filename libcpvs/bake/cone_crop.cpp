#include "libcpvs/bake/cone_crop.h"

#include <algorithm>
#include <cmath>

namespace cpvs {

ConeCrop coneCropOf(const Light& light, const LightView& view) {
  ConeCrop crop;
  if (!hasCone(light) || view.projection != Projection::Perspective || view.resolution == 0) return crop;
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

RowSpans ConeCrop::inside(const LightView& view, const RegionRect& rect) const {
  RowSpans spans;
  spans.begin.assign(rect.height, 0);
  spans.end.assign(rect.height, rect.width);
  if (!active || rect.width == 0) return spans;
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  for (uint32_t y = 0; y < rect.height; ++y) {
    const double b = view.yMin + (rect.y0 + y + 0.5) * ey / n;
    // Texel x's centre is at lateral a(x), which grows with x: the texels within the radius are one run around
    // the texel nearest the axis, found from it by bisection on each side.
    const auto within = [&](int64_t x) {
      const double a = view.xMin + (rect.x0 + x + 0.5) * ex / n;
      return a * a + b * b <= radius * radius;
    };
    const int64_t last = int64_t(rect.width) - 1;
    const int64_t nearest = std::clamp<int64_t>(int64_t(std::llround(-view.xMin * n / ex - rect.x0 - 0.5)), 0, last);
    int64_t seed = -1;
    for (int64_t x : {nearest, nearest - 1, nearest + 1})
      if (x >= 0 && x <= last && within(x)) {
        seed = x;
        break;
      }
    if (seed < 0) {
      spans.begin[y] = spans.end[y] = 0;
      continue;
    }
    int64_t lo = 0, hi = seed;  // first texel within: in [lo, hi]
    while (lo < hi) {
      const int64_t mid = lo + (hi - lo) / 2;
      if (within(mid))
        hi = mid;
      else
        lo = mid + 1;
    }
    spans.begin[y] = uint32_t(lo);
    lo = seed;
    hi = last;  // last texel within: in [lo, hi]
    while (lo < hi) {
      const int64_t mid = lo + (hi - lo + 1) / 2;
      if (within(mid))
        lo = mid;
      else
        hi = mid - 1;
    }
    spans.end[y] = uint32_t(lo + 1);
  }
  return spans;
}

uint64_t ConeCrop::freeOutside(const RowSpans& inside, DepthRegion& region) {
  const RegionRect& rect = region.rect;
  uint64_t freed = 0;
  for (uint32_t y = 0; y < rect.height; ++y) {
    const size_t row = size_t(y) * rect.width;
    const auto freeRun = [&](uint32_t from, uint32_t to) {
      std::fill(region.enter.begin() + ptrdiff_t(row + from), region.enter.begin() + ptrdiff_t(row + to), 0u);
      std::fill(region.exit.begin() + ptrdiff_t(row + from), region.exit.begin() + ptrdiff_t(row + to), region.resolution);
      freed += to - from;
    };
    freeRun(0, inside.begin[y]);
    freeRun(std::max(inside.begin[y], inside.end[y]), rect.width);
  }
  return freed;
}

}  // namespace cpvs
