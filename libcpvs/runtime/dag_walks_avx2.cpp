// dag_walks.h with AVX2: eight walks per instruction, 32 bits a lane, for the CPUs without AVX-512 (AMD Zen 2
// and 3, Intel's client chips since 2021). The same passes as dag_walks_avx512.cpp and the scalar descendGroup
// in batch_lookup.cpp: gather the nodes' headers, decode the child's code, write the results of the walks that
// end, gather the references of the others, pack them for the next pass and prefetch their nodes, read one
// pass later. What AVX2 lacks is done another way: masks are vectors of all-ones lanes; the packing is a
// permutation from a table (no compress); the results are stored lane by lane (no scatter).
#include "libcpvs/runtime/portability.h"

#if CPVS_X86_VECTOR_PATHS

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <immintrin.h>


#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {
namespace {

// For each 8-bit lane mask, the indices of its set lanes packed to the front (3 bits each, lane k's index at
// bits 3k): the permutation that stands in for a compress. Computed once, 1 KiB.
constexpr std::array<uint32_t, 256> kPackOrder = [] {
  std::array<uint32_t, 256> table{};
  for (uint32_t mask = 0; mask < 256; ++mask) {
    uint32_t packed = 0, kept = 0;
    for (uint32_t lane = 0; lane < 8; ++lane)
      if (mask & (1u << lane)) packed |= lane << (3 * kept++);
    table[mask] = packed;
  }
  return table;
}();

}  // namespace
}  // namespace cpvs

CPVS_TARGET_BEGIN_AVX2

namespace cpvs {
namespace {

// Eight unsigned 32-bit lanes (a wrapper: __m256i's own operators work on 64-bit lanes), and a lane mask: all
// ones in the lanes that are set.
struct V {
  __m256i v;
  V() = default;
  V(__m256i x) : v(x) {}
};
struct M {
  __m256i v;
};
constexpr size_t kLanes = 8;

inline V splat(uint32_t x) { return _mm256_set1_epi32(int32_t(x)); }
inline V operator&(V a, V b) { return _mm256_and_si256(a.v, b.v); }
inline V operator|(V a, V b) { return _mm256_or_si256(a.v, b.v); }
inline V operator+(V a, V b) { return _mm256_add_epi32(a.v, b.v); }
inline V operator-(V a, V b) { return _mm256_sub_epi32(a.v, b.v); }
inline V operator<<(V a, unsigned n) { return _mm256_slli_epi32(a.v, int(n)); }
inline V shr(V a, unsigned n) { return _mm256_srli_epi32(a.v, int(n)); }
inline V shr(V a, V n) { return _mm256_srlv_epi32(a.v, n.v); }
inline V shl(V a, V n) { return _mm256_sllv_epi32(a.v, n.v); }
inline M operator&(M a, M b) { return {_mm256_and_si256(a.v, b.v)}; }
inline M operator|(M a, M b) { return {_mm256_or_si256(a.v, b.v)}; }
inline M andNot(M a, M b) { return {_mm256_andnot_si256(b.v, a.v)}; }  // a and not b
inline M equal(V a, V b) { return {_mm256_cmpeq_epi32(a.v, b.v)}; }
inline V blend(M m, V a, V b) { return _mm256_blendv_epi8(a.v, b.v, m.v); }  // b where m, else a
inline V iota() { return _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7); }
inline M laneMask(size_t lanes) { return {_mm256_cmpgt_epi32(splat(uint32_t(std::min<size_t>(lanes, 8))).v, iota().v)}; }
inline unsigned bits(M m) { return unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(m.v))); }
inline size_t lanesSet(M m) { return size_t(std::popcount(bits(m))); }
// Masked lanes read nothing (a masked load does not fault), and are 0.
inline V load(const uint32_t* p, M m) { return _mm256_maskload_epi32(reinterpret_cast<const int*>(p), m.v); }
inline V load(const int32_t* p, M m) { return _mm256_maskload_epi32(p, m.v); }
// The lanes of m packed to the front, stored as a whole vector: up to 7 slots past the last kept lane are
// written (within kWalkPadding).
inline void compress(uint32_t* p, M m, V v) {
  const V order = shr(splat(kPackOrder[bits(m)]), _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21)) & splat(7);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), _mm256_permutevar8x32_epi32(v.v, order.v));
}
// 32 bits at base + kScale * index[lane] for the lanes of m, 0 elsewhere.
template <int kScale>
inline V gather(M m, V index, const void* base) {
  return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), static_cast<const int*>(base), index.v, m.v, kScale);
}
inline void store(uint32_t (&lanes)[8], V v) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(lanes), v.v); }

