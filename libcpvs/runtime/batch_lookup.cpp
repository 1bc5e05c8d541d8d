// The batch engine of LightShadow::visibility: a batch's points mapped to cells (batch_cells.h), grouped by
// view, and their DAG walks interleaved so that the memory latency of one walk hides behind the others
// (dag_walks.h; AVX-512 walks in dag_walks_avx512.cpp).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/dag_footprint.h"
#include "libcpvs/runtime/dag_walks.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

using namespace lookup_detail;

// ---- batches: interleaved walks ----------------------------------------------------------------------

// A point of the batch whose answer needs the DAG.
struct LightShadow::PendingPoint {
  Footprint f;    // clipped K x K footprint (inclusive texel bounds); K = 1: (x0, y0) is the texel
  uint32_t z;
  uint32_t out;   // index into the batch
};

namespace {

// Reused buffers of a batch (per thread: one LightShadow serves many threads).
struct BatchScratch {
  std::vector<int32_t> x, y, z;
  std::vector<uint8_t> state;
  std::vector<uint32_t> indices, face;
  std::vector<LightShadow::PendingPoint> pending;
  std::vector<uint32_t> counts;  // sized by the counting functions
  void resize(size_t count) {
    if (x.size() >= count) return;
    x.resize(count);
    y.resize(count);
    z.resize(count);
    state.resize(count);
    indices.resize(count);
    face.resize(count);
    pending.resize(count);
  }
};
constexpr uint32_t kNoView = ~0u;
// Kernels up to this size cover at most 2 x 2 tiles: LightShadow::countCornerTiles.
constexpr int kCornerTileKernel = 9;

inline void prefetch(const void* p) { portable::prefetchRead(p); }
// A node is at most 17 units (34 bytes: a header and 8 wide references) and may straddle two cache lines:
// fetch its first and its last possible byte.
inline void prefetchNode(const uint16_t* node) {
  portable::prefetchRead(node);
  portable::prefetchRead(reinterpret_cast<const char*>(node) + 33);
}

inline uint32_t area(const Footprint& f, uint32_t ox, uint32_t oy, uint32_t size) {
  return overlap(ox, ox + size - 1, f.x0, f.x1) * overlap(oy, oy + size - 1, f.y0, f.y1);
}

// Where a walk's result goes (as dag_walks.h's WalkResult): a visibility (1 lit, 0 shadowed) or the 8 x 8 mask
// of its tile at its slice.
struct VoxelAnswers {
  float* answers;
  void homogeneous(uint32_t out, uint32_t code) const { answers[out] = float(code != uint32_t(ChildCode::Shadowed)); }
  void leaf(uint32_t out, uint32_t x, uint32_t y, uint64_t mask) const {
    answers[out] = float(uint32_t(mask >> ((y & 7u) * 8u + (x & 7u)) & 1u) ^ 1u);
  }
};
struct TileMasks {
  uint64_t* masks;
  void homogeneous(uint32_t out, uint32_t code) const {
    masks[out] = 0 - uint64_t(code == uint32_t(ChildCode::Shadowed));
  }
  void leaf(uint32_t out, uint32_t, uint32_t, uint64_t mask) const { masks[out] = mask; }
};

WalkDag walkDag(const DagView& dag) {
  return {dag.nodes.data(), dag.nodes.size(), dag.leaves.data(), dag.childBase, dag.resolution};
}
WalkStart walkStart(const DagView& dag, const TopGrid& grid) {
  return {walkDag(dag), grid.empty() ? nullptr : grid.cells.data(), grid.shift, grid.level, uint32_t(dag.rootCode)};
}
// The vector walks the CPU runs (AVX-512, else AVX2), where the DAG and the batch (`slots` results: answers, or
// four tile masks per footprint) fit their signed 32-bit gather and scatter indices; else Scalar.
CellIsa vectorWalks(const DagView& dag, size_t slots) {
  const bool fits = dag.nodes.size() >= 2 && dag.nodes.size() < (size_t(1) << 31) &&
                    dag.leaves.size() < (size_t(1) << 30) && slots < (size_t(1) << 31);
  if (!fits) return CellIsa::Scalar;
  if (vectorWalksAvailable()) return CellIsa::Avx512;
  // No NEON walks: on ARM64 a port of the vector walks, without gathers, took more instructions per lookup than
  // the scalar walks (docs/runtime.md, "ARM64: the NEON path").
  return bestCellIsa() >= CellIsa::Avx2 ? CellIsa::Avx2 : CellIsa::Scalar;
}

// The walks w[0, active) (active <= kWalksInFlight), each at a node of edge startSize, go down level by level
// (dag_walks.h): every walk of the group takes its step at one level before any takes the next, in a loop
// without data-dependent branches (the child's code decides only which values are kept), so the loop runs at
// the speed of its loads: each child's node is prefetched when its reference is read and read one pass over
// the group later, by which time it has arrived. A walk's result is written at every step (final unless a
// reference follows). The scalar path: with AVX-512 the batches walk in dag_walks_avx512.cpp
// (walkVoxelsAvx512, filterFootprintsAvx512), with AVX2 in dag_walks_avx2.cpp (walkVoxelsAvx2,
// filterFootprintsAvx2), which give the same results.
template <class Results>
[[gnu::always_inline]] inline void descendGroup(const DagView& dag, const WalkSet& w, size_t active,
                                                uint32_t startSize, const Results& results) {
  const uint16_t* nodes = nodeUnits(dag);
  // Octree levels: child c = (z, y, x bits at the child's edge) in Z-order.
  for (uint32_t size = startSize; size > 8 && active > 0; size >>= 1) {
    const unsigned bit = unsigned(std::countr_zero(size)) - 1u;  // log2 of the child's edge
    const uint32_t base = dag.childBase[bit + 1];
    size_t kept = 0;
    for (size_t i = 0; i < active; ++i) {
      const uint32_t x = w.x[i], y = w.y[i], z = w.z[i], offset = w.offset[i], out = w.out[i];
      const uint32_t header = nodes[offset];
      const unsigned c = (((z >> bit) & 1u) << 2) | (((y >> bit) & 1u) << 1) | ((x >> bit) & 1u);
      const uint32_t code = childCodeOf(header, c);
      results.homogeneous(out, code);
      // Without a reference this reads the header again: in bounds, and no branch.
      const uint32_t child = base + readRef(nodes, offset, header, c);
      prefetchNode(nodes + child);
      w.set(kept, x, y, z, child, out);
      kept += code == uint32_t(ChildCode::Ref);
    }
    active = kept;
  }
  // Leaf-parent level: z-only split into 8x8x1 leaves.
  size_t kept = 0;
  for (size_t i = 0; i < active; ++i) {
    const uint32_t x = w.x[i], y = w.y[i], z = w.z[i], offset = w.offset[i], out = w.out[i];
    const uint32_t header = nodes[offset];
    const unsigned c = z & 7u;
    const uint32_t code = childCodeOf(header, c);
    const uint32_t ref = code == uint32_t(ChildCode::Ref);
    results.homogeneous(out, code);
    const uint32_t leaf = readRef(nodes, offset, header, c) & (0u - ref);  // leaf 0 when not a reference
    prefetch(dag.leaves.data() + leaf);
    w.set(kept, x, y, z, leaf, out);
    kept += ref;
  }
  // Leaves.
  const uint64_t* leaves = dag.leaves.data();
  for (size_t i = 0; i < kept; ++i) results.leaf(w.out[i], w.x[i], w.y[i], leaves[w.offset[i]]);
}

template <class Results>
[[gnu::always_inline]] inline void descend(const DagView& dag, const WalkSet& w, size_t active, uint32_t startSize,
                                           const Results& results) {
  for (size_t begin = 0; begin < active; begin += kWalksInFlight)
    descendGroup(dag, w.from(begin), std::min(kWalksInFlight, active - begin), startSize, results);
}

// The top-grid entry of voxel (x, y, z), or the root's (code, offset 0) without a grid.
[[gnu::always_inline]] inline uint32_t startEntry(const uint32_t* gridCells, uint32_t shift, uint32_t level,
                                                  uint32_t rootEntry, uint32_t x, uint32_t y, uint32_t z) {
  return gridCells ? gridCells[(size_t(z >> shift) << (2 * level)) | (size_t(y >> shift) << level) | (x >> shift)]
                   : rootEntry;
}

thread_local WalkStorage tWalks;

}  // namespace

