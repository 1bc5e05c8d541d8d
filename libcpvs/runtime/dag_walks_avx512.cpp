// dag_walks.h with AVX-512F: sixteen walks per instruction, 32 bits a lane. Same passes as the scalar
// descendGroup in batch_lookup.cpp: gather the nodes' headers, decode the child's code, write the results of
// the walks that end (scatters), gather the references of the others, compress-store them for the next pass
// and prefetch their nodes, read one pass later.
#include "libcpvs/runtime/portability.h"

#if CPVS_X86_VECTOR_PATHS

// GCC 12's AVX-512 intrinsics pass _mm512_undefined_*() as the unused merge operand, which
// -Wmaybe-uninitialized reports wherever they are inlined (as in batch_cells_avx512.cpp).
CPVS_IGNORE_MAYBE_UNINITIALIZED

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <immintrin.h>


#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {

bool vectorWalksAvailable() { return bestCellIsa() == CellIsa::Avx512; }

}  // namespace cpvs

CPVS_TARGET_BEGIN_AVX512F

namespace cpvs {
namespace {

// Sixteen unsigned 32-bit lanes (a wrapper: __m512i's own operators work on 64-bit lanes).
struct V {
  __m512i v;
  V() = default;
  V(__m512i x) : v(x) {}
};
using M = __mmask16;
constexpr size_t kLanes = 16;

inline V splat(uint32_t x) { return _mm512_set1_epi32(int32_t(x)); }
inline V operator&(V a, V b) { return _mm512_and_si512(a.v, b.v); }
inline V operator|(V a, V b) { return _mm512_or_si512(a.v, b.v); }
inline V operator+(V a, V b) { return _mm512_add_epi32(a.v, b.v); }
inline V operator-(V a, V b) { return _mm512_sub_epi32(a.v, b.v); }
inline V operator<<(V a, unsigned n) { return _mm512_slli_epi32(a.v, n); }
inline V shr(V a, unsigned n) { return _mm512_srli_epi32(a.v, n); }
inline V shr(V a, V n) { return _mm512_srlv_epi32(a.v, n.v); }
inline V shl(V a, V n) { return _mm512_sllv_epi32(a.v, n.v); }
inline M equal(V a, V b) { return _mm512_cmpeq_epi32_mask(a.v, b.v); }
inline V blend(M m, V a, V b) { return _mm512_mask_blend_epi32(m, a.v, b.v); }  // b where m, else a
inline M andNot(M a, M b) { return M(a & ~b); }
inline M laneMask(size_t lanes) { return lanes >= 16 ? M(0xFFFF) : M((1u << lanes) - 1u); }
inline V load(const uint32_t* p, M m) { return _mm512_maskz_loadu_epi32(m, p); }
inline V load(const int32_t* p, M m) { return _mm512_maskz_loadu_epi32(m, p); }
// The lanes of m packed to the front, stored as a whole vector: up to 15 slots past the last kept lane are
// written (kWalkPadding). A compress straight to memory (vpcompressd m512) gives the same slots but is
// microcoded on AMD Zen 4: 23.3 ns a store against 1.7 ns for this pair (benchmarks/compress_store_bench.cpp),
// and the walks take five per sixteen walks and level.
inline void compress(uint32_t* p, M m, V v) { _mm512_storeu_si512(p, _mm512_maskz_compress_epi32(m, v.v)); }
// 32 bits at base + kScale * index[lane] for the lanes of m, 0 elsewhere.
template <int kScale>
inline V gather(M m, V index, const void* base) {
  return _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), m, index.v, base, kScale);
}
inline size_t lanesSet(M m) { return size_t(std::popcount(unsigned(m))); }
// Lanes 8h .. 8h + 7 of v (the indices of eight 64-bit gathers or scatters) and of mask m.
inline __m256i half(V v, int h) { return h ? _mm512_extracti64x4_epi64(v.v, 1) : _mm512_castsi512_si256(v.v); }
inline __mmask8 half(M m, int h) { return __mmask8(m >> (8 * h)); }

// Unit reads: 32 bits gathered at a unit index give that unit and the next, except at the DAG's last unit,
// where the read starts one unit earlier and is shifted down (the caller needs only the low half there: a
// header or a narrow reference), so no lane reads past the array.
struct Units {
  const uint16_t* nodes;
  V last;
  V pair(M m, V index) const {
    const M atLast = equal(index, last);
    const V at = _mm512_mask_sub_epi32(index.v, atLast, index.v, splat(1).v);
    const V v = gather<2>(m, at, nodes);
    return _mm512_mask_srli_epi32(v.v, atLast, v.v, 16);
  }
};

