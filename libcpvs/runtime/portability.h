#pragma once
// What differs between compilers and systems, in one place, so that the rest of the runtime is standard C++20:
// which vector paths are compiled and how a function is compiled for a wider instruction set, the CPU's
// features, prefetching, the POPCNT copies of the hot walks, a diagnostic GCC gets wrong, and mapping a file.
// Nothing else in libcpvs/runtime/ names a compiler builtin, attribute, pragma or system call
// (tests/layering_check.py fails on one).
//
// Tested: GCC 12 and clang 14 on x86-64 Linux, MinGW-w64's GCC 12 with its Windows file mapping under Wine, and
// GCC 12 on AArch64 under qemu, its NEON mapping included (tests/runtime_cross_test.sh). Written as the
// compilers' documentation says, not yet built here: MSVC (x64, ARM64) (docs/runtime.md, "Compilers and systems").
//
// Standard headers only: the vector files include it before their CPVS_TARGET_BEGIN_* line, and it must not
// pull anything into that range.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

// x86-64 with GCC or clang: the AVX2 and AVX-512 paths are compiled (for their targets, below) and chosen at run
// time. Elsewhere (MSVC, other CPUs) only the scalar path is compiled, and the NEON one on AArch64 (below).
#if (defined(__x86_64__) || defined(_M_X64)) && defined(__GNUC__)
#define CPVS_X86_VECTOR_PATHS 1
#else
#define CPVS_X86_VECTOR_PATHS 0
#endif
// AArch64 with GCC or clang: the NEON paths (Advanced SIMD, part of every ARMv8-A CPU, so compiled for the
// build's own target and always chosen unless CPVS_LOOKUP_ISA lowers it). MSVC on ARM64 runs the scalar paths.
#if defined(__aarch64__) && defined(__ARM_NEON) && defined(__GNUC__)
#define CPVS_ARM_NEON_PATHS 1
#else
#define CPVS_ARM_NEON_PATHS 0
#endif

// Compiling one file's functions for a wider instruction set than the rest of the build, the same way with GCC
// and clang. Between CPVS_TARGET_BEGIN_* and CPVS_TARGET_END every function (inline helpers, templates and
// lambdas included) gets the target attribute: GCC through its target pragma, clang through
// `#pragma clang attribute`, which applies __attribute__((target)) to each function declared in the range.
// The callers check the CPU first (bestCellIsa in batch_cells.h). Standard headers go before the BEGIN line,
// so that nothing they define is compiled for the wider target.
#if defined(__clang__)
#define CPVS_TARGET_BEGIN_AVX2 _Pragma("clang attribute push(__attribute__((target(\"avx2\"))), apply_to = function)")
#define CPVS_TARGET_BEGIN_AVX512F \
  _Pragma("clang attribute push(__attribute__((target(\"avx512f\"))), apply_to = function)")
#define CPVS_TARGET_END _Pragma("clang attribute pop")
#elif defined(__GNUC__)
#define CPVS_TARGET_BEGIN_AVX2 _Pragma("GCC push_options") _Pragma("GCC target(\"avx2\")")
#define CPVS_TARGET_BEGIN_AVX512F _Pragma("GCC push_options") _Pragma("GCC target(\"avx512f\")")
#define CPVS_TARGET_END _Pragma("GCC pop_options")
#endif

// The hot walks compiled twice, with and without POPCNT, the loader picking the POPCNT copy where the CPU has it
// (nearly every x86-64): the build targets baseline x86-64, where a population count is a libgcc call. GCC
// only (clang has no target_clones before 14, and its popcount without POPCNT is inline); an ELF feature
// (ifunc), so not on Windows.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__POPCNT__) && defined(__ELF__)
#define CPVS_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define CPVS_POPCNT_CLONES
#endif

// GCC 12 warns "may be used uninitialized" on AVX-512 mask intrinsics whose masked-off lanes are never read.
#if defined(__GNUC__) && !defined(__clang__)
#define CPVS_IGNORE_MAYBE_UNINITIALIZED _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"")
#else
#define CPVS_IGNORE_MAYBE_UNINITIALIZED
#endif

// Lane masks combined with & on purpose (no branches): where Mask is bool, clang suggests &&.
#if defined(__clang__)
#define CPVS_BITWISE_LOGIC_BEGIN \
  _Pragma("clang diagnostic push") _Pragma("clang diagnostic ignored \"-Wbitwise-instead-of-logical\"")
#define CPVS_BITWISE_LOGIC_END _Pragma("clang diagnostic pop")
#else
#define CPVS_BITWISE_LOGIC_BEGIN
#define CPVS_BITWISE_LOGIC_END
#endif

#if defined(_MSC_VER) && (defined(_M_X64) || defined(_M_IX86))
#include <xmmintrin.h>  // _mm_prefetch
#endif

namespace cpvs::portable {

// Asks for the cache line holding `p` (for reading, kept in every level); a hint, never a fault.
inline void prefetchRead(const void* p) {
#if defined(__GNUC__)
  __builtin_prefetch(p, 0, 3);
#elif defined(_MSC_VER) && (defined(_M_X64) || defined(_M_IX86))
  _mm_prefetch(static_cast<const char*>(p), _MM_HINT_T0);
#else
  (void)p;
#endif
}

// Whether this CPU (and its operating system, for the wider registers' state) runs AVX2 / AVX-512F code.
bool cpuHasAvx2();
bool cpuHasAvx512f();

// A file read-only in memory: mapped (POSIX mmap, Windows file mapping), or read whole where neither exists.
// Move-only; the bytes stay valid until it is destroyed. The file must not be truncated meanwhile (SIGBUS, as
// with any mapping).
class ReadOnlyFile {
public:
  ReadOnlyFile() = default;
  ~ReadOnlyFile();
  ReadOnlyFile(ReadOnlyFile&& other) noexcept;
  ReadOnlyFile& operator=(ReadOnlyFile&& other) noexcept;
  ReadOnlyFile(const ReadOnlyFile&) = delete;
  ReadOnlyFile& operator=(const ReadOnlyFile&) = delete;

  // Opens `path`, which must be a regular file (a FIFO does not block the open). False with `error` set to
  // "cannot open: <reason>", "cannot stat: <reason>", "not a regular file" or "cannot map: <reason>".
  bool open(const std::string& path, std::string& error);
  // At least 8-byte aligned (a mapping is page-aligned); null for an empty file.
  const uint8_t* data() const { return data_; }
  uint64_t size() const { return size_; }

private:
  void release();
  const uint8_t* data_ = nullptr;
  uint64_t size_ = 0;
  void* mapping_ = nullptr;       // the mapped view, or null
  void* mappingHandle_ = nullptr; // Windows: the file-mapping object
  std::vector<uint64_t> owned_;   // the bytes read where nothing maps (uint64_t: 8-byte aligned)
};

}  // namespace cpvs::portable
