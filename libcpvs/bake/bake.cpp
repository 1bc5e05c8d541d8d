#include "libcpvs/bake/bake.h"

#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>
#include <optional>

#include <nlohmann/json.hpp>
#include <xxhash.h>

#include "libcpvs/bake/bake_cache.h"
#include "libcpvs/bake/cone_crop.h"
#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/peak_memory.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/raster/next_surface.h"
#include "libcpvs/version.h"
#include "libcpvs/views/view_geometry.h"
#include "libcpvs/views/view_fitting.h"

namespace cpvs {
namespace {

ShadowDag allLitDag(uint32_t resolution) {
  ShadowDag dag;
  dag.resolution = resolution;
  dag.rootCode = ChildCode::Lit;
  const uint32_t levels = DagView{resolution, ChildCode::Lit, {}, {}}.levels();
  dag.nodesPerLevel.assign(levels, 0);
  dag.levelOffsets.assign(levels, 0);
  return dag;
}

std::string settingsJson(const BakeSettings& settings, uint64_t inputHash, const std::vector<uint32_t>& part,
                         size_t sceneLights) {
  // Only what determines the bytes of the result: no timestamps, no thread count, no paths.
  nlohmann::json j = {{"tool", "cpvs-bake"},
                      {"tool_version", kVersion},
                      {"resolution", settings.resolution},
                      {"undefined", undefinedModeName(settings.undefinedMode)},
                      {"node_reuse", settings.nodeReuse},
                      {"max_peels", settings.peel.maxPeels},
                      {"region", std::min(settings.regionSize, settings.resolution)},
                      {"ground", groundSheetsName(settings.ground)},
                      {"input_hash", hex64(inputHash)}};
  if (settings.voxelSize > 0) j["voxel_size"] = settings.voxelSize;
  if (settings.maxVoxelError) j["max_voxel_error"] = *settings.maxVoxelError;
  if (settings.maxEdgeError) j["max_edge_error"] = settings.maxEdgeError;
  j["crop_to_cone"] = settings.cropToCone;
  // The rasterisers agree on all but a few texels, not on every byte.
  j["backend"] = rasterBackendName(settings.backend);
  // A run that bakes only some lights says which: cpvs-merge checks and drops this key.
  if (part.size() != sceneLights) j["part"] = {{"lights", formatLightList(part)}, {"of", sceneLights}};
  return j.dump();
}

}  // namespace

std::vector<uint64_t> lossySettingWords(const BakeSettings& settings) {
  std::vector<uint64_t> words;
  if (settings.maxVoxelError) {
    words.push_back(0x6c6f737379ull);  // "lossy"
    words.push_back(*settings.maxVoxelError);
  }
  if (settings.maxEdgeError) {
    words.push_back(0x6564676573ull);  // "edges"
    words.push_back(settings.maxEdgeError);
  }
  return words;
}

uint64_t bakeInputHash(const WorldGeometry& world, const std::vector<Light>& lights, const BakeSettings& settings) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  XXH3_64bits_update(state, world.positions.data(), world.positions.size() * sizeof(glm::dvec3));
  XXH3_64bits_update(state, world.indices.data(), world.indices.size() * sizeof(uint32_t));
  const uint64_t closed = world.closedTriangleCount;
  XXH3_64bits_update(state, &closed, sizeof closed);
  if (world.masked.count()) {  // what the alpha test reads: which triangles, their coordinates, the masks' bits
    const uint64_t begin = world.masked.begin;
    XXH3_64bits_update(state, &begin, sizeof begin);
    XXH3_64bits_update(state, world.masked.maskOf.data(), world.masked.maskOf.size() * sizeof(uint32_t));
    XXH3_64bits_update(state, world.masked.uvs.data(), world.masked.uvs.size() * sizeof(glm::vec2));
    for (const CoverageMask& mask : world.masked.masks) {
      const uint64_t h = mask.hash();
      XXH3_64bits_update(state, &h, sizeof h);
    }
  }
  for (const Light& l : lights) {
    XXH3_64bits_update(state, l.name.data(), l.name.size());
    const double values[] = {double(l.type), l.color.r, l.color.g, l.color.b, l.intensity, l.range,
                             l.innerConeAngle, l.outerConeAngle, l.position.x, l.position.y, l.position.z,
                             l.direction.x, l.direction.y, l.direction.z};
    XXH3_64bits_update(state, values, sizeof values);
  }
  // The region size orders the nodes within each level, so it is part of what the bytes depend on.
  const uint64_t s[] = {settings.resolution, uint64_t(settings.undefinedMode), settings.nodeReuse,
                        settings.peel.maxPeels, std::min(settings.regionSize, settings.resolution),
                        uint64_t(settings.ground)};
  XXH3_64bits_update(state, s, sizeof s);
  if (settings.voxelSize > 0) XXH3_64bits_update(state, &settings.voxelSize, sizeof settings.voxelSize);
  const uint64_t more[] = {uint64_t(settings.cropToCone), uint64_t(settings.backend)};
  XXH3_64bits_update(state, more, sizeof more);
  const std::vector<uint64_t> lossy = lossySettingWords(settings);
  if (!lossy.empty()) XXH3_64bits_update(state, lossy.data(), lossy.size() * sizeof(uint64_t));
  // The container's version changes the bytes too (a 2.0 bake's hash is what it was before 3.0 existed).
  if (settings.formatMajor != 2) {
    const uint64_t major = settings.formatMajor;
    XXH3_64bits_update(state, &major, sizeof major);
  }
  const uint64_t hash = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return hash;
}

