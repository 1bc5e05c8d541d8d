#include "tools/cpvs-view/view_report.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "libcpvs/version.h"

namespace cpvs::tools {

namespace {

using json = nlohmann::ordered_json;

json cameraJson(const PreviewCamera& c) {
  return {{"eye", {c.eye.x, c.eye.y, c.eye.z}},
          {"target", {c.target.x, c.target.y, c.target.z}},
          {"up", {c.up.x, c.up.y, c.up.z}},
          {"fov_degrees", c.yfov * 180.0 / M_PI}};
}

json passesJson(const Frame& f) {
  json passes = json::object();
  for (const PassTime& p : f.passes) passes[p.pass] = p.milliseconds;
  return passes;
}

json shadowMapsJson(const ShadowMapFrame& maps, const ShadowMapSettings& settings, ShadowMode mode) {
  uint64_t most = 0, sum = 0, lit = 0;
  for (uint64_t t : maps.trianglesPerLight)
    if (t) most = std::max(most, t), sum += t, ++lit;
  json out = {{"caster_culling", mode == ShadowMode::ManyPsm ? "bvh traversal" : casterCullingName(settings.casterCulling)},
              {"mask_variant", receiverMaskVariantName(settings.maskVariant)},
              {"size", maps.size}, {"maps", maps.views.size()},
              {"triangles_drawn", maps.trianglesDrawn()},
              {"triangles_per_light_mean", lit ? double(sum) / double(lit) : 0.0},
              {"triangles_per_light_max", most}, {"lights_with_maps", lit},
              {"gpu_bytes", maps.bytes},
              {"fragments", maps.fragmentsDrawn()}, {"texels_cleared", maps.texelsCleared},
              {"draw_calls", maps.drawCalls}};
  if (mode == ShadowMode::ManyPsm) {
    std::map<uint32_t, uint64_t> perResolution;
    for (const LightView& v : maps.views) ++perResolution[v.resolution];
    json levels = json::array();
    for (const auto& [resolution, count] : perResolution) levels.push_back({{"resolution", resolution}, {"maps", count}});
    out["min_size"] = settings.minSize;
    out["atlas_levels"] = levels;
    out["atlas_layers"] = maps.atlasLayers;
    out["dispatches"] = maps.dispatches;
    out["nodes_visited"] = maps.nodesVisited;
    out["points"] = maps.points;
    out["triangle_fragments"] = maps.fragments.empty() ? 0 : maps.fragments[0];
    out["point_fragments"] = maps.fragments.size() < 2 ? 0 : maps.fragments[1];
    out["nodes_per_light_mean"] = lit ? double(maps.nodesVisited) / double(lit) : 0.0;
  }
  return out;
}

}  // namespace

ViewReport::ViewReport(const std::string& scene, const std::string& file, const PreviewRenderer& renderer,
                       const FrameSettings& settings, Overlay overlay, double ambient, const BakedFromCheck& check,
                       const std::string& automaticShadows)
    : renderer_(renderer), settings_(settings) {
  report_ = {{"tool", "cpvs-view"}, {"tool_version", kVersion}, {"scene", scene}, {"cpvs", file},
             {"context", renderer.contextDescription()}, {"size", {settings.width, settings.height}},
             {"pcf", settings.pcfKernel}, {"shadows", shadowModeName(settings.shadows)},
             {"shadows_auto", automaticShadows.empty() ? json(nullptr) : json(automaticShadows)},
             {"rays_per_pair", settings.shadows == ShadowMode::RayTraced ? json(settings.raysPerSide * settings.raysPerSide) : json(nullptr)},
             {"overlay", overlayName(overlay)}, {"ambient", ambient}, {"lights", renderer.lights().size()},
             {"clusters", settings.shadows == ShadowMode::LightCluster ? json(settings.shadowMaps.clusters) : json(nullptr)},
             {"scene_triangles", renderer.sceneTriangles()},
             {"baked_from", {{"checked", check.checked}, {"matches", check.matches}, {"reason", check.reason}}}};
}

void ViewReport::addFrame(const std::string& image, const PreviewCamera& camera, const Frame& frame, double exposure,
                          const std::optional<Coverage>& coverage) {
  lastLists_ = lightListStats(frame, renderer_.lights().size());
  const LightListStats& lists = lastLists_;
  json entry = {{"image", image}, {"camera", cameraJson(camera)}, {"passes_ms", passesJson(frame)},
                {"gpu_timers", frame.passes.empty() || frame.passes.front().gpuTimer},
                {"light_lists", {{"covered_tiles", lists.coveredTiles}, {"mean_lights_per_tile", lists.meanLightsPerTile},
                                 {"max_lights_per_tile", lists.maxLightsPerTile}, {"pairs_listed", lists.pairsListed},
                                 {"pairs_culled", lists.pairsCulled}}},
                {"uploaded_bytes", {{"once", renderer_.staticUploadBytes()},
                                    {"this_frame", frame.uploadedBytes - renderer_.staticUploadBytes()}}},
                {"exposure", exposure}};
  if (coverage)
    entry["shadow_coverage"] = {{"light", coverage->light},
                                {"geometry_pixels", coverage->figures.geometryPixels},
                                {"in_shadow", coverage->figures.inShadow},
                                {"near_black", coverage->figures.nearBlack}};
  const ShadowMode mode = settings_.shadows;
  if (mode == ShadowMode::ShadowMap || mode == ShadowMode::LightCluster || mode == ShadowMode::ManyPsm)
    entry["shadow_maps"] = shadowMapsJson(frame.shadowMaps, settings_.shadowMaps, mode);
  else if (mode == ShadowMode::Gpu || mode == ShadowMode::Cpu)
    // The DAGs and their records, in GPU memory for the GPU walk, in CPU memory (the mapped file) for the CPU's.
    entry[mode == ShadowMode::Gpu ? "cpvs_gpu_bytes" : "cpvs_cpu_bytes"] = renderer_.shadowDataBytes();
  entry["lookup_bytes"] = frame.lookupBytesCounted ? json(frame.lookupBytes) : json(nullptr);
  if (!frame.lookupBytesPerLight.empty()) {
    uint64_t most = 0, lit = 0;
    for (uint64_t b : frame.lookupBytesPerLight)
      if (b) most = std::max(most, b), ++lit;
    entry["lookup_bytes_per_light"] = {{"mean", lit ? double(frame.lookupBytes) / double(lit) : 0.0}, {"max", most},
                                       {"lights_read", lit}};
  }
  if (settings_.compareWithRays) {
    lastErrors_ = errorsAgainstRays(frame, exposure);
    const RayErrors& e = lastErrors_;
    entry["against_rays"] = {{"rmse", e.rmse}, {"wrong_pixels_percent", e.wrongPixelPercent()},
                             {"wrong_pixels", e.wrongPixels}, {"covered_pixels", e.coveredPixels},
                             {"wrong_pairs", e.wrongPairs}, {"pairs", e.pairs},
                             {"mean_abs_visibility_difference", e.meanAbsoluteDifference},
                             {"reference_rays_per_pair", settings_.compareRaysPerSide * settings_.compareRaysPerSide}};
  }
  for (const PassTime& p : frame.passes) {
    auto& s = sums_[p.pass];
    s.first += p.milliseconds;
    s.second = std::max(s.second, p.milliseconds);
  }
  frames_.push_back(std::move(entry));
}

std::string ViewReport::text() const {
  json report = report_;
  report["frames"] = frames_;
  json summary = json::object();
  const double n = double(std::max<size_t>(1, frames_.size()));
  for (const auto& [pass, s] : sums_) summary[pass] = {{"mean_ms", s.first / n}, {"max_ms", s.second}};
  report["summary"] = summary;
  return report.dump(2) + "\n";
}

}  // namespace cpvs::tools
