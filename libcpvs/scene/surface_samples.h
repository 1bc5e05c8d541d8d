#pragma once
// Deterministic, area-weighted random points on a scene's surfaces, with their outward normals: the test
// points of cpvs-query's accuracy checks, the demo and the speed-vs-error sweep.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/scene/scene.h"

namespace cpvs {

struct SurfaceSample {
  glm::dvec3 position;
  glm::dvec3 normal;  // unit geometric normal of the triangle, front side (counter-clockwise winding)
};

// `count` points, each on a triangle chosen with probability proportional to its area, uniform within it.
// The same geometry, count and seed give the same points on every machine (no std:: distributions: their
// algorithms are implementation-defined). Degenerate triangles are never chosen. Empty when the geometry
// has no area. Never on a cut-away texel of an alpha-tested triangle (fewer than `count` points only when
// nearly all the area is cut away).
std::vector<SurfaceSample> sampleSurfaces(const WorldGeometry& world, size_t count, uint64_t seed);

}  // namespace cpvs