uint64_t sceneInputHash(const Scene& scene, const BakeSettings& requested) {
  BakeSettings settings = requested;
  settings.regionSize = regionSizeWithinBudget(requested);
  return bakeInputHash(flatten(scene, settings.ground), scene.lights, settings);
}

namespace {

// Per view of a light: its triangles (view space) and the estimated cost of baking it: the texels of the
// regions its triangles overlap plus a weight per triangle and region drawn.
struct LightGeometry {
  std::vector<ViewGeometry> views;
  double cost = 0;
  bool reachesGeometry = false;
};

LightGeometry gatherLightGeometry(const WorldGeometry& world, const TriangleBvh& index, const std::vector<LightView>& views,
                                  uint32_t regionSize) {
  constexpr double kTexelsPerTriangleDraw = 64;
  LightGeometry out;
  for (const LightView& view : views) {
    out.views.push_back(view.empty ? ViewGeometry{} : gatherViewGeometry(world, view, &index));
    const ViewGeometry& g = out.views.back();
    if (g.triangleCount() == 0) continue;
    out.reachesGeometry = true;
    const uint32_t size = std::min(regionSize, view.resolution);
    const uint32_t perSide = (view.resolution + size - 1) / size;
    std::vector<uint8_t> occupied(size_t(perSide) * perSide, 0);
    uint64_t draws = 0;
    for (const glm::vec4& b : g.gridBounds) {
      const auto cell = [&](float t) { return uint32_t(std::clamp(std::floor(t / float(size)), 0.0f, float(perSide - 1))); };
      for (uint32_t y = cell(b.z); y <= cell(b.w); ++y)
        for (uint32_t x = cell(b.x); x <= cell(b.y); ++x) {
          occupied[size_t(y) * perSide + x] = 1;
          ++draws;
        }
    }
    const double regions = double(std::count(occupied.begin(), occupied.end(), uint8_t(1)));
    out.cost += regions * double(size) * double(size) + kTexelsPerTriangleDraw * double(draws);
  }
  return out;
}

// settings.lights (or every light), ascending, each once; an index past the scene's lights is an error.
std::vector<uint32_t> requestedLights(const Scene& scene, const BakeSettings& settings) {
  std::vector<uint32_t> chosen = settings.lights;
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  if (chosen.empty())
    for (uint32_t i = 0; i < scene.lights.size(); ++i) chosen.push_back(i);
  for (const uint32_t i : chosen)
    if (i >= scene.lights.size())
      throw Error(ErrorCategory::InvalidArgument, "light index " + std::to_string(i) + " is out of range: the scene has " +
                                                      std::to_string(scene.lights.size()) + " light(s)");
  return chosen;
}

// The views of the `requested` lights (the others' stay empty), each fitted on its own, in parallel: the fit looks
// at the triangles near what each light reaches (`index`).
std::vector<std::vector<LightView>> viewsOfLights(const Scene& scene, const WorldGeometry& world, const TriangleBvh& index,
                                                  const BakeSettings& settings, const std::vector<uint32_t>& requested) {
  std::vector<std::vector<LightView>> views(scene.lights.size());
  parallelFor(requested.size(), [&](size_t r) {
    const size_t i = requested[r];
    const Light& light = scene.lights[i];
    views[i] = makeLightViews(light, world, settings.resolution, &index);
    if (settings.voxelSize <= 0) return;
    uint32_t n = resolutionForVoxelSize(views[i], settings.voxelSize, settings.resolution);
    // The estimate scales the fit at the largest N; the fit's padding grows at small N, so check and double.
    while (n < settings.resolution) {
      std::vector<LightView> fitted = makeLightViews(light, world, n, &index);
      double largest = 0;
      for (const LightView& v : fitted)
        if (!v.empty) largest = std::max(largest, largestVoxelSize(v));
      if (largest <= settings.voxelSize) {
        views[i] = std::move(fitted);
        break;
      }
      n *= 2;
    }
  }, 1);
  return views;
}

// The requested lights, or their shard, balanced by each light's estimated cost: every light index ends in
// exactly one shard.
std::vector<uint32_t> selectLights(const Scene& scene, const BakeSettings& settings, const WorldGeometry& world,
                                   const TriangleBvh& index, const std::vector<std::vector<LightView>>& views,
                                   const std::vector<uint32_t>& requested) {
  if (settings.shard.count <= 1) return requested;
  std::vector<double> cost(scene.lights.size(), 0.0);
  parallelFor(requested.size(), [&](size_t r) {
    const uint32_t i = requested[r];
    cost[i] = gatherLightGeometry(world, index, views[i], settings.regionSize).cost;
  }, 1);
  return shardLights(requested, cost, settings.shard);
}

// Lights whose range is tiny against the scene usually mean a unit mismatch (a level in centimetres, lights in
// metres): every shadow would be baked into a speck.
void warnAboutRanges(const Scene& scene, const WorldGeometry& world, std::vector<std::string>& warnings) {
  if (world.bounds.empty()) return;
  const double diagonal = glm::length(world.bounds.extent());
  // The largest range of the spot and point lights (infinite when one is unlimited; -1 when there are none).
  double largest = -1;
  for (const Light& l : scene.lights)
    if (hasRange(l)) largest = std::max(largest, l.range);
  constexpr double kTinyFraction = 0.01;
  if (largest >= 0 && largest < kTinyFraction * diagonal) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "every spot and point light's range is under 1 %% of the scene's size (largest range %.4g, scene "
                  "diagonal %.4g): are the lights and the geometry in the same units (a level authored in "
                  "centimetres with ranges in metres)?",
                  largest, diagonal);
    warnings.emplace_back(text);
  }
}

