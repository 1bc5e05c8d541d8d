#pragma once
// A punctual light as baked into a .cpvs and looked up at run time (the glTF KHR_lights_punctual model).
#include <cstdint>
#include <limits>
#include <string>

#include <glm/glm.hpp>

namespace cpvs {

enum class LightType : uint8_t { Directional = 0, Spot = 1, Point = 2 };
const char* lightTypeName(LightType type);

// A punctual light (KHR_lights_punctual semantics, world space).
struct Light {
  std::string name;
  LightType type = LightType::Directional;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;
  double range = std::numeric_limits<double>::infinity();  // spot and point only
  double innerConeAngle = 0.0;                             // spot only, radians
  double outerConeAngle = 0.7853981633974483;              // spot only, radians (pi/4)
  glm::dvec3 position{0.0};                                // spot and point
  glm::dvec3 direction{0.0, 0.0, -1.0};                    // the way the light travels (unit)
};

}  // namespace cpvs