// The lanes of m whose 2-bit child code is a reference (2 or 3).
inline M isReference(M m, V raw) { return _mm512_mask_cmpge_epu32_mask(m, raw.v, splat(2).v); }

// Results of the walks that end, as dag_walks.h's WalkResult says.
template <WalkResult kKind>
struct Results {
  void* slots;
  // Walks ending on a homogeneous child: code 1 shadowed, else lit.
  void homogeneous(M m, size_t, V out, V code) const {
    const M shadowed = equal(code, splat(1));
    if constexpr (kKind == WalkResult::Visibility) {
      const __m512 lit = _mm512_mask_blend_ps(shadowed, _mm512_set1_ps(1.0f), _mm512_setzero_ps());
      _mm512_mask_i32scatter_ps(slots, m, out.v, lit, 4);
    } else {
      for (int h = 0; h < 2; ++h)  // eight 64-bit masks per half
        _mm512_mask_i32scatter_epi64(slots, half(m, h), half(out, h),
                                     _mm512_maskz_set1_epi64(half(shadowed, h), -1), 8);
    }
  }
  // Walks ending in a leaf: leaf index `leaf`, voxel (x, y) in its tile.
  void leaf(const uint64_t* leaves, M m, size_t, V out, V leaf, V x, V y) const {
    if constexpr (kKind == WalkResult::Visibility) {
      const V bit = ((y & splat(7)) << 3) | (x & splat(7));  // bit (y & 7) * 8 + (x & 7) of the leaf
      const V word = gather<4>(m, leaf + leaf + shr(bit, 5), leaves);
      homogeneous(m, 16, out, shr(word, bit & splat(31)) & splat(1));
    } else {
      (void)x, (void)y;
      for (int h = 0; h < 2; ++h) {
        const __m512i mask = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), half(m, h), half(leaf, h), leaves, 8);
        _mm512_mask_i32scatter_epi64(slots, half(m, h), half(out, h), mask, 8);
      }
    }
  }
};

#include "libcpvs/runtime/dag_walk_passes.h"

// Lanes j .. j + 15 (those of m) of a mapped batch: the cell, its state, and the slot of its answer
// (indices[j + lane], or j + lane without an index list).
struct CellLanes16 {
  V x, y, z, state, out;
};
inline CellLanes16 loadCells(const CellBatchOutput& cells, const uint32_t* indices, size_t j, M m) {
  alignas(16) uint8_t stateBytes[16] = {};
  std::copy_n(cells.state + j, lanesSet(m), stateBytes);  // m covers the first lanes
  const V iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  return {load(cells.x + j, m), load(cells.y + j, m), load(cells.z + j, m),
          _mm512_cvtepu8_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(stateBytes))),
          indices ? load(indices + j, m) : iota + splat(uint32_t(j))};
}

// The top-grid entries ((offset << 2) | code) of voxels (x, y, z) in the lanes of m, or the root's entry.
inline V startEntries(const WalkStart& g, M m, V x, V y, V z) {
  const V entry = splat(g.rootEntry);
  if (!g.gridCells) return entry;
  const V sh = splat(g.gridShift);
  const V cell = shl(shr(z, sh), splat(2 * g.gridLevel)) | shl(shr(y, sh), splat(g.gridLevel)) | shr(x, sh);
  return _mm512_mask_i32gather_epi32(entry.v, m, cell.v, g.gridCells, 4);
}

thread_local WalkStorage tVoxelWalks;

}  // namespace

void descendGroupAvx512(const WalkDag& dag, const WalkSet& walks, size_t count, uint32_t startSize, WalkResult kind,
                        void* results) {
  if (kind == WalkResult::Visibility)
    return descend(dag, walks, count, startSize, Results<WalkResult::Visibility>{results});
  descend(dag, walks, count, startSize, Results<WalkResult::TileMask>{results});
}

void walkVoxelsAvx512(const VoxelWalkBatch& b) {
  const WalkStart& g = b.start;
  const WalkSet w = tVoxelWalks.reserve(b.count);
  const Results<WalkResult::Visibility> results{b.answers};
  size_t started = 0;
  for (size_t j = 0; j < b.count; j += 16) {
    const M m = laneMask(b.count - j);
    const auto [x, y, z, state, out] = loadCells(b.cells, b.indices, j, m);
    const V entry = startEntries(g, m, x, y, z);
    const V code = entry & splat(3);
    const M voxel = m & equal(state, splat(kCellVoxel));
    // As walkVoxels: lit for a voxel in a cell that is not shadowed or a lane mapped lit; final unless a walk
    // follows.
    const M lit = (voxel & M(~equal(code, splat(1)))) | equal(state, splat(kCellLit));
    results.homogeneous(m, 16, out, blend(lit, splat(1), splat(0)));
    started = storeWalks(w, started, voxel & equal(code, splat(2)), {x, y, z, shr(entry, 2), out});
  }
  descendFromStart(g, w, started, results);
}

