#pragma once
// Compiling one file's functions for a wider instruction set than the rest of the build, the same way with
// GCC and clang. Between CPVS_TARGET_BEGIN_* and CPVS_TARGET_END every function (inline helpers, templates
// and lambdas included) gets the target attribute: GCC through its target pragma, clang through
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
