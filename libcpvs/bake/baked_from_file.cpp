#include "libcpvs/bake/baked_from_file.h"

#include <bit>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "libcpvs/bake/bake.h"
#include "libcpvs/tiles/tile_masks.h"

namespace cpvs {

Result<BakedLight> bakedLightOf(const CpvsFile& file, const CpvsFile::LightEntry& entry) {
  BakedLight baked;
  baked.light = entry.light;
  for (const CpvsFile::View& v : entry.views) {
    Result<ShadowDag> dag = file.ownDag(v);
    if (!dag) return dag.outcome();
    baked.views.push_back({v.view, std::move(dag).value()});
  }
  return baked;
}

}  // namespace cpvs

namespace cpvs {

BakedFromCheck checkBakedFrom(const Scene& scene, const CpvsFile& file) {
  BakedFromCheck check;
  const nlohmann::json settings = nlohmann::json::parse(file.settingsJson(), nullptr, false);
  if (!settings.is_object() || !settings.contains("input_hash") || !settings["input_hash"].is_string()) {
    check.reason = "the file records no input hash";
    return check;
  }
  // The hash has covered the backend and the cone crop since 0.5.0; older files hash other settings.
  const std::string version = settings.value("tool_version", std::string("0.0.0"));
  int major = 0, minor = 0;
  if (std::sscanf(version.c_str(), "%d.%d", &major, &minor) != 2 || major * 1000 + minor < 5) {
    check.reason = "the file was written by cpvs " + version + ", whose input hash covers other settings than 0.5's";
    return check;
  }
  if (settings.contains("part")) {
    check.reason = "the file is a part of a split bake (merge the parts with cpvs-merge first)";
    return check;
  }
  try {
    check.recordedHash = std::stoull(settings["input_hash"].get<std::string>(), nullptr, 16);
    BakeSettings bake;
    bake.resolution = settings.at("resolution").get<uint32_t>();
    bake.undefinedMode = parseUndefinedMode(settings.at("undefined").get<std::string>());
    bake.nodeReuse = settings.at("node_reuse").get<bool>();
    bake.peel.maxPeels = settings.at("max_peels").get<uint32_t>();
    bake.regionSize = settings.value("region", bake.resolution);
    bake.ground = parseGroundSheets(settings.value("ground", std::string("off")));
    bake.backend = parseRasterBackend(settings.value("backend", std::string("osmesa")));
    bake.cropToCone = settings.value("crop_to_cone", false);
    bake.voxelSize = settings.value("voxel_size", 0.0);
    if (settings.contains("max_voxel_error")) bake.maxVoxelError = settings.at("max_voxel_error").get<uint32_t>();
    bake.maxEdgeError = settings.value("max_edge_error", 0u);
    bake.formatMajor = file.majorVersion() >= 3 ? file.majorVersion() : 2;
    std::vector<Light> lights;
    for (const CpvsFile::LightEntry& entry : file.lights()) lights.push_back(entry.light);
    check.sceneHash = bakeInputHash(flatten(scene, bake.ground), lights, bake);
  } catch (const std::exception& e) {
    check.reason = std::string("the file's bake settings cannot be read back (") + e.what() + ")";
    return check;
  }
  check.checked = true;
  check.matches = check.sceneHash == check.recordedHash;
  return check;
}

}  // namespace cpvs
