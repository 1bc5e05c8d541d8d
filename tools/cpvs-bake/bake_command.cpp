#include "tools/cpvs-bake/bake_command.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/base/peak_memory.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/version.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/common/ground_json.h"
#include "tools/common/progress.h"

namespace cpvs::tools {
namespace {


void dumpDepthRegion(const std::string& dir, size_t light, size_t view, const DepthRegion& depth) {
  const size_t count = size_t(depth.rect.width) * depth.rect.height;
  ExrImage image;
  image.width = depth.rect.width;
  image.height = depth.rect.height;
  image.channels = {"enter", "exit"};
  image.pixels.resize(count * 2);
  for (size_t i = 0; i < count; ++i) {
    image.pixels[2 * i] = float(depth.enter[i]);
    image.pixels[2 * i + 1] = float(depth.exit[i]);
  }
  char name[128];
  std::snprintf(name, sizeof name, "light%zu_view%zu_region%u_%u.exr", light, view, depth.rect.x0, depth.rect.y0);
  writeExr((std::filesystem::path(dir) / name).string(), image);
}

nlohmann::json groundSheetsJson(const std::vector<GroundSheet>& sheets) {
  nlohmann::json out = nlohmann::json::array();
  for (const GroundSheet& g : sheets) out.push_back(groundSheetJson<nlohmann::json>(g));
  return out;
}

// The bake's work and span (bakeSpanMs), and what they let one predict: on N cores at least max(work / N, span)
// and at most work / N + span.
nlohmann::json workJson(const BakeSettings& settings, const BakeReport& report) {
  const double span = bakeSpanMs(report);
  nlohmann::json bounds = nlohmann::json::object();
  std::vector<unsigned> cores = {1, 2, 4, 8, 16};
  if (std::find(cores.begin(), cores.end(), settings.threads) == cores.end()) cores.push_back(settings.threads);
  for (const unsigned n : cores) {
    const WallBounds b = bakeWallBounds(report, n);
    bounds[std::to_string(n)] = {b.atLeastMs, b.atMostMs};
  }
  return {{"cpu_ms", report.cpuMs},
          {"span_ms", span},
          {"serial_fraction", report.cpuMs > 0 ? span / report.cpuMs : 0.0},
          {"setup_serial_ms", report.setupSerialMs},
          {"end_serial_ms", report.endSerialMs},
          {"wall_bounds_ms", bounds}};
}

nlohmann::json reportJson(const BakeCommand& options, const BakeSettings& settings,
                          const BakeReport& report, double totalMs, double loadMs, uint64_t fileBytes) {
  uint64_t dagBytes = 0;
  for (const LightReport& l : report.lights)
    for (const ViewReport& v : l.views) dagBytes += v.bytes;
  nlohmann::json lights = nlohmann::json::array();
  for (const LightReport& l : report.lights) {
    nlohmann::json views = nlohmann::json::array();
    for (const ViewReport& v : l.views) {
      // The file is written once for all views; its time is shared out by each view's bytes.
      const double share = dagBytes ? double(v.bytes) / double(dagBytes) : 0.0;
      views.push_back({{"resolution", v.resolution},
                       {"face", v.face},
                       {"empty", v.empty},
                       {"regions", v.regions},
                       {"regions_reused", v.regionsReused},
                       {"phases_ms",
                        {{"depth", v.depthMs}, {"peel", v.peelMs}, {"next_surface", v.nextSurfaceMs},
                         {"masks", v.masksMs}, {"dag", v.dagMs}, {"write", report.writeMs * share}}},
                       {"triangles_submitted", v.trianglesSubmitted},
                       {"peel_iterations", v.peelIterations},
                       {"texels_at_peel_cap", v.texelsAtPeelCap},
                       {"texels_outside_cone", v.texelsOutsideCone},
                       {"tile_masks", v.tileMasks},
                       {"tiles", v.tiles},
                       {"uniform_tiles", v.uniformTiles},
                       {"summarized_tiles", v.summarizedTiles},
                       {"uniform_tile_fraction", v.tiles ? double(v.uniformTiles) / double(v.tiles) : 0.0},
                       {"nodes_per_level", v.nodesPerLevel},
                       {"nodes_built", v.nodesBuilt},
                       {"nodes_reused", v.nodesReused},
                       {"unique_leaves", v.uniqueLeaves},
                       {"bytes", v.bytes},
                       {"shadow_map_bytes", v.shadowMapBytes},
                       {"free_voxels_lit", v.freeVoxelsLit},
                       {"voxels_delayed", v.voxelsDelayed},
                       {"leaves_merged", v.leavesMerged},
                       {"edge_texels_flipped", v.edgeTexelsFlipped},
                       {"serial_ms", {{"lane", v.laneSerialMs}, {"dag_chain", v.dagChainMs}, {"encode", v.encodeMs}}}});
    }
    const char* cache = l.cache == LightReport::Cache::Hit ? "hit" : l.cache == LightReport::Cache::Miss ? "miss" : "off";
    lights.push_back({{"name", l.name},
                      {"index", l.index},
                      {"type", lightTypeName(l.type)},
                      {"ms", l.ms},
                      {"cache", cache},
                      {"estimated_cost", l.estimatedCost},
                      {"reaches_geometry", l.reachesGeometry},
                      {"serial_ms", l.serialMs},
                      {"views", views}});
  }
  return {{"version", kVersion},
          {"tool", "cpvs-bake"},
          {"inputs", {{"scene", options.scene}, {"excluded_meshes", options.lights.excludedMeshes}}},
          {"output", options.output},
          {"settings",
           {{"resolution", settings.resolution},
            {"voxel_size", settings.voxelSize},
            {"undefined", undefinedModeName(settings.undefinedMode)},
            {"node_reuse", settings.nodeReuse},
            {"threads", settings.threads},
            {"backend", rasterBackendName(settings.backend)},
            {"region_size", regionSizeWithinBudget(settings)},  // as baked: a budget may lower it
            {"max_peels", settings.peel.maxPeels},
            {"max_memory_bytes", settings.maxMemoryBytes},
            {"max_memory_source", settings.maxMemorySource},
            {"max_mapped_bytes", settings.maxMappedBytes},
            {"max_mapped_source", settings.maxMappedSource},
            {"ground", groundSheetsName(settings.ground)},
            {"max_voxel_error", settings.maxVoxelError ? nlohmann::json(*settings.maxVoxelError) : nlohmann::json()},
            {"max_edge_error", settings.maxEdgeError}}},
          {"renderer", report.renderer},
          {"triangles", report.sceneTriangles},
          {"ground_sheets", groundSheetsJson(report.groundSheets)},
          {"scene_lights", report.sceneLights},
          {"warnings", report.warnings},
          {"total_ms", totalMs},
          {"load_ms", loadMs},
          {"setup_ms", report.setupMs},
          {"work", workJson(settings, report)},
          {"peak_rss_bytes", peakRssBytes()},
          {"file_bytes", fileBytes},
          {"cache", settings.cacheFolder.empty() ? nlohmann::json(nullptr)
                                                 : nlohmann::json{{"folder", settings.cacheFolder},
                                                                  {"max_bytes", settings.cacheMaxBytes},
                                                                  {"entries_removed", report.cacheEntriesRemoved},
                                                                  {"bytes", report.cacheBytes}}},
          {"lights", lights}};
}

}  // namespace

// One bake of the scene with the options: outputs opened first (a path that cannot be written fails before the
// work), written atomically once everything is done. Returns the files the import read (what --watch watches).
BakeOutcome bakeOnce(const BakeCommand& o, BakeSettings settings, const std::string& usage,
                      const std::function<void(double)>& progressHook) {
  // Every output is opened before the work: a path that cannot be written fails now, not after the bake.
  std::optional<AtomicFile> cpvsFile, reportFile;
  if (!o.output.empty()) cpvsFile.emplace(o.output);
  if (!o.report.empty()) reportFile.emplace(o.report);
  if (!o.dumpDepth.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.dumpDepth, ec);
    if (ec) throw Error(ErrorCategory::OutputFailed, o.dumpDepth + ": cannot create folder: " + ec.message());
  }
  const Stopwatch total;
  expectScene(o.scene, usage);
  Scene scene = importGltf(o.scene, o.import);
  const double loadMs = total.ms();
  o.lights.applyTo(scene);
  for (const std::string& w : scene.warnings)
    if (!o.quiet) std::cerr << "cpvs-bake: warning: " << w << "\n";
  if (scene.lights.empty())
    throw Error(ErrorCategory::InvalidArgument, o.scene + ": the scene has no KHR_lights_punctual lights; give --sun, --spot or --point");
  if (!o.lightList.empty())
    settings.lights = forFlag("--lights", [&] { return parseLightList(o.lightList, scene.lights); });