void describeDag(const ShadowDag& dag, ViewReport& vr) {
  vr.nodesPerLevel = dag.nodesPerLevel;
  vr.uniqueLeaves = dag.leaves.size();
  vr.bytes = dag.bytes();
}

// What one bake shares between its lights: the scene as flattened, every light's views, the settings, the
// cache, the callbacks (serialised), and the renderers (one per lane: a GL context is tied to one thread).
struct BakeRun {
  const Scene& scene;
  const BakeSettings& settings;
  const WorldGeometry& world;
  const TriangleBvh& index;
  const std::vector<std::vector<LightView>>& allViews;
  const BakeCallbacks& callbacks;
  std::optional<BakeCache>& cache;
  std::vector<uint64_t> maskHashes;  // per alpha mask of the world, for the cache's region keys
  // Cache entries written by this bake, committed together once it succeeds (a bake that fails or is cancelled
  // leaves the cache as it was), and the light entries they supersede (under `mutex`).
  std::vector<std::unique_ptr<BakeCache::NewEntry>> newEntries;
  std::vector<uint64_t> newKeys, supersededKeys;
  std::vector<std::unique_ptr<DepthRenderer>> renderers;  // per lane, opened on first use
  std::mutex mutex;                                       // callbacks, progress, the renderer's description
  std::string rendererDescription;
  size_t totalViews = 0, doneViews = 0;
  // What the lanes' DAG encodings under way will still allocate: a lane's budget check counts the others'.
  std::atomic<uint64_t> encodingBytes{0};

  void progress(double viewsDone) {
    if (callbacks.progress) callbacks.progress(viewsDone / double(totalViews));
  }
};

// One light's result: what goes into the file, its report, and the warnings it raised (kept in light order).
struct LightOutcome {
  BakedLight baked;
  LightReport report;
  std::vector<std::string> warnings;
  uint64_t cacheKey = 0;                 // with a cache: the light's entry
  std::vector<uint64_t> supersededKeys;  // light entries the views' previous region packs were stored with
};

// Stops the bake when the process's resident memory (or, under a mapped-memory budget, what that counts), plus
// `extraBytes` about to be needed, exceeds the budget. Other lanes' encodings under way count too: each may still
// allocate what it reserved.
void checkMemoryBudget(const BakeRun& run, uint64_t extraBytes, const Light& light, size_t vi, const LightView& view) {
  const BakeSettings& settings = run.settings;
  if (!settings.maxMemoryBytes && !settings.maxMappedBytes) return;
  extraBytes += run.encodingBytes.load();
  const auto check = [&](uint64_t budget, MemoryMeasure measure, const std::string& source) {
    if (!budget) return;
    const uint64_t used = currentMemoryBytes(measure);
    if (used + extraBytes <= budget) return;
    const char* what = measure == MemoryMeasure::Resident       ? "resident"
                       : measure == MemoryMeasure::AddressSpace ? "of address space mapped" : "of data mapped";
    throw MemoryBudgetError(
        "memory budget of " + std::to_string(budget >> 20) + " MiB" + (source.empty() ? "" : " (" + source + ")") +
        " exceeded (" + std::to_string(used >> 20) + " MiB " + what +
        ((extraBytes >> 20) ? ", and about " + std::to_string(extraBytes >> 20) + " MiB more to encode the view's DAG" : "") +
        ") while baking light '" + light.name + "' view " + std::to_string(vi) + " at " +
        std::to_string(view.resolution) + "^3: lower the resolution or raise the " +
        (measure == MemoryMeasure::Resident ? "budget" : "limit"));
  };
  check(settings.maxMemoryBytes, MemoryMeasure::Resident, settings.maxMemorySource);
  check(settings.maxMappedBytes, settings.maxMappedMeasure, settings.maxMappedSource);
}

