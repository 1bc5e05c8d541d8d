// Per tile, the lights whose bounding volume meets the tile's bounds, in light order: COUNT_PASS writes how
// many, else the list is filled from the tile's offset (prefix_sum.comp). One invocation per tile.
// Two levels, so that the work follows the lights a tile can see rather than tiles x lights: SUPER_TILES runs it
// once over the super-tiles' bounds (super_bounds.comp) against every light, with the cone test's sphere
// doubled (the sphere around a super-tile's box then holds every one of its tiles' spheres, so a light any of
// its tiles meets is kept), counting and listing at once into a fixed stride of lightCount per super-tile;
// without it, each tile tests only the lights its super-tile kept (bindings 16, 17), with the exact test of
// light_cull.glsl, so the lists are the brute-force ones (tests/preview_test.cpp).
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer TileBounds { vec4 tileBounds[]; };
layout(std430, binding = 1) readonly buffer LightReals { double lightReals[]; };
layout(std430, binding = 2) readonly buffer LightWords { uint lightWords[]; };
layout(std430, binding = 3) buffer TileCounts { uint tileCounts[]; };     // count per tile
layout(std430, binding = 4) readonly buffer TileOffsets { uint tileOffsets[]; };
layout(std430, binding = 5) writeonly buffer TileLights { uint tileLights[]; };
#ifndef SUPER_TILES
layout(std430, binding = 16) readonly buffer SuperCounts { uint superCounts[]; };
layout(std430, binding = 17) readonly buffer SuperLights { uint superLights[]; };
// Per tile, a bit per candidate of its super-tile: set by the count pass where the light meets the tile, read by
// the fill pass, which so tests nothing again.
layout(std430, binding = 19) buffer TileBits { uint tileBits[]; };
uniform ivec2 tileCount;
uniform int wordsPerTile;
#endif
uniform int tiles;
uniform int lightCount;

bool meets(uint light, vec4 lo, vec4 hi) {
  if (lightWords[light * CPVS_LIGHT_WORDS + CPVS_LIGHT_DISABLED] != 0u) return false;
  uint r = light * CPVS_LIGHT_REALS;
  return cpvsLightMeetsBox(lightWords[light * CPVS_LIGHT_WORDS + CPVS_LIGHT_SHAPE],
                           dvec3(lightReals[r], lightReals[r + 1u], lightReals[r + 2u]),
                           dvec3(lightReals[r + 3u], lightReals[r + 4u], lightReals[r + 5u]),
                           lightReals[r + CPVS_LIGHT_RANGE], lightReals[r + CPVS_LIGHT_COS_OUTER],
                           lightReals[r + CPVS_LIGHT_SIN_OUTER], dvec3(lo.xyz), dvec3(hi.xyz));
}

void main() {
  uint tile = gl_GlobalInvocationID.x;
  if (tile >= uint(tiles)) return;
  vec4 lo = tileBounds[2u * tile], hi = tileBounds[2u * tile + 1u];
  uint count = 0u;
  if (lo.w > 0.0) {
#ifdef SUPER_TILES
    uint first = 0u, last = uint(lightCount);
#else
    uint supersX = (uint(tileCount.x) + CPVS_SUPER_TILE - 1u) / CPVS_SUPER_TILE;
    uint super = (tile / uint(tileCount.x)) / CPVS_SUPER_TILE * supersX + (tile % uint(tileCount.x)) / CPVS_SUPER_TILE;
    uint first = super * uint(lightCount), last = first + superCounts[super];
#endif
#if defined(SUPER_TILES)
    for (uint light = first; light < last; ++light) {
      if (!meets(light, lo, hi)) continue;
      tileLights[tile * uint(lightCount) + count] = light;
      ++count;
    }
#elif defined(COUNT_PASS)
    uint bits = tile * uint(wordsPerTile), word = 0u;
    for (uint k = first; k < last; ++k) {
      uint i = k - first;
      if (meets(superLights[k], lo, hi)) {
        word |= 1u << (i & 31u);
        ++count;
      }
      if ((i & 31u) == 31u || k + 1u == last) {
        tileBits[bits + i / 32u] = word;
        word = 0u;
      }
    }
#else
    uint bits = tile * uint(wordsPerTile);
    for (uint k = first; k < last; ++k) {
      uint i = k - first;
      if (((tileBits[bits + i / 32u] >> (i & 31u)) & 1u) == 0u) continue;
      tileLights[tileOffsets[tile] + count] = superLights[k];
      ++count;
    }
#endif
  }
#if defined(COUNT_PASS) || defined(SUPER_TILES)
  tileCounts[tile] = count;
#endif
}
