// The AVX2 path of batch_cells.h: cell_lanes.h's templates on four doubles. Only this file is compiled for
// AVX2 (by CPVS_TARGET_BEGIN_AVX2 below, after the standard headers, so that nothing they define is); mapCells calls it
// only on CPUs that have AVX2. No FMA: the target is plain "avx2", and -ffp-contract=off keeps every multiply
// and add separate, as in the scalar path.
#include "libcpvs/runtime/portability.h"

#if CPVS_X86_VECTOR_PATHS

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include <immintrin.h>


CPVS_TARGET_BEGIN_AVX2

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs {
namespace {

// Four lanes of booleans (all bits set or clear per lane).
struct Mask4 {
  __m256d bits;
  Mask4() = default;
  Mask4(__m256d b) : bits(b) {}
  explicit Mask4(bool b) : bits(_mm256_castsi256_pd(_mm256_set1_epi64x(b ? -1 : 0))) {}
};
inline Mask4 operator&(Mask4 a, Mask4 b) { return _mm256_and_pd(a.bits, b.bits); }
inline Mask4 operator|(Mask4 a, Mask4 b) { return _mm256_or_pd(a.bits, b.bits); }
inline Mask4 operator!(Mask4 a) { return _mm256_xor_pd(a.bits, _mm256_castsi256_pd(_mm256_set1_epi64x(-1))); }

// Four doubles.
struct Real4 {
  __m256d v;
  Real4() = default;
  Real4(__m256d x) : v(x) {}
  explicit Real4(double x) : v(_mm256_set1_pd(x)) {}
};
inline Real4 operator+(Real4 a, Real4 b) { return _mm256_add_pd(a.v, b.v); }
inline Real4 operator-(Real4 a, Real4 b) { return _mm256_sub_pd(a.v, b.v); }
inline Real4 operator*(Real4 a, Real4 b) { return _mm256_mul_pd(a.v, b.v); }
inline Real4 operator/(Real4 a, Real4 b) { return _mm256_div_pd(a.v, b.v); }
inline Real4 operator-(Real4 a) { return _mm256_xor_pd(a.v, _mm256_set1_pd(-0.0)); }  // the scalar negation
// The scalar comparisons: ordered (false with a NaN), except != (true with a NaN).
inline Mask4 operator>(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ); }
inline Mask4 operator>=(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ); }
inline Mask4 operator<(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ); }
inline Mask4 operator<=(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_LE_OQ); }
inline Mask4 operator==(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_EQ_OQ); }
inline Mask4 operator!=(Real4 a, Real4 b) { return _mm256_cmp_pd(a.v, b.v, _CMP_NEQ_UQ); }

inline Real4 laneSelect(Mask4 m, Real4 a, Real4 b) { return _mm256_blendv_pd(b.v, a.v, m.bits); }
inline Real4 laneSqrt(Real4 x) { return _mm256_sqrt_pd(x.v); }
inline Real4 laneAbs(Real4 x) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x.v); }
// view_mapping.h's mappingLog on four lanes: the same exact decomposition (the exponent converted through
// the 2^52 trick, exact for 0..2047), then the shared polynomial.
inline Real4 laneLog(Real4 x) {
  const __m256i bits = _mm256_castpd_si256(x.v);
  const Real4 m1 = _mm256_castsi256_pd(_mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi64x(0x000fffffffffffffll)),
                                                       _mm256_set1_epi64x(0x3ff0000000000000ll)));
  const __m256i biased = _mm256_and_si256(_mm256_srli_epi64(bits, 52), _mm256_set1_epi64x(0x7ff));
  const Real4 e1 = Real4(_mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(biased, _mm256_set1_epi64x(0x4330000000000000ll))),
                                       _mm256_set1_pd(4503599627370496.0))) -
                   Real4(1023.0);
  const Mask4 high = m1 > Real4(kSqrt2);
  return logOfParts(laneSelect(high, m1 * Real4(0.5), m1), laneSelect(high, e1 + Real4(1.0), e1));
}

}  // namespace
}  // namespace cpvs

#include "libcpvs/runtime/lanes_x86.h"

namespace cpvs {
namespace {

struct Avx2Lanes {
  using Real = Real4;
  using Mask = Mask4;
  static constexpr size_t kWidth = 4;
  static void load(const double* const (&p)[4], Real4 (&c)[6]) {
    const Coords4 t = transpose4(p[0], p[1], p[2], p[3]);
    for (int i = 0; i < 6; ++i) c[i] = t.c[i];
  }
  static void loadSplit(const double* const (&p)[4], const double* const (&n)[4], Real4 (&c)[6]) {
    const Coords4 t = transposeSplit4(p, n);
    for (int i = 0; i < 6; ++i) c[i] = t.c[i];
  }
  static uint64_t cells(const CellVerdict<Real4, Mask4>& v, int32_t* xs, int32_t* ys, int32_t* zs) {
    _mm_store_si128(reinterpret_cast<__m128i*>(xs), _mm256_cvttpd_epi32(v.x.v));
    _mm_store_si128(reinterpret_cast<__m128i*>(ys), _mm256_cvttpd_epi32(v.y.v));
    _mm_store_si128(reinterpret_cast<__m128i*>(zs), _mm256_cvttpd_epi32(v.z.v));
    return kSpreadBits[_mm256_movemask_pd(v.voxel.bits)] * kCellVoxel +
           kSpreadBits[_mm256_movemask_pd(v.lit.bits)] * kCellLit;
  }
};

}  // namespace

namespace detail {

void mapCellsAvx2(const CellBatchInput& in, const CellBatchOutput& out) {
  mapCellsLanes<Avx2Lanes>(in, out);
}

}  // namespace detail
}  // namespace cpvs

CPVS_TARGET_END

#endif
