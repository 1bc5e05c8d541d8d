#pragma once
// What the scene and .cpvs halves of cpvs-info share: number formatting and how a light is shown.
#include <string>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "libcpvs/scene/scene.h"

namespace cpvs::info {

inline constexpr const char* kTool = "cpvs-info";

std::string number(double value);  // 6 significant digits, "inf" for infinities
std::string vec(const glm::dvec3& v);
nlohmann::ordered_json jsonVec(const glm::dvec3& v);
// A float as the shortest double that reads back as the same float (0.95f prints as 0.95, not 0.949999988).
double shortest(float value);

// "directional 'Sun': direction (...) colour (...) intensity 3 ..." (no indentation, no newline).
std::string lightText(const Light& light);
// {"name", "type", "color", "intensity", ["position", "range"], ["direction"], ["innerConeAngle", ...]}.
nlohmann::ordered_json lightJson(const Light& light);

// Prints a .cpvs file (validated by the runtime reader) as text or JSON. Returns the exit code: 0 for a valid
// file; for an invalid one the message (naming the file and what is wrong) and the checksum status of every
// section that can be located go to stderr (and, with json, a {"valid": false, ...} object to stdout), and
// the result is 2.
int printCpvs(const std::string& path, bool json);

}  // namespace cpvs::info
