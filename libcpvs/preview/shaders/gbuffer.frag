// Position (w = 1 where covered; the clear value 0 marks the background), the normal of the side the camera
// sees (an open surface seen from behind shows its back), base colour: the material's factor times its
// base-colour texture where it has one (an sRGB texture array: sampling returns linear values). Alpha-tested
// surfaces are cut where their coverage mask lets light through (libcpvs/scene/coverage_mask.h, the bake's
// rule), so receivers are cut as the casters are.
in vec3 vPosition;
flat in vec3 vNormal;
flat in vec4 vColor;
in vec2 vTexcoord;
flat in float vLayer;
in vec2 vMaskUv;
flat in int vMask;
layout(std430, binding = 14) readonly buffer MaskHeaders { ivec4 maskHeaders[]; };  // first byte, w, h, wraps
layout(std430, binding = 15) readonly buffer MaskBytes { uint maskWords[]; };      // 4 mask bytes a word
layout(binding = 4) uniform sampler2DArray baseColorTextures;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;
int wrapTexel(float coordinate, int size, int wrap) {
  int i = int(floor(clamp(coordinate * float(size), -1073741824.0, 1073741824.0)));
  if (wrap == 33071) return clamp(i, 0, size - 1);
  if (wrap == 33648) {
    int m = ((i % (2 * size)) + 2 * size) % (2 * size);
    return m < size ? m : 2 * size - 1 - m;
  }
  return ((i % size) + size) % size;
}
bool blocksLight() {
  if (isnan(vMaskUv.x) || isnan(vMaskUv.y) || isinf(vMaskUv.x) || isinf(vMaskUv.y)) return true;
  ivec4 h = maskHeaders[vMask];
  int at = h.x + wrapTexel(vMaskUv.y, h.z, h.w >> 16) * h.y + wrapTexel(vMaskUv.x, h.y, h.w & 0xFFFF);
  return ((maskWords[at >> 2] >> (8 * (at & 3))) & 0xFFu) != 0u;
}
void main() {
  if (vMask >= 0 && !blocksLight()) discard;
  outPosition = vec4(vPosition, 1.0);
  outNormal = vec4(gl_FrontFacing ? vNormal : -vNormal, 0.0);
  outColor = vLayer >= 0.0 ? vColor * texture(baseColorTextures, vec3(vTexcoord, vLayer)) : vColor;
}