  ProgressBar progress("baking", o.quiet);
  BakeCallbacks callbacks;
  callbacks.progress = [&](double f) {
    progress.update(f);
    if (progressHook) progressHook(f);
  };
  callbacks.lightStarted = [&](const std::string& name) { progress.setDetail(name); };
  // Build logs (stderr not a terminal) get one line per light instead of a bar.
  const bool lightLines = !o.quiet && !stderrIsTerminal();
  callbacks.lightDone = [&](const LightReport& l, size_t done, size_t total) {
    if (!lightLines) return;
    uint64_t bytes = 0, regions = 0, reused = 0;
    for (const ViewReport& v : l.views) {
      bytes += v.bytes;
      regions += v.regions;
      reused += v.regionsReused;
    }
    std::string cache = l.cache == LightReport::Cache::Hit ? ", from the cache" : "";
    if (reused) cache = ", " + std::to_string(reused) + " of " + std::to_string(regions) + " regions from the cache";
    std::fprintf(stderr, "cpvs-bake: light %zu/%zu '%s' (index %u): %zu view(s), %.2f s, %llu bytes%s\n", done, total,
                 l.name.c_str(), l.index, l.views.size(), l.ms / 1000.0, (unsigned long long)bytes, cache.c_str());
  };
  if (!o.dumpDepth.empty())
    callbacks.depthRegion = [&](size_t light, size_t view, const LightView&, const DepthRegion& depth) {
      dumpDepthRegion(o.dumpDepth, light, view, depth);
    };
  // The file is written as the lights finish (memory holds the lights in flight, not the whole file).
  BakeReport report;
  uint64_t fileBytes = 0;
  if (cpvsFile)
    fileBytes = bakeSceneTo(scene, settings, [&](uint64_t at, const char* data, size_t n) {
      cpvsFile->writeAt(at, {data, n});
    }, &report, callbacks);
  else
    bakeScene(scene, settings, &report, callbacks);
  progress.finish();
  if (!o.quiet)
    for (const std::string& w : report.warnings) std::cerr << "cpvs-bake: warning: " << w << "\n";
  if (!o.quiet)
    for (const GroundSheet& g : report.groundSheets)
      std::fprintf(stderr, "cpvs-bake: ground: mesh '%s' (node '%s') %s\n", g.mesh.c_str(), g.node.c_str(),
                   g.used ? "is the top of solid ground (voxels under it are free)"
                          : ("spans the scene but is not used as ground: " + g.reason).c_str());