void addRenderStats(const RenderStats& stats, ViewReport& vr) {
  vr.depthMs += stats.enterMs;
  vr.peelMs += stats.peelMs;
  vr.peelIterations = std::max(vr.peelIterations, stats.peelIterations);
  vr.texelsAtPeelCap += stats.texelsAtPeelCap;
  vr.trianglesSubmitted += stats.trianglesSubmitted;
  vr.uniformTiles += stats.uniformTiles;
  vr.summarizedTiles += stats.summarizedTiles;
}

// The renderer of `lane`, opened on first use.
DepthRenderer& laneRenderer(BakeRun& run, unsigned lane) {
  std::unique_ptr<DepthRenderer>& renderer = run.renderers[lane];
  if (!renderer) {
    renderer = DepthRenderer::create(run.settings.backend);
    const std::lock_guard<std::mutex> lock(run.mutex);
    run.rendererDescription = renderer->description();
  }
  return *renderer;
}

// One region's enter and exit slices: free where the spot's cone leaves it all out, else rendered (and, for
// lossy bakes, the next surfaces found).
std::shared_ptr<DepthRegion> renderRegion(DepthRenderer& renderer, const BakeSettings& settings, const ConeCrop& crop,
                                          const LightView& view, const ViewGeometry& regionGeometry,
                                          const RegionRect& rect, bool outsideCone, bool summarizeTiles, ViewReport& vr) {
  RenderStats stats;
  std::shared_ptr<DepthRegion> depth;
  if (outsideCone) {
    depth = std::make_shared<DepthRegion>(ConeCrop::freeRegion(view, rect));
    vr.texelsOutsideCone += depth->enter.size();
  } else {
    const RowSpans inside = crop.inside(view, rect);
    depth = std::make_shared<DepthRegion>(renderer.render(regionGeometry, view, rect, settings.peel, &stats,
                                                          crop.active ? &inside : nullptr, summarizeTiles));
    vr.tiles += uint64_t(rect.width / 8) * (rect.height / 8);
    vr.texelsOutsideCone += ConeCrop::freeOutside(inside, *depth);
    if (settings.maxVoxelError) {
      const Stopwatch next;
      findNextSurfaces(regionGeometry, view, *depth);
      vr.nextSurfaceMs += next.ms();
    }
  }
  addRenderStats(stats, vr);
  return depth;
}

// The builder's DAG once every region is in, with the bytes its encoding reserves counted against the budget
// of every lane while it runs.
ShadowDag finishDag(BakeRun& run, DagBuilder& builder, const Light& light, size_t vi, const LightView& view,
                    ViewReport& vr) {
  const uint64_t encoding = builder.finishExtraBytes();
  checkMemoryBudget(run, encoding, light, vi, view);  // the last region's tables too
  Stopwatch finish;
  const SerialCpuTimer encodeCpu;
  run.encodingBytes += encoding;
  ShadowDag dag;
  try {
    dag = builder.finish();
  } catch (...) {
    run.encodingBytes -= encoding;
    throw;
  }
  run.encodingBytes -= encoding;
  vr.dagMs += finish.ms();
  vr.encodeMs += encodeCpu.ms();
  vr.nodesBuilt = builder.stats().nodesBuilt;
  vr.nodesReused = builder.stats().nodesReused;
  vr.leavesMerged = builder.stats().leavesMerged;
  vr.edgeTexelsFlipped = builder.stats().edgeTexelsFlipped;
  return dag;
}

// Region reuse (docs/incremental-bakes.md): with a cache, each region's DAG events are kept under a key of what
// they depend on, and a region whose key is unchanged since the view frame's last bake is replayed instead of
// rendered. Packs are read and written region by region: an incremental bake holds no pack in memory.
struct RegionReuse {
  bool active = false;
  uint64_t frameKey = 0;
  std::optional<RegionPackReader> previous;   // the frame's last pack, when it has this view's regions
  std::unique_ptr<BakeCache::NewEntry> file;  // this bake's pack, written as the regions finish
  std::optional<RegionPackWriter> writer;
  struct Waiting {
    uint64_t key = 0;
    std::string record;
  };
  std::vector<Waiting> waiting;  // per region: its key and record until written
  size_t written = 0;            // regions written to the new pack, in order
};

// A cache write that failed costs later bakes their reuse, not this bake its result.
void dropNewPack(RegionReuse& reuse, const Error& e, std::vector<std::string>& warnings) {
  warnings.push_back(std::string("bake cache regions not stored: ") + e.what());
  reuse.writer.reset();
  reuse.file.reset();
}