// K = 1: one path per point (descend), started from the top-grid cell, whose code may answer at once.
CPVS_POPCNT_CLONES void LightShadow::walkVoxels(uint32_t view, const CellBatchOutput& cells,
                                                const uint32_t* indices, size_t count, std::span<float> out) const {
  const DagView& dag = dags_[view];
  const TopGrid& grid = grids_[view];
  if (const CellIsa isa = vectorWalks(dag, out.size()); isa != CellIsa::Scalar) {
    VoxelWalkBatch batch;
    batch.start = walkStart(dag, grid);
    batch.cells = cells;
    batch.indices = indices;
    batch.count = count;
    batch.answers = out.data();
    return isa == CellIsa::Avx512 ? walkVoxelsAvx512(batch) : walkVoxelsAvx2(batch);
  }
  const uint16_t* nodes = nodeUnits(dag);
  // Locals, not members: the float stores to out[] could otherwise alias them and force reloads.
  const uint32_t* gridCells = grid.empty() ? nullptr : grid.cells.data();
  const uint32_t sh = grid.shift, level = grid.level, rootEntry = uint32_t(dag.rootCode);
  const int32_t *xs = cells.x, *ys = cells.y, *zs = cells.z;
  const uint8_t* states = cells.state;
  float* answers = out.data();
  const WalkSet w = tWalks.reserve(count);
  size_t started = 0;
  for (size_t j = 0; j < count; ++j) {
    const uint32_t i = indices ? indices[j] : uint32_t(j);
    const uint32_t x = uint32_t(xs[j]), y = uint32_t(ys[j]), z = uint32_t(zs[j]);  // 0 unless a voxel
    const uint32_t state = states[j];
    const uint32_t entry = startEntry(gridCells, sh, level, rootEntry, x, y, z);
    const uint32_t code = entry & 3u;
    // Integer flags, not conditionals: the outcomes are unpredictable, and a branch on them mispredicts.
    const uint32_t voxel = state == kCellVoxel;
    const uint32_t lit = (voxel & uint32_t(code != uint32_t(ChildCode::Shadowed))) | uint32_t(state == kCellLit);
    answers[i] = float(lit);  // final unless a walk follows
    prefetchNode(nodes + (entry >> 2));
    w.set(started, x, y, z, entry >> 2, i);
    started += voxel & uint32_t(code == uint32_t(ChildCode::Ref));
  }
  descend(dag, w, started, grid.empty() ? dag.resolution : 1u << grid.shift, VoxelAnswers{answers});
}

