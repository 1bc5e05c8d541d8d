// Position (w = 1 where covered; the clear value 0 marks the background), the normal of the side the camera
// sees (an open surface seen from behind shows its back), base colour: the material's factor times its
// base-colour texture where it has one (an sRGB texture array: sampling returns linear values). Alpha-tested
// surfaces are cut where their coverage mask lets light through (libcpvs/scene/coverage_mask.h, the bake's
// rule, coverage_mask.glsl), so receivers are cut as the casters are.
in vec3 vPosition;
flat in vec3 vNormal;
flat in vec4 vColor;
in vec2 vTexcoord;
flat in float vLayer;
in vec2 vMaskUv;
flat in int vMask;
layout(binding = 4) uniform sampler2DArray baseColorTextures;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;
void main() {
  if (vMask >= 0 && !maskBlocks(vMask, vMaskUv)) discard;
  outPosition = vec4(vPosition, 1.0);
  outNormal = vec4(gl_FrontFacing ? vNormal : -vNormal, 0.0);
  outColor = vLayer >= 0.0 ? vColor * texture(baseColorTextures, vec3(vTexcoord, vLayer)) : vColor;
}
