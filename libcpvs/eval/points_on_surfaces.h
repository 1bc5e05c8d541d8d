#pragma once
// Whether query points lie on the surfaces of the scene they are scored against. Points sampled on one level
// and queried against another level's bake and scene give an error figure that means nothing (often 0 %:
// outside every light both sides answer 0), so cpvs-query checks a sample of them (docs/query.md).
#include <cstddef>
#include <span>
#include <vector>

#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/scene/surface_proximity.h"

namespace cpvs {

// A point farther than this many voxels from every surface is off the scene. A voxel is the largest edge of
// the voxel at the point in the first light view covering it; the radius is never under kOffSurfaceFloor of
// the scene's diagonal (positions stored in float, or rebuilt from a depth buffer, stray that far), nor over
// kOffSurfaceCeiling of it (coarse views: the test stays a few triangles per point).
inline constexpr double kOffSurfaceVoxels = 4.0;
inline constexpr double kOffSurfaceFloor = 1e-4;
inline constexpr double kOffSurfaceCeiling = 1e-2;
// How many points a check looks at, at most.
inline constexpr size_t kSurfaceCheckPoints = 4096;

struct SurfaceCheck {
  size_t checked = 0;     // finite points looked at
  size_t offSurface = 0;  // of them, off every surface
  // "Most" points off the scene: a warning's worth.
  bool mostOff() const { return checked > 0 && 2 * offSurface > checked; }
};

// Checks up to `most` of `points`, spread evenly over them, against `scene`, with the voxels of `lights`' views.
SurfaceCheck checkPointsOnSurfaces(const SurfaceProximity& scene, const std::vector<const LightShadow*>& lights,
                                   std::span<const SurfacePoint> points, size_t most = kSurfaceCheckPoints);

// The largest edge, in world units, of the voxel of `view` at `world` (the grid is not uniform in perspective
// views, nor in depth).
double voxelEdgeAt(const LightView& view, const glm::dvec3& world);

}  // namespace cpvs
