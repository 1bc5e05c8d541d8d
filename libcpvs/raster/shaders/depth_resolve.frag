uniform sampler2D enterDepth;
uniform usampler2D kinds;
uniform sampler2D cursors;
uniform sampler2D counts;
uniform float resolution;
layout(location = 0) out vec2 slices;   // (enter, exit); exit = -(x + 1) flags a texel capped by the peel limit
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  uint k = texelFetch(kinds, p, 0).r;
  float N = resolution;
  float e = N, x = N;
  if (k != 0u) {
    float z = texelFetch(enterDepth, p, 0).r;
    e = min(N - 1.0, floor(2.0 * z * N));
    x = e + 1.0;
    if (k == 1u) {
      vec2 c = texelFetch(cursors, p, 0).rg;
      float n = texelFetch(counts, p, 0).r;
      x = min(N, max(e + 1.0, floor(2.0 * max(c.x, c.y) * N)));
      if (n < kStuck + 0.5) x = N;   // every voxel up to the far plane lies inside the solid
      else if (n < kCapped + 0.5 || n > 0.0) x = -x - 1.0;   // capped, or still inside when peeling stopped
    }
  }
  slices = vec2(e, x);
}
