#pragma once
// The checks a glTF file's JSON passes before the importer relies on it (json_checks.cpp). Both throw Error
// naming `path` and the element at fault.
#include <string>

#include <nlohmann/json.hpp>

namespace cpvs::gltf {

// A file that names a geometry extension cpvs cannot import (in extensionsUsed or extensionsRequired) is
// refused, Error(NotSupported), before any buffer is read.
void checkGeometryExtensions(const std::string& path, const nlohmann::json& root);
// The JSON types of the properties that decide the geometry, the transforms and the lights' placement:
// tinygltf silently ignores optional properties of the wrong type. Error(InvalidInput).
void checkJsonTypes(const std::string& path, const nlohmann::json& root);

}  // namespace cpvs::gltf