RegionReuse openRegionReuse(BakeRun& run, const Light& light, const LightView& view, uint32_t regionSize,
                            bool summarizeTiles, size_t regionCount, LightOutcome& out) {
  RegionReuse reuse;
  if (!run.cache || run.callbacks.depthRegion) return reuse;  // that caller wants every region's depth
  reuse.active = true;
  reuse.frameKey = viewFrameKey(run.settings, light, view, regionSize, summarizeTiles);
  std::string problem;
  if (std::optional<RegionPackReader> found = run.cache->findRegions(reuse.frameKey, &problem))
    reuse.previous.emplace(std::move(*found));
  if (!problem.empty()) out.warnings.push_back("bake cache regions ignored and baked again: " + problem);
  if (reuse.previous) {
    if (reuse.previous->lightKey() != out.cacheKey) out.supersededKeys.push_back(reuse.previous->lightKey());
    if (reuse.previous->size() != regionCount) reuse.previous.reset();
  }
  reuse.waiting.resize(regionCount);
  try {
    reuse.file = run.cache->newRegions(reuse.frameKey);
    reuse.writer.emplace(reuse.file->fd(), reuse.file->path(), reuse.frameKey, out.cacheKey);
  } catch (const Error& e) {
    dropNewPack(reuse, e, out.warnings);
  }
  return reuse;
}

// The previous bake's events of region `ri` when its key is `key` and they read and decode for `builder`.
// The events view the record, kept in `waiting` until the replay is done and it is written to the new pack.
std::optional<RegionEvents> reusableRegion(RegionReuse& reuse, size_t ri, uint64_t key, DagBuilder& builder,
                                           std::vector<std::string>& warnings) {
  RegionReuse::Waiting& waiting = reuse.waiting[ri];
  waiting.key = key;
  if (!reuse.previous || reuse.previous->key(ri) != key) return std::nullopt;
  try {
    waiting.record = reuse.previous->record(ri);
    if (!waiting.record.empty()) return builder.decodeRecord(waiting.record);
  } catch (const Error& e) {  // a damaged pack: this region and those after it are rendered
    warnings.push_back(std::string("bake cache region ignored and baked again, with the pack's later ones: ") + e.what());
    reuse.previous.reset();
  }
  std::string().swap(waiting.record);  // rendered and recorded again
  return std::nullopt;
}

// Writes the waiting records of the regions before `end` (all finished) to the new pack.
void writeWaiting(RegionReuse& reuse, size_t end, std::vector<std::string>& warnings) {
  for (; reuse.written < end; ++reuse.written) {
    RegionReuse::Waiting& r = reuse.waiting[reuse.written];
    if (reuse.writer) try {
        reuse.writer->add(r.key, r.record);
      } catch (const Error& e) {
        dropNewPack(reuse, e, warnings);
      }
    std::string().swap(r.record);  // frees it: assigning an empty string would keep its capacity
  }
}

void storeRegions(BakeRun& run, RegionReuse& reuse, std::vector<std::string>& warnings) {
  if (!reuse.active) return;
  writeWaiting(reuse, reuse.waiting.size(), warnings);
  if (!reuse.writer) return;
  try {
    reuse.writer->finish();
    reuse.file->close();
    const std::lock_guard<std::mutex> lock(run.mutex);
    run.newEntries.push_back(std::move(reuse.file));
  } catch (const Error& e) {
    dropNewPack(reuse, e, warnings);
  }
}

