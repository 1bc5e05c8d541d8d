#include "libcpvs/bake/merge_parts.h"

#include <map>
#include <optional>

#include <nlohmann/json.hpp>

#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/bake/light_subsets.h"
#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

[[noreturn]] void fail(const std::string& message) { throw Error(ErrorCategory::InvalidInput, message); }

// The light indices a part holds: its "part" key, or every light of a whole bake.
std::vector<uint32_t> partLights(const NamedPart& part, const nlohmann::json& settings, size_t& sceneLights) {
  const size_t held = part.file->lights().size();
  if (!settings.contains("part")) {
    sceneLights = held;
    std::vector<uint32_t> all(held);
    for (uint32_t i = 0; i < held; ++i) all[i] = i;
    return all;
  }
  const nlohmann::json& p = settings["part"];
  if (!p.is_object() || !p.contains("lights") || !p["lights"].is_string() || !p.contains("of") ||
      !p["of"].is_number_unsigned())
    fail(part.name + ": the settings block's \"part\" key is malformed (expected {\"lights\": \"0-3,7\", \"of\": N})");
  sceneLights = p["of"].get<size_t>();
  constexpr size_t kMostLights = 1u << 24;
  if (sceneLights < held || sceneLights > kMostLights)
    fail(part.name + ": the settings block's part says the scene has " + std::to_string(sceneLights) +
         " light(s), but the file holds " + std::to_string(held) + " (at most " + std::to_string(kMostLights) + ")");
  const std::vector<Light> placeholders(sceneLights);  // unnamed: the list holds indices only
  std::vector<uint32_t> lights;
  try {
    // An empty list: a shard that got no light (more shards than lights).
    if (!p["lights"].get<std::string>().empty()) lights = parseLightList(p["lights"].get<std::string>(), placeholders);
  } catch (const Error& e) {
    fail(part.name + ": the settings block's part list: " + e.what());
  }
  if (lights.size() != held)
    fail(part.name + ": the settings block says it holds " + std::to_string(lights.size()) + " light(s) but the file has " +
         std::to_string(held));
  return lights;
}

}  // namespace

CpvsContent mergeParts(const std::vector<NamedPart>& parts) {
  if (parts.empty()) fail("no parts to merge");
  std::optional<nlohmann::json> common;
  std::string commonFrom;
  size_t sceneLights = 0;
  std::map<uint32_t, std::pair<size_t, size_t>> owner;  // light index -> (part, light within the part)
  for (size_t pi = 0; pi < parts.size(); ++pi) {
    const NamedPart& part = parts[pi];
    nlohmann::json settings = nlohmann::json::parse(part.file->settingsJson(), nullptr, false);
    if (!settings.is_object() || !settings.contains("input_hash"))
      fail(part.name + ": its settings block is not a cpvs-bake settings object, so it cannot be matched with other parts");
    size_t lightsOf = 0;
    const std::vector<uint32_t> lights = partLights(part, settings, lightsOf);
    settings.erase("part");
    if (part.file->majorVersion() != parts[0].file->majorVersion())
      fail(part.name + " is a .cpvs " + std::to_string(part.file->majorVersion()) + ".x file and " + parts[0].name +
           " a " + std::to_string(parts[0].file->majorVersion()) + ".x one: the parts of one bake share a format version");
    if (!common) {
      common = settings;
      commonFrom = part.name;
      sceneLights = lightsOf;
    } else {
      if (settings != *common) {
        std::string differs;
        for (const auto& [key, value] : common->items())
          if (!settings.contains(key) || settings[key] != value) differs += (differs.empty() ? "" : ", ") + key;
        for (const auto& [key, value] : settings.items())
          if (!common->contains(key)) differs += (differs.empty() ? "" : ", ") + key;
        fail(part.name + " and " + commonFrom + " are parts of different bakes (their settings differ in: " + differs +
             "; input_hash covers the scene, its lights and the settings)");
      }
      if (lightsOf != sceneLights)
        fail(part.name + " says the scene has " + std::to_string(lightsOf) + " light(s), " + commonFrom + " says " +
             std::to_string(sceneLights));
    }
    for (size_t k = 0; k < lights.size(); ++k) {
      const auto [it, fresh] = owner.emplace(lights[k], std::make_pair(pi, k));
      if (!fresh)
        fail("light " + std::to_string(lights[k]) + " is in both " + parts[it->second.first].name + " and " + part.name);
    }
  }
  std::vector<uint32_t> missing;
  for (uint32_t i = 0; i < sceneLights; ++i)
    if (!owner.count(i)) missing.push_back(i);
  if (!missing.empty())
    fail("the parts hold " + std::to_string(owner.size()) + " of the scene's " + std::to_string(sceneLights) +
         " lights; missing: " + formatLightList(missing) + " (bake them with cpvs-bake --lights " +
         formatLightList(missing) + ")");
  CpvsContent content;
  content.settingsJson = common->dump();
  for (const auto& [index, where] : owner)
    content.lights.push_back(orThrow(bakedLightOf(*parts[where.first].file, parts[where.first].file->lights()[where.second])));
  return content;
}

}  // namespace cpvs
