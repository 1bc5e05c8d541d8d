#pragma once
// Coverage masks (libcpvs/scene/coverage_mask.h) as every GPU pass that cuts alpha-tested triangles reads them
// (the GL depth renderer's enter pass, cpvs-view's G-buffer and shadow maps): one packed layout and one GLSL
// texel rule, so that they pick the texel CoverageMask::texel picks.
#include <cstdint>
#include <vector>

#include "libcpvs/raster/glsl_sources.h"
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

// wrapTexel(coordinate, size, wrap) in GLSL: shaders/mask_texel.glsl.
inline constexpr const char* kMaskTexelGlsl = glsl::mask_texel_glsl;

}  // namespace cpvs
