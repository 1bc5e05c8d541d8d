// The NEON path of batch_cells.h (AArch64): cell_lanes.h's templates on four doubles, held as two 128-bit
// vectors of two (NEON's widest for doubles; four lanes give the core two independent chains per operation).
// Every operation is the scalar path's IEEE operation (add, subtract, multiply, divide, square root, compare),
// lane by lane and in the same order; built with -ffp-contract=off (runtime_sources.cmake) nothing is fused, so
// the answers are the scalar path's bit for bit (tests/runtime_cross_test.sh compares both under qemu).
#include "libcpvs/runtime/portability.h"

#if CPVS_ARM_NEON_PATHS

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include <arm_neon.h>

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs {
namespace {

// Four lanes of booleans (all bits set or clear per lane), lanes 0-1 in lo, 2-3 in hi.
struct MaskN {
  uint64x2_t lo, hi;
  MaskN() = default;
  MaskN(uint64x2_t l, uint64x2_t h) : lo(l), hi(h) {}
  explicit MaskN(bool b) : lo(vdupq_n_u64(b ? ~uint64_t(0) : 0)), hi(lo) {}
};
inline MaskN operator&(MaskN a, MaskN b) { return {vandq_u64(a.lo, b.lo), vandq_u64(a.hi, b.hi)}; }
inline MaskN operator|(MaskN a, MaskN b) { return {vorrq_u64(a.lo, b.lo), vorrq_u64(a.hi, b.hi)}; }
inline uint64x2_t not64(uint64x2_t a) { return vreinterpretq_u64_u32(vmvnq_u32(vreinterpretq_u32_u64(a))); }
inline MaskN operator!(MaskN a) { return {not64(a.lo), not64(a.hi)}; }

// Four doubles.
struct RealN {
  float64x2_t lo, hi;
  RealN() = default;
  RealN(float64x2_t l, float64x2_t h) : lo(l), hi(h) {}
  explicit RealN(double x) : lo(vdupq_n_f64(x)), hi(lo) {}
};
inline RealN operator+(RealN a, RealN b) { return {vaddq_f64(a.lo, b.lo), vaddq_f64(a.hi, b.hi)}; }
inline RealN operator-(RealN a, RealN b) { return {vsubq_f64(a.lo, b.lo), vsubq_f64(a.hi, b.hi)}; }
inline RealN operator*(RealN a, RealN b) { return {vmulq_f64(a.lo, b.lo), vmulq_f64(a.hi, b.hi)}; }
inline RealN operator/(RealN a, RealN b) { return {vdivq_f64(a.lo, b.lo), vdivq_f64(a.hi, b.hi)}; }
inline RealN operator-(RealN a) { return {vnegq_f64(a.lo), vnegq_f64(a.hi)}; }  // the sign bit flipped, as scalar
// The scalar comparisons: ordered (false with a NaN), except != (true with a NaN).
inline MaskN operator>(RealN a, RealN b) { return {vcgtq_f64(a.lo, b.lo), vcgtq_f64(a.hi, b.hi)}; }
inline MaskN operator>=(RealN a, RealN b) { return {vcgeq_f64(a.lo, b.lo), vcgeq_f64(a.hi, b.hi)}; }
inline MaskN operator<(RealN a, RealN b) { return {vcltq_f64(a.lo, b.lo), vcltq_f64(a.hi, b.hi)}; }
inline MaskN operator<=(RealN a, RealN b) { return {vcleq_f64(a.lo, b.lo), vcleq_f64(a.hi, b.hi)}; }
inline MaskN operator==(RealN a, RealN b) { return {vceqq_f64(a.lo, b.lo), vceqq_f64(a.hi, b.hi)}; }
inline MaskN operator!=(RealN a, RealN b) { return !(a == b); }

inline RealN laneSelect(MaskN m, RealN a, RealN b) { return {vbslq_f64(m.lo, a.lo, b.lo), vbslq_f64(m.hi, a.hi, b.hi)}; }
inline RealN laneSqrt(RealN x) { return {vsqrtq_f64(x.lo), vsqrtq_f64(x.hi)}; }
inline RealN laneAbs(RealN x) { return {vabsq_f64(x.lo), vabsq_f64(x.hi)}; }
// view_mapping.h's mappingLog on two lanes: the exact decomposition of batch_cells_avx2.cpp's laneLog (the
// exponent converted through the 2^52 trick, exact for 0..2047).
inline float64x2_t mantissaOne(float64x2_t x) {
  const uint64x2_t bits = vreinterpretq_u64_f64(x);
  return vreinterpretq_f64_u64(
      vorrq_u64(vandq_u64(bits, vdupq_n_u64(0x000fffffffffffffull)), vdupq_n_u64(0x3ff0000000000000ull)));
}
inline float64x2_t exponentOf(float64x2_t x) {
  const uint64x2_t biased = vandq_u64(vshrq_n_u64(vreinterpretq_u64_f64(x), 52), vdupq_n_u64(0x7ff));
  const float64x2_t big = vreinterpretq_f64_u64(vorrq_u64(biased, vdupq_n_u64(0x4330000000000000ull)));
  return vsubq_f64(big, vdupq_n_f64(4503599627370496.0));
}
inline RealN laneLog(RealN x) {
  const RealN m1{mantissaOne(x.lo), mantissaOne(x.hi)};
  const RealN e1 = RealN{exponentOf(x.lo), exponentOf(x.hi)} - RealN(1023.0);
  const MaskN high = m1 > RealN(kSqrt2);
  return logOfParts(laneSelect(high, m1 * RealN(0.5), m1), laneSelect(high, e1 + RealN(1.0), e1));
}

}  // namespace
}  // namespace cpvs