// K <= 9: a footprint covers at most 2 x 2 tiles of 8 x 8 texels, the tiles of its four corners: each
// distinct corner tile walks from its own top-grid cell (the same descent as K = 1, ending in the tile's mask
// at the slice), and the masks are AND-ed with the kernel's part of each tile and counted. With AVX-512 or AVX2
// the whole filter runs in dag_walks_avx512.cpp or dag_walks_avx2.cpp instead (filterFootprintsAvx512,
// filterFootprintsAvx2), sixteen or eight footprints at a time, with the same answers. (Walking once per
// footprint to the node its corner tiles share, then from there, took as long: the grouping it needs cost
// what the shared steps saved; docs/lookups.md.)
CPVS_POPCNT_CLONES void LightShadow::countCornerTiles(uint32_t view, std::span<const PendingPoint> pending,
                                                      std::vector<uint32_t>& counts) const {
  const DagView& dag = dags_[view];
  const TopGrid& grid = grids_[view];
  const size_t n = pending.size();
  const uint16_t* nodes = nodeUnits(dag);
  const uint32_t* gridCells = grid.empty() ? nullptr : grid.cells.data();
  const uint32_t sh = grid.shift, level = grid.level, rootEntry = uint32_t(dag.rootCode);
  const uint32_t startSize = grid.empty() ? dag.resolution : 1u << grid.shift;
  thread_local std::vector<uint64_t> masks;
  thread_local WalkStorage cornerStorage;
  if (masks.size() < 4 * n) masks.resize(4 * n);
  const WalkSet corners = cornerStorage.reserve(4 * n);
  auto cornerAt = [](const Footprint& f, uint32_t q) {
    return std::pair<uint32_t, uint32_t>{q & 1u ? f.x1 : f.x0, q & 2u ? f.y1 : f.y0};
  };
  // Corner q of footprint p: its mask in masks[4 p + q], 0 for a corner in the same tile as another.
  size_t started = 0;
  for (size_t p = 0; p < n; ++p) {
    const Footprint& f = pending[p].f;
    const uint32_t twoColumns = (f.x0 >> 3) != (f.x1 >> 3), twoRows = (f.y0 >> 3) != (f.y1 >> 3);
    for (uint32_t q = 0; q < 4; ++q) {
      const auto [x, y] = cornerAt(f, q);
      const uint32_t keep = (uint32_t((q & 1u) == 0) | twoColumns) & (uint32_t((q & 2u) == 0) | twoRows);
      const uint32_t entry = startEntry(gridCells, sh, level, rootEntry, x, y, pending[p].z);
      const uint32_t code = entry & 3u;
      masks[4 * p + q] = (0 - uint64_t(code == uint32_t(ChildCode::Shadowed))) & (0 - uint64_t(keep));
      prefetchNode(nodes + (entry >> 2));
      corners.set(started, x, y, pending[p].z, entry >> 2, uint32_t(4 * p + q));
      started += keep & uint32_t(code == uint32_t(ChildCode::Ref));
    }
  }
  descend(dag, corners, started, startSize, TileMasks{masks.data()});
  counts.resize(n);
  for (size_t p = 0; p < n; ++p) {
    const Footprint& f = pending[p].f;
    uint32_t count = 0;
    for (uint32_t q = 0; q < 4; ++q) {
      const auto [x, y] = cornerAt(f, q);
      count += popcount64(masks[4 * p + q] & tileMask(f, x & ~7u, y & ~7u));
    }
    counts[p] = count;
  }
}

