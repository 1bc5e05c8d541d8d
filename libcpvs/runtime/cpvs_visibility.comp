#version 450
// The runtime's GPU lookup as a Vulkan compute shader: for each surface point (and its normal), the visibility
// of one light with K x K PCF, as LightShadow::visibility answers it. An engine compiles it to SPIR-V
// (glslangValidator -V --target-env vulkan1.1 -I<this folder>) and binds the records cpvs-view's GPU path
// uploads (libcpvs/runtime/gpu_records.h writes them; lookup_records.glsl has their layout) in set 0; docs/runtime.md,
// "Vulkan", shows the binding. Needs shaderFloat64 (the mapping runs in doubles, as the CPU's does) and
// std430 storage buffers. The walk and the cell are the runtime's own GLSL (dag_walk.glsl.h,
// lookup_cell.glsl), included as they are. Comments stay ASCII (GLSL).
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer LightReals { double lightReals[]; };
layout(std430, set = 0, binding = 1) readonly buffer LightWords { uint lightWords[]; };
layout(std430, set = 0, binding = 2) readonly buffer ViewReals { double viewReals[]; };
layout(std430, set = 0, binding = 3) readonly buffer ViewWords { uint viewWords[]; };
layout(std430, set = 0, binding = 4) readonly buffer DagNodes { uint dagNodes[]; };     // u16 units, two per uint
layout(std430, set = 0, binding = 5) readonly buffer DagLeaves { uvec2 dagLeaves[]; };  // (low, high) 32 bits
// SurfacePoint's layout: 6 doubles a point (x, y, z, nx, ny, nz), so a C++ array of them uploads as it is.
layout(std430, set = 0, binding = 6) readonly buffer Points { double points[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Visibility { float visibility[]; };

layout(push_constant) uniform Lookup {
  double biasMargin;  // LookupOptions::biasMargin (kDefaultBiasMargin)
  uint light;         // the light record
  uint count;         // points
  int pcfKernel;      // K, odd, 1 = unfiltered
} lookup;

#include "light.glsl.h"
#include "lookup_records.glsl"

// The accessors lookup_cell.glsl and dag_walk.glsl.h call, for the light and view being looked up.
uint gLight = 0u, gView = 0u;
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
  return (dagNodes[unit >> 1u] >> ((unit & 1u) * 16u)) & 0xFFFFu;
}
uvec2 cpvsLeaf(uint i) { return dagLeaves[cpvsViewWord(CPVS_VIEW_LEAF_BASE) + i]; }
uint cpvsResolution() { return cpvsViewWord(CPVS_VIEW_RESOLUTION); }
uint cpvsRootCode() { return cpvsViewWord(CPVS_VIEW_ROOT_CODE); }
uint cpvsChildBase(uint log2Edge) { return cpvsViewWord(CPVS_VIEW_CHILD_BASE + log2Edge); }

#include "lookup_cell.glsl"
#include "dag_walk.glsl.h"

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= lookup.count) return;
  dvec3 p = dvec3(points[6u * i], points[6u * i + 1u], points[6u * i + 2u]);
  dvec3 n = dvec3(points[6u * i + 3u], points[6u * i + 4u], points[6u * i + 5u]);
  gLight = lookup.light;
  float answer = 0.0;  // outside the light's influence, or not a finite point: 0, as the CPU answers
  int view = cpvsSelectView(p);
  if (view >= 0) {
    gView = cpvsLightWord(CPVS_LIGHT_FIRST_VIEW) + uint(view);
    CpvsCell cell = cpvsLookupCell(p, n, 0.5LF * double(lookup.pcfKernel), lookup.biasMargin);
    if (cell.verdict == CPVS_CELL_LIT) answer = 1.0;
    if (cell.verdict == CPVS_CELL_VOXEL) {
      int k = lookup.pcfKernel;
      uint shadowed = k <= 1 ? (cpvsShadowed(uint(cell.voxel.x), uint(cell.voxel.y), uint(cell.voxel.z)) ? 1u : 0u)
                             : cpvsShadowedTexels(cell.voxel.x, cell.voxel.y, uint(cell.voxel.z), k);
      answer = k <= 1 ? (shadowed != 0u ? 0.0 : 1.0) : float(1.0LF - double(shadowed) / (double(k) * double(k)));
    }
  }
  visibility[i] = answer;
}
