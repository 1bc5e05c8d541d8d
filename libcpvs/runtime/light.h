#pragma once
// The light model: a punctual light as baked into a .cpvs and looked up at run time (the glTF
// KHR_lights_punctual model), and every rule about a light that more than one stage needs: which parameters a
// type has, where its influence ends, which way the light lies from a point, and which surfaces face it. A new
// light type is a value of LightType plus its cases here and in light.cpp (docs/architecture.md lists the rest).
// The GLSL readers take the shape bits (shapeBits) and the type codes from light.glsl.h.
#include <cstdint>
#include <limits>
#include <string>

#include <glm/glm.hpp>

namespace cpvs {

enum class LightType : uint8_t { Directional = 0, Spot = 1, Point = 2 };
// Stored types are below this; a reader rejects any other code.
inline constexpr uint32_t kLightTypeCount = 3;
const char* lightTypeName(LightType type);

// A punctual light (KHR_lights_punctual semantics, world space).
struct Light {
  std::string name;
  LightType type = LightType::Directional;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;
  double range = std::numeric_limits<double>::infinity();  // where hasRange: spot and point
  double innerConeAngle = 0.0;                             // where hasCone: spot, radians
  double outerConeAngle = 0.7853981633974483;              // where hasCone: spot, radians (pi/4)
  glm::dvec3 position{0.0};                                // where hasPosition: spot and point
  glm::dvec3 direction{0.0, 0.0, -1.0};                    // where hasDirection: the way the light travels (unit)
};

// Which of Light's parameters a type uses (what a report prints, what a cache key must hold). Inline: the
// lookups ask them per point.
inline bool hasPosition(const Light& light) { return light.type != LightType::Directional; }  // spot, point
inline bool hasDirection(const Light& light) { return light.type != LightType::Point; }       // directional, spot
inline bool hasRange(const Light& light) { return light.type != LightType::Directional; }     // spot, point
inline bool hasCone(const Light& light) { return light.type == LightType::Spot; }             // spot

// The views a type is baked into: one (face -1) that covers its whole influence, or the six cube faces
// (point; view i is face i: +X, -X, +Y, -Y, +Z, -Z). The reader holds every file to it, and view selection
// relies on it.
inline bool hasCubeFaces(const Light& light) { return light.type == LightType::Point; }
inline uint32_t viewCountOf(const Light& light) { return hasCubeFaces(light) ? 6u : 1u; }

// The shape bits the shaders read instead of the type (light.glsl.h: CPVS_SHAPE_POSITION, _CONE, _CUBE_FACES).
uint32_t shapeBits(const Light& light);

// How far the light reaches from its position: `range` where the type has one, else infinity.
inline double influenceRange(const Light& light) {
  return hasRange(light) ? light.range : std::numeric_limits<double>::infinity();
}

// Whether a point lies in the light's influence: directional: always; spot and point: within range (and not at
// the light itself, for a spot); spot: inside the outer cone, capped at pi/2. Bit for bit the runtime's test
// (cell_lanes.h insideSpot of spotInfluence, selectView).
bool withinInfluence(const Light& light, const glm::dvec3& point);
// The influence of a light with a position and no cone: toPoint (point - position) within range. Inline:
// view selection asks it per point.
inline bool withinRange(const Light& light, const glm::dvec3& toPoint) { return glm::length(toPoint) <= light.range; }

// A spot light's cone and range in the form the lookups' lanes test (cell_lanes.h).
struct SpotInfluence;
SpotInfluence spotInfluence(const Light& light);

// The vector from a point toward the light, not normalised: a directional light's -direction, else
// position - point (zero at the light itself).
inline glm::dvec3 towardLight(const Light& light, const glm::dvec3& point) {
  return hasPosition(light) ? light.position - point : -light.direction;
}

// How a query's normal is read: as given (outward normals; a back face answers 0), or flipped where it faces
// away from the light before biasing (two-sided surfaces, normals of unknown sign).
enum class NormalOrientation : uint8_t {
  AsGiven = 0,      // offset along n as supplied (outward normals; the default)
  TowardLight = 1,  // flip n where it faces away from the light before biasing
};

// The facing rule, the one every stage uses: a surface point faces the light when n . towardLight >= 0. A zero
// normal faces every light, a normal at a right angle to the light faces it (a lookup answers it from its
// voxel, not 0), and with NormalOrientation::TowardLight every normal faces the light, since the lookup flips
// the others. The lookup's own test (cell_lanes.h: back = the grid-space normal's z > 0) has the same sign, up
// to rounding where n . l is within a hair of 0; the reference tests it on unit vectors.
bool facesLight(const Light& light, const glm::dvec3& point, const glm::dvec3& normal,
                NormalOrientation orientation = NormalOrientation::AsGiven);

// The points a shadow answer can be scored at: within the influence and facing the light. Elsewhere the
// answer is 0 by rule, not by a shadow (cpvs-query's "facing" figures, the sweep's points).
bool receivesLight(const Light& light, const glm::dvec3& point, const glm::dvec3& normal,
                   NormalOrientation orientation = NormalOrientation::AsGiven);

// Illuminance-like strength at a point for picking the dominant light: intensity times the colour's luminance,
// over the squared distance for lights with a position; 0 outside the influence or at the light itself.
double strengthAt(const Light& light, const glm::dvec3& point);

// One line for reports: "sun, direction (x, y, z)", "spot at (x, y, z), direction (...), outer cone A rad,
// range R", "point at (x, y, z), range R" (the parameters the type has, 3 to 4 significant digits).
std::string describeLight(const Light& light);

}  // namespace cpvs
