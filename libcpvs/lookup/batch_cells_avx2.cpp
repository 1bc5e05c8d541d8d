// The AVX2 path of batch_cells.h: cell_lanes.h's templates on four doubles. Only this file is compiled for
// AVX2 (by the pragma below, after the standard headers, so that nothing they define is); mapCells calls it
// only on CPUs that have AVX2. No FMA: the target is plain "avx2", and -ffp-contract=off keeps every multiply
// and add separate, as in the scalar path.
#if defined(__x86_64__) && defined(__GNUC__)

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include <immintrin.h>

#pragma GCC push_options
#pragma GCC target("avx2")

#include "libcpvs/lookup/batch_cells.h"

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

// Bit l of a 4-bit lane mask spread to byte l (little-endian: byte l of the stored word is lane l).
constexpr uint32_t kSpreadBits[16] = {0x00000000, 0x00000001, 0x00000100, 0x00000101, 0x00010000, 0x00010001,
                                      0x00010100, 0x00010101, 0x01000000, 0x01000001, 0x01000100, 0x01000101,
                                      0x01010000, 0x01010001, 0x01010100, 0x01010101};

// Four points (position and normal, 6 doubles each) as six vectors of one coordinate each.
struct Points4 {
  Real4 px, py, pz, nx, ny, nz;
};
inline Points4 transpose(const double* p0, const double* p1, const double* p2, const double* p3) {
  const __m256d r0 = _mm256_loadu_pd(p0), r1 = _mm256_loadu_pd(p1);  // x y z nx
  const __m256d r2 = _mm256_loadu_pd(p2), r3 = _mm256_loadu_pd(p3);
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);  // x0 x1 z0 z1, y0 y1 nx0 nx1
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  const __m256d n02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p0 + 4)), _mm_loadu_pd(p2 + 4), 1);
  const __m256d n13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p1 + 4)), _mm_loadu_pd(p3 + 4), 1);
  return {_mm256_permute2f128_pd(t0, t2, 0x20), _mm256_permute2f128_pd(t1, t3, 0x20),
          _mm256_permute2f128_pd(t0, t2, 0x31), _mm256_permute2f128_pd(t1, t3, 0x31),
          _mm256_unpacklo_pd(n02, n13), _mm256_unpackhi_pd(n02, n13)};
}

}  // namespace

namespace detail {

namespace {

template <class Shape>
void mapCellsShaped(const CellBatchInput& in, const CellBatchOutput& out) {
  // Local copies: the byte stores to out.state could alias *in.mapping, which would make the compiler reload
  // every constant in every iteration.
  const ViewMapping mapping = *in.mapping;
  const CellSettings settings = in.settings;
  const SpotInfluence spot = in.spot ? *in.spot : SpotInfluence{};
  const SpotInfluence* spotOrNull = in.spot ? &spot : nullptr;
  const double* const points = in.points;
  const uint32_t* const indices = in.indices;
  auto pointAt = [&](size_t j) { return points + 6 * size_t(indices ? indices[j] : j); };
  for (size_t j = 0; j < in.count; j += 4) {
    const size_t lanes = in.count - j < 4 ? in.count - j : 4;
    // A short last group repeats its last point in the unused lanes (read, never stored).
    const double* p[4];
    for (size_t l = 0; l < 4; ++l) p[l] = pointAt(j + (l < lanes ? l : lanes - 1));
    const Points4 q = transpose(p[0], p[1], p[2], p[3]);
    const CellVerdict<Real4, Mask4> v =
        cellVerdict<Real4, Mask4, Shape>(mapping, settings, spotOrNull, q.px, q.py, q.pz, q.nx, q.ny, q.nz);
    const __m128i x = _mm256_cvttpd_epi32(v.x.v), y = _mm256_cvttpd_epi32(v.y.v), z = _mm256_cvttpd_epi32(v.z.v);
    const uint32_t state = kSpreadBits[_mm256_movemask_pd(v.voxel.bits)] * kCellVoxel +
                           kSpreadBits[_mm256_movemask_pd(v.lit.bits)] * kCellLit;  // one byte per lane
    if (lanes == 4) {
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out.x + j), x);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out.y + j), y);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out.z + j), z);
      std::memcpy(out.state + j, &state, 4);
      continue;
    }
    alignas(16) int32_t xs[4], ys[4], zs[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(xs), x);
    _mm_store_si128(reinterpret_cast<__m128i*>(ys), y);
    _mm_store_si128(reinterpret_cast<__m128i*>(zs), z);
    for (size_t l = 0; l < lanes; ++l) {
      out.x[j + l] = xs[l];
      out.y[j + l] = ys[l];
      out.z[j + l] = zs[l];
      out.state[j + l] = uint8_t(state >> (8 * l));
    }
  }
}

}  // namespace

void mapCellsAvx2(const CellBatchInput& in, const CellBatchOutput& out) {
  withFixedShape(*in.mapping, [&](auto shape) { mapCellsShaped<decltype(shape)>(in, out); });
}

}  // namespace detail
}  // namespace cpvs

#pragma GCC pop_options

#endif
