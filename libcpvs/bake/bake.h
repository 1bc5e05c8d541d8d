#pragma once
// cpvs-bake's pipeline (docs/architecture.md): per light, per view, per region: depth maps -> tile chains -> DAG.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/bake/light_subsets.h"
#include "libcpvs/base/memory_limit.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/tiles/tile_masks.h"

namespace cpvs {

struct BakeSettings {
  uint32_t resolution = 4096;  // N of every view; with voxelSize, the most any view gets
  // > 0: each light gets the smallest power-of-two resolution whose voxels are at most this big, in scene
  // units, at the farthest geometry it reaches (resolutionForVoxelSize): small lights do not pay for N.
  double voxelSize = 0;
  // Leave the voxels of a spot light's view outside its cone (plus a margin) free: they are never looked up
  // (libcpvs/bake/cone_crop.h). Off only to measure it.
  bool cropToCone = true;
  UndefinedMode undefinedMode = UndefinedMode::Kampe;
  bool nodeReuse = true;           // Kämpe et al. 2015, §3.2; off only to measure it
  // Take every tile through the CPU rasteriser's per-texel passes, also where a tile is uniform (one plane in
  // front, the same order of surfaces behind it at every texel) and its chain follows from planes: the
  // reference path, same bytes (docs/depth-maps.md, "Uniform tiles"); on only to measure or test it.
  bool perTexel = false;
  unsigned threads = 2;            // tile chains and DAG building overlap with rendering when > 1
  // The CPU rasteriser: 4-6x faster than llvmpipe on every scene measured (docs/many-lights.md); EGL puts
  // the depth passes on a GPU where there is one.
  RasterBackend backend = RasterBackend::Cpu;
  // Clamped to the renderer's limit and to N. 1024 on llvmpipe: a region's 41 MB of GL buffers stay in the
  // CPU's cache (docs/depth-maps.md "Regions" has the measurement).
  uint32_t regionSize = 1024;
  PeelSettings peel;
  GroundSheets ground = GroundSheets::Auto;  // close ground sheets into solids (libcpvs/scene/ground_sheet.h)
  // Lossy bake (docs/lossy.md): each texel's shadow may start up to this many voxels behind its first surface,
  // and anywhere in front of the next surface behind it. Unset: lossless (the default).
  std::optional<uint32_t> maxVoxelError;
  // Lossy leaves (docs/lossy.md, "Edge merging"): a leaf mask may be answered by one stored before it that
  // differs in at most this many texels on its shadow edges (0, the default: none; at most 2).
  uint32_t maxEdgeError = 0;
  // Memory budget in bytes (0: none). The region size is lowered until a region's buffers take at most a
  // quarter of it, and the bake stops with Error(RuntimeFailure) as soon as the process's resident memory
  // exceeds it (checked after every region), before the system would kill it. The library sets none by
  // itself; cpvs-bake defaults to defaultMemoryBudget() (libcpvs/base/memory_limit.h).
  uint64_t maxMemoryBytes = 0;
  // The .cpvs major version written: 2 (a DAG per view) or 3 (one node pool per file; formats/cpvs/format.md).
  uint16_t formatMajor = kCpvsDefaultMajor;
  std::string maxMemorySource;  // where the budget came from, for the message when it is exceeded
  // A budget the caller did not ask for (cpvs-bake's default) only stops the bake: it never lowers the region
  // size, which is recorded in the file and its input hash, so the bytes never depend on the machine.
  bool maxMemoryOnlyStops = false;
  // A second budget, on mapped memory (0: none): where `ulimit -v` or `ulimit -d` is set, allocations fail at the
  // limit however much memory is free, so the bake stops with the same error once what maxMappedMeasure counts
  // exceeds this (checked with the resident budget). cpvs-bake defaults to defaultMappedBudget(); it never
  // changes the bytes.
  uint64_t maxMappedBytes = 0;
  MemoryMeasure maxMappedMeasure = MemoryMeasure::AddressSpace;
  std::string maxMappedSource;

