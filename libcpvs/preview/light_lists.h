#pragma once
// Tile light lists computed on the CPU, the way the GPU's light-list passes must (tests compare the two), and
// the per-pixel check that no list misses a light whose influence a pixel lies in.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/preview/frame.h"
#include "libcpvs/runtime/light.h"

namespace cpvs {

// light_cull.glsl's test in C++, operation for operation (doubles, the same order).
bool lightMeetsBox(const Light& light, const glm::dvec3& lo, const glm::dvec3& hi);

// Per tile: the bounds of its covered pixels (positions[i].w != 0), then every light meeting them, in order.
TileLists bruteForceLightLists(const std::vector<glm::vec4>& positions, uint32_t width, uint32_t height,
                               const std::vector<Light>& lights);

// Pixels whose tile's list lacks a light whose influence (withinInfluence) the pixel's position lies in,
// as (pixel index, light index) pairs.
std::vector<std::pair<size_t, uint32_t>> missingLights(const std::vector<glm::vec4>& positions, uint32_t width,
                                                        uint32_t height, const TileLists& lists,
                                                        const std::vector<Light>& lights);

}  // namespace cpvs
