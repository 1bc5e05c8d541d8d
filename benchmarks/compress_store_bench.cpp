// Why the AVX-512 walks compact in a register (libcpvs/runtime/dag_walks_avx512.cpp, `compress`): the same
// sixteen-lane compaction of 65 536 values (about half of each vector kept) written with vpcompressd straight to
// memory, and with vpcompressd into a register followed by an ordinary 64-byte store. On AMD Zen 4 the first
// form is microcoded. Time per 16-lane compaction is items_per_second's inverse.
//
//   build/bin/compress_store_bench
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

namespace {

constexpr size_t kValues = 65536;

std::vector<uint32_t> values() {
  std::vector<uint32_t> v(kValues);
  for (size_t i = 0; i < v.size(); ++i) v[i] = uint32_t(i * 2654435761u);
  return v;
}

template <bool kToMemory>
__attribute__((target("avx512f"))) size_t compact(const std::vector<uint32_t>& in, std::vector<uint32_t>& out) {
  size_t at = 0;
  for (size_t i = 0; i < in.size(); i += 16) {
    const __m512i v = _mm512_loadu_si512(in.data() + i);
    const __mmask16 keep = _mm512_cmpgt_epu32_mask(v, _mm512_set1_epi32(0x7fffffff));
    if constexpr (kToMemory) _mm512_mask_compressstoreu_epi32(out.data() + at, keep, v);
    else _mm512_storeu_si512(out.data() + at, _mm512_maskz_compress_epi32(keep, v));
    at += size_t(__builtin_popcount(keep));
  }
  return at;
}

template <bool kToMemory>
void compaction(benchmark::State& state) {
  if (!__builtin_cpu_supports("avx512f")) {
    state.SkipWithError("no AVX-512F on this CPU");
    return;
  }
  const std::vector<uint32_t> in = values();
  std::vector<uint32_t> out(kValues + 16);
  for (auto _ : state) benchmark::DoNotOptimize(compact<kToMemory>(in, out));
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(kValues / 16));
}

void CompressStoreToMemory(benchmark::State& state) { compaction<true>(state); }
void CompressInRegisterThenStore(benchmark::State& state) { compaction<false>(state); }
BENCHMARK(CompressStoreToMemory);
BENCHMARK(CompressInRegisterThenStore);

}  // namespace

#endif