namespace {

// Bits set in each 64-bit lane.
inline __m512i splat64(uint64_t x) { return _mm512_set1_epi64(int64_t(x)); }
inline __m512i popcount64(__m512i v) {
  v = _mm512_sub_epi64(v, _mm512_and_si512(_mm512_srli_epi64(v, 1), splat64(0x5555555555555555ull)));
  v = _mm512_add_epi64(_mm512_and_si512(v, splat64(0x3333333333333333ull)),
                       _mm512_and_si512(_mm512_srli_epi64(v, 2), splat64(0x3333333333333333ull)));
  v = _mm512_and_si512(_mm512_add_epi64(v, _mm512_srli_epi64(v, 4)), splat64(0x0F0F0F0F0F0F0F0Full));
  v = _mm512_add_epi64(v, _mm512_srli_epi64(v, 8));
  v = _mm512_add_epi64(v, _mm512_srli_epi64(v, 16));
  v = _mm512_add_epi64(v, _mm512_srli_epi64(v, 32));
  return _mm512_and_si512(v, splat64(0x7F));
}

inline V maxU(V a, V b) { return _mm512_max_epu32(a.v, b.v); }
inline V minU(V a, V b) { return _mm512_min_epu32(a.v, b.v); }
inline V maxS(V a, V b) { return _mm512_max_epi32(a.v, b.v); }
inline V minS(V a, V b) { return _mm512_min_epi32(a.v, b.v); }
inline __m512i widen(V v, int h) { return _mm512_cvtepu32_epi64(half(v, h)); }  // lanes 8h .. 8h + 7, 64-bit


// The bits of an 8 x 8 tile (bit row * 8 + column) in columns a..b of every row and in rows c..d, for 64-bit
// lanes (kTileSpans' entries, computed: a variable shift by 64 gives 0, so rows up to 7 need no special case).
inline __m512i tileSpan(__m512i a, __m512i b, __m512i c, __m512i d) {
  const __m512i one = _mm512_set1_epi64(1);
  const __m512i below = _mm512_sub_epi64(_mm512_sllv_epi64(one, a), one);  // columns 0 .. a - 1
  __m512i columns = _mm512_andnot_si512(below, _mm512_sub_epi64(_mm512_sllv_epi64(_mm512_set1_epi64(2), b), one));
  columns = _mm512_or_si512(columns, _mm512_slli_epi64(columns, 8));  // the row's byte into every row
  columns = _mm512_or_si512(columns, _mm512_slli_epi64(columns, 16));
  columns = _mm512_or_si512(columns, _mm512_slli_epi64(columns, 32));
  const __m512i upTo = _mm512_sub_epi64(_mm512_sllv_epi64(one, _mm512_slli_epi64(_mm512_add_epi64(d, one), 3)), one);
  const __m512i rows = _mm512_andnot_si512(_mm512_sub_epi64(_mm512_sllv_epi64(one, _mm512_slli_epi64(c, 3)), one), upTo);
  return _mm512_and_si512(columns, rows);
}

thread_local WalkStorage tCornerWalks;
thread_local FootprintStorage tFootprints;
thread_local std::vector<uint64_t> tCornerMasks;

// Step 1 of filterFootprintsAvx512: every lane's answer without the DAG, and the voxel lanes' footprints packed
// into `f`. Returns how many.
size_t packFootprints(const FootprintBatch& b, const FootprintArrays& f) {
  const V h = splat(b.kernelHalf), last = splat(b.start.dag.resolution - 1), zero = splat(0);
  size_t packed = 0;
  for (size_t j = 0; j < b.count; j += 16) {
    const M m = laneMask(b.count - j);
    const auto [x, y, z, state, out] = loadCells(b.cells, b.indices, j, m);
    const M lit = m & equal(state, splat(kCellLit)), voxel = m & equal(state, splat(kCellVoxel));
    // Final unless a walk follows (the scalar filter's out[i] = float(state == kCellLit)).
    _mm512_mask_i32scatter_ps(b.answers, m, out.v, _mm512_maskz_mov_ps(lit, _mm512_set1_ps(1.0f)), 4);
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

void filterFootprintsAvx512(const FootprintBatch& b) {
  const WalkStart& g = b.start;
  const FootprintArrays f = tFootprints.reserve(b.count);
  const size_t n = packFootprints(b, f);
  // Corner q of footprint i: x1 if q & 1 else x0, y1 if q & 2 else y0; its mask in masks[q * n + i].
  const WalkSet w = tCornerWalks.reserve(4 * n);
  if (tCornerMasks.size() < 4 * n) tCornerMasks.resize(4 * n);
  uint64_t* masks = tCornerMasks.data();
  const V iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  size_t started = 0;
  for (size_t i = 0; i < n; i += 16) {
    const M m = laneMask(n - i);
    const FootprintLanes l = loadFootprints(f, i, m);
    const M twoColumns = M(~equal(shr(l.x0, 3), shr(l.x1, 3))), twoRows = M(~equal(shr(l.y0, 3), shr(l.y1, 3)));
    for (uint32_t q = 0; q < 4; ++q) {
      const V x = q & 1u ? l.x1 : l.x0, y = q & 2u ? l.y1 : l.y0;
      // A corner in the same tile as corner 0, 1 or 2 counts nothing (its tile is counted once).
      const M keep = m & (q & 1u ? twoColumns : M(0xFFFF)) & (q & 2u ? twoRows : M(0xFFFF));
      const V entry = startEntries(g, keep, x, y, l.z);
      const V code = entry & splat(3);
      const M shadowed = keep & equal(code, splat(1));
      for (int h = 0; h < 2; ++h)  // the homogeneous answers (0 where not kept), final unless a walk follows
        _mm512_mask_storeu_epi64(masks + q * n + i + 8 * h, half(m, h), _mm512_maskz_set1_epi64(half(shadowed, h), -1));
      started = storeWalks(w, started, keep & equal(code, splat(2)),
                           {x, y, l.z, shr(entry, 2), iota + splat(uint32_t(q * n + i))});
    }
  }
  descendFromStart(g, w, started, Results<WalkResult::TileMask>{masks});
  // Count: each corner's mask AND-ed with the footprint's part of its tile, sixteen footprints per step (their
  // 64-bit masks in two halves of eight); then the answer, float(1 - shadowed / K^2) as the scalar filter's.
  const double kernelArea = double(2 * b.kernelHalf + 1) * double(2 * b.kernelHalf + 1);
  for (size_t i = 0; i < n; i += 16) {
    const M m = laneMask(n - i);
    const FootprintLanes l = loadFootprints(f, i, m);
    __m512i total[2] = {_mm512_setzero_si512(), _mm512_setzero_si512()};
    for (uint32_t q = 0; q < 4; ++q) {
      // The corner tile's origin and the footprint's columns a..b and rows c..d inside it.
      const V ox = (q & 1u ? l.x1 : l.x0) & splat(~7u), oy = (q & 2u ? l.y1 : l.y0) & splat(~7u);
      const V a = maxU(l.x0, ox) - ox, bEnd = minU(l.x1, ox + splat(7)) - ox;
      const V c = maxU(l.y0, oy) - oy, d = minU(l.y1, oy + splat(7)) - oy;
      for (int h = 0; h < 2; ++h) {
        const __m512i tile = tileSpan(widen(a, h), widen(bEnd, h), widen(c, h), widen(d, h));
        const __m512i mask = _mm512_maskz_loadu_epi64(half(m, h), masks + q * n + i + 8 * h);
        total[h] = _mm512_add_epi64(total[h], popcount64(_mm512_and_si512(mask, tile)));
      }
    }
    __m256 value[2];
    for (int h = 0; h < 2; ++h) {
      const __m512d shadowed = _mm512_cvtepi32_pd(_mm512_cvtepi64_epi32(total[h]));
      value[h] = _mm512_cvtpd_ps(_mm512_sub_pd(_mm512_set1_pd(1.0), _mm512_div_pd(shadowed, _mm512_set1_pd(kernelArea))));
    }
    const __m512 values = _mm512_castpd_ps(
        _mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(value[0])), _mm256_castps_pd(value[1]), 1));
    _mm512_mask_i32scatter_ps(b.answers, m, l.out.v, values, 4);
  }
}

}  // namespace cpvs

CPVS_TARGET_END

#else

#include <cstdlib>

#include "libcpvs/runtime/dag_walks.h"

namespace cpvs {
bool vectorWalksAvailable() { return false; }
void descendGroupAvx512(const WalkDag&, const WalkSet&, size_t, uint32_t, WalkResult, void*) {
  std::abort();  // unreachable: vectorWalksAvailable() is false
}
void walkVoxelsAvx512(const VoxelWalkBatch&) { std::abort(); }
void filterFootprintsAvx512(const FootprintBatch&) { std::abort(); }
}  // namespace cpvs

#endif
