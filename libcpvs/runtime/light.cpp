#include "libcpvs/runtime/light.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <iterator>

#include "libcpvs/runtime/cell_lanes.h"
#include "libcpvs/runtime/light.glsl.h"

namespace cpvs {

// The GLSL readers use these codes by name (light.glsl.h); the file stores the same values.
static_assert(CPVS_LIGHT_DIRECTIONAL == uint32_t(LightType::Directional));
static_assert(CPVS_LIGHT_SPOT == uint32_t(LightType::Spot));
static_assert(CPVS_LIGHT_POINT == uint32_t(LightType::Point));
static_assert(CPVS_LIGHT_TYPE_COUNT == kLightTypeCount);

const char* lightTypeName(LightType type) {
  // Indexed by the enum's value (0, 1, 2 in declaration order).
  static constexpr const char* kNames[] = {"directional", "spot", "point"};
  static_assert(std::size(kNames) == kLightTypeCount);
  const size_t i = size_t(type);
  return i < std::size(kNames) ? kNames[i] : "unknown";
}

uint32_t shapeBits(const Light& light) {
  return (hasPosition(light) ? CPVS_SHAPE_POSITION : 0u) | (hasCone(light) ? CPVS_SHAPE_CONE : 0u) |
         (hasCubeFaces(light) ? CPVS_SHAPE_CUBE_FACES : 0u);
}

SpotInfluence spotInfluence(const Light& light) {
  SpotInfluence spot;
  for (int i = 0; i < 3; ++i) {
    spot.position[i] = light.position[i];
    spot.direction[i] = light.direction[i];
  }
  spot.range = light.range;
  spot.cosOuter = std::cos(std::min(light.outerConeAngle, 3.14159265358979323846 / 2));
  return spot;
}

bool withinInfluence(const Light& light, const glm::dvec3& point) {
  switch (light.type) {
    case LightType::Directional: return true;
    case LightType::Spot: return insideSpot<double, bool>(spotInfluence(light), point.x, point.y, point.z);
    case LightType::Point: break;
  }
  return withinRange(light, point - light.position);
}

bool facesLight(const Light& light, const glm::dvec3& point, const glm::dvec3& normal,
                NormalOrientation orientation) {
  if (orientation == NormalOrientation::TowardLight) return true;
  return glm::dot(normal, towardLight(light, point)) >= 0.0;  // also true for a zero normal
}

bool receivesLight(const Light& light, const glm::dvec3& point, const glm::dvec3& normal,
                   NormalOrientation orientation) {
  return withinInfluence(light, point) && facesLight(light, point, normal, orientation);
}

double strengthAt(const Light& light, const glm::dvec3& point) {
  const double luminance = 0.2126 * light.color.r + 0.7152 * light.color.g + 0.0722 * light.color.b;
  const double strength = double(light.intensity) * luminance;
  if (!hasPosition(light)) return strength;
  const double distance = glm::length(light.position - point);
  if (!(distance > 0) || !withinInfluence(light, point)) return 0.0;
  return strength / (distance * distance);
}

std::string describeLight(const Light& light) {
  char part[128];
  std::string text = light.type == LightType::Directional ? "sun" : lightTypeName(light.type);
  if (hasPosition(light)) {
    std::snprintf(part, sizeof part, " at (%.4g, %.4g, %.4g)", light.position.x, light.position.y, light.position.z);
    text += part;
  }
  if (hasDirection(light)) {
    std::snprintf(part, sizeof part, ", direction (%.3g, %.3g, %.3g)", light.direction.x, light.direction.y,
                  light.direction.z);
    text += part;
  }
  if (hasCone(light)) {
    std::snprintf(part, sizeof part, ", outer cone %.3g rad", light.outerConeAngle);
    text += part;
  }
  if (hasRange(light)) {
    std::snprintf(part, sizeof part, ", range %.4g", light.range);
    text += part;
  }
  return text;
}

}  // namespace cpvs
