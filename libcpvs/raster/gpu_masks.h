#pragma once
// Coverage masks (libcpvs/scene/coverage_mask.h) as every GPU pass that cuts alpha-tested triangles reads them
// (the GL depth renderer's enter pass, cpvs-view's G-buffer and shadow maps): one packed layout and one GLSL
// texel rule, so that they pick the texel CoverageMask::texel picks.
#include <cstdint>
#include <vector>

#include "libcpvs/scene/coverage_mask.h"

namespace cpvs {

// All masks' bytes back to back, and per mask a header (first byte, width, height, wrap S | wrap T << 16).
struct PackedMasks {
  std::vector<int32_t> headers;  // 4 per mask
  std::vector<uint8_t> bytes;
};
inline PackedMasks packMasks(const std::vector<CoverageMask>& masks) {
  PackedMasks packed;
  for (const CoverageMask& m : masks) {
    packed.headers.insert(packed.headers.end(), {int32_t(packed.bytes.size()), int32_t(m.width), int32_t(m.height),
                                                 int32_t(uint32_t(m.wrapS) | (uint32_t(m.wrapT) << 16))});
    packed.bytes.insert(packed.bytes.end(), m.blocks.begin(), m.blocks.end());
  }
  return packed;
}

// wrapTexel(coordinate, size, wrap): floor of the coordinate times the size, clamped to +-2^30, then
// CLAMP_TO_EDGE (33071), MIRRORED_REPEAT (33648) or REPEAT. (A header's wraps: w & 0xFFFF and (w >> 16) & 0xFFFF;
// the mask keeps the sign bit that >> copies down out of the T wrap.)

inline constexpr const char* kMaskTexelGlsl = R"(
int wrapTexel(float coordinate, int size, int wrap) {
  int i = int(floor(clamp(coordinate * float(size), -1073741824.0, 1073741824.0)));
  if (wrap == 33071) return clamp(i, 0, size - 1);
  // The periods as unsigned, from i shifted by a multiple of the period that makes it non-negative (GLSL leaves
  // % of a negative operand undefined): i >= -2^30, so i + offset lies in [0, 2^32).
  uint period = uint(wrap == 33648 ? 2 * size : size);
  uint m = (uint(i) + period * (1073741824u / period + 1u)) % period;
  if (wrap == 33648) return int(m < uint(size) ? m : period - 1u - m);
  return int(m);
}
)";

}  // namespace cpvs