// Bakes one view of light `li` on `lane` (its renderer), region after region; masks and DAG of a region run beside
// the rasterising of the next one.
ShadowDag bakeView(BakeRun& run, uint32_t li, const Light& light, unsigned lane, size_t vi, const LightView& view,
                   const ViewGeometry& geometry, ViewReport& vr, LightOutcome& out) {
  const BakeSettings& settings = run.settings;
  const BakeCallbacks& callbacks = run.callbacks;
  const SerialCpuTimer laneCpu;  // this lane's work outside parallel loops and the DAG beside it
  DepthRenderer& renderer = laneRenderer(run, lane);
  const uint32_t regionSize = std::min({settings.regionSize, renderer.maxRegionSize(), view.resolution});
  const std::vector<RegionRect> regions = splitIntoRegions(view.resolution, regionSize);
  DagBuilder builder(view.resolution, regionSize, settings.nodeReuse, settings.maxEdgeError);
  const ConeCrop crop = settings.cropToCone ? coneCropOf(light, view) : ConeCrop{};
  // Uniform tiles may be summarised unless someone wants every texel's slices, or mode none (whose exits are
  // every texel's e + 1) builds the chains.
  const bool summarizeTiles =
      !settings.perTexel && !callbacks.depthRegion && settings.undefinedMode != UndefinedMode::None;
  vr.regions = uint32_t(regions.size());
  RegionReuse reuse = openRegionReuse(run, light, view, regionSize, summarizeTiles, regions.size(), out);
  // Each region's candidate triangles, from one pass over the view's (not one per region).
  const std::vector<std::vector<uint32_t>> regionTriangles = binToRegions(geometry, view.resolution, regionSize);
  // Rendering stays on this thread (it owns the GL context); masks and DAG of the previous region run
  // beside it. The DAG still takes regions in order, so the bytes do not depend on the overlap.
  BackgroundWork pending;
  const auto runBeside = [&](size_t ri, auto&& work) {
    pending.wait();
    // The builder is idle here. Its tables only grow, so once what encoding them would need no longer fits,
    // the view cannot finish within the budget: stop now rather than at the end.
    checkMemoryBudget(run, builder.finishExtraBytes(), light, vi, view);
    if (reuse.active) writeWaiting(reuse, ri, out.warnings);  // the regions before this one are done
    if (settings.threads > 1) {
      pending.start(work);
    } else {
      const InParallelLoop beside;  // the DAG's chain, not the lane's, on one thread as with several
      work();
    }
  };
  for (size_t ri = 0; ri < regions.size(); ++ri) {
    const RegionRect& rect = regions[ri];
    const bool outsideCone = crop.regionOutside(view, rect);
    const ViewGeometry regionGeometry = outsideCone ? ViewGeometry{} : cullToRegion(geometry, rect, regionTriangles[ri]);
    std::optional<RegionEvents> reused;
    if (reuse.active)
      reused = reusableRegion(reuse, ri, regionKey(reuse.frameKey, rect, outsideCone, regionGeometry, run.maskHashes),
                              builder, out.warnings);
    if (reused) {
      ++vr.regionsReused;
      runBeside(ri, [&, ri, events = *reused]() {
        Stopwatch dag;
        const SerialCpuTimer dagCpu;
        builder.replayRegion(regions[ri], events);
        vr.dagMs += dag.ms();
        vr.dagChainMs += dagCpu.ms();
      });
    } else {
      const std::shared_ptr<DepthRegion> depth =
          renderRegion(renderer, settings, crop, view, regionGeometry, rect, outsideCone, summarizeTiles, vr);
      if (callbacks.depthRegion) {
        const std::lock_guard<std::mutex> lock(run.mutex);
        callbacks.depthRegion(li, vi, view, *depth);
      }
      runBeside(ri, [&, ri, depth]() {
        Stopwatch masks;
        const TileChains chains =
            buildTileChains(*depth, settings.undefinedMode, std::max(1u, settings.threads), settings.maxVoxelError);
        vr.masksMs += masks.ms();
        vr.tileMasks += chains.start.size();
        vr.freeVoxelsLit += chains.freeVoxelsLit;
        vr.voxelsDelayed += chains.voxelsDelayed;
        Stopwatch dag;
        const SerialCpuTimer dagCpu;
        builder.addRegion(chains, reuse.active ? &reuse.waiting[ri].record : nullptr);
        vr.dagMs += dag.ms();
        vr.dagChainMs += dagCpu.ms();
      });
    }
    if (callbacks.progress) {
      const std::lock_guard<std::mutex> lock(run.mutex);
      run.progress(double(run.doneViews) + double(ri + 1) / double(regions.size()));
    }
  }
  pending.wait();
  // The regions are in: the pack is finished and the previous one closed, and the builder's region scratch
  // freed, before the DAG is encoded (where the bake's memory peaks).
  storeRegions(run, reuse, out.warnings);
  reuse.previous.reset();
  builder.releaseRegionScratch();
  vr.laneSerialMs += laneCpu.ms();
  return finishDag(run, builder, light, vi, view, vr);
}

// The light's entry in the bake cache, when there is a cache: a hit fills `out.baked`; a miss, or an entry that
// cannot be used (a warning says why), leaves it to be baked. Returns the key to store the result under.
uint64_t lookUpCache(BakeRun& run, const std::vector<LightView>& views, const LightGeometry& lightGeometry,
                     LightOutcome& out) {
  if (!run.cache) return 0;
  BakedLight& baked = out.baked;
  LightReport& lightReport = out.report;
  const uint64_t cacheKey = lightBakeKey(run.settings, baked.light, views, lightGeometry.views);
  std::string problem;
  if (std::optional<BakedLight> hit = run.cache->find(cacheKey, baked.light, &problem)) {
    if (hit->views.size() == views.size()) {
      baked = std::move(*hit);
      lightReport.cache = LightReport::Cache::Hit;
    } else {
      problem = run.cache->pathOf(cacheKey) + ": holds " + std::to_string(hit->views.size()) + " view(s), expected " +
                std::to_string(views.size());
    }
  }
  if (!problem.empty()) out.warnings.push_back("bake cache entry ignored and baked again: " + problem);
  if (lightReport.cache != LightReport::Cache::Hit) lightReport.cache = LightReport::Cache::Miss;
  return cacheKey;
}