// Unit reads as in dag_walks_avx512.cpp: 32 bits gathered at a unit index give that unit and the next, except at
// the DAG's last unit, where the read starts one unit earlier and is shifted down.
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

// Stores value[k] at slots[out[k]] for the first `lanes` lanes: one store a lane, no branch on the values (AVX2
// has no scatter).
template <class T>
inline void storeLanes(T* slots, size_t lanes, const uint32_t (&out)[8], const T (&value)[8]) {
  if (lanes == 8) {
    for (size_t k = 0; k < 8; ++k) slots[out[k]] = value[k];
  } else {
    for (size_t k = 0; k < lanes; ++k) slots[out[k]] = value[k];
  }
}

// Results, as dag_walks.h's WalkResult says, for the first `lanes` lanes (the walks of a group). As the scalar
// walks do, every walk's result is written at every step, final unless a reference follows: a store per lane
// whatever the codes, where storing only the walks that end took a branch per lane that mispredicts.
template <WalkResult kKind>
struct Results {
  void* slots;
  // Code 1 shadowed, else lit; every lane of the group, not only the `ending` ones.
  void homogeneous(M, size_t lanes, V out, V code) const {
    uint32_t outs[8];
    store(outs, out);
    const M shadowed = equal(code, splat(1));
    if constexpr (kKind == WalkResult::Visibility) {
      alignas(32) float values[8];
      _mm256_store_ps(values, _mm256_castsi256_ps(_mm256_andnot_si256(shadowed.v, _mm256_castps_si256(_mm256_set1_ps(1.0f)))));
      storeLanes(static_cast<float*>(slots), lanes, outs, values);
    } else {
      alignas(32) uint64_t values[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(values), _mm256_cvtepi32_epi64(_mm256_castsi256_si128(shadowed.v)));
      _mm256_store_si256(reinterpret_cast<__m256i*>(values + 4), _mm256_cvtepi32_epi64(_mm256_extracti128_si256(shadowed.v, 1)));
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
      (void)x, (void)y;
      alignas(32) uint64_t values[8];
      const __m128i low = _mm256_castsi256_si128(leaf.v), high = _mm256_extracti128_si256(leaf.v, 1);
      const __m256i lowMask = _mm256_cvtepi32_epi64(_mm256_castsi256_si128(m.v));
      const __m256i highMask = _mm256_cvtepi32_epi64(_mm256_extracti128_si256(m.v, 1));
      const auto* base = reinterpret_cast<const long long*>(leaves);
      _mm256_store_si256(reinterpret_cast<__m256i*>(values),
                         _mm256_mask_i32gather_epi64(_mm256_setzero_si256(), base, low, lowMask, 8));
      _mm256_store_si256(reinterpret_cast<__m256i*>(values + 4),
                         _mm256_mask_i32gather_epi64(_mm256_setzero_si256(), base, high, highMask, 8));
      uint32_t outs[8];
      store(outs, out);
      storeLanes(static_cast<uint64_t*>(slots), lanes, outs, values);
    }
  }
};

#include "libcpvs/runtime/dag_walk_passes.h"

// Lanes j .. j + 7 (those of m) of a mapped batch: the cell, its state, and the slot of its answer
// (indices[j + lane], or j + lane without an index list).
struct CellLanes8 {
  V x, y, z, state, out;
};
inline CellLanes8 loadCells(const CellBatchOutput& cells, const uint32_t* indices, size_t j, M m) {
  alignas(8) uint8_t stateBytes[8] = {};
  std::copy_n(cells.state + j, lanesSet(m), stateBytes);  // m covers the first lanes
  return {load(cells.x + j, m), load(cells.y + j, m), load(cells.z + j, m),
          _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(stateBytes))),
          indices ? load(indices + j, m) : iota() + splat(uint32_t(j))};
}

// The top-grid entries ((offset << 2) | code) of voxels (x, y, z) in the lanes of m, or the root's entry.
inline V startEntries(const WalkStart& g, M m, V x, V y, V z) {
  const V entry = splat(g.rootEntry);
  if (!g.gridCells) return entry;
  const V sh = splat(g.gridShift);
  const V cell = shl(shr(z, sh), splat(2 * g.gridLevel)) | shl(shr(y, sh), splat(g.gridLevel)) | shr(x, sh);
  return _mm256_mask_i32gather_epi32(entry.v, reinterpret_cast<const int*>(g.gridCells), cell.v, m.v, 4);
}