// K > 1: the shadowed texels of each pending footprint (all in one view), counted level by level like
// walkVoxels: every node the footprint overlaps is one entry; each level's pass reads its entries' nodes and
// writes the next level's entries, up to four per node (the children the footprint overlaps), with the
// homogeneous children's overlap counted at once, so no step branches on what it finds. Leaf masks are
// AND-ed with the kernel's mask of their tile and counted.
CPVS_POPCNT_CLONES void LightShadow::countFootprints(uint32_t view, std::span<const PendingPoint> pending, int pcfKernel,
                                                     std::vector<uint32_t>& counts) const {
  struct Entry {
    uint32_t offset;  // the node's units, then (below the leaf parents) the leaf's index
    uint32_t point;   // index into pending
    uint32_t ox, oy;  // the node's (or leaf's) first texel
  };
  const DagView& dag = dags_[view];
  const TopGrid& grid = grids_[view];
  const uint16_t* nodes = nodeUnits(dag);
  const uint64_t* leaves = dag.leaves.data();
  counts.assign(pending.size(), 0);
  // A footprint of K texels spans at most `span` nodes per axis at any level (nodes are at least 8 texels
  // wide), so a chunk of points has at most span^2 entries each per level.
  const size_t span = size_t(pcfKernel + 6) / 8 + 1;
  const size_t chunk = std::max<size_t>(1, kLookupBatch / (span * span));
  thread_local std::vector<Entry> current, next;
  const size_t capacity = std::min(chunk, pending.size()) * span * span + 4;  // + 4: a rejected last write
  if (current.size() < capacity) current.resize(capacity), next.resize(capacity);
  const uint32_t startSize = grid.empty() ? dag.resolution : 1u << grid.shift;
  for (size_t begin = 0; begin < pending.size(); begin += chunk) {
    const size_t end = std::min(pending.size(), begin + chunk);
    size_t active = 0;
    // Start: the root, or the top-grid cells the footprint overlaps (whose codes may answer at once).
    for (size_t p = begin; p < end; ++p) {
      const PendingPoint& pp = pending[p];
      if (grid.empty()) {
        current[active++] = {0, uint32_t(p), 0, 0};
        continue;
      }
      const uint32_t sh = grid.shift, level = grid.level;
      const size_t zRow = size_t(pp.z >> sh) << (2 * level);
      for (uint32_t gy = pp.f.y0 >> sh; gy <= (pp.f.y1 >> sh); ++gy)
        for (uint32_t gx = pp.f.x0 >> sh; gx <= (pp.f.x1 >> sh); ++gx) {
          const uint32_t entry = grid.cells[zRow | (size_t(gy) << level) | gx];
          const uint32_t code = entry & 3u;
          counts[p] += area(pp.f, gx << sh, gy << sh, startSize) * uint32_t(code == uint32_t(ChildCode::Shadowed));
          prefetchNode(nodes + (entry >> 2));
          current[active] = {entry >> 2, uint32_t(p), gx << sh, gy << sh};
          active += code == uint32_t(ChildCode::Ref);
        }
    }
    // Octree levels: the children c = (z bit, y half, x half) the footprint overlaps.
    for (uint32_t size = startSize; size > 8 && active > 0; size >>= 1) {
      const uint32_t half = size >> 1;
      const uint32_t base = dag.childBase[std::countr_zero(size)];  // as DagView::child
      size_t kept = 0;
      for (size_t i = 0; i < active; ++i) {
        const Entry e = current[i];
        const PendingPoint& pp = pending[e.point];
        const uint32_t header = nodes[e.offset];
        const unsigned zbit = (pp.z & half) ? 4u : 0u;
        uint32_t shadowed = 0;
        for (unsigned q = 0; q < 4; ++q) {
          const unsigned xb = q & 1u, yb = q >> 1;
          const uint32_t cx = e.ox + xb * half, cy = e.oy + yb * half;
          const uint32_t covered = area(pp.f, cx, cy, half);
          const unsigned c = zbit | q;
          const uint32_t code = childCodeOf(header, c);
          shadowed += covered * uint32_t(code == uint32_t(ChildCode::Shadowed));
          const uint32_t child = base + readRef(nodes, e.offset, header, c);
          const uint32_t keep = uint32_t(covered != 0) & uint32_t(code == uint32_t(ChildCode::Ref));
          prefetchNode(nodes + (keep ? child : e.offset));
          next[kept] = {child, e.point, cx, cy};
          kept += keep;
        }
        counts[e.point] += shadowed;
      }
      std::swap(current, next);
      active = kept;
    }
    // Leaf parents: the z-only split into 8 x 8 x 1 leaves.
    size_t kept = 0;
    for (size_t i = 0; i < active; ++i) {
      const Entry e = current[i];
      const PendingPoint& pp = pending[e.point];
      const uint32_t header = nodes[e.offset];
      const unsigned c = pp.z & 7u;
      const uint32_t code = childCodeOf(header, c);
      counts[e.point] += area(pp.f, e.ox, e.oy, 8) * uint32_t(code == uint32_t(ChildCode::Shadowed));
      const uint32_t keep = code == uint32_t(ChildCode::Ref);
      const uint32_t leaf = readRef(nodes, e.offset, header, c);
      prefetch(leaves + (keep ? leaf : 0u));
      next[kept] = {leaf, e.point, e.ox, e.oy};
      kept += keep;
    }
    // Leaves: the kernel's texels of the tile.
    for (size_t i = 0; i < kept; ++i) {
      const Entry e = next[i];
      counts[e.point] += popcount64(leaves[e.offset] & tileMask(pending[e.point].f, e.ox, e.oy));
    }
  }
}

