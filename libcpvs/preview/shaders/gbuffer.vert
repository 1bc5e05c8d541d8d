// G-buffer pass: world-space triangles (float) with their face normal and base colour per vertex.
layout(location = 0) in vec3 worldPosition;
layout(location = 1) in vec3 faceNormal;
layout(location = 2) in vec4 baseColor;
layout(location = 3) in vec3 texcoordLayer;  // TEXCOORD_0 and the base-colour texture's layer (-1: none)
layout(location = 4) in vec4 maskUvIndex;    // coverage-mask coordinates, the mask's index (-1: none), casts (1/0)
uniform mat4 clipFromWorld;
out vec3 vPosition;
flat out vec3 vNormal;
flat out vec4 vColor;
out vec2 vTexcoord;
flat out float vLayer;
out vec2 vMaskUv;
flat out int vMask;
void main() {
  gl_Position = clipFromWorld * vec4(worldPosition, 1.0);
  vPosition = worldPosition;
  vNormal = faceNormal;
  vColor = baseColor;
  vTexcoord = texcoordLayer.xy;
  vLayer = texcoordLayer.z;
  vMaskUv = maskUvIndex.xy;
  vMask = int(maskUvIndex.z);
}
