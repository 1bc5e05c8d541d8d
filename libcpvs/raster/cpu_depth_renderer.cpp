// The CPU rasteriser at the build's baseline instruction set, and the choice between it and the AVX2 copy of
// the same passes (cpu_depth_renderer_avx2.cpp): both give the same maps bit for bit (the target is plain AVX2,
// without FMA, so every multiply and add stays separate and rounds as in the baseline).
#define CPVS_RASTER_NAMESPACE baseline
#define CPVS_RASTER_ISA_NAME "baseline"
#include "libcpvs/raster/cpu_depth_renderer_passes.h"

#include <cstdlib>
#include <cstring>

namespace cpvs {

#if defined(__x86_64__) && defined(__GNUC__)
namespace avx2 {
std::unique_ptr<DepthRenderer> createCpuDepthRendererHere(CpuPeel peel);
}  // namespace avx2
#endif

RasterIsa bestRasterIsa() {
  RasterIsa best = RasterIsa::Baseline;
#if defined(__x86_64__) && defined(__GNUC__)
  if (__builtin_cpu_supports("avx2")) best = RasterIsa::Avx2;
#endif
  const char* limit = std::getenv("CPVS_RASTER_ISA");
  if (limit && std::strcmp(limit, "scalar") == 0) best = RasterIsa::Baseline;
  return best;
}

std::unique_ptr<DepthRenderer> createCpuDepthRenderer(CpuPeel peel, RasterIsa isa) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (isa == RasterIsa::Avx2 && __builtin_cpu_supports("avx2")) return avx2::createCpuDepthRendererHere(peel);
#endif
  (void)isa;
  return baseline::createCpuDepthRendererHere(peel);
}

}  // namespace cpvs
