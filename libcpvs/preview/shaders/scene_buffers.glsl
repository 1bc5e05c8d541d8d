// The buffers every per-pixel pass reads: the lights and views (lookup_records.glsl's layouts), the tile light
// lists, and the accessors lookup_cell.glsl and dag_walk.glsl.h call for the light and view being looked up.
layout(binding = 0) uniform sampler2D positions;
layout(binding = 1) uniform sampler2D normals;
layout(std430, binding = 1) readonly buffer LightReals { double lightReals[]; };
layout(std430, binding = 2) readonly buffer LightWords { uint lightWords[]; };
layout(std430, binding = 4) readonly buffer TileOffsets { uint tileOffsets[]; };
layout(std430, binding = 5) readonly buffer TileLights { uint tileLights[]; };
layout(std430, binding = 6) readonly buffer ViewReals { double viewReals[]; };
layout(std430, binding = 7) readonly buffer ViewWords { uint viewWords[]; };
layout(std430, binding = 8) readonly buffer DagNodes { uint dagNodes[]; };     // u16 units, two per uint
layout(std430, binding = 9) readonly buffer DagLeaves { uvec2 dagLeaves[]; };  // (low, high) 32 bits
layout(std430, binding = 10) buffer Visibility { float visibility[]; };         // per (tile list entry, pixel)
uniform ivec2 imageSize_;
uniform ivec2 tileCount;

uint gLight = 0u, gView = 0u;
uint gDagBytesRead = 0u;  // by this invocation's DAG walks: 2 per node unit, 8 per leaf (the work counters)
double cpvsLightReal(uint i) { return lightReals[gLight * CPVS_LIGHT_REALS + i]; }
uint cpvsLightWord(uint i) { return lightWords[gLight * CPVS_LIGHT_WORDS + i]; }
uint cpvsLightShape() { return cpvsLightWord(CPVS_LIGHT_SHAPE); }
int cpvsFaceView(uint face) {
  uint v = cpvsLightWord(CPVS_LIGHT_FACE_VIEW + face);
  return v == 0xFFFFFFFFu ? -1 : int(v);
}
double cpvsMappingReal(uint i) { return viewReals[gView * CPVS_MAP_REALS + i]; }
uint cpvsViewWord(uint i) { return viewWords[gView * CPVS_VIEW_WORDS + i]; }
uint cpvsMappingFlags() { return cpvsViewWord(CPVS_VIEW_FLAGS); }
uint cpvsNodeUnit(uint i) {
  uint unit = cpvsViewWord(CPVS_VIEW_NODE_BASE) + i;
  gDagBytesRead += 2u;
  return (dagNodes[unit >> 1u] >> ((unit & 1u) * 16u)) & 0xFFFFu;
}
uvec2 cpvsLeaf(uint i) {
  gDagBytesRead += 8u;
  return dagLeaves[cpvsViewWord(CPVS_VIEW_LEAF_BASE) + i];
}
uint cpvsResolution() { return cpvsViewWord(CPVS_VIEW_RESOLUTION); }
uint cpvsRootCode() { return cpvsViewWord(CPVS_VIEW_ROOT_CODE); }
uint cpvsChildBase(uint log2Edge) { return cpvsViewWord(CPVS_VIEW_CHILD_BASE + log2Edge); }

// The pair index of (list entry `slot` of `tile`, pixel `local` of the tile's 64).
uint pairIndex(uint tile, uint slot, uint local) { return (tileOffsets[tile] + slot) * 64u + local; }
