#ifndef CPVS_RUNTIME_DAG_WALK_GLSL_H
#define CPVS_RUNTIME_DAG_WALK_GLSL_H
// The DAG walk of shadow_dag.h / shadow_lookup.h written once for two compilers: this file is C++ (the walk
// lives in cpvs::gpu::DagWalk, over a DagView) and, pasted after "#version 450" and a prelude, GLSL 4.50
// (tests/glsl_walk_test.cpp has the prelude: SSBOs and the accessors below). Integer arithmetic only, so a
// GPU answers exactly what the CPU does.
//
// The shared code below uses only what both languages have: uint / int / bool, uvec2 built as uvec2(a, b) and
// read through .x / .y, the GLSL built-ins bitCount, findLSB, min and max (defined for C++ here), and these
// accessors, which whoever includes the text provides:
//   uint  cpvsNodeUnit(uint i)         node unit i (GLSL: u16 units packed two per uint, low half first)
//   uvec2 cpvsLeaf(uint i)             leaf mask i as (low 32 bits, high 32 bits): GLSL has no 64-bit ints
//   uint  cpvsResolution()             N, a power of two >= 8
//   uint  cpvsRootCode()               0 lit, 1 shadowed, 2 reference (root at unit 0)
//   uint  cpvsChildBase(uint log2Edge) DagView::childBase
// No recursion (GLSL has none): PCF walks once per 8x8 tile the footprint touches instead of once per
// footprint. Nothing here is written for speed.
//
// Identifiers avoid GLSL's reserved words (half, sample, shared, buffer, ...); comments stay ASCII.

#ifdef __cplusplus
#include <bit>
#include <cstdint>

#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs::gpu {

using uint = uint32_t;
struct uvec2 {
  uint x = 0, y = 0;
  uvec2() = default;
  uvec2(uint a, uint b) : x(a), y(b) {}
};
inline int bitCount(uint v) { return int(popcount32(v)); }
inline int findLSB(uint v) { return v ? std::countr_zero(v) : -1; }
inline int min(int a, int b) { return a < b ? a : b; }
inline int max(int a, int b) { return a > b ? a : b; }
inline uint min(uint a, uint b) { return a < b ? a : b; }
inline uint max(uint a, uint b) { return a > b ? a : b; }

