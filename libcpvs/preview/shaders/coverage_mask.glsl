// The coverage-mask rule of libcpvs/scene/coverage_mask.h for cpvs-view's raster passes (the G-buffer and the
// per-frame shadow maps): the texel that contains (u, v), wrapped by the sampler's modes (wrapTexel, from
// libcpvs/raster/gpu_masks.h), of the scene's masks (headers: first byte, width, height,
// wrap S | wrap T << 16; bytes packed four to a word).
layout(std430, binding = 14) readonly buffer MaskHeaders { ivec4 maskHeaders[]; };
layout(std430, binding = 15) readonly buffer MaskBytes { uint maskWords[]; };
// Whether mask `mask` blocks light at `uv` (a coordinate that is not finite blocks).
bool maskBlocks(int mask, vec2 uv) {
  if (isnan(uv.x) || isnan(uv.y) || isinf(uv.x) || isinf(uv.y)) return true;
  ivec4 h = maskHeaders[mask];
  int at = h.x + wrapTexel(uv.y, h.z, (h.w >> 16) & 0xFFFF) * h.y + wrapTexel(uv.x, h.y, h.w & 0xFFFF);
  return ((maskWords[at >> 2] >> (8 * (at & 3))) & 0xFFu) != 0u;
}
