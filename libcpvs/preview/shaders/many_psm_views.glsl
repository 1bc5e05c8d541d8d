// ManyPSMs' views and scene tree as its passes read them (many_psm_shadows.cpp writes the same layouts).
struct PsmView {
  mat4 viewFromWorld;
  vec4 lateral;  // xMin, yMin, xMax - xMin, yMax - yMin (shadow_map_clip.glsl)
  vec4 depth;    // orthographic (0 / 1), linear (0 / 1), near, slice scale at the view's resolution
  uvec4 cell;    // atlas layer, texel origin x, y, resolution
};
layout(std430, binding = 21) readonly buffer PsmViews { PsmView psmViews[]; };
// Inner node: hi.w == 0, children at lo.w and lo.w + 1; leaf: triangles leafTriangles[lo.w, lo.w + hi.w).
struct PsmNode {
  vec4 lo;  // w: first (uint bits)
  vec4 hi;  // w: count (uint bits)
};
layout(std430, binding = 20) readonly buffer PsmNodes { PsmNode psmNodes[]; };
// Counters: [0] triangles emitted, [1] points emitted, [2 + level] items of each level.
layout(std430, binding = 24) buffer PsmCounters { uint psmCounters[]; };
layout(std430, binding = 25) buffer PsmTriangles { uvec2 psmTriangles[]; };  // (triangle, view)
layout(std430, binding = 26) buffer PsmPoints { uvec2 psmPoints[]; };        // (node, view)
