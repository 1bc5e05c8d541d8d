#pragma once
// What the x86 batch kernels (batch_cells_avx2.cpp, batch_cells_avx512.cpp) share besides lane_loop.h: loading
// four points as coordinate vectors, and spreading lane masks to bytes. Included only by those files,
// after their CPVS_TARGET_BEGIN_* (portability.h), and all in an unnamed namespace: each file compiles its own copy for its
// own instruction set, and no copy can stand in for another at link time.
#include <immintrin.h>

#include "libcpvs/runtime/lane_loop.h"

namespace cpvs {
namespace {

// Four points (position and normal, 6 doubles each) as six vectors of one coordinate each: px py pz nx ny nz.
struct Coords4 {
  __m256d c[6];
};
inline Coords4 transpose4(const double* p0, const double* p1, const double* p2, const double* p3) {
  const __m256d r0 = _mm256_loadu_pd(p0), r1 = _mm256_loadu_pd(p1);  // x y z nx
  const __m256d r2 = _mm256_loadu_pd(p2), r3 = _mm256_loadu_pd(p3);
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);  // x0 x1 z0 z1, y0 y1 nx0 nx1
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  const __m256d n02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p0 + 4)), _mm_loadu_pd(p2 + 4), 1);
  const __m256d n13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p1 + 4)), _mm_loadu_pd(p3 + 4), 1);
  return {{_mm256_permute2f128_pd(t0, t2, 0x20), _mm256_permute2f128_pd(t1, t3, 0x20),
           _mm256_permute2f128_pd(t0, t2, 0x31), _mm256_permute2f128_pd(t1, t3, 0x31),
           _mm256_unpacklo_pd(n02, n13), _mm256_unpackhi_pd(n02, n13)}};
}

// Four 3-vectors, each anywhere, as three vectors of one coordinate each (x, y, z). Reads exactly three doubles
// at each address (a fourth could lie past the end of the caller's array).
inline void transpose3x4(const double* v0, const double* v1, const double* v2, const double* v3, __m256d& x,
                         __m256d& y, __m256d& z) {
  const __m256d xy02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(v0)), _mm_loadu_pd(v2), 1);
  const __m256d xy13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(v1)), _mm_loadu_pd(v3), 1);
  x = _mm256_unpacklo_pd(xy02, xy13);  // x0 x1 x2 x3
  y = _mm256_unpackhi_pd(xy02, xy13);
  const __m128d z01 = _mm_loadh_pd(_mm_load_sd(v0 + 2), v1 + 2), z23 = _mm_loadh_pd(_mm_load_sd(v2 + 2), v3 + 2);
  z = _mm256_insertf128_pd(_mm256_castpd128_pd256(z01), z23, 1);
}

// Four points from separate position and normal arrays, as transpose4 gives them.
inline Coords4 transposeSplit4(const double* const* p, const double* const* n) {
  Coords4 t;
  transpose3x4(p[0], p[1], p[2], p[3], t.c[0], t.c[1], t.c[2]);
  transpose3x4(n[0], n[1], n[2], n[3], t.c[3], t.c[4], t.c[5]);
  return t;
}

// Bit l of a 4-bit lane mask spread to byte l (little-endian: byte l of the stored word is lane l).
constexpr uint32_t kSpreadBits[16] = {0x00000000, 0x00000001, 0x00000100, 0x00000101, 0x00010000, 0x00010001,
                                      0x00010100, 0x00010101, 0x01000000, 0x01000001, 0x01000100, 0x01000101,
                                      0x01010000, 0x01010001, 0x01010100, 0x01010101};

}  // namespace
}  // namespace cpvs
