// Shared by every geometry fragment shader: the stored depth t / 2 with t = clamp(slice / N, 0, 1), evaluated
// from the triangle's plane at the exact texel centre (u0 + du, v0 + dv) -- region-independent.
//  depthMode 0: q = t (orthographic, linear)      1: q = d (orthographic, logarithmic)
//            2: q = 1/d (perspective, linear)     3: q = 1/d (perspective, logarithmic)
uniform ivec2 regionOrigin;
uniform int depthMode;
uniform float nearDepth;
uniform float invNear;
uniform float depthScale;   // linear: 1 / (far - near); logarithmic: 1 / log2(far / near)
flat in vec3 vPlane;
flat in ivec2 vOrigin;
flat in vec2 vRange;
float storedDepth() {
  vec2 du = vec2(ivec2(gl_FragCoord.xy) + regionOrigin - vOrigin) + 0.5;
  float q = clamp(vPlane.x + vPlane.y * du.x + vPlane.z * du.y, vRange.x, vRange.y);
  float t;
  if (depthMode == 0) t = q;
  else if (depthMode == 1) t = log2(max(q * invNear, 1e-30)) * depthScale;
  else if (depthMode == 2) t = (1.0 / max(q, 1e-30) - nearDepth) * depthScale;
  else t = -log2(max(q * nearDepth, 1e-30)) * depthScale;
  return 0.5 * clamp(t, 0.0, 1.0);
}
