// Position (w = 1 where covered; the clear value 0 marks the background), the normal of the side the camera
// sees (an open surface seen from behind shows its back), base colour: the material's factor times its
// base-colour texture where it has one (an sRGB texture array: sampling returns linear values).
in vec3 vPosition;
flat in vec3 vNormal;
flat in vec4 vColor;
in vec2 vTexcoord;
flat in float vLayer;
layout(binding = 4) uniform sampler2DArray baseColorTextures;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;
void main() {
  outPosition = vec4(vPosition, 1.0);
  outNormal = vec4(gl_FrontFacing ? vNormal : -vNormal, 0.0);
  outColor = vLayer >= 0.0 ? vColor * texture(baseColorTextures, vec3(vTexcoord, vLayer)) : vColor;
}
