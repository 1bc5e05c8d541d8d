// The coverage-mask rule of libcpvs/scene/coverage_mask.h for cpvs-view's raster passes (the G-buffer and the
// per-frame shadow maps): the texel that contains (u, v), wrapped by the sampler's modes, of the scene's masks
// (headers: first byte, width, height, wrap S | wrap T << 16; bytes packed four to a word).
layout(std430, binding = 14) readonly buffer MaskHeaders { ivec4 maskHeaders[]; };
layout(std430, binding = 15) readonly buffer MaskBytes { uint maskWords[]; };
const int kNoShadow = -2;  // a vertex's mask index for a mesh that casts no shadow (drawn, never into a map)
int wrapTexel(float coordinate, int size, int wrap) {
  int i = int(floor(clamp(coordinate * float(size), -1073741824.0, 1073741824.0)));
  if (wrap == 33071) return clamp(i, 0, size - 1);
  if (wrap == 33648) {
    int m = ((i % (2 * size)) + 2 * size) % (2 * size);
    return m < size ? m : 2 * size - 1 - m;
  }
  return ((i % size) + size) % size;
}
// Whether mask `mask` blocks light at `uv` (a coordinate that is not finite blocks).
bool maskBlocks(int mask, vec2 uv) {
  if (isnan(uv.x) || isnan(uv.y) || isinf(uv.x) || isinf(uv.y)) return true;
  ivec4 h = maskHeaders[mask];
  int at = h.x + wrapTexel(uv.y, h.z, h.w >> 16) * h.y + wrapTexel(uv.x, h.y, h.w & 0xFFFF);
  return ((maskWords[at >> 2] >> (8 * (at & 3))) & 0xFFu) != 0u;
}