// Bakes one light's views on `lane` (its renderer), or takes them from the cache.
LightOutcome bakeLight(BakeRun& run, uint32_t li, unsigned lane) {
  const Stopwatch lightTime;
  const SerialCpuTimer lightCpu;
  LightOutcome out;
  BakedLight& baked = out.baked;
  baked.light = run.scene.lights[li];
  if (run.callbacks.lightStarted) {
    const std::lock_guard<std::mutex> lock(run.mutex);
    run.callbacks.lightStarted(baked.light.name);
  }
  LightReport& lightReport = out.report;
  lightReport.name = baked.light.name;
  lightReport.index = li;
  lightReport.type = baked.light.type;
  const std::vector<LightView>& views = run.allViews[li];
  const LightGeometry lightGeometry = gatherLightGeometry(run.world, run.index, views, run.settings.regionSize);
  lightReport.estimatedCost = lightGeometry.cost;
  lightReport.reachesGeometry = lightGeometry.reachesGeometry;
  if (!lightGeometry.reachesGeometry)
    out.warnings.push_back("light '" + baked.light.name + "' (index " + std::to_string(li) +
                           ") reaches no geometry: every voxel of its views is lit (check its position, direction "
                           "and range)");
  const uint64_t cacheKey = lookUpCache(run, views, lightGeometry, out);
  out.cacheKey = cacheKey;
  const bool fromCache = lightReport.cache == LightReport::Cache::Hit;
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const LightView& view = views[vi];
    ViewReport vr;
    vr.resolution = view.resolution;
    vr.face = view.face;
    vr.empty = view.empty;
    vr.shadowMapBytes = uint64_t(view.resolution) * view.resolution * 2;
    if (!fromCache) {
      const ViewGeometry& geometry = lightGeometry.views[vi];
      BakedView bakedView{view, {}};
      bakedView.dag = view.empty || geometry.triangleCount() == 0
                          ? allLitDag(view.resolution)
                          : bakeView(run, li, baked.light, lane, vi, view, geometry, vr, out);
      baked.views.push_back(std::move(bakedView));
    }
    describeDag(baked.views[vi].dag, vr);
    lightReport.views.push_back(vr);
    const std::lock_guard<std::mutex> lock(run.mutex);
    run.progress(double(++run.doneViews));
  }
  if (run.cache && !fromCache) {
    try {
      std::unique_ptr<BakeCache::NewEntry> entry = run.cache->write(cacheKey, baked);
      const std::lock_guard<std::mutex> lock(run.mutex);
      run.newEntries.push_back(std::move(entry));
      run.newKeys.push_back(cacheKey);
      run.supersededKeys.insert(run.supersededKeys.end(), out.supersededKeys.begin(), out.supersededKeys.end());
    } catch (const Error& e) {  // the bake itself is fine: only later runs lose the entry
      out.warnings.push_back(std::string("bake cache entry not stored: ") + e.what());
    }
  }
  lightReport.ms = lightTime.ms();
  double inViews = 0;
  for (const ViewReport& v : lightReport.views) inViews += v.laneSerialMs + v.encodeMs;
  lightReport.serialMs = std::max(0.0, lightCpu.ms() - inViews);
  return out;
}

// The bake succeeded: its cache entries go into place. The light entries its region packs replaced describe a
// scene that is gone (the light as it was before the edit): they are removed, so the folder holds one version
// of each light and view, not every edit's.
void commitCacheEntries(BakeRun& run, std::vector<std::string>& warnings) {
  for (const std::unique_ptr<BakeCache::NewEntry>& entry : run.newEntries) try {
      entry->commit();
    } catch (const Error& e) {
      warnings.push_back(std::string("bake cache entry not stored: ") + e.what());
    }
  std::sort(run.newKeys.begin(), run.newKeys.end());
  std::sort(run.supersededKeys.begin(), run.supersededKeys.end());
  run.supersededKeys.erase(std::unique(run.supersededKeys.begin(), run.supersededKeys.end()), run.supersededKeys.end());
  for (const uint64_t old : run.supersededKeys)
    if (!std::binary_search(run.newKeys.begin(), run.newKeys.end(), old)) run.cache->remove(old);
}

// How many lights bake at once. The CPU rasteriser runs one light per thread: the per-region passes of one light
// keep two cores only ~90 % busy (and cost a quarter more CPU time in hand-offs) where independent lights keep
// them full. A GL context belongs to one thread, so GL backends bake one light at a time. Within a memory
// budget, each lane's region must fit.
unsigned lanesFor(const BakeSettings& settings, size_t lights) {
  if (settings.backend != RasterBackend::Cpu) return 1;
  uint64_t lanes = std::min<uint64_t>(std::max(1u, settings.threads), std::max<size_t>(1, lights));
  if (settings.maxMemoryBytes)
    lanes = std::min<uint64_t>(lanes, std::max<uint64_t>(1, settings.maxMemoryBytes / 4 / regionMemoryBytes(settings.regionSize)));
  return unsigned(lanes);
}

