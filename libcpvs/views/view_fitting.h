#pragma once
// Fitting a light's views to the scene: the extent and depth range of each view come from the geometry the
// light actually reaches (its range and cone), never from a hand-set box.
#include <cstdint>
#include <vector>

#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/scene/triangle_bvh.h"

namespace cpvs {

// Builds the views of a light, fitted to the geometry it reaches (x/y extent and near/far), docs/architecture.md, "The voxel convention"
// Directional: 1 orthographic; spot: 1 perspective (field of view from the outer cone); point: 6 cube faces.
// With `index` (built over `geometry`), only the triangles near what the light can reach are looked at: the same
// views, at a cost that follows the light's reach instead of the scene's size.
std::vector<LightView> makeLightViews(const Light& light, const WorldGeometry& geometry, uint32_t resolution,
                                      const TriangleBvh* index = nullptr);

// The edge of the view's largest voxel in scene units: at the far plane (the farthest geometry the view holds),
// the larger of its lateral extent and its depth (logarithmic slices are deepest there).
double largestVoxelSize(const LightView& view);

// The resolution that gives every one of `views` (fitted at `maxResolution`) voxels of at most `voxelSize`:
// the smallest power of two that does, from 8 up to `maxResolution` (which caps it). Views without geometry
// need 8.
uint32_t resolutionForVoxelSize(const std::vector<LightView>& views, double voxelSize, uint32_t maxResolution);

}  // namespace cpvs
