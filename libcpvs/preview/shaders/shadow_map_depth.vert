// A per-frame shadow map of one light view (cpvs-view --shadows shadowmap / lightcluster): the view's own
// lateral mapping (light_view.h) onto the map's M x M texels; depth is written by the fragment shader.
layout(location = 0) in vec3 worldPosition;
layout(location = 4) in vec4 maskUvIndex;  // the G-buffer's vertices: mask coordinates, index, casts (gbuffer.vert)
uniform mat4 viewFromWorld;
uniform vec4 lateral;      // xMin, yMin, xMax - xMin, yMax - yMin (perspective: of x / d and y / d)
uniform int orthographic;
out float vDepth;          // view-space depth d, interpolated perspective-correctly
out vec2 vMaskUv;
flat out int vMask;
flat out int vCasts;
void main() {
  vec4 v = viewFromWorld * vec4(worldPosition, 1.0);
  float d = -v.z;
  vDepth = d;
  vMaskUv = maskUvIndex.xy;
  vMask = int(maskUvIndex.z);
  vCasts = int(maskUvIndex.w);
  // Clip x = 2 (x - xMin w) / width - w with w = 1 (orthographic) or d (perspective): NDC x = 2 (a - xMin) /
  // width - 1. z = 0 keeps every depth (no near or far clipping, as the CPU map clamps instead); w > 0 clips
  // what lies behind a perspective eye.
  float w = orthographic != 0 ? 1.0 : d;
  gl_Position = vec4(2.0 * (v.x - lateral.x * w) / lateral.z - w, 2.0 * (v.y - lateral.y * w) / lateral.w - w, 0.0, w);
}
