// dag_walks.h with NEON (AArch64): four walks per instruction, 32 bits a lane. The same passes as
// dag_walks_avx2.cpp (dag_walk_passes.h) and the scalar descendGroup in batch_lookup.cpp, with the same results
// bit for bit. What NEON lacks is done another way: there is no gather, so the node and leaf reads are four
// loads, each from a lane's own index (masked-off lanes read a safe address and are zeroed); the packing is a
// byte table lookup (TBL) from a table of the sixteen lane masks; the results are stored lane by lane.
#include "libcpvs/runtime/portability.h"

#if CPVS_ARM_NEON_PATHS

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include <arm_neon.h>

#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {
namespace {

// For each 4-bit lane mask, the bytes of its set lanes packed to the front (TBL indices; 0xFF reads 0).
constexpr std::array<std::array<uint8_t, 16>, 16> kPackBytes = [] {
  std::array<std::array<uint8_t, 16>, 16> table{};
  for (uint32_t mask = 0; mask < 16; ++mask) {
    table[mask].fill(0xFF);
    uint32_t kept = 0;
    for (uint32_t lane = 0; lane < 4; ++lane)
      if (mask & (1u << lane)) {
        for (uint32_t b = 0; b < 4; ++b) table[mask][4 * kept + b] = uint8_t(4 * lane + b);
        ++kept;
      }
  }
  return table;
}();

// Four unsigned 32-bit lanes, and a lane mask: all ones in the lanes that are set.
struct V {
  uint32x4_t v;
  V() = default;
  V(uint32x4_t x) : v(x) {}
};
struct M {
  uint32x4_t v;
};
constexpr size_t kLanes = 4;

inline V splat(uint32_t x) { return vdupq_n_u32(x); }
inline V operator&(V a, V b) { return vandq_u32(a.v, b.v); }
inline V operator|(V a, V b) { return vorrq_u32(a.v, b.v); }
inline V operator+(V a, V b) { return vaddq_u32(a.v, b.v); }
inline V operator-(V a, V b) { return vsubq_u32(a.v, b.v); }
// Shifts by a count in a register (USHL: a negative count shifts right, 32 or more gives 0, as AVX2's).
inline V operator<<(V a, unsigned n) { return vshlq_u32(a.v, vdupq_n_s32(int32_t(n))); }
inline V shr(V a, unsigned n) { return vshlq_u32(a.v, vdupq_n_s32(-int32_t(n))); }
inline V shr(V a, V n) { return vshlq_u32(a.v, vnegq_s32(vreinterpretq_s32_u32(n.v))); }
inline V shl(V a, V n) { return vshlq_u32(a.v, vreinterpretq_s32_u32(n.v)); }
inline M operator&(M a, M b) { return {vandq_u32(a.v, b.v)}; }
inline M operator|(M a, M b) { return {vorrq_u32(a.v, b.v)}; }
inline M andNot(M a, M b) { return {vbicq_u32(a.v, b.v)}; }  // a and not b
inline M equal(V a, V b) { return {vceqq_u32(a.v, b.v)}; }
inline V blend(M m, V a, V b) { return vbslq_u32(m.v, b.v, a.v); }  // b where m, else a
inline V iota() {
  static constexpr uint32_t kIota[4] = {0, 1, 2, 3};
  return vld1q_u32(kIota);
}
inline M laneMask(size_t lanes) { return {vcltq_u32(iota().v, splat(uint32_t(std::min<size_t>(lanes, 4))).v)}; }
inline unsigned bits(M m) {
  static constexpr uint32_t kBit[4] = {1, 2, 4, 8};
  return vaddvq_u32(vandq_u32(m.v, vld1q_u32(kBit)));
}
inline size_t lanesSet(M m) { return size_t(std::popcount(bits(m))); }
inline void store(uint32_t (&lanes)[4], V v) { vst1q_u32(lanes, v.v); }
// The lanes of m (the first lanes of a group: laneMask's) read from p; the others read nothing and are 0.
inline V load(const uint32_t* p, M m) {
  if (bits(m) == 15u) return vld1q_u32(p);
  uint32_t lanes[4] = {0, 0, 0, 0};
  for (size_t k = 0; k < lanesSet(m); ++k) lanes[k] = p[k];
  return vld1q_u32(lanes);
}
inline V load(const int32_t* p, M m) { return load(reinterpret_cast<const uint32_t*>(p), m); }
// The lanes of m packed to the front, stored as a whole vector: up to 3 slots past the last kept lane are
// written (within kWalkPadding).
inline void compress(uint32_t* p, M m, V v) {
  const uint8x16_t order = vld1q_u8(kPackBytes[bits(m)].data());
  vst1q_u32(p, vreinterpretq_u32_u8(vqtbl1q_u8(vreinterpretq_u8_u32(v.v), order)));
}
// 32 bits at base + kScale * index[lane] for the lanes of m, 0 elsewhere. Four loads: the lanes outside m read
// at index 0, which the callers guarantee readable (a DAG's first unit pair, a group's first leaf or grid cell).
template <int kScale>
inline V gather(M m, V index, const void* base) {
  uint32_t at[4];
  store(at, blend(m, splat(0), index));
  uint32_t lanes[4];
  const auto* bytes = static_cast<const uint8_t*>(base);
  for (size_t k = 0; k < 4; ++k) std::memcpy(&lanes[k], bytes + size_t(kScale) * at[k], 4);
  return V(vld1q_u32(lanes)) & V(m.v);
}

// Unit reads as in dag_walks_avx2.cpp: 32 bits at a unit index give that unit and the next, except at the DAG's
// last unit, where the read starts one unit earlier and is shifted down.
struct Units {
  const uint16_t* nodes;
  V last;
  V pair(M m, V index) const {
    const M atLast = equal(index, last);
    const V v = gather<2>(m, index - (splat(1) & V(atLast.v)), nodes);
    return blend(atLast, v, shr(v, 16));
  }
};

// The lanes of m whose 2-bit child code is a reference (2 or 3).
inline M isReference(M m, V raw) { return m & equal(raw & splat(2), splat(2)); }

// Stores value[k] at slots[out[k]] for the first `lanes` lanes.
template <class T>
inline void storeLanes(T* slots, size_t lanes, const uint32_t (&out)[4], const T (&value)[4]) {
  if (lanes == 4) {
    for (size_t k = 0; k < 4; ++k) slots[out[k]] = value[k];
  } else {
    for (size_t k = 0; k < lanes; ++k) slots[out[k]] = value[k];
  }
}

// Results, as dag_walks_avx2.cpp's: every lane of the group written at every step, final unless a reference
// follows.
template <WalkResult kKind>
struct Results {
  void* slots;
  void homogeneous(M, size_t lanes, V out, V code) const {
    uint32_t outs[4];
    store(outs, out);
    const M shadowed = equal(code, splat(1));
    if constexpr (kKind == WalkResult::Visibility) {
      float values[4];
      vst1q_f32(values, vreinterpretq_f32_u32(vbicq_u32(vreinterpretq_u32_f32(vdupq_n_f32(1.0f)), shadowed.v)));
      storeLanes(static_cast<float*>(slots), lanes, outs, values);
    } else {
      uint64_t values[4];
      const int32x4_t s = vreinterpretq_s32_u32(shadowed.v);
      vst1q_u64(values, vreinterpretq_u64_s64(vmovl_s32(vget_low_s32(s))));
      vst1q_u64(values + 2, vreinterpretq_u64_s64(vmovl_s32(vget_high_s32(s))));
      storeLanes(static_cast<uint64_t*>(slots), lanes, outs, values);
    }
  }
  // Walks ending in a leaf: leaf index `leaf`, voxel (x, y) in its tile.
  void leaf(const uint64_t* leaves, M m, size_t lanes, V out, V leaf, V x, V y) const {
    if constexpr (kKind == WalkResult::Visibility) {
      const V bit = ((y & splat(7)) << 3) | (x & splat(7));  // bit (y & 7) * 8 + (x & 7) of the leaf
      const V word = gather<4>(m, leaf + leaf + shr(bit, 5), leaves);
      homogeneous(m, lanes, out, shr(word, bit & splat(31)) & splat(1));
    } else {
      (void)x, (void)y, (void)m;
      uint32_t index[4], outs[4];
      store(index, leaf);
      store(outs, out);
      uint64_t values[4] = {0, 0, 0, 0};
      for (size_t k = 0; k < lanes; ++k) values[k] = leaves[index[k]];
      storeLanes(static_cast<uint64_t*>(slots), lanes, outs, values);
    }
  }
};

#include "libcpvs/runtime/dag_walk_passes.h"

// Lanes j .. j + 3 (those of m) of a mapped batch: the cell, its state, and the slot of its answer
// (indices[j + lane], or j + lane without an index list).
struct CellLanes4 {
  V x, y, z, state, out;
};
inline CellLanes4 loadCells(const CellBatchOutput& cells, const uint32_t* indices, size_t j, M m) {
  uint32_t states[4] = {0, 0, 0, 0};
  for (size_t k = 0; k < lanesSet(m); ++k) states[k] = cells.state[j + k];  // m covers the first lanes
  return {load(cells.x + j, m), load(cells.y + j, m), load(cells.z + j, m), vld1q_u32(states),
          indices ? load(indices + j, m) : iota() + splat(uint32_t(j))};
}

// The top-grid entries ((offset << 2) | code) of voxels (x, y, z) in the lanes of m, or the root's entry.
inline V startEntries(const WalkStart& g, M m, V x, V y, V z) {
  const V entry = splat(g.rootEntry);
  if (!g.gridCells) return entry;
  const V sh = splat(g.gridShift);
  const V cell = shl(shr(z, sh), splat(2 * g.gridLevel)) | shl(shr(y, sh), splat(g.gridLevel)) | shr(x, sh);
  return blend(m, entry, gather<4>(m, cell, g.gridCells));
}

thread_local WalkStorage tVoxelWalks;

}  // namespace

