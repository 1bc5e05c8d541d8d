// The AVX-512 path of batch_cells.h: cell_lanes.h's templates on eight doubles. Same rules as
// batch_cells_avx2.cpp (only this file is compiled for AVX-512F, after the standard headers; no FMA, so the
// very operations of the scalar path). Eight lanes take half the instructions per point of four, which lets
// the out-of-order core overlap more points' long chains (a perspective view's divisions, square roots and
// log); on CPUs that split 512-bit operations in two the arithmetic itself costs the same.
#include "libcpvs/runtime/portability.h"

#if CPVS_X86_VECTOR_PATHS

// GCC 12's AVX-512 intrinsics pass _mm512_undefined_*() (`__m512d __Y = __Y;`) as the unused merge operand,
// which -Wmaybe-uninitialized reports wherever they are inlined (a known false positive of GCC 12.0-12.2):
// silence that one warning for this file only.
CPVS_IGNORE_MAYBE_UNINITIALIZED

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include <immintrin.h>


CPVS_TARGET_BEGIN_AVX512F

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs {
namespace {

// Eight lanes of booleans: a mask register's bits.
struct Mask8 {
  __mmask8 bits;
  Mask8() = default;
  Mask8(__mmask8 b) : bits(b) {}
  explicit Mask8(bool b) : bits(b ? 0xff : 0) {}
};
inline Mask8 operator&(Mask8 a, Mask8 b) { return __mmask8(a.bits & b.bits); }
inline Mask8 operator|(Mask8 a, Mask8 b) { return __mmask8(a.bits | b.bits); }
inline Mask8 operator!(Mask8 a) { return __mmask8(~a.bits); }

// Eight doubles.
struct Real8 {
  __m512d v;
  Real8() = default;
  Real8(__m512d x) : v(x) {}
  explicit Real8(double x) : v(_mm512_set1_pd(x)) {}
};
inline Real8 operator+(Real8 a, Real8 b) { return _mm512_add_pd(a.v, b.v); }
inline Real8 operator-(Real8 a, Real8 b) { return _mm512_sub_pd(a.v, b.v); }
inline Real8 operator*(Real8 a, Real8 b) { return _mm512_mul_pd(a.v, b.v); }
inline Real8 operator/(Real8 a, Real8 b) { return _mm512_div_pd(a.v, b.v); }
inline Real8 operator-(Real8 a) {  // the scalar negation: the sign bit flipped
  return _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(a.v), _mm512_set1_epi64(INT64_MIN)));
}
// The scalar comparisons: ordered (false with a NaN), except != (true with a NaN).
inline Mask8 operator>(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ); }
inline Mask8 operator>=(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_GE_OQ); }
inline Mask8 operator<(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ); }
inline Mask8 operator<=(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_LE_OQ); }
inline Mask8 operator==(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_EQ_OQ); }
inline Mask8 operator!=(Real8 a, Real8 b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_NEQ_UQ); }

inline Real8 laneSelect(Mask8 m, Real8 a, Real8 b) { return _mm512_mask_blend_pd(m.bits, b.v, a.v); }
inline Real8 laneSqrt(Real8 x) { return _mm512_sqrt_pd(x.v); }
inline Real8 laneAbs(Real8 x) { return _mm512_abs_pd(x.v); }
// view_mapping.h's mappingLog on eight lanes (see batch_cells_avx2.cpp's).
inline Real8 laneLog(Real8 x) {
  const __m512i bits = _mm512_castpd_si512(x.v);
  const Real8 m1 = _mm512_castsi512_pd(_mm512_or_si512(_mm512_and_si512(bits, _mm512_set1_epi64(0x000fffffffffffffll)),
                                                       _mm512_set1_epi64(0x3ff0000000000000ll)));
  const __m512i biased = _mm512_and_si512(_mm512_srli_epi64(bits, 52), _mm512_set1_epi64(0x7ff));
  const Real8 e1 = Real8(_mm512_sub_pd(_mm512_castsi512_pd(_mm512_or_si512(biased, _mm512_set1_epi64(0x4330000000000000ll))),
                                       _mm512_set1_pd(4503599627370496.0))) -
                   Real8(1023.0);
  const Mask8 high = m1 > Real8(kSqrt2);
  return logOfParts(laneSelect(high, m1 * Real8(0.5), m1), laneSelect(high, e1 + Real8(1.0), e1));
}

}  // namespace
}  // namespace cpvs

#include "libcpvs/runtime/lanes_x86.h"

namespace cpvs {
namespace {

struct Avx512Lanes {
  using Real = Real8;
  using Mask = Mask8;
  static constexpr size_t kWidth = 8;
  static constexpr bool kPrefetchRecords = true;  // lane_loop.h
  static void load(const double* const (&p)[8], Real8 (&c)[6]) {
    const Coords4 lo = transpose4(p[0], p[1], p[2], p[3]), hi = transpose4(p[4], p[5], p[6], p[7]);
    for (int i = 0; i < 6; ++i) c[i] = _mm512_insertf64x4(_mm512_castpd256_pd512(lo.c[i]), hi.c[i], 1);
  }
  static void loadSplit(const double* const (&p)[8], const double* const (&n)[8], Real8 (&c)[6]) {
    const Coords4 lo = transposeSplit4(p, n), hi = transposeSplit4(p + 4, n + 4);
    for (int i = 0; i < 6; ++i) c[i] = _mm512_insertf64x4(_mm512_castpd256_pd512(lo.c[i]), hi.c[i], 1);
  }
  static uint64_t cells(const CellVerdict<Real8, Mask8>& v, int32_t* xs, int32_t* ys, int32_t* zs) {
    _mm256_store_si256(reinterpret_cast<__m256i*>(xs), _mm512_cvttpd_epi32(v.x.v));
    _mm256_store_si256(reinterpret_cast<__m256i*>(ys), _mm512_cvttpd_epi32(v.y.v));
    _mm256_store_si256(reinterpret_cast<__m256i*>(zs), _mm512_cvttpd_epi32(v.z.v));
    const unsigned voxel = v.voxel.bits, lit = v.lit.bits;
    return (uint64_t(kSpreadBits[voxel >> 4]) << 32 | kSpreadBits[voxel & 15u]) * kCellVoxel +
           (uint64_t(kSpreadBits[lit >> 4]) << 32 | kSpreadBits[lit & 15u]) * kCellLit;
  }
};

}  // namespace

namespace detail {

void mapCellsAvx512(const CellBatchInput& in, const CellBatchOutput& out) {
  mapCellsLanes<Avx512Lanes>(in, out);
}

}  // namespace detail
}  // namespace cpvs

CPVS_TARGET_END

#endif
