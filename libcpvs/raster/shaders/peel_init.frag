uniform sampler2D enterDepth;
uniform usampler2D kinds;
uniform int noPeel;
layout(location = 0) out vec2 cursor;
layout(location = 1) out float count;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  float z = texelFetch(enterDepth, p, 0).r;
  uint k = texelFetch(kinds, p, 0).r;
  // Front faces at the enter depth are the enter itself; back faces at the enter depth (silhouettes,
  // zero-thickness parts) must still be seen, so the back cursor starts one float below it.
  cursor = vec2(z, z > 0.0 ? uintBitsToFloat(floatBitsToUint(z) - 1u) : -1.0);
  count = k == 1u ? (noPeel != 0 ? kCapped : 1.0) : 0.0;
}
