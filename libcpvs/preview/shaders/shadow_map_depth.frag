// The 16-bit depth of eval/shadow_map.h: q = min(floor(65536 s / M), 65535) of the slice s at resolution M,
// stored as q / 65536 in a 32-bit float depth buffer (exact), nearest kept by the depth test.
in float vDepth;
uniform int linearDepth;    // the view's depth mapping (light_view.h)
uniform float nearDepth;
uniform float sliceScale;   // linear: M / (far - near); logarithmic: M / log(far / near)
uniform float mapSize;      // M
void main() {
  float s = linearDepth != 0 ? (vDepth - nearDepth) * sliceScale : log(max(vDepth / nearDepth, 1e-30)) * sliceScale;
  float q = clamp(floor(s * 65536.0 / mapSize), 0.0, 65535.0);
  gl_FragDepth = q / 65536.0;
}
