#pragma once
// Serialises a generated scene as a binary glTF 2.0 (.glb) container.
//
// Written by hand (nlohmann::json for the JSON chunk) rather than through tinygltf so that every byte is
// under our control: object keys are sorted, numbers are printed shortest-round-trip, nothing depends on
// time, locale or addresses, hence the same scene always gives the same bytes.
#include <string>

#include <nlohmann/json.hpp>

#include "gen_scene.h"

namespace cpvs::scenegen {

// `generator` goes to asset.generator; `extras` (may be null) to asset.extras.
std::string writeGlb(const GenScene& scene, const std::string& generator, const nlohmann::json& extras);

}  // namespace cpvs::scenegen
