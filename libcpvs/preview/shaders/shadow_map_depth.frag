// The 16-bit depth of eval/shadow_map.h: q = min(floor(65536 s / M), 65535) of the slice s at resolution M,
// stored as q / 65536 in a 32-bit float depth buffer (exact), nearest kept by the depth test.
// Alpha-tested casters are cut as the bake cuts them, and meshes that cast no shadow are left out
// (coverage_mask.glsl). The view's depth mapping comes from the vertex shader (one view per draw for the
// per-light maps, one per primitive for ManyPSMs' atlas).
in float vDepth;
in vec2 vMaskUv;
flat in int vMask;
flat in int vCasts;          // 0: the mesh casts no shadow (extras flag, --exclude-material)
flat in int vLinearDepth;    // the view's depth mapping (light_view.h)
flat in float vNearDepth;
flat in float vSliceScale;   // linear: M / (far - near); logarithmic: M / log(far / near)
flat in float vMapSize;      // M
void main() {
  if (vCasts == 0 || (vMask >= 0 && !maskBlocks(vMask, vMaskUv))) discard;
  float s = vLinearDepth != 0 ? (vDepth - vNearDepth) * vSliceScale : log(max(vDepth / vNearDepth, 1e-30)) * vSliceScale;
  float q = clamp(floor(s * 65536.0 / vMapSize), 0.0, 65535.0);
  gl_FragDepth = q / 65536.0;
}
