// The AVX2 path of batch_cells.h: cell_lanes.h's templates on four doubles. Only this file is compiled for
// AVX2 (by CPVS_TARGET_BEGIN_AVX2 below, after the standard headers, so that nothing they define is); mapCells calls it
// only on CPUs that have AVX2. No FMA: the target is plain "avx2", and -ffp-contract=off keeps every multiply
// and add separate, as in the scalar path.
#include "libcpvs/runtime/portability.h"

#if CPVS_X86_VECTOR_PATHS

#include <bit>
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

// Eight floats, for the single-precision mapping (float_cells.h), and their lane masks.
struct FMask8 {
  __m256 bits;
  FMask8() = default;
  FMask8(__m256 b) : bits(b) {}
  explicit FMask8(bool b) : bits(_mm256_castsi256_ps(_mm256_set1_epi32(b ? -1 : 0))) {}
};
inline FMask8 operator&(FMask8 a, FMask8 b) { return _mm256_and_ps(a.bits, b.bits); }
inline FMask8 operator|(FMask8 a, FMask8 b) { return _mm256_or_ps(a.bits, b.bits); }
inline FMask8 operator!(FMask8 a) { return _mm256_xor_ps(a.bits, _mm256_castsi256_ps(_mm256_set1_epi32(-1))); }

struct Float8 {
  __m256 v;
  Float8() = default;
  Float8(__m256 x) : v(x) {}
  explicit Float8(float x) : v(_mm256_set1_ps(x)) {}
  explicit Float8(double x) : v(_mm256_set1_ps(float(x))) {}
};
inline Float8 operator+(Float8 a, Float8 b) { return _mm256_add_ps(a.v, b.v); }
inline Float8 operator-(Float8 a, Float8 b) { return _mm256_sub_ps(a.v, b.v); }
inline Float8 operator*(Float8 a, Float8 b) { return _mm256_mul_ps(a.v, b.v); }
inline Float8 operator/(Float8 a, Float8 b) { return _mm256_div_ps(a.v, b.v); }
inline Float8 operator-(Float8 a) { return _mm256_xor_ps(a.v, _mm256_set1_ps(-0.0f)); }
inline FMask8 operator>(Float8 a, Float8 b) { return _mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ); }
inline FMask8 operator>=(Float8 a, Float8 b) { return _mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ); }
inline FMask8 operator<(Float8 a, Float8 b) { return _mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ); }
inline FMask8 operator<=(Float8 a, Float8 b) { return _mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ); }
inline FMask8 operator==(Float8 a, Float8 b) { return _mm256_cmp_ps(a.v, b.v, _CMP_EQ_OQ); }
inline Float8 laneSelect(FMask8 m, Float8 a, Float8 b) { return _mm256_blendv_ps(b.v, a.v, m.bits); }
inline Float8 laneSqrt(Float8 x) { return _mm256_sqrt_ps(x.v); }
inline Float8 laneAbs(Float8 x) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), x.v); }
inline Float8 laneMax(Float8 a, Float8 b) { return _mm256_max_ps(a.v, b.v); }
inline Float8 laneMin(Float8 a, Float8 b) { return _mm256_min_ps(a.v, b.v); }
inline Float8 laneFloor(Float8 x) { return _mm256_floor_ps(x.v); }
struct FloatBits8 {  // floatLog's decomposition of a normal positive float
  static Float8 mantissaOne(Float8 x) {
    return _mm256_castsi256_ps(_mm256_or_si256(_mm256_and_si256(_mm256_castps_si256(x.v), _mm256_set1_epi32(0x007fffff)),
                                               _mm256_set1_epi32(0x3f800000)));
  }
  static Float8 exponent(Float8 x) {
    const __m256i biased = _mm256_and_si256(_mm256_srli_epi32(_mm256_castps_si256(x.v), 23), _mm256_set1_epi32(0xff));
    return _mm256_cvtepi32_ps(_mm256_sub_epi32(biased, _mm256_set1_epi32(127)));
  }
};

}  // namespace
}  // namespace cpvs

#include "libcpvs/runtime/lanes_x86.h"

