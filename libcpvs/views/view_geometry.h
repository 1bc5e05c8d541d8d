#pragma once
// The triangles that can reach one light view, in that view's own space (float precision is then relative to
// the light, not to the world origin).
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/views/view_regions.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

struct ViewGeometry {
  std::vector<glm::vec3> positions;      // view space (x, y, z_view), only vertices that are used
  std::vector<uint32_t> closedIndices;   // triangles of closed meshes, CCW = outward-facing front
  std::vector<uint32_t> openIndices;     // triangles of open meshes
  // Per triangle (closed first, then open): grid-space lateral bounds [uMin, uMax] x [vMin, vMax] of the
  // part inside the view, for cheap region culling.
  std::vector<glm::vec4> gridBounds;
  // Alpha-tested triangles (libcpvs/scene/coverage_mask.h); all three empty when the view has none. Per
  // triangle (closed first, then open) the index of its mask in *masks, or -1; per position its mask
  // coordinates. `masks` points into the WorldGeometry the view was gathered from.
  std::vector<int32_t> maskOf;
  std::vector<glm::vec2> maskUvs;
  const std::vector<CoverageMask>* masks = nullptr;
  bool hasMasks() const { return !maskOf.empty(); }
  size_t triangleCount() const { return (closedIndices.size() + openIndices.size()) / 3; }
};

// Keeps the triangles of `world` that intersect the view's volume (lateral extent, depth range, and for
// perspective views the space in front of the light), transformed to view space.
ViewGeometry gatherViewGeometry(const WorldGeometry& world, const LightView& view);

// The subset of `geometry` whose grid bounds overlap the region (with a one-texel guard band).
ViewGeometry cullToRegion(const ViewGeometry& geometry, const RegionRect& rect);

}  // namespace cpvs
