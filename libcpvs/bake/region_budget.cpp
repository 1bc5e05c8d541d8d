// What one region of a view costs in memory, and the region size a memory budget allows (bake.h).
#include <cstdint>

#include "libcpvs/bake/bake.h"

namespace cpvs {

uint64_t regionMemoryBytes(uint32_t regionSize) {
  // llvmpipe's colour, depth and stencil targets and read-back (about 40 bytes a texel, docs/depth-maps.md),
  // the enter/exit maps (8) and tile chains (up to about 16). A lossy bake's next-surface layer and its pass
  // (16 more, raster/next_surface.cpp) fit in the GL targets' share, which the CPU rasteriser does not use.
  constexpr uint64_t kBytesPerTexel = 64;
  return uint64_t(regionSize) * regionSize * kBytesPerTexel;
}

uint32_t regionSizeWithinBudget(const BakeSettings& settings) {
  uint32_t size = settings.regionSize;
  if (settings.maxMemoryBytes == 0 || settings.maxMemoryOnlyStops) return size;
  while (size > 64 && regionMemoryBytes(size) > settings.maxMemoryBytes / 4) size /= 2;
  return size;
}

}  // namespace cpvs
