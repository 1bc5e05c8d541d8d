#include "libcpvs/preview/light_lists.h"

#include <algorithm>
#include <cmath>

#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

bool lightMeetsBox(const Light& light, const glm::dvec3& lo, const glm::dvec3& hi) {
  if (!hasRange(light)) return true;
  const glm::dvec3 p = light.position, dir = light.direction;
  const glm::dvec3 gap = glm::max(lo - p, glm::dvec3(0.0)) + glm::max(p - hi, glm::dvec3(0.0));
  const double gap2 = (gap.x * gap.x + gap.y * gap.y) + gap.z * gap.z;
  if (gap2 > light.range * light.range * 1.000001) return false;
  const double cosOuter = hasCone(light) ? spotInfluence(light).cosOuter : -1.0;
  const double sinOuter = std::sin(std::min(light.outerConeAngle, 3.14159265358979323846 / 2));
  if (!hasCone(light) || cosOuter <= 0.0) return true;
  const glm::dvec3 centre = 0.5 * (lo + hi), size = hi - lo;
  const double radius = 0.5 * std::sqrt((size.x * size.x + size.y * size.y) + size.z * size.z) * 1.000001 +
                        1e-9 * ((std::fabs(centre.x) + std::fabs(centre.y)) + std::fabs(centre.z) + 1.0);
  const glm::dvec3 toCentre = centre - p;
  const double along = (toCentre.x * dir.x + toCentre.y * dir.y) + toCentre.z * dir.z;
  const double length2 = (toCentre.x * toCentre.x + toCentre.y * toCentre.y) + toCentre.z * toCentre.z;
  const double across = std::sqrt(std::max(length2 - along * along, 0.0));
  const double side = cosOuter * across - along * sinOuter;
  if (side > radius) return false;
  return along >= -radius;
}

TileLists bruteForceLightLists(const std::vector<glm::vec4>& positions, uint32_t width, uint32_t height,
                               const std::vector<Light>& lights) {
  TileLists lists;
  lists.tilesX = (width + kTileSize - 1) / kTileSize;
  lists.tilesY = (height + kTileSize - 1) / kTileSize;
  lists.offsets.assign(lists.tiles() + 1, 0);
  for (uint32_t ty = 0; ty < lists.tilesY; ++ty)
    for (uint32_t tx = 0; tx < lists.tilesX; ++tx) {
      glm::vec3 lo(3.0e38f), hi(-3.0e38f);
      bool covered = false;
      for (uint32_t y = ty * kTileSize; y < std::min(height, (ty + 1) * kTileSize); ++y)
        for (uint32_t x = tx * kTileSize; x < std::min(width, (tx + 1) * kTileSize); ++x) {
          const glm::vec4& p = positions[size_t(y) * width + x];
          if (p.w == 0.0f) continue;
          lo = glm::min(lo, glm::vec3(p));
          hi = glm::max(hi, glm::vec3(p));
          covered = true;
        }
      const size_t tile = size_t(ty) * lists.tilesX + tx;
      if (covered)
        for (uint32_t l = 0; l < lights.size(); ++l)
          if (lightMeetsBox(lights[l], glm::dvec3(lo), glm::dvec3(hi))) lists.lights.push_back(l);
      lists.offsets[tile + 1] = uint32_t(lists.lights.size());
    }
  return lists;
}

std::vector<std::pair<size_t, uint32_t>> missingLights(const std::vector<glm::vec4>& positions, uint32_t width,
                                                        uint32_t height, const TileLists& lists,
                                                        const std::vector<Light>& lights) {
  std::vector<std::pair<size_t, uint32_t>> missing;
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const size_t i = size_t(y) * width + x;
      if (positions[i].w == 0.0f) continue;
      const size_t tile = size_t(y / kTileSize) * lists.tilesX + x / kTileSize;
      const auto begin = lists.lights.begin() + lists.offsets[tile], end = lists.lights.begin() + lists.offsets[tile + 1];
      for (uint32_t l = 0; l < lights.size(); ++l)
        if (withinInfluence(lights[l], glm::dvec3(glm::vec3(positions[i]))) && std::find(begin, end, l) == end)
          missing.emplace_back(i, l);
    }
  return missing;
}

}  // namespace cpvs
