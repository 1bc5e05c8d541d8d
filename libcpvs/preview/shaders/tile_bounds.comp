// Per 8x8 screen tile, the world-space bounds of its covered pixels (w: how many). One invocation per tile.
layout(local_size_x = 256) in;
layout(binding = 0) uniform sampler2D positions;
layout(std430, binding = 0) writeonly buffer TileBounds { vec4 tileBounds[]; };  // (min, count), (max, 0)
uniform ivec2 imageSize_;
uniform ivec2 tileCount;
void main() {
  uint tile = gl_GlobalInvocationID.x;
  if (tile >= uint(tileCount.x * tileCount.y)) return;
  ivec2 origin = ivec2(int(tile) % tileCount.x, int(tile) / tileCount.x) * 8;
  vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38);
  float covered = 0.0;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      ivec2 p = origin + ivec2(x, y);
      if (p.x >= imageSize_.x || p.y >= imageSize_.y) continue;
      vec4 position = texelFetch(positions, p, 0);
      if (position.w == 0.0) continue;
      lo = min(lo, position.xyz);
      hi = max(hi, position.xyz);
      covered += 1.0;
    }
  tileBounds[2u * tile] = vec4(lo, covered);
  tileBounds[2u * tile + 1u] = vec4(hi, 0.0);
}
