// A per-frame shadow map of one light view (cpvs-view --shadows shadowmap / lightcluster), drawn into its own
// layer; depth is written by the fragment shader (shadow_map_depth.frag) from the view's depth mapping.
layout(location = 0) in vec3 worldPosition;
layout(location = 4) in vec4 maskUvIndex;  // the G-buffer's vertices: mask coordinates, index, casts (gbuffer.vert)
uniform mat4 viewFromWorld;
uniform vec4 lateral;
uniform int orthographic;
uniform int linearDepth;
uniform float nearDepth;
uniform float sliceScale;
uniform float mapSize;
out float vDepth;          // view-space depth d, interpolated perspective-correctly
out vec2 vMaskUv;
flat out int vMask;
flat out int vCasts;
flat out int vLinearDepth;
flat out float vNearDepth, vSliceScale, vMapSize;
void main() {
  gl_Position = shadowMapClip(worldPosition, viewFromWorld, lateral, orthographic != 0, vDepth);
  vMaskUv = maskUvIndex.xy;
  vMask = int(maskUvIndex.z);
  vCasts = int(maskUvIndex.w);
  vLinearDepth = linearDepth;
  vNearDepth = nearDepth;
  vSliceScale = sliceScale;
  vMapSize = mapSize;
}
