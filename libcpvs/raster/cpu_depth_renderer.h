#pragma once
// Enter and exit depth maps rasterised on the CPU: the same triangles (triangle_setup.h), coverage rule
// (vertices snapped to 1/256 texel, texel centres, top-left ties) and lockstep peeling as the GL renderer, in
// passes over per-texel state instead of GL targets (docs/depth-maps.md, "The CPU rasteriser").
#include <memory>

#include "libcpvs/raster/depth_renderer.h"

namespace cpvs {

std::unique_ptr<DepthRenderer> createCpuDepthRenderer();

}  // namespace cpvs
