#pragma once
// The second depth layer a lossy bake reads (docs/lossy.md): per texel, the nearest surface behind the voxels
// its exit must shadow, within one texel around it. No receiver lies in front of that surface, so the texel's
// shadow may start anywhere before it without changing an answer on a surface.
#include <cstdint>

#include "libcpvs/raster/depth_maps.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/views/view_geometry.h"

namespace cpvs {

// Texels around a texel whose surfaces count for it: a lookup's footprint reaches one texel beside its own at
// 3x3 PCF (docs/query.md, "Bias").
inline constexpr int32_t kNextSurfaceReach = 1;
// Slices kept exact in front of the next surface: more than a lookup's bias moves a point toward the light at
// 3x3 PCF (at most 1.3 voxels along depth).
inline constexpr uint32_t kNextSurfaceGuard = 2;

// Fills region.next: for each texel, the slice of the nearest surface (any triangle, either facing) whose depth
// at the texel's centre lies at or past the texel's exit slice, among the triangles that cover the texel or a
// texel beside it (kNextSurfaceReach; a triangle's plane is extended to the texels beside it), each counted
// from its near side (the depth a lookup from a receiver on it can reach). An alpha-tested triangle counts on
// texels it covers only where its mask blocks, and on the texels beside them always. N where there is none.
// Where a counted surface reaches in front of the exit, the slice may be anything up to the exit's: the chains
// use max(exit, next - kNextSurfaceGuard), which is then the exit. A summarised tile's texels count from its
// minExit. `regionGeometry`: the view's triangles culled to the region with their one-texel guard band
// (cullToRegion), as the renderer got them.
void findNextSurfaces(const ViewGeometry& regionGeometry, const LightView& view, DepthRegion& region);

}  // namespace cpvs
