#pragma once
// The triangles that can reach one light view, in that view's own space (float precision is then relative to
// the light, not to the world origin).
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/views/view_regions.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/scene/triangle_bvh.h"

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
// With `index` (built over `world`), only the triangles near the view's volume are looked at (same result).
ViewGeometry gatherViewGeometry(const WorldGeometry& world, const LightView& view, const TriangleBvh* index = nullptr);

// The world-space box around the view-space points `corners` (a view's volume), grown by `margin`: triangles
// outside it cannot reach the volume.
void worldBoxOf(const LightView& view, const std::vector<glm::dvec3>& corners, double margin, glm::dvec3& lo,
                glm::dvec3& hi);

// The triangles `index` finds near the view-space volume spanned by `corners`, or every triangle without an
// index (or without corners: an unbounded volume).
std::vector<uint32_t> trianglesNear(const WorldGeometry& world, const LightView& view,
                                    const std::vector<glm::dvec3>& corners, const TriangleBvh* index);

// The subset of `geometry` whose grid bounds overlap the region (with a one-texel guard band).
ViewGeometry cullToRegion(const ViewGeometry& geometry, const RegionRect& rect);
// The same subset, looking only at `candidates` (triangle indices, closed first then open, ascending) instead of
// every triangle: with binToRegions, the view's triangles are visited once for all its regions.
ViewGeometry cullToRegion(const ViewGeometry& geometry, const RegionRect& rect, const std::vector<uint32_t>& candidates);
// Per region of splitIntoRegions(resolution, regionSize), the indices of the triangles whose grid bounds may
// overlap it with its guard band (ascending; a superset of what cullToRegion keeps there).
std::vector<std::vector<uint32_t>> binToRegions(const ViewGeometry& geometry, uint32_t resolution, uint32_t regionSize);

}  // namespace cpvs
