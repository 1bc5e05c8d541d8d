#pragma once
// Walks that descend one view's DAG together, level by level: the inner loop of LightShadow's batch lookups
// (batch_lookup.cpp). Each pass over the walks still going reads their nodes, writes the result of those that
// reach a homogeneous child or a leaf, and compacts the others for the next pass, prefetching their nodes,
// which are read one pass later. The walks are kept one array per field, so that the AVX-512 path
// (dag_walks_avx512.cpp) takes sixteen of them per instruction: gathers for the node reads, compress-stores
// for the compaction; the AVX2 path (dag_walks_avx2.cpp) eight, packing by a permutation table. The scalar path
// (batch_lookup.cpp) runs the same passes on the same arrays, and all give the same results bit for bit.
//
// Why a vector path: once the mapping ran eight points at a time, the scalar walk's ~50 instructions per
// level and walk (child index, header decode, the reference's popcount, compaction) were most of a lookup's
// time even with the DAG in L2; sixteen lanes made unfiltered lookups 1.5-2.0x faster (docs/lookups.md).
//
// Same rule as view_mapping.h: standard headers only (dag_walks_avx512.cpp includes it before its
// CPVS_TARGET_BEGIN_* (portability.h)).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/portability.h"

namespace cpvs {

// A DAG as the walks read it: DagView's stored form (formats/cpvs/format.md).
struct WalkDag {
  const uint16_t* nodes = nullptr;
  size_t nodeUnits = 0;
  const uint64_t* leaves = nullptr;
  const uint32_t* childBase = nullptr;  // DagView::childBase
  uint32_t resolution = 0;
};

// Walk i: voxel (x[i], y[i], z[i]), at the node whose first unit is offset[i] (a leaf index once past the
// leaf parents), writing its result to slot out[i].
struct WalkSet {
  uint32_t *x = nullptr, *y = nullptr, *z = nullptr, *offset = nullptr, *out = nullptr;
  void set(size_t i, uint32_t vx, uint32_t vy, uint32_t vz, uint32_t voffset, uint32_t vout) const {
    x[i] = vx, y[i] = vy, z[i] = vz, offset[i] = voffset, out[i] = vout;
  }
  WalkSet from(size_t first) const { return {x + first, y + first, z + first, offset + first, out + first}; }
};

// Slots a WalkSet needs past its walks: the AVX-512 walks compact sixteen lanes at a time with a full 16-lane
// store (dag_walks_avx512.cpp), which may write up to 15 slots past the last walk kept.
inline constexpr size_t kWalkPadding = 16;

// Storage for a WalkSet (per thread: one LightShadow serves many threads), with kWalkPadding slots to spare.
struct WalkStorage {
  std::vector<uint32_t> x, y, z, offset, out;
  WalkSet reserve(size_t count) {
    if (x.size() < count + kWalkPadding)
      for (std::vector<uint32_t>* v : {&x, &y, &z, &offset, &out}) v->resize(count + kWalkPadding);
    return {x.data(), y.data(), z.data(), offset.data(), out.data()};
  }
};

// What a walk writes to slot out[i] of the results when it ends.
enum class WalkResult : uint8_t {
  Visibility,  // float: 1 lit, 0 shadowed (the voxel's bit)
  TileMask,    // uint64_t: the 8 x 8 mask of the voxel's tile at its slice (bit (y & 7) * 8 + (x & 7) set = shadowed)
};

// Texel masks of an 8 x 8 tile (bit (y & 7) * 8 + (x & 7)) for PCF footprints, from two small tables: columns
// a..b of every row, and every column of rows a..b (entry a * 8 + b, a <= b); their AND is the footprint's part
// of the tile.
struct TileSpans {
  uint64_t columns[64] = {}, rows[64] = {};
  constexpr TileSpans() {
    for (uint32_t a = 0; a < 8; ++a)
      for (uint32_t b = a; b < 8; ++b) {
        columns[a * 8 + b] = (((uint64_t(2) << b) - 1) & ~((uint64_t(1) << a) - 1)) * 0x0101010101010101ull;
        const uint64_t upTo = b == 7 ? ~uint64_t(0) : (uint64_t(1) << (8 * (b + 1))) - 1;  // rows 0 .. b
        rows[a * 8 + b] = upTo & ~((uint64_t(1) << (8 * a)) - 1);
      }
  }
};
inline constexpr TileSpans kTileSpans;

// Walks that descend together: enough that each pass hides the previous pass's misses, few enough that the
// lines they prefetched are still in L1 when read. On the lookups benchmark's files (docs/lookups.md, "The
// walks") groups of 32 to 256 ran alike with the scalar walks. Once the vector walks compacted in registers
// their passes got shorter than a miss: on the 165-spot city at 8k (cpvs-view --shadows cpu, 1080p, two
// cameras, alternating) 512 beat 128 in 6 of 8 pairs by 1-3 core-ns per pair, about the machine's noise.
inline constexpr size_t kWalksInFlight = 512;

// Whether this CPU runs the AVX-512 walks (AVX-512F; CPVS_LOOKUP_ISA below avx512 turns them off, as it
// lowers mapCells). Without them, a CPU with AVX2 runs the AVX2 walks (dag_walks_avx2.cpp: the K = 1 lookups
// and the K <= 9 PCF filter, filterFootprintsAvx2).
bool vectorWalksAvailable();

// As prefetchNode in batch_lookup.cpp, for the walks offsets[begin, end): a node (at most 34 bytes) may straddle
// two cache lines.
inline void prefetchWalkNodes(const uint16_t* nodes, const uint32_t* offsets, size_t begin, size_t end) {
  for (size_t i = begin; i < end; ++i) {
    const char* node = reinterpret_cast<const char*>(nodes + offsets[i]);
    portable::prefetchRead(node);
    portable::prefetchRead(node + 33);
  }
}

// AVX-512: walks [0, count) (best in groups of kWalksInFlight), each at a node of edge startSize, descend level
// by level to their voxels; each writes its result when it reaches a homogeneous child or a leaf. The batch
// functions below run the same passes.
// Preconditions: vectorWalksAvailable(), 2 <= dag.nodeUnits < 2^31, fewer than 2^30 leaves, result slots below
// 2^31 (the gathers' and scatters' indices are signed 32-bit: units, a leaf's two 32-bit halves, slots). The
// walks' arrays may be written up to kWalkPadding - 1 slots past `count` (a WalkStorage's spare slots, or the
// next group's when `count` is a multiple of 16, which those writes then never reach).
void descendGroupAvx512(const WalkDag& dag, const WalkSet& walks, size_t count, uint32_t startSize, WalkResult kind,
                        void* results);
// The same eight walks at a time with AVX2 (bestCellIsa() >= CellIsa::Avx2), the same results bit for bit.
void descendGroupAvx2(const WalkDag& dag, const WalkSet& walks, size_t count, uint32_t startSize, WalkResult kind,
                      void* results);

// Where the walks of a batch start: the DAG and its top grid.
struct WalkStart {
  WalkDag dag;
  const uint32_t* gridCells = nullptr;  // TopGrid::cells, or null: every walk starts at the root
  uint32_t gridShift = 0, gridLevel = 0;
  uint32_t rootEntry = 0;  // the root's child code (offset 0)
};

// K = 1, AVX-512: the start of LightShadow::walkVoxels for a mapped batch (lane j answers point indices[j],
// or j when null): each voxel's top-grid cell (or the root), the answers that need no walk, then the walks.
struct VoxelWalkBatch {
  WalkStart start;
  CellBatchOutput cells;
  const uint32_t* indices = nullptr;
  size_t count = 0;
  float* answers = nullptr;
};
// Same preconditions as descendGroupAvx512.
void walkVoxelsAvx512(const VoxelWalkBatch& batch);
// The same with AVX2 (descendGroupAvx2's preconditions).
void walkVoxelsAvx2(const VoxelWalkBatch& batch);

// K <= 9 PCF, AVX-512: LightShadow's filter for one view's mapped batch (lane j answers point indices[j], or j
// when null), where the DAG's root is a reference. Every lane gets its answer without the DAG first (1 for
// kCellLit, else 0); the voxel lanes' footprints (the K x K texels around (x, y) clipped to [0, N), at slice z)
// are packed into arrays of their own, and since K <= 9 each spans at most 2 x 2 tiles of 8 x 8 texels: one walk
// per distinct corner tile, from its top-grid cell (or the root) down to the tile's mask at the slice, AND-ed
// with the footprint's part of the tile and counted; the answer is float(1 - shadowed / K^2), as the scalar
// filter's. No step needs bookkeeping that sixteen lanes cannot do at once.
struct FootprintBatch {
  WalkStart start;
  CellBatchOutput cells;
  const uint32_t* indices = nullptr;
  size_t count = 0;
  uint32_t kernelHalf = 0;  // K / 2, K odd and <= 9
  float* answers = nullptr;
};
// Same preconditions as descendGroupAvx512, with 4 * count walks.
void filterFootprintsAvx512(const FootprintBatch& batch);
// The same eight footprints at a time with AVX2 (descendGroupAvx2's preconditions), the same answers bit for bit.
void filterFootprintsAvx2(const FootprintBatch& batch);

}  // namespace cpvs