  const double totalMs = total.ms();

  BakeOutcome outcome{scene.files, reportJson(o, settings, report, totalMs, loadMs, fileBytes)};
  if (reportFile) reportFile->write(outcome.report.dump(2) + "\n");
  commitTogether({cpvsFile ? &*cpvsFile : nullptr, reportFile ? &*reportFile : nullptr});
  if (!o.quiet) {
    size_t views = 0;
    for (const auto& l : report.lights) views += l.views.size();
    size_t hits = 0;
    uint64_t regions = 0, reused = 0;
    for (const auto& l : report.lights) {
      hits += l.cache == LightReport::Cache::Hit;
      for (const ViewReport& v : l.views) {
        regions += l.cache == LightReport::Cache::Hit ? 0 : v.regions;
        reused += v.regionsReused;
      }
    }
    std::fprintf(stderr, "cpvs-bake: %zu light(s)", report.lights.size());
    if (report.lights.size() != report.sceneLights) std::fprintf(stderr, " of %zu", report.sceneLights);
    if (!settings.cacheFolder.empty()) {
      std::fprintf(stderr, " (%zu from the cache", hits);
      if (regions) std::fprintf(stderr, "; of the others' regions %llu of %llu", (unsigned long long)reused, (unsigned long long)regions);
      std::fprintf(stderr, ")");
    }
    if (report.cacheEntriesRemoved > 0)
      std::fprintf(stderr, " (%llu least recently used cache entries removed: %s)",
                   (unsigned long long)report.cacheEntriesRemoved, o.cacheMaxSize.c_str());
    std::fprintf(stderr, ", %zu view(s) at %u^3 in %.2f s", views, settings.resolution, totalMs / 1000.0);
    if (!o.output.empty()) std::fprintf(stderr, " -> %s (%llu bytes)", o.output.c_str(), (unsigned long long)fileBytes);
    std::fprintf(stderr, "\n");
    const double span = bakeSpanMs(report), work = report.cpuMs;
    if (work > 0)
      std::fprintf(stderr, "cpvs-bake: work %.1f CPU-s, %.1f s of it on one thread (%.1f %%): 16 cores would take at "
                   "least %.1f s\n", work / 1000.0, span / 1000.0, 100.0 * span / work,
                   bakeWallBounds(report, 16).atLeastMs / 1000.0);
  }
  return outcome;
}