thread_local WalkStorage tVoxelWalks;

}  // namespace

void descendGroupAvx2(const WalkDag& dag, const WalkSet& walks, size_t count, uint32_t startSize, WalkResult kind,
                      void* results) {
  if (kind == WalkResult::Visibility)
    return descend(dag, walks, count, startSize, Results<WalkResult::Visibility>{results});
  descend(dag, walks, count, startSize, Results<WalkResult::TileMask>{results});
}

void walkVoxelsAvx2(const VoxelWalkBatch& b) {
  const WalkStart& g = b.start;
  const WalkSet w = tVoxelWalks.reserve(b.count);
  const Results<WalkResult::Visibility> results{b.answers};
  size_t started = 0;
  for (size_t j = 0; j < b.count; j += 8) {
    const size_t lanes = std::min<size_t>(8, b.count - j);
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

// 64-bit lanes, four to an AVX2 vector: half h of eight 32-bit lanes widened, a footprint's masks counted.
inline __m256i widen(V v, int h) {
  return _mm256_cvtepu32_epi64(h ? _mm256_extracti128_si256(v.v, 1) : _mm256_castsi256_si128(v.v));
}
inline __m256i widenMask(M m, int h) {  // all-ones 32-bit lanes to all-ones 64-bit lanes
  return _mm256_cvtepi32_epi64(h ? _mm256_extracti128_si256(m.v, 1) : _mm256_castsi256_si128(m.v));
}
// Bits set in each 64-bit lane: a nibble table per byte, summed per lane (AVX2 has no 64-bit popcount).
inline __m256i popcount64(__m256i v) {
  const __m256i table = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1, 2,
                                         2, 3, 2, 3, 3, 4);
  const __m256i nibble = _mm256_set1_epi8(0x0F);
  const __m256i low = _mm256_shuffle_epi8(table, _mm256_and_si256(v, nibble));
  const __m256i high = _mm256_shuffle_epi8(table, _mm256_and_si256(_mm256_srli_epi16(v, 4), nibble));
  return _mm256_sad_epu8(_mm256_add_epi8(low, high), _mm256_setzero_si256());
}
inline V maxU(V a, V b) { return _mm256_max_epu32(a.v, b.v); }
inline V minU(V a, V b) { return _mm256_min_epu32(a.v, b.v); }
inline V maxS(V a, V b) { return _mm256_max_epi32(a.v, b.v); }
inline V minS(V a, V b) { return _mm256_min_epi32(a.v, b.v); }
inline M allLanes() { return {_mm256_set1_epi32(-1)}; }

// As dag_walks_avx512.cpp's tileSpan, four 64-bit lanes: the bits of an 8 x 8 tile in columns a..b of every row
// and in rows c..d (a variable shift by 64 gives 0, so rows up to 7 need no special case).
inline __m256i tileSpan(__m256i a, __m256i b, __m256i c, __m256i d) {
  const __m256i one = _mm256_set1_epi64x(1);
  const __m256i below = _mm256_sub_epi64(_mm256_sllv_epi64(one, a), one);
  __m256i columns = _mm256_andnot_si256(below, _mm256_sub_epi64(_mm256_sllv_epi64(_mm256_set1_epi64x(2), b), one));
  columns = _mm256_or_si256(columns, _mm256_slli_epi64(columns, 8));
  columns = _mm256_or_si256(columns, _mm256_slli_epi64(columns, 16));
  columns = _mm256_or_si256(columns, _mm256_slli_epi64(columns, 32));
  const __m256i upTo = _mm256_sub_epi64(_mm256_sllv_epi64(one, _mm256_slli_epi64(_mm256_add_epi64(d, one), 3)), one);
  const __m256i rows = _mm256_andnot_si256(_mm256_sub_epi64(_mm256_sllv_epi64(one, _mm256_slli_epi64(c, 3)), one), upTo);
  return _mm256_and_si256(columns, rows);
}

thread_local WalkStorage tCornerWalks;
thread_local FootprintStorage tFootprints;
thread_local std::vector<uint64_t> tCornerMasks;

// Step 1 of filterFootprintsAvx2: every lane's answer without the DAG, and the voxel lanes' footprints packed
// into `f`. Returns how many.
size_t packFootprints(const FootprintBatch& b, const FootprintArrays& f) {
  const V h = splat(b.kernelHalf), last = splat(b.start.dag.resolution - 1), zero = splat(0);
  size_t packed = 0;
  for (size_t j = 0; j < b.count; j += 8) {
    const size_t lanes = std::min<size_t>(8, b.count - j);
    const M m = laneMask(lanes);
    const auto [x, y, z, state, out] = loadCells(b.cells, b.indices, j, m);
    const M lit = m & equal(state, splat(kCellLit)), voxel = m & equal(state, splat(kCellVoxel));
    // Final unless a walk follows (the scalar filter's out[i] = float(state == kCellLit)).
    uint32_t outs[8];
    store(outs, out);
    alignas(32) float values[8];
    _mm256_store_ps(values, _mm256_and_ps(_mm256_castsi256_ps(lit.v), _mm256_set1_ps(1.0f)));
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

// The AVX-512 filter's steps (filterFootprintsAvx512) eight footprints at a time: pack the voxel lanes'
// footprints, walk each distinct corner tile to its mask, count each mask within the footprint's part of its
// tile. The answers are computed per lane as the scalar filter's, float(1 - shadowed / K^2).
void filterFootprintsAvx2(const FootprintBatch& b) {
  const WalkStart& g = b.start;
  const FootprintArrays f = tFootprints.reserve(b.count);
  const size_t n = packFootprints(b, f);
  // Corner q of footprint i: x1 if q & 1 else x0, y1 if q & 2 else y0; its mask in masks[q * n + i].
  const WalkSet w = tCornerWalks.reserve(4 * n);
  if (tCornerMasks.size() < 4 * n) tCornerMasks.resize(4 * n);
  uint64_t* masks = tCornerMasks.data();
  size_t started = 0;
  for (size_t i = 0; i < n; i += 8) {
    const size_t lanes = std::min<size_t>(8, n - i);
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
      const M shadowed = keep & equal(code, splat(1));
      for (int h = 0; h < 2; ++h)  // the homogeneous answers (0 where not kept), final unless a walk follows
        _mm256_maskstore_epi64(reinterpret_cast<long long*>(masks + q * n + i + 4 * h), widenMask(m, h),
                               widenMask(shadowed, h));
      started = storeWalks(w, started, keep & equal(code, splat(2)),
                           {x, y, l.z, shr(entry, 2), iota() + splat(uint32_t(q * n + i))});
    }
  }
  descendFromStart(g, w, started, Results<WalkResult::TileMask>{masks});
  const double kernelArea = double(2 * b.kernelHalf + 1) * double(2 * b.kernelHalf + 1);
  for (size_t i = 0; i < n; i += 8) {
    const size_t lanes = std::min<size_t>(8, n - i);
    const M m = laneMask(lanes);
    const FootprintLanes l = loadFootprints(f, i, m);
    __m256i total[2] = {_mm256_setzero_si256(), _mm256_setzero_si256()};
    for (uint32_t q = 0; q < 4; ++q) {
      // The corner tile's origin and the footprint's columns a..b and rows c..d inside it.
      const V ox = (q & 1u ? l.x1 : l.x0) & splat(~7u), oy = (q & 2u ? l.y1 : l.y0) & splat(~7u);
      const V a = maxU(l.x0, ox) - ox, bEnd = minU(l.x1, ox + splat(7)) - ox;
      const V c = maxU(l.y0, oy) - oy, d = minU(l.y1, oy + splat(7)) - oy;
      for (int h = 0; h < 2; ++h) {
        const __m256i tile = tileSpan(widen(a, h), widen(bEnd, h), widen(c, h), widen(d, h));
        const __m256i mask = _mm256_maskload_epi64(reinterpret_cast<const long long*>(masks + q * n + i + 4 * h),
                                                   widenMask(m, h));
        total[h] = _mm256_add_epi64(total[h], popcount64(_mm256_and_si256(mask, tile)));
      }
    }
    alignas(32) uint64_t shadowed[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(shadowed), total[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(shadowed + 4), total[1]);
    float values[8];
    for (size_t k = 0; k < 8; ++k) values[k] = float(1.0 - double(shadowed[k]) / kernelArea);
    uint32_t outs[8];
    store(outs, l.out);
    storeLanes(b.answers, lanes, outs, values);
  }
}

}  // namespace cpvs

CPVS_TARGET_END

#else

#include <cstdlib>

#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {
void descendGroupAvx2(const WalkDag&, const WalkSet&, size_t, uint32_t, WalkResult, void*) {
  std::abort();  // unreachable: walkIsa() is never Avx2 here
}
void walkVoxelsAvx2(const VoxelWalkBatch&) { std::abort(); }
void filterFootprintsAvx2(const FootprintBatch&) { std::abort(); }
}  // namespace cpvs

#endif