#include "libcpvs/runtime/lane_loop.h"

namespace cpvs {
namespace {

// Two points' coordinate c and c + 1 (of six doubles each) as one vector of each.
inline void pairOf(const double* a, const double* b, float64x2_t& first, float64x2_t& second) {
  const float64x2_t ra = vld1q_f64(a), rb = vld1q_f64(b);
  first = vzip1q_f64(ra, rb);
  second = vzip2q_f64(ra, rb);
}
// Two 3-vectors as x, y, z vectors; reads exactly three doubles at each address.
inline void threeOf(const double* a, const double* b, float64x2_t& x, float64x2_t& y, float64x2_t& z) {
  pairOf(a, b, x, y);
  z = vsetq_lane_f64(b[2], vdupq_n_f64(a[2]), 1);
}
// Mask lanes (all ones or zero) as one byte each, 0 or 1: byte l of the result is lane l.
inline uint32_t laneBytes(MaskN m) {
  const uint32x4_t words = vcombine_u32(vmovn_u64(m.lo), vmovn_u64(m.hi));
  const uint8x8_t bytes = vmovn_u16(vcombine_u16(vmovn_u32(words), vdup_n_u16(0)));
  return vget_lane_u32(vreinterpret_u32_u8(bytes), 0) & 0x01010101u;
}
inline int32x4_t truncated(RealN v) {
  return vcombine_s32(vmovn_s64(vcvtq_s64_f64(v.lo)), vmovn_s64(vcvtq_s64_f64(v.hi)));
}

struct NeonLanes {
  using Real = RealN;
  using Mask = MaskN;
  static constexpr size_t kWidth = 4;
  static void load(const double* const (&p)[4], RealN (&c)[6]) {
    for (int i = 0; i < 6; i += 2) {
      pairOf(p[0] + i, p[1] + i, c[i].lo, c[i + 1].lo);
      pairOf(p[2] + i, p[3] + i, c[i].hi, c[i + 1].hi);
    }
  }
  static void loadSplit(const double* const (&p)[4], const double* const (&n)[4], RealN (&c)[6]) {
    threeOf(p[0], p[1], c[0].lo, c[1].lo, c[2].lo);
    threeOf(p[2], p[3], c[0].hi, c[1].hi, c[2].hi);
    threeOf(n[0], n[1], c[3].lo, c[4].lo, c[5].lo);
    threeOf(n[2], n[3], c[3].hi, c[4].hi, c[5].hi);
  }
  // x, y and z are 0 outside the voxel lanes and in [0, 2^31) inside: truncation toward zero is the scalar
  // int32_t conversion.
  static uint64_t cells(const CellVerdict<RealN, MaskN>& v, int32_t* xs, int32_t* ys, int32_t* zs) {
    vst1q_s32(xs, truncated(v.x));
    vst1q_s32(ys, truncated(v.y));
    vst1q_s32(zs, truncated(v.z));
    return uint64_t(laneBytes(v.voxel)) * kCellVoxel + uint64_t(laneBytes(v.lit)) * kCellLit;
  }
};

}  // namespace

namespace detail {

void mapCellsNeon(const CellBatchInput& in, const CellBatchOutput& out) { mapCellsLanes<NeonLanes>(in, out); }

}  // namespace detail
}  // namespace cpvs

#else

#include <cstdlib>

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs::detail {
void mapCellsNeon(const CellBatchInput&, const CellBatchOutput&) {
  std::abort();  // unreachable: bestCellIsa() is never Neon here
}
}  // namespace cpvs::detail

#endif