// Bakes the chosen lights; with `stream`, each finished light goes to a CpvsWriter instead of the content.
CpvsContent bakeSceneHere(const Scene& scene, const BakeSettings& requested, BakeReport* report,
                          const BakeCallbacks& callbacks, const CpvsWriter::WriteAt* stream, uint64_t* fileBytes) {
  const Stopwatch setup;
  const double cpuAtStart = processCpuMs();
  const SerialCpuTimer setupCpu;
  BakeSettings settings = requested;
  settings.regionSize = regionSizeWithinBudget(requested);
  const WorldGeometry world = flatten(scene, settings.ground);
  const uint64_t inputHash = bakeInputHash(world, scene.lights, settings);
  const TriangleBvh index(world);  // once per bake: each light then looks only at what it reaches
  const std::vector<uint32_t> asked = requestedLights(scene, settings);
  const std::vector<std::vector<LightView>> allViews = viewsOfLights(scene, world, index, settings, asked);
  const std::vector<uint32_t> chosen = selectLights(scene, settings, world, index, allViews, asked);
  CpvsContent content;
  content.settingsJson = settingsJson(settings, inputHash, chosen, scene.lights.size());

  BakeReport localReport;
  BakeReport& rep = report ? *report : localReport;
  rep.setupMs = setup.ms();
  rep.setupSerialMs = setupCpu.ms();
  rep.inputHash = inputHash;
  rep.groundSheets = world.groundSheets;
  rep.sceneTriangles = world.sceneTriangleCount();
  rep.sceneLights = scene.lights.size();
  warnAboutRanges(scene, world, rep.warnings);
  std::optional<BakeCache> cache;
  if (!settings.cacheFolder.empty()) cache.emplace(settings.cacheFolder);

  std::optional<CpvsWriter> writer;
  if (stream) {
    const Stopwatch write;
    std::vector<Light> lights;
    std::vector<size_t> viewCounts;
    for (const uint32_t li : chosen) {
      lights.push_back(scene.lights[li]);
      viewCounts.push_back(allViews[li].size());
    }
    writer.emplace(content.settingsJson, std::move(lights), std::move(viewCounts), *stream, settings.formatMajor);
    rep.writeMs += write.ms();
  }
  const unsigned lanes = lanesFor(settings, chosen.size());
  BakeRun run{scene, settings, world, index, allViews, callbacks, cache, {}, {}, {}, {}, {}, {}, {}, {}, 0, 0};
  if (cache)
    for (const CoverageMask& mask : world.masked.masks) run.maskHashes.push_back(mask.hash());
  run.renderers.resize(lanes);
  for (const uint32_t li : chosen) run.totalViews += allViews[li].size();  // progress counts views, weighted equally

  // Lights finish in any order on several lanes; the file, the report and the per-light callbacks take them in
  // the chosen order, each as soon as every light before it is done.
  std::vector<std::optional<LightOutcome>> outcomes(chosen.size());
  size_t handedOver = 0;
  const auto handOverFinished = [&] {  // under run.mutex
    while (handedOver < outcomes.size() && outcomes[handedOver]) {
      LightOutcome& o = *outcomes[handedOver];
      rep.warnings.insert(rep.warnings.end(), o.warnings.begin(), o.warnings.end());
      if (writer) {
        const Stopwatch write;
        writer->add(o.baked);
        rep.writeMs += write.ms();
      } else {
        content.lights.push_back(std::move(o.baked));
      }
      rep.lights.push_back(std::move(o.report));
      outcomes[handedOver].reset();
      ++handedOver;
      if (callbacks.lightDone) callbacks.lightDone(rep.lights.back(), handedOver, chosen.size());
    }
  };
  parallelLanes(chosen.size(), lanes, [&](unsigned lane, size_t i) {
    LightOutcome outcome = bakeLight(run, chosen[i], lane);
    const std::lock_guard<std::mutex> lock(run.mutex);
    outcomes[i] = std::move(outcome);
    handOverFinished();
  });
  rep.renderer = run.rendererDescription;
  const SerialCpuTimer endCpu;
  if (cache) commitCacheEntries(run, rep.warnings);
  if (cache && settings.cacheMaxBytes > 0) {
    const BakeCache::Trimmed trimmed = cache->trim(settings.cacheMaxBytes);
    rep.cacheEntriesRemoved = trimmed.removed;
    rep.cacheBytes = trimmed.bytesLeft;
  }
  if (writer) {
    const Stopwatch write;
    const uint64_t size = writer->finish();
    rep.writeMs += write.ms();
    if (fileBytes) *fileBytes = size;
  }
  rep.endSerialMs = endCpu.ms();
  rep.cpuMs = processCpuMs() - cpuAtStart;
  return content;
}

}  // namespace

CpvsContent bakeScene(const Scene& scene, const BakeSettings& settings, BakeReport* report,
                      const BakeCallbacks& callbacks) {
  // Every parallel loop of the bake (rasterising, tile masks, the DAG beside them) runs on `threads` threads.
  tbb::task_arena arena(int(std::clamp(settings.threads, 1u, 256u)));
  CpvsContent content;
  arena.execute([&] { content = bakeSceneHere(scene, settings, report, callbacks, nullptr, nullptr); });
  return content;
}

uint64_t bakeSceneTo(const Scene& scene, const BakeSettings& settings, const CpvsWriter::WriteAt& writeAt,
                     BakeReport* report, const BakeCallbacks& callbacks) {
  tbb::task_arena arena(int(std::clamp(settings.threads, 1u, 256u)));
  uint64_t fileBytes = 0;
  arena.execute([&] { bakeSceneHere(scene, settings, report, callbacks, &writeAt, &fileBytes); });
  return fileBytes;
}

}  // namespace cpvs
