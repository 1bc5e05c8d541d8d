// The 16-bit depth of eval/shadow_map.h: q = min(floor(65536 s / M), 65535) of the slice s at resolution M,
// stored as q / 65536 in a 32-bit float depth buffer (exact), nearest kept by the depth test.
// Alpha-tested casters are cut as the bake cuts them, and meshes that cast no shadow are left out
// (coverage_mask.glsl).
in float vDepth;
in vec2 vMaskUv;
flat in int vMask;
flat in int vCasts;   // 0: the mesh casts no shadow (extras flag, --exclude-material)
uniform int linearDepth;    // the view's depth mapping (light_view.h)
uniform float nearDepth;
uniform float sliceScale;   // linear: M / (far - near); logarithmic: M / log(far / near)
uniform float mapSize;      // M
void main() {
  if (vCasts == 0 || (vMask >= 0 && !maskBlocks(vMask, vMaskUv))) discard;
  float s = linearDepth != 0 ? (vDepth - nearDepth) * sliceScale : log(max(vDepth / nearDepth, 1e-30)) * sliceScale;
  float q = clamp(floor(s * 65536.0 / mapSize), 0.0, 65535.0);
  gl_FragDepth = q / 65536.0;
}
