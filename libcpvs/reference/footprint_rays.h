#pragma once
// A ray-traced reference for a filtered lookup: what a K x K PCF lookup estimates, measured with shadow rays
// instead of voxels. The lookup's cell comes from the same rule the runtime uses (lookupCell: the view of the
// point, the bias along the normal, the slice); then shadow rays leave from points spread over the K x K
// texel footprint at that slice, mapped back to world space (gridToWorld), toward the light. The fraction that
// reach the light is the reference's visibility; with one ray per texel centre (raysPerSide = K) it is exactly
// the quantity PCF counts, with the scene's true geometry in place of the voxels. Texels outside the view's
// grid count as lit, as they do for the lookups; a point the lookup answers without the DAG (outside the
// light's influence or the grid, facing away) gets the lookup's answer.
#include <span>

#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

// out[i] for points[i]. raysPerSide s >= 1: s x s rays at the centres of an s x s grid of cells over the
// footprint (s = K: the texel centres). Rays are traced in packets on the calling thread.
void footprintVisibility(const ShadowReference& reference, const LightShadow& shadow,
                         std::span<const SurfacePoint> points, const LookupOptions& options, int raysPerSide,
                         std::span<float> out);

}  // namespace cpvs
