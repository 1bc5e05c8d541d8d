// The clip position of a world point in a per-frame shadow map's view (cpvs-view's map modes): the view's own
// lateral mapping (light_view.h) onto the map's texels, and the view-space depth d. Shared by the per-light
// maps and ManyPSMs' atlas, so a view drawn at the same size gets the same bits from either.
// Clip x = 2 (x - xMin w) / width - w with w = 1 (orthographic) or d (perspective): NDC x = 2 (a - xMin) /
// width - 1. z = 0 keeps every depth (no near or far clipping, as the CPU map clamps instead); w > 0 clips what
// lies behind a perspective eye.
// lateral: xMin, yMin, xMax - xMin, yMax - yMin (perspective: of x / d and y / d).
vec4 shadowMapClip(vec3 world, mat4 viewFromWorld, vec4 lateral, bool orthographic, out float depth) {
  vec4 v = viewFromWorld * vec4(world, 1.0);
  depth = -v.z;
  float w = orthographic ? 1.0 : depth;
  return vec4(2.0 * (v.x - lateral.x * w) / lateral.z - w, 2.0 * (v.y - lateral.y * w) / lateral.w - w, 0.0, w);
}
