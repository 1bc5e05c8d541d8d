// KHR_lights_punctual: the file's light definitions, and the lights the scene's nodes place in world space.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "libcpvs/import/gltf_importer.h"

namespace cpvs::gltf {

// The KHR_lights_punctual light definitions (placed later by nodes).
void GltfImporter::parseLights() {
  const auto extension = model_.extensions.find(kLightsExtension);
  if (extension == model_.extensions.end()) return;
  const tinygltf::Value& root = extension->second;
  const std::string prefix = std::string("extensions.") + kLightsExtension;
  if (!root.IsObject()) fail(prefix + " is not an object");
  if (!root.Has("lights")) return;
  const tinygltf::Value& lights = root.Get("lights");
  if (!lights.IsArray()) fail(prefix + ".lights is not an array");
  for (size_t i = 0; i < lights.ArrayLen(); ++i) {
    const tinygltf::Value& object = lights.Get(int(i));
    const std::string what = prefix + ".lights[" + std::to_string(i) + "]";
    if (!object.IsObject()) fail(what + " is not an object");
    Light light;
    if (object.Has("name")) {
      if (!object.Get("name").IsString()) fail(what + ".name is not a string");
      light.name = object.Get("name").Get<std::string>();
    }
    if (!object.Has("type") || !object.Get("type").IsString()) fail(what + ".type is missing or not a string");
    const std::string type = object.Get("type").Get<std::string>();
    if (type == "directional")
      light.type = LightType::Directional;
    else if (type == "spot")
      light.type = LightType::Spot;
    else if (type == "point")
      light.type = LightType::Point;
    else
      fail(what + ".type '" + type + "' is not directional, spot or point");
    if (object.Has("color")) {
      const tinygltf::Value& color = object.Get("color");
      if (!color.IsArray() || color.ArrayLen() != 3) fail(what + ".color is not an array of 3 numbers");
      for (int c = 0; c < 3; ++c) {
        light.color[c] = float(finiteNumber(color.Get(c), what + ".color[" + std::to_string(c) + "]"));
        if (light.color[c] < 0.0f) fail(what + ".color is negative");
      }
    }
    if (object.Has("intensity")) {
      light.intensity = float(finiteNumber(object.Get("intensity"), what + ".intensity"));
      if (light.intensity < 0.0f) fail(what + ".intensity is negative");
    }
    if (object.Has("range") && hasRange(light)) {
      light.range = finiteNumber(object.Get("range"), what + ".range");
      if (!(light.range > 0.0)) fail(what + ".range must be greater than zero");
    }
    if (hasCone(light) && object.Has("spot")) {
      const tinygltf::Value& spot = object.Get("spot");
      if (!spot.IsObject()) fail(what + ".spot is not an object");
      if (spot.Has("innerConeAngle"))
        light.innerConeAngle = finiteNumber(spot.Get("innerConeAngle"), what + ".spot.innerConeAngle");
      if (spot.Has("outerConeAngle"))
        light.outerConeAngle = finiteNumber(spot.Get("outerConeAngle"), what + ".spot.outerConeAngle");
      if (!(light.outerConeAngle > 0.0 && light.outerConeAngle <= std::numbers::pi / 2))
        fail(what + ".spot.outerConeAngle " + std::to_string(light.outerConeAngle) + " is not in (0, pi/2]");
      // Exporters write inner == outer (Blender with blend 0); only the outer cone matters for shadows.
      if (light.innerConeAngle < 0.0 || light.innerConeAngle > light.outerConeAngle) {
        warn(what + ".spot.innerConeAngle is outside [0, outerConeAngle]; clamped");
        light.innerConeAngle = std::clamp(light.innerConeAngle, 0.0, light.outerConeAngle);
      }
    }
    lightDefinitions_.push_back(light);
  }
}

// A node's light (KHR_lights_punctual), in world space: position = node origin, direction = node's local -Z.
void GltfImporter::placeLight(int index, const glm::dmat4& worldFromLocal) {
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  const auto extension = node.extensions.find(kLightsExtension);
  if (extension == node.extensions.end()) return;
  const tinygltf::Value& reference = extension->second;
  const std::string what = describeNode(index) + ": extensions." + kLightsExtension + ".light";
  if (!reference.IsObject() || !reference.Has("light")) fail(what + " is missing");
  const double lightIndex = finiteNumber(reference.Get("light"), what);
  if (lightIndex < 0 || lightIndex >= double(lightDefinitions_.size()) || lightIndex != std::floor(lightIndex))
    fail(what + " " + std::to_string(lightIndex) + " is not the index of a light (the file defines " +
         std::to_string(lightDefinitions_.size()) + ")");
  Light light = lightDefinitions_[size_t(lightIndex)];
  if (light.name.empty()) light.name = node.name.empty() ? "light" + std::to_string(size_t(lightIndex)) : node.name;
  light.position = glm::dvec3(worldFromLocal * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  const glm::dvec3 direction = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 0.0, -1.0);
  const double length = glm::length(direction);
  if (!(length > 0.0) || !std::isfinite(length)) fail(describeNode(index) + ": the light's transform is degenerate");
  light.direction = direction / length;
  scene_.lights.push_back(light);
}

}  // namespace cpvs::gltf