void descendGroupNeon(const WalkDag& dag, const WalkSet& walks, size_t count, uint32_t startSize, WalkResult kind,
                      void* results) {
  if (kind == WalkResult::Visibility)
    return descend(dag, walks, count, startSize, Results<WalkResult::Visibility>{results});
  descend(dag, walks, count, startSize, Results<WalkResult::TileMask>{results});
}

void walkVoxelsNeon(const VoxelWalkBatch& b) {
  const WalkStart& g = b.start;
  const WalkSet w = tVoxelWalks.reserve(b.count);
  const Results<WalkResult::Visibility> results{b.answers};
  size_t started = 0;
  for (size_t j = 0; j < b.count; j += 4) {
    const size_t lanes = std::min<size_t>(4, b.count - j);
    const M m = laneMask(lanes);
    const auto [x, y, z, state, out] = loadCells(b.cells, b.indices, j, m);
    const V entry = startEntries(g, m, x, y, z);
    const V code = entry & splat(3);
    const M voxel = m & equal(state, splat(kCellVoxel));
    // As walkVoxels: lit for a voxel in a cell that is not shadowed or a lane mapped lit; final unless a walk
    // follows.
    const M lit = andNot(voxel, equal(code, splat(1))) | equal(state, splat(kCellLit));
    results.homogeneous(m, lanes, out, blend(lit, splat(1), splat(0)));
    started = storeWalks(w, started, voxel & equal(code, splat(2)), {x, y, z, shr(entry, 2), out});
  }
  descendFromStart(g, w, started, results);
}