void BakeCommand::addTo(CLI::App& app) {
  app.add_option("scene", scene, "Input scene (.gltf or .glb)")->required()->type_name("SCENE");
  app.add_option("-o,--output", output, "Output .cpvs file (written atomically)");
  shape.addTo(app);
  lights.addTo(app);
  addImportOptions(app, import);
  app.add_option("-j,--threads", threads, "Worker threads (output bytes do not depend on it)")->capture_default_str();
  app.add_option("--backend", backend, "Depth rendering: cpu (default: the CPU rasteriser), osmesa (OpenGL on llvmpipe, no GPU or display) or egl (OpenGL on a GPU)")
      ->capture_default_str();
  app.add_option("--report", report, "Write a JSON report (timings per phase, nodes, bytes)");
  app.add_option("--dump-depth", dumpDepth, "Write enter/exit depth maps (EXR, slice units) into this folder");
  app.add_option("--lights", lightList,
                 "Bake only these lights: indices, inclusive index ranges and names, e.g. 0-11,20,Lantern (the file is "
                 "then a part for cpvs-merge)")
      ->type_name("LIST");
  app.add_option("--shard", shard,
                 "Bake shard I of N (0-based) of the lights: a deterministic, cost-balanced subset; cpvs-merge joins "
                 "the N parts into the file one run writes")
      ->type_name("I/N");
  app.add_option("--cache", cache,
                 "Folder of finished light bakes and of each view's regions, keyed by what each depends on: unchanged "
                 "lights are read back, and in changed ones the regions an edit does not reach are replayed, not "
                 "rendered (same bytes as a clean bake)")
      ->type_name("DIR");
  app.add_option("--cache-max-size", cacheMaxSize,
                 "With --cache: after the bake, remove the least recently used entries until the folder's entries "
                 "take at most SIZE (1M to 4096T: 500M, 20G)")
      ->type_name("SIZE");
  app.add_flag("--watch", watch,
               "After the bake, bake again whenever the scene (or a buffer or image it reads) is saved, until Ctrl-C; "
               "a save that fails to bake says why and leaves the output as it was (with --cache, only the lights and "
               "regions the edit reaches are baked)");
  app.add_flag("-q,--quiet", quiet,
               "No progress (a bar on a terminal, else one line per finished light) and no warnings");
}

BakeSettings BakeCommand::settings() const {
  BakeSettings settings;
  if (output.empty() && dumpDepth.empty())
    throw Error(ErrorCategory::InvalidArgument, "nothing to do: give -o OUT.cpvs (and/or --dump-depth DIR)");
  if (threads < 1 || threads > 256) throw Error(ErrorCategory::InvalidArgument, "--threads must be in 1..256");
  shape.applyTo(settings);
  settings.threads = threads;
  settings.backend = forFlag("--backend", [&] { return parseRasterBackend(backend); });
  if (!shard.empty()) settings.shard = forFlag("--shard", [&] { return parseShard(shard); });
  settings.cacheFolder = cache;
  if (!cacheMaxSize.empty()) {
    if (cache.empty()) throw Error(ErrorCategory::InvalidArgument, "--cache-max-size needs --cache DIR");
    settings.cacheMaxBytes = forFlag("--cache-max-size", [&] { return parseByteSize(cacheMaxSize); });
    if (settings.cacheMaxBytes == 0) throw Error(ErrorCategory::InvalidArgument, "--cache-max-size: a size above 0");
  }
  return settings;
}

}  // namespace cpvs::tools
