#pragma once
// Enter and exit depth maps rasterised on the CPU: the same triangles (triangle_setup.h), coverage rule
// (vertices snapped to 1/256 texel, texel centres, top-left ties) and lockstep peeling as the GL renderer, in
// passes over per-texel state instead of GL targets (docs/depth-maps.md, "The CPU rasteriser").
#include <memory>

#include "libcpvs/raster/depth_renderer.h"

namespace cpvs {

// How the exit depth's lockstep peel runs. Both give the same maps.
enum class CpuPeel {
  // One pass keeps each texel's nearest closed crossings behind its enter surface and the peel is replayed per
  // texel from them (peel caps up to 3; deeper caps peel in passes).
  Replay,
  // One pass for the enter surface, then one pass over the closed triangles per peel iteration, as the GL
  // renderer does.
  Passes,
};

// The instruction sets the rasteriser is built for; both give the same maps bit for bit.
enum class RasterIsa { Baseline, Avx2 };
// The widest one this CPU runs; the environment variable CPVS_RASTER_ISA=scalar keeps the baseline.
RasterIsa bestRasterIsa();

// `isa` is lowered to what the CPU runs.
std::unique_ptr<DepthRenderer> createCpuDepthRenderer(CpuPeel peel = CpuPeel::Replay, RasterIsa isa = bestRasterIsa());

}  // namespace cpvs