namespace cpvs {
namespace {

struct Avx2Lanes {
  using Real = Real4;
  using Mask = Mask4;
  static constexpr size_t kWidth = 4;
  static constexpr bool kPrefetchRecords = true;  // lane_loop.h
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

// Eight points in single precision: two groups of four loaded as Avx2Lanes loads them, their view coordinates
// computed in double exactly as mapToGrid computes them (so that the float bounds start from the double path's
// values), and the offsets from the spot in double as insideSpot takes them; then rounded.
struct FloatAvx2Lanes {
  using Real = Float8;
  using Mask = FMask8;
  using Bits = FloatBits8;
  static constexpr size_t kWidth = 8;
  static constexpr bool kPrefetchRecords = true;  // lane_loop.h
  [[gnu::always_inline]] static __m256 joined(Real4 low, Real4 high) {
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(low.v)), _mm256_cvtpd_ps(high.v), 1);
  }
  // kInterleaved: SurfacePoint records, six doubles in a row (n[l] is p[l] + 3).
  template <bool kInterleaved>
  [[gnu::always_inline]] static void load(const double* const (&p)[8], const double* const (&n)[8],
                                          const ViewMapping& m, const FloatViewMapping& fm, Float8 (&c)[9]) {
    const double* const p0[4] = {p[0], p[1], p[2], p[3]};
    const double* const p1[4] = {p[4], p[5], p[6], p[7]};
    const double* const n0[4] = {n[0], n[1], n[2], n[3]};
    const double* const n1[4] = {n[4], n[5], n[6], n[7]};
    const Coords4 a = kInterleaved ? transpose4(p[0], p[1], p[2], p[3]) : transposeSplit4(p0, n0);
    const Coords4 b = kInterleaved ? transpose4(p[4], p[5], p[6], p[7]) : transposeSplit4(p1, n1);
    for (int i = 0; i < 3; ++i) {
      const auto view = [&](const Coords4& q) {
        return (Real4(m.row[i][0]) * Real4(q.c[0]) + Real4(m.row[i][1]) * Real4(q.c[1])) +
               (Real4(m.row[i][2]) * Real4(q.c[2]) + Real4(m.row[i][3]));
      };
      c[i] = joined(view(a), view(b));
      c[3 + i] = joined(Real4(a.c[3 + i]), Real4(b.c[3 + i]));
      if (fm.spot) {
        const Real4 spot(fm.spotPosition[i]);
        c[6 + i] = joined(Real4(a.c[i]) - spot, Real4(b.c[i]) - spot);
      } else {
        c[6 + i] = Float8(0.0f);
      }
    }
  }
  // Writes lanes [0, lanes) of the certain ones at out[j..]; returns the uncertain lanes' bits.
  static uint32_t store(const FloatCellLanes<Float8, FMask8>& v, const CellBatchOutput& out, size_t j, size_t lanes) {
    alignas(32) int32_t xs[8], ys[8], zs[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(xs), _mm256_cvttps_epi32(v.x.v));
    _mm256_store_si256(reinterpret_cast<__m256i*>(ys), _mm256_cvttps_epi32(v.y.v));
    _mm256_store_si256(reinterpret_cast<__m256i*>(zs), _mm256_cvttps_epi32(v.z.v));
    const unsigned voxel = unsigned(_mm256_movemask_ps(v.voxel.bits)), lit = unsigned(_mm256_movemask_ps(v.lit.bits));
    const uint64_t state = (uint64_t(kSpreadBits[voxel & 15]) | uint64_t(kSpreadBits[voxel >> 4]) << 32) * kCellVoxel +
                           (uint64_t(kSpreadBits[lit & 15]) | uint64_t(kSpreadBits[lit >> 4]) << 32) * kCellLit;
    const uint32_t all = lanes == 8 ? 0xffu : (1u << lanes) - 1;
    if (lanes == 8 && std::endian::native == std::endian::little) {
      std::memcpy(out.x + j, xs, sizeof xs);
      std::memcpy(out.y + j, ys, sizeof ys);
      std::memcpy(out.z + j, zs, sizeof zs);
      std::memcpy(out.state + j, &state, 8);
    } else {
      for (size_t l = 0; l < lanes; ++l) {
        out.x[j + l] = xs[l];
        out.y[j + l] = ys[l];
        out.z[j + l] = zs[l];
        out.state[j + l] = uint8_t(state >> (8 * l));
      }
    }
    return ~unsigned(_mm256_movemask_ps(v.certain.bits)) & all;
  }
};

}  // namespace

namespace detail {

void mapCellsAvx2(const CellBatchInput& in, const CellBatchOutput& out) {
  mapCellsFloatOrDouble<FloatAvx2Lanes, Avx2Lanes>(in, out);
}

}  // namespace detail
}  // namespace cpvs

CPVS_TARGET_END

#endif
