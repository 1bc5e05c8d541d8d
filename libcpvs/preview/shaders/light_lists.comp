// Per tile, the lights whose bounding volume meets the tile's bounds, in light order: COUNT_PASS writes how
// many, else the list is filled from the tile's offset (prefix_sum.comp). One invocation per tile.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer TileBounds { vec4 tileBounds[]; };
layout(std430, binding = 1) readonly buffer LightReals { double lightReals[]; };
layout(std430, binding = 2) readonly buffer LightWords { uint lightWords[]; };
layout(std430, binding = 3) buffer TileCounts { uint tileCounts[]; };     // count per tile
layout(std430, binding = 4) readonly buffer TileOffsets { uint tileOffsets[]; };
layout(std430, binding = 5) writeonly buffer TileLights { uint tileLights[]; };
uniform int tiles;
uniform int lightCount;
void main() {
  uint tile = gl_GlobalInvocationID.x;
  if (tile >= uint(tiles)) return;
  vec4 lo = tileBounds[2u * tile], hi = tileBounds[2u * tile + 1u];
  uint count = 0u;
  if (lo.w > 0.0) {
    for (uint light = 0u; light < uint(lightCount); ++light) {
      if (lightWords[light * CPVS_LIGHT_WORDS + CPVS_LIGHT_DISABLED] != 0u) continue;
      uint r = light * CPVS_LIGHT_REALS;
      bool meets = cpvsLightMeetsBox(lightWords[light * CPVS_LIGHT_WORDS + CPVS_LIGHT_TYPE],
                                     dvec3(lightReals[r], lightReals[r + 1u], lightReals[r + 2u]),
                                     dvec3(lightReals[r + 3u], lightReals[r + 4u], lightReals[r + 5u]),
                                     lightReals[r + CPVS_LIGHT_RANGE], lightReals[r + CPVS_LIGHT_COS_OUTER],
                                     lightReals[r + CPVS_LIGHT_SIN_OUTER], dvec3(lo.xyz), dvec3(hi.xyz));
      if (!meets) continue;
#ifndef COUNT_PASS
      tileLights[tileOffsets[tile] + count] = light;
#endif
      ++count;
    }
  }
#ifdef COUNT_PASS
  tileCounts[tile] = count;
#endif
}
