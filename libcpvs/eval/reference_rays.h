#pragma once
// The reference's own speed, measured as the shadow methods' is (throughput.h): Embree occlusion rays per
// second, one thread, one ray per point and light.
#include <span>

#include "libcpvs/reference/shadow_reference.h"

namespace cpvs {

// One rtcOccluded1 ray per point and light.
double raysPerSecond(const ShadowReference& reference, std::span<const Light> lights, std::span<const SurfacePoint> points,
                     double seconds);
// The same rays in 16-wide packets (rtcOccluded16).
double packetRaysPerSecond(const ShadowReference& reference, std::span<const Light> lights,
                           std::span<const SurfacePoint> points, double seconds);

}  // namespace cpvs
