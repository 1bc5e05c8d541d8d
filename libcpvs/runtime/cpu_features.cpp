// portability.h's CPU features: GCC's and clang's builtin where they have it, CPUID and XGETBV with MSVC.
#include "libcpvs/runtime/portability.h"

#if defined(_MSC_VER) && (defined(_M_X64) || defined(_M_IX86))
#include <immintrin.h>  // _xgetbv
#include <intrin.h>     // __cpuidex
#endif

namespace cpvs::portable {

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
bool cpuHasAvx2() { return __builtin_cpu_supports("avx2"); }
bool cpuHasAvx512f() { return __builtin_cpu_supports("avx512f"); }
#elif defined(_MSC_VER) && (defined(_M_X64) || defined(_M_IX86))
namespace {
// CPUID leaf 7's EBX, and whether the OS saves the AVX (YMM) and AVX-512 (opmask, ZMM) state (XCR0).
bool osSaves(uint64_t bits) {
  int info[4];
  __cpuidex(info, 1, 0);
  const bool osxsave = (info[2] >> 27) & 1;
  return osxsave && (_xgetbv(0) & bits) == bits;
}
int leaf7Ebx() {
  int info[4];
  __cpuidex(info, 0, 0);
  if (info[0] < 7) return 0;
  __cpuidex(info, 7, 0);
  return info[1];
}
}  // namespace
bool cpuHasAvx2() { return osSaves(0x6) && ((leaf7Ebx() >> 5) & 1); }
bool cpuHasAvx512f() { return osSaves(0xE6) && ((leaf7Ebx() >> 16) & 1); }
#else
bool cpuHasAvx2() { return false; }
bool cpuHasAvx512f() { return false; }
#endif

}  // namespace cpvs::portable