namespace {

thread_local WalkStorage tCornerWalks;
thread_local FootprintStorage tFootprints;
thread_local std::vector<uint64_t> tCornerMasks;

inline V maxS(V a, V b) { return vreinterpretq_u32_s32(vmaxq_s32(vreinterpretq_s32_u32(a.v), vreinterpretq_s32_u32(b.v))); }
inline V minS(V a, V b) { return vreinterpretq_u32_s32(vminq_s32(vreinterpretq_s32_u32(a.v), vreinterpretq_s32_u32(b.v))); }
inline M allLanes() { return {vdupq_n_u32(~0u)}; }

// Step 1 of filterFootprintsNeon: every lane's answer without the DAG, and the voxel lanes' footprints packed
// into `f`. Returns how many.
size_t packFootprints(const FootprintBatch& b, const FootprintArrays& f) {
  const V h = splat(b.kernelHalf), last = splat(b.start.dag.resolution - 1), zero = splat(0);
  size_t packed = 0;
  for (size_t j = 0; j < b.count; j += 4) {
    const size_t lanes = std::min<size_t>(4, b.count - j);
    const M m = laneMask(lanes);
    const auto [x, y, z, state, out] = loadCells(b.cells, b.indices, j, m);
    const M lit = m & equal(state, splat(kCellLit)), voxel = m & equal(state, splat(kCellVoxel));
    // Final unless a walk follows (the scalar filter's out[i] = float(state == kCellLit)).
    uint32_t outs[4];
    store(outs, out);
    float values[4];
    vst1q_f32(values, vreinterpretq_f32_u32(vandq_u32(lit.v, vreinterpretq_u32_f32(vdupq_n_f32(1.0f)))));
    storeLanes(b.answers, lanes, outs, values);
    compress(f.x0 + packed, voxel, maxS(x - h, zero));  // x and y are below 2^31 - 9: no overflow
    compress(f.x1 + packed, voxel, minS(x + h, last));
    compress(f.y0 + packed, voxel, maxS(y - h, zero));
    compress(f.y1 + packed, voxel, minS(y + h, last));
    compress(f.z + packed, voxel, z);
    compress(f.out + packed, voxel, out);
    packed += lanesSet(voxel);
  }
  return packed;
}

}  // namespace