// The walk over one DagView (referenced, not copied: the view's storage must outlive it). Reads past the
// arrays give 0, as robust buffer access does on a GPU: a malformed DAG gives wrong answers, not a crash.
struct DagWalk {
  const DagView& dag;
  uint cpvsNodeUnit(uint i) const { return i < dag.nodes.size() ? dag.nodes[i] : 0u; }
  uvec2 cpvsLeaf(uint i) const {
    uint64_t m = i < dag.leaves.size() ? dag.leaves[i] : 0u;
    return uvec2(uint(m), uint(m >> 32));
  }
  uint cpvsResolution() const { return dag.resolution; }
  uint cpvsRootCode() const { return uint(dag.rootCode); }
  uint cpvsChildBase(uint log2Edge) const { return dag.childBase[log2Edge]; }
#define CPVS_CONST const
#else
#define CPVS_CONST
#endif

// ---- shared C++ / GLSL text (member functions of DagWalk in C++) ----

// 2-bit child code folded to 0 lit, 1 shadowed, 2 reference (of either width).
uint cpvsChildCode(uint header, uint c) CPVS_CONST {
  uint raw = (header >> (2u * c)) & 3u;
  return raw - (raw & (raw >> 1u));
}

// Child c's reference as stored (c must be a reference): the references follow the header in child order,
// one unit each, two for code 3, so its position is the number of reference units before it.
uint cpvsReadRef(uint node, uint header, uint c) CPVS_CONST {
  uint unitBits = (header & 0xAAAAu) | (header & (header >> 1u) & 0x5555u);  // refUnitBits
  uint at = node + 1u + uint(bitCount(unitBits & ((1u << (2u * c)) - 1u)));
  uint ref = cpvsNodeUnit(at);
  if (((header >> (2u * c)) & 3u) == 3u) ref |= cpvsNodeUnit(at + 1u) << 16u;
  return ref;
}

// The 64-bit mask (low, high) of the 8x8 tile holding texel (x, y) at slice z, all in [0, N): the leaf's,
// or all ones / all zeros where a homogeneous node above covers the tile.
uvec2 cpvsTileMask(uint x, uint y, uint z) CPVS_CONST {
  uint code = cpvsRootCode();
  uint node = 0u;
  // Octree levels: the child's edge is 1 << shift; references count from childBase[log2(parent's edge)].
  for (uint shift = uint(findLSB(cpvsResolution())) - 1u; shift >= 3u && code == 2u; --shift) {
    uint bit = 1u << shift;
    uint c = ((z & bit) != 0u ? 4u : 0u) | ((y & bit) != 0u ? 2u : 0u) | ((x & bit) != 0u ? 1u : 0u);
    uint header = cpvsNodeUnit(node);
    code = cpvsChildCode(header, c);
    if (code == 2u) node = cpvsChildBase(shift + 1u) + cpvsReadRef(node, header, c);
  }
  if (code == 2u) {  // leaf parent: child z & 7 is the 8x8x1 slice, its reference a leaf index
    uint header = cpvsNodeUnit(node);
    code = cpvsChildCode(header, z & 7u);
    if (code == 2u) return cpvsLeaf(cpvsChildBase(3u) + cpvsReadRef(node, header, z & 7u));
  }
  return code == 1u ? uvec2(0xFFFFFFFFu, 0xFFFFFFFFu) : uvec2(0u, 0u);
}

// DagView::shadowed: voxel (x, y, z), all in [0, N).
bool cpvsShadowed(uint x, uint y, uint z) CPVS_CONST {
  uvec2 m = cpvsTileMask(x, y, z);
  uint bit = (y & 7u) * 8u + (x & 7u);
  return (((bit < 32u ? m.x : m.y) >> (bit & 31u)) & 1u) != 0u;
}

// Bits a..b (0 <= a <= b <= 31) of a 32-bit word.
uint cpvsBitSpan(uint a, uint b) CPVS_CONST { return (0xFFFFFFFFu >> (31u - (b - a))) << a; }

// Mask of columns xa..xb and rows ya..yb of an 8x8 tile (0 <= a <= b <= 7), as (rows 0-3, rows 4-7).
uvec2 cpvsRectMask(uint xa, uint xb, uint ya, uint yb) CPVS_CONST {
  uint columns = cpvsBitSpan(xa, xb) * 0x01010101u;  // the row's bits repeated in the 4 rows of a half
  uint low = ya <= 3u ? cpvsBitSpan(ya * 8u, min(yb, 3u) * 8u + 7u) : 0u;
  uint high = yb >= 4u ? cpvsBitSpan((max(ya, 4u) - 4u) * 8u, (yb - 4u) * 8u + 7u) : 0u;
  return uvec2(columns & low, columns & high);
}

// shadowedTexels: shadowed texels of the K x K footprint centred on (x, y) at slice z in [0, N); texels
// outside [0, N) are lit. x and y may lie outside the grid (|x|, |y| < 2^30); K odd >= 1 (an even K covers
// K + 1 texels, as shadowedTexels does).
uint cpvsShadowedTexels(int x, int y, uint z, int k) CPVS_CONST {
  int n = int(cpvsResolution());
  int h = k / 2;
  int x0 = max(0, x - h), x1 = min(n - 1, x + h);
  int y0 = max(0, y - h), y1 = min(n - 1, y + h);
  uint count = 0u;
  // Empty when clipped away: the loops do not run.
  for (int ty = y0 >> 3; y0 <= y1 && ty <= (y1 >> 3); ++ty) {
    for (int tx = x0 >> 3; x0 <= x1 && tx <= (x1 >> 3); ++tx) {
      int ox = tx * 8, oy = ty * 8;
      uvec2 tile = cpvsTileMask(uint(ox), uint(oy), z);
      uvec2 kernel = cpvsRectMask(uint(max(x0, ox) - ox), uint(min(x1, ox + 7) - ox), uint(max(y0, oy) - oy),
                                  uint(min(y1, oy + 7) - oy));
      count += uint(bitCount(tile.x & kernel.x) + bitCount(tile.y & kernel.y));
    }
  }
  return count;
}

#undef CPVS_CONST
#ifdef __cplusplus
};  // struct DagWalk
}  // namespace cpvs::gpu
#endif
#endif  // CPVS_RUNTIME_DAG_WALK_GLSL_H