Outcome LightShadow::visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                                std::span<float> out) const {
  if (out.size() != points.size())
    return {ErrorCategory::InvalidArgument, "LightShadow::visibility: " + std::to_string(out.size()) +
                                                " outputs for " + std::to_string(points.size()) + " points"};
  static_assert(sizeof(SurfacePoint) == 6 * sizeof(double) && offsetof(SurfacePoint, normal) == 3 * sizeof(double),
                "PointArrays reads SurfacePoint as 6 doubles, the normal after the position");
  PointArrays arrays;
  arrays.positions = reinterpret_cast<const double*>(points.data());
  arrays.positionStride = 6;
  arrays.normals = arrays.positions + 3;
  arrays.normalStride = 6;
  return visibility(arrays, options, out);
}

CPVS_POPCNT_CLONES Outcome LightShadow::visibility(const PointArrays& points, const LookupOptions& options,
                                                std::span<float> out) const {
  if (!out.empty() && (!points.positions || !points.normals))
    return {ErrorCategory::InvalidArgument, "LightShadow::visibility: no position or normal array"};
  if (Outcome kernel = checkPcfKernel(options.pcfKernel); !kernel) return kernel;
  const int k = options.pcfKernel;
  const int64_t h = k / 2;
  const double kernelArea = double(k) * double(k);
  auto value = [&](uint32_t shadowed) { return float(1.0 - double(shadowed) / kernelArea); };  // K > 1

  // Where each point lands (batch_cells.h: eight or four points at a time where the CPU has AVX-512 or AVX2),
  // view by view; then that view's walks (K = 1: walkVoxels) or footprints (K > 1: filter below).
  const size_t count = out.size();
  thread_local BatchScratch scratch;
  scratch.resize(count);
  std::vector<PendingPoint>& pendingStore = scratch.pending;
  CellBatchInput in;
  in.settings = cellSettings(options);
  in.points = points;
  const CellBatchOutput cells{scratch.x.data(), scratch.y.data(), scratch.z.data(), scratch.state.data()};
  // K > 1, lane j of a mapped run (point indices[j], or j): the answers that need no DAG into out[], the
  // footprints that do counted (countCornerTiles for K <= 9, countFootprints above), then their answers.
  auto filter = [&](uint32_t view, const uint32_t* indices, size_t lanes) {
    const DagView& dag = dags_[view];
    const int64_t n = dag.resolution;
    const bool walks = dag.rootCode == ChildCode::Ref;
    if (const CellIsa isa = walks && k <= kCornerTileKernel ? vectorWalks(dag, 4 * lanes) : CellIsa::Scalar;
        isa != CellIsa::Scalar) {
      FootprintBatch batch;
      batch.start = walkStart(dag, grids_[view]);
      batch.cells = cells;
      batch.indices = indices;
      batch.count = lanes;
      batch.kernelHalf = uint32_t(h);
      batch.answers = out.data();
      return isa == CellIsa::Avx512 ? filterFootprintsAvx512(batch) : filterFootprintsAvx2(batch);
    }
    size_t pendingCount = 0;
    for (size_t j = 0; j < lanes; ++j) {
      const uint32_t i = indices ? indices[j] : uint32_t(j);
      const uint32_t state = cells.state[j];
      const int64_t x = cells.x[j], y = cells.y[j];
      const Footprint f{uint32_t(std::max<int64_t>(0, x - h)), uint32_t(std::min<int64_t>(n - 1, x + h)),
                        uint32_t(std::max<int64_t>(0, y - h)), uint32_t(std::min<int64_t>(n - 1, y + h))};
      out[i] = float(uint32_t(state == kCellLit));  // final unless a walk follows
      if (!walks && state == kCellVoxel)  // a DAG of one colour (rare): no walk
        out[i] = dag.rootCode == ChildCode::Lit ? 1.0f : value((f.x1 - f.x0 + 1) * (f.y1 - f.y0 + 1));
      // Written every time, kept only for a walk: no branch on the point's (unpredictable) outcome.
      pendingStore[pendingCount] = {f, uint32_t(cells.z[j]), i};
      pendingCount += uint32_t(state == kCellVoxel) & uint32_t(walks);
    }
    const std::span<const PendingPoint> pending(pendingStore.data(), pendingCount);
    std::vector<uint32_t>& counts = scratch.counts;
    if (k <= kCornerTileKernel) countCornerTiles(view, pending, counts);
    else countFootprints(view, pending, k, counts);
    for (size_t p = 0; p < pending.size(); ++p) out[pending[p].out] = value(counts[p]);
  };
  if (!hasCubeFaces(light_)) {  // one view (directional and spot lights): the influence test runs in mapCells
    in.mapping = &mappings_[0];
    in.spot = hasCone(light_) ? &spot_ : nullptr;
    in.count = count;
    mapCells(in, cells);
    if (k <= 1) walkVoxels(0, cells, nullptr, count, out);
    else filter(0, nullptr, count);
  } else {  // point lights: the cube face of each point first, then each face's points together
    std::vector<uint32_t>& order = scratch.indices;
    std::vector<uint32_t>& face = scratch.face;
    std::vector<uint32_t> starts(views_.size() + 1, 0);  // then: where each view's run begins in `order`
    for (size_t i = 0; i < count; ++i) {
      out[i] = 0.0f;
      const double* xyz = points.positions + points.positionStride * i;
      const glm::dvec3 position(xyz[0], xyz[1], xyz[2]);
      const int index = finite(position) ? viewIndex(position) : -1;
      face[i] = index < 0 ? kNoView : uint32_t(index);
      if (index >= 0) ++starts[size_t(index) + 1];
    }
    for (size_t v = 0; v < views_.size(); ++v) starts[v + 1] += starts[v];
    std::vector<uint32_t> fill(starts.begin(), starts.end() - 1);
    for (size_t i = 0; i < count; ++i)
      if (face[i] != kNoView) order[fill[face[i]]++] = uint32_t(i);
    in.spot = nullptr;
    for (uint32_t v = 0; v < views_.size(); ++v) {
      in.mapping = &mappings_[v];
      in.indices = order.data() + starts[v];
      in.count = starts[v + 1] - starts[v];
      mapCells(in, cells);
      if (k <= 1) walkVoxels(v, cells, in.indices, in.count, out);
      else filter(v, in.indices, in.count);
    }
  }
  return {};
}

}  // namespace cpvs