// The AVX2 filter's steps (filterFootprintsAvx2) four footprints at a time: pack the voxel lanes' footprints,
// walk each distinct corner tile to its mask, count each mask within the footprint's part of its tile (per
// footprint, from the kTileSpans tables and CNT). The answers are the scalar filter's, float(1 - shadowed / K^2).
void filterFootprintsNeon(const FootprintBatch& b) {
  const WalkStart& g = b.start;
  const FootprintArrays f = tFootprints.reserve(b.count);
  const size_t n = packFootprints(b, f);
  // Corner q of footprint i: x1 if q & 1 else x0, y1 if q & 2 else y0; its mask in masks[q * n + i].
  const WalkSet w = tCornerWalks.reserve(4 * n);
  if (tCornerMasks.size() < 4 * n) tCornerMasks.resize(4 * n);
  uint64_t* masks = tCornerMasks.data();
  size_t started = 0;
  for (size_t i = 0; i < n; i += 4) {
    const size_t lanes = std::min<size_t>(4, n - i);
    const M m = laneMask(lanes);
    const FootprintLanes l = loadFootprints(f, i, m);
    const M twoColumns = andNot(allLanes(), equal(shr(l.x0, 3), shr(l.x1, 3)));
    const M twoRows = andNot(allLanes(), equal(shr(l.y0, 3), shr(l.y1, 3)));
    for (uint32_t q = 0; q < 4; ++q) {
      const V x = q & 1u ? l.x1 : l.x0, y = q & 2u ? l.y1 : l.y0;
      // A corner in the same tile as corner 0, 1 or 2 counts nothing (its tile is counted once).
      const M keep = m & (q & 1u ? twoColumns : allLanes()) & (q & 2u ? twoRows : allLanes());
      const V entry = startEntries(g, keep, x, y, l.z);
      const V code = entry & splat(3);
      uint32_t shadowed[4];
      store(shadowed, V((keep & equal(code, splat(1))).v));
      for (size_t k = 0; k < lanes; ++k)  // the homogeneous answers (0 where not kept), final unless a walk follows
        masks[q * n + i + k] = shadowed[k] ? ~uint64_t(0) : 0;
      started = storeWalks(w, started, keep & equal(code, splat(2)),
                           {x, y, l.z, shr(entry, 2), iota() + splat(uint32_t(q * n + i))});
    }
  }
  descendFromStart(g, w, started, Results<WalkResult::TileMask>{masks});
  const double kernelArea = double(2 * b.kernelHalf + 1) * double(2 * b.kernelHalf + 1);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t x0 = f.x0[i], x1 = f.x1[i], y0 = f.y0[i], y1 = f.y1[i];
    uint64_t shadowed = 0;
    for (uint32_t q = 0; q < 4; ++q) {
      // The corner tile's origin and the footprint's columns a..b and rows c..d inside it.
      const uint32_t ox = (q & 1u ? x1 : x0) & ~7u, oy = (q & 2u ? y1 : y0) & ~7u;
      const uint32_t a = std::max(x0, ox) - ox, bEnd = std::min(x1, ox + 7) - ox;
      const uint32_t c = std::max(y0, oy) - oy, d = std::min(y1, oy + 7) - oy;
      const uint64_t tile = kTileSpans.columns[a * 8 + bEnd] & kTileSpans.rows[c * 8 + d];
      shadowed += uint64_t(std::popcount(masks[q * n + i] & tile));
    }
    b.answers[f.out[i]] = float(1.0 - double(shadowed) / kernelArea);
  }
}

}  // namespace cpvs

#else

#include <cstdlib>

#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {
void descendGroupNeon(const WalkDag&, const WalkSet&, size_t, uint32_t, WalkResult, void*) {
  std::abort();  // unreachable: the walks never pick Neon here
}
void walkVoxelsNeon(const VoxelWalkBatch&) { std::abort(); }
void filterFootprintsNeon(const FootprintBatch&) { std::abort(); }
}  // namespace cpvs

#endif
