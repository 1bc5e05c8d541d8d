#include "libcpvs/views/view_regions.h"

#include <algorithm>

#include "libcpvs/base/error.h"

namespace cpvs {

std::vector<RegionRect> splitIntoRegions(uint32_t resolution, uint32_t regionSize) {
  if (resolution == 0) return {};
  if (regionSize == 0) throw Error(ErrorCategory::InvalidArgument, "splitIntoRegions: region size must be positive");
  std::vector<RegionRect> regions;
  for (uint64_t y0 = 0; y0 < resolution; y0 += regionSize) {
    for (uint64_t x0 = 0; x0 < resolution; x0 += regionSize) {
      RegionRect rect;
      rect.x0 = uint32_t(x0);
      rect.y0 = uint32_t(y0);
      rect.width = uint32_t(std::min<uint64_t>(regionSize, resolution - x0));
      rect.height = uint32_t(std::min<uint64_t>(regionSize, resolution - y0));
      regions.push_back(rect);
    }
  }
  return regions;
}

}  // namespace cpvs
