#include "tools/cpvs-info/info_common.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace cpvs::info {
namespace {

// Control characters in a name (from an untrusted file) are shown as \xNN, not sent to the terminal.
std::string printableName(const std::string& name) {
  std::string out;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7F) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

std::string number(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

std::string vec(const glm::dvec3& v) {
  std::string text = "(";  // appended piece by piece (GCC 12 warns falsely on "(" + std::string&&)
  text.append(number(v.x)).append(", ").append(number(v.y)).append(", ").append(number(v.z)).append(")");
  return text;
}

nlohmann::ordered_json jsonVec(const glm::dvec3& v) { return nlohmann::ordered_json::array({v.x, v.y, v.z}); }

double shortest(float value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", double(value));
  for (int digits = 1; digits <= 9; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, double(value));
    if (std::strtof(text, nullptr) == value) break;
  }
  return std::strtod(text, nullptr);
}

std::string lightText(const Light& light) {
  std::ostringstream out;
  out << lightTypeName(light.type) << " '" << printableName(light.name) << "':";
  if (hasPosition(light)) out << " position " << vec(light.position);
  if (hasDirection(light)) out << " direction " << vec(light.direction);
  out << " colour " << vec(glm::dvec3(light.color)) << " intensity " << number(light.intensity);
  if (hasRange(light)) out << " range " << number(light.range);
  if (hasCone(light))
    out << " cone " << number(light.innerConeAngle) << ".." << number(light.outerConeAngle) << " rad";
  return out.str();
}

nlohmann::ordered_json lightJson(const Light& light) {
  nlohmann::ordered_json entry = {{"name", light.name},
                                  {"type", lightTypeName(light.type)},
                                  {"color", {shortest(light.color.r), shortest(light.color.g), shortest(light.color.b)}},
                                  {"intensity", shortest(light.intensity)}};
  if (hasPosition(light)) entry["position"] = jsonVec(light.position);
  if (hasRange(light))  // null: unlimited
    entry["range"] = std::isinf(light.range) ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(light.range);
  if (hasDirection(light)) entry["direction"] = jsonVec(light.direction);
  if (hasCone(light)) {
    entry["innerConeAngle"] = light.innerConeAngle;
    entry["outerConeAngle"] = light.outerConeAngle;
  }
  return entry;
}

}  // namespace cpvs::info