  // Which lights this run bakes (none of this changes a light's bytes, nor the input hash):
  std::vector<uint32_t> lights;  // indices into the scene's lights, ascending; empty: every light
  ShardSpec shard;               // then only this cost-balanced shard of them (libcpvs/bake/light_subsets.h)
  // A folder of finished light bakes (libcpvs/bake/bake_cache.h); empty: no cache.
  std::string cacheFolder;
  // The most the cache folder may hold after the bake: its least recently used entries past it are removed
  // (BakeCache::trim). 0: no bound.
  uint64_t cacheMaxBytes = 0;
};

struct ViewReport {
  uint32_t resolution = 0;
  int face = -1;
  bool empty = false;
  double depthMs = 0, peelMs = 0, masksMs = 0, dagMs = 0, writeMs = 0;
  // The view's work that runs on one thread (CPU ms; bakeSpanMs): on the rendering lane outside parallel loops,
  // in the DAG's region-by-region construction beside it, and in encoding the DAG once every region is in.
  double laneSerialMs = 0, dagChainMs = 0, encodeMs = 0;
  uint32_t regions = 0;
  uint32_t regionsReused = 0;        // with a cache: regions replayed from it, not rendered (incremental bakes)
  uint64_t trianglesSubmitted = 0;
  uint32_t peelIterations = 0;       // most iterations any region needed
  uint64_t texelsAtPeelCap = 0;
  uint64_t texelsOutsideCone = 0;    // left free: outside a spot light's cone (and margin)
  uint64_t tileMasks = 0;            // chain entries over all tiles
  uint64_t tiles = 0;                // 8x8 tiles rendered (regions outside a spot's cone not counted)
  uint64_t uniformTiles = 0;         // of those, the tiles whose slices came from planes, not texel by texel
  uint64_t summarizedTiles = 0;      // of those, the tiles whose chain came from two values (no texel written)
  double nextSurfaceMs = 0;          // lossy bakes: finding each texel's next surface (raster/next_surface.h)
  // Lossy bakes: voxels left lit at or past their exit, free (no receiver) and delayed (docs/lossy.md).
  uint64_t freeVoxelsLit = 0, voxelsDelayed = 0;
  uint64_t leavesMerged = 0;         // edge merging: distinct leaf masks answered by another leaf
  uint64_t edgeTexelsFlipped = 0;    // and their texels that differ from their answers, summed
  std::vector<uint64_t> nodesPerLevel;
  uint64_t uniqueLeaves = 0;
  uint64_t nodesBuilt = 0, nodesReused = 0;
  uint64_t bytes = 0;                // node units + leaf masks as stored
  uint64_t shadowMapBytes = 0;       // a 16-bit shadow map of the same resolution
};

struct LightReport {
  std::string name;
  uint32_t index = 0;  // in the scene's light list
  LightType type = LightType::Directional;
  std::vector<ViewReport> views;
  double ms = 0;               // wall time of this light, cache look-up included
  double serialMs = 0;         // CPU ms on one thread outside its views: gathering its geometry, the cache
  double estimatedCost = 0;    // what shards are balanced by (arbitrary units)
  enum class Cache { Off, Hit, Miss } cache = Cache::Off;
  bool reachesGeometry = true;
};

struct BakeReport {
  std::string renderer;  // GL_RENDERER of the backend
  std::vector<LightReport> lights;
  uint64_t inputHash = 0;
  std::vector<GroundSheet> groundSheets;  // the height fields spanning the scene, used or not (and why)
  size_t sceneTriangles = 0;              // the scene's own triangles, as flattened for the bake
  size_t sceneLights = 0;                 // lights in the scene; `lights` holds those this run baked
  std::vector<std::string> warnings;      // a light that reaches no geometry, ranges tiny against the scene
  double writeMs = 0;                     // bakeSceneTo: time spent writing the file
  double setupMs = 0;                     // the once-per-bake work over the whole scene: flattening, the input
                                          // hash, the triangle index, every asked light's views and the selection
  double cpuMs = 0;                       // CPU time of the whole bake (every thread of the process): its work
  double setupSerialMs = 0, endSerialMs = 0;  // CPU ms on one thread before the lights and after them (bakeSpanMs)
  // With a cache bounded by cacheMaxBytes: the entries removed after the bake and the bytes the folder's
  // entries take then.
  uint64_t cacheEntriesRemoved = 0, cacheBytes = 0;
};

// The bake's span: the longest chain of its work that must run on one thread, in CPU ms. Per view, the rendering
// lane's serial work and the DAG's construction run beside each other (the longer counts), then the encoding;
// a light's views follow each other; lights run side by side (the longest counts), after the setup and before
// the end. Parallel loops count as if they had cores enough (their imbalance is not in it). On N cores a bake
// takes at least max(cpuMs / N, span) and, with ideal scheduling, at most cpuMs / N + span (Brent's bound).
double bakeSpanMs(const BakeReport& report);
// Those two bounds on the bake's wall time on `cores` cores, in ms.
struct WallBounds {
  double atLeastMs = 0, atMostMs = 0;
};
WallBounds bakeWallBounds(const BakeReport& report, unsigned cores);

struct BakeCallbacks {
  // Fraction of the whole bake done, in [0, 1].
  std::function<void(double)> progress;
  // Called for each rendered region, e.g. to dump depth maps.
  std::function<void(size_t light, size_t view, const LightView&, const DepthRegion&)> depthRegion;
  // Called when a light starts and when it is finished (`done` lights of `total` finished).
  std::function<void(const std::string& name)> lightStarted;
  std::function<void(const LightReport&, size_t done, size_t total)> lightDone;
};

// The same bake, written as it goes: each light's DAGs are handed to a CpvsWriter as soon as it and every light
// before it are done, so memory holds the lights in flight rather than the whole file. `writeAt` receives the
// bytes writeCpvs(bakeScene(...)) would return. Returns the file size.
uint64_t bakeSceneTo(const Scene& scene, const BakeSettings& settings, const CpvsWriter::WriteAt& writeAt,
                     BakeReport* report = nullptr, const BakeCallbacks& callbacks = {});

// The lossy settings as words for a hash (empty for a lossless bake, so its hashes stay what they were before
// the lossy options existed): the input hash and the bake cache's key both take them.
std::vector<uint64_t> lossySettingWords(const BakeSettings& settings);

// Hash of what determines a bake's result: the flattened geometry, the lights and the settings.
uint64_t bakeInputHash(const WorldGeometry& world, const std::vector<Light>& lights, const BakeSettings& settings);
// The input hash bakeScene(scene, settings) writes into its file (every light of the scene counts, whichever
// lights the settings select), so a pipeline can tell before baking whether a file is up to date.
uint64_t sceneInputHash(const Scene& scene, const BakeSettings& settings);

// Bytes a region of `regionSize` x `regionSize` texels takes while it is baked (GL buffers, depth maps, tile
// chains), as the memory budget counts it.
uint64_t regionMemoryBytes(uint32_t regionSize);
// The region size `settings` bakes with: its regionSize, halved (down to 64) while regionMemoryBytes exceeds a
// quarter of maxMemoryBytes (unless maxMemoryOnlyStops).
uint32_t regionSizeWithinBudget(const BakeSettings& settings);

// Bakes the scene's lights that `settings` selects (every light by default). A run that bakes only some of them
// writes a part: its settings block names the lights it holds and how many the scene has, and cpvs-merge joins
// parts into the file one run would write. Throws Error (NotSupported when the backend is missing).
CpvsContent bakeScene(const Scene& scene, const BakeSettings& settings, BakeReport* report = nullptr,
                      const BakeCallbacks& callbacks = {});

}  // namespace cpvs
