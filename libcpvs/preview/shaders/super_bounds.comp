// Per super-tile (CPVS_SUPER_TILE x CPVS_SUPER_TILE screen tiles), the bounds of its covered tiles' bounds (w: 1 when any
// tile is covered). The light lists first cull the lights against these, then each tile against its
// super-tile's survivors only. One invocation per super-tile.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer TileBounds { vec4 tileBounds[]; };
layout(std430, binding = 18) writeonly buffer SuperBounds { vec4 superBounds[]; };
uniform ivec2 tileCount;
void main() {
  uint super = gl_GlobalInvocationID.x;
  uint supersX = (uint(tileCount.x) + CPVS_SUPER_TILE - 1u) / CPVS_SUPER_TILE, supersY = (uint(tileCount.y) + CPVS_SUPER_TILE - 1u) / CPVS_SUPER_TILE;
  if (super >= supersX * supersY) return;
  uint x0 = (super % supersX) * CPVS_SUPER_TILE, y0 = (super / supersX) * CPVS_SUPER_TILE;
  vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38);
  float covered = 0.0;
  for (uint y = y0; y < min(y0 + CPVS_SUPER_TILE, uint(tileCount.y)); ++y)
    for (uint x = x0; x < min(x0 + CPVS_SUPER_TILE, uint(tileCount.x)); ++x) {
      uint tile = y * uint(tileCount.x) + x;
      vec4 l = tileBounds[2u * tile], h = tileBounds[2u * tile + 1u];
      if (l.w == 0.0) continue;
      lo = min(lo, l.xyz);
      hi = max(hi, h.xyz);
      covered = 1.0;
    }
  superBounds[2u * super] = vec4(lo, covered);
  superBounds[2u * super + 1u] = vec4(hi, 0.0);
}
