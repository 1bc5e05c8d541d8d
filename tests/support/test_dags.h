#pragma once
// Synthetic depth maps and DAGs shared by the tests of the tiles, the DAG, the format, the lookups and the GPU
// walk.
#include <cstdint>

#include "libcpvs/raster/depth_maps.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs::test {

// A depth map with the structure of real ones: blocky casters at a few depths (mid-air shadow boundaries),
// solids of various thickness, a sloped open surface, single-texel open specks and empty texels. `rect`
// (default: the whole N x N view) is the part returned, so regions of one map can be made separately.
// The same n, seed and rect give the same map.
DepthRegion syntheticDepth(uint32_t n, uint32_t seed, RegionRect rect = {});

// A 16^3 DAG whose leaf parents reference leaves past index 65535 (two-unit references), mixed with
// homogeneous children and one-unit references; leaf masks from a hash. Baked DAGs of test size are too small
// to need two-unit references.
ShadowDag wideReferenceDag();

// An orthographic view whose grid is world space itself: u = x, v = y, s = -z (the light travels along -Z), and
// the directional light that goes with it: the point (x + 0.5, y + 0.5, -(z + 0.5)) looks up voxel (x, y, z).
LightView identityView(uint32_t n);
Light sun();

}  // namespace cpvs::test
