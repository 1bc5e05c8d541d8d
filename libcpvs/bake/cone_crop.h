#pragma once
// A spot light's view is a square frustum around its round cone. Points outside the cone are outside the
// light's influence: every lookup returns "unlit" there without reading the DAG (runtime withinInfluence). So
// the texels whose rays leave the cone by more than a margin are never read, and the bake leaves their voxels
// free: nothing to render there, and the DAG compresses them away (docs/many-lights.md, "Only what a light needs").
#include <cstdint>

#include "libcpvs/raster/depth_maps.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"

namespace cpvs {

// Texels a lookup inside the cone may still read beyond it: half of the widest PCF kernel kept exact (33 x 33)
// plus the normal-offset bias (a few voxels).
inline constexpr double kConeMarginTexels = 24;

struct ConeCrop {
  bool active = false;     // a spot light whose cone is narrower than its view
  double radius = 0;       // in the view's lateral units (x/d, y/d): tan(outer cone) plus the margin
  // Whether no texel of the region lies within the radius: the region needs no rendering at all.
  bool regionOutside(const LightView& view, const RegionRect& rect) const;
  // A region all free, for one wholly outside (nothing rendered).
  static DepthRegion freeRegion(const LightView& view, const RegionRect& rect);
  // Per row of the region, the texels within the radius (each row's are contiguous): what the renderer must
  // render. Inactive: every texel.
  RowSpans inside(const LightView& view, const RegionRect& rect) const;
  // Leaves every texel of `region` outside `inside` free (enter 0, exit N: all voxels but the first may be
  // either); returns how many.
  static uint64_t freeOutside(const RowSpans& inside, DepthRegion& region);
};

ConeCrop coneCropOf(const Light& light, const LightView& view);

}  // namespace cpvs
