// The coverage-mask rule of libcpvs/scene/coverage_mask.h: the texel containing (u, v), wrapped, in the mask
// bytes of all the view's masks (headers: first byte, width, height, wrap S | wrap T << 16).
uniform int closedGeometry;
uniform usamplerBuffer maskBytes;
uniform isamplerBuffer maskHeaders;
flat in int vMask;
flat in vec3 vMaskU, vMaskV, vMaskW;
layout(location = 0) out uint kind;
bool blocksLight() {
  vec2 du = vec2(ivec2(gl_FragCoord.xy) + regionOrigin - vOrigin) + 0.5;
  float w = vMaskW.x + vMaskW.y * du.x + vMaskW.z * du.y;
  if (w == 0.0) return true;
  float u = (vMaskU.x + vMaskU.y * du.x + vMaskU.z * du.y) / w;
  float v = (vMaskV.x + vMaskV.y * du.x + vMaskV.z * du.y) / w;
  if (isnan(u) || isnan(v) || isinf(u) || isinf(v)) return true;
  ivec4 h = texelFetch(maskHeaders, vMask);
  int x = wrapTexel(u, h.y, h.w & 0xFFFF), y = wrapTexel(v, h.z, (h.w >> 16) & 0xFFFF);
  return texelFetch(maskBytes, h.x + y * h.y + x).r != 0u;
}
void main() {
  if (vMask >= 0 && !blocksLight()) discard;
  gl_FragDepth = storedDepth();
  kind = closedGeometry != 0 ? (gl_FrontFacing ? 1u : 2u) : 3u;
}
