#pragma once
// cpvs-bake's pipeline (docs/architecture.md): per light, per view, per region: depth maps -> tile chains -> DAG.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/tiles/tile_masks.h"

namespace cpvs {

struct BakeSettings {
  uint32_t resolution = 4096;
  UndefinedMode undefinedMode = UndefinedMode::Kampe;
  bool nodeReuse = true;           // Kämpe et al. 2015, §3.2; off only to measure it
  unsigned threads = 2;            // tile chains and DAG building overlap with rendering when > 1
  RasterBackend backend = RasterBackend::OSMesa;
  // Clamped to the renderer's limit and to N. 1024 on llvmpipe: a region's 41 MB of GL buffers stay in the
  // CPU's cache (docs/depth-maps.md "Regions" has the measurement).
  uint32_t regionSize = 1024;
  PeelSettings peel;
  GroundSheets ground = GroundSheets::Auto;  // close ground sheets into solids (libcpvs/scene/ground_sheet.h)
  // Memory budget in bytes (0: none). The region size is lowered until a region's buffers take at most a
  // quarter of it, and the bake stops with Error(RuntimeFailure) as soon as the process's resident memory
  // exceeds it (checked after every region), before the system would kill it.
  uint64_t maxMemoryBytes = 0;
};

struct ViewReport {
  uint32_t resolution = 0;
  int face = -1;
  bool empty = false;
  double depthMs = 0, peelMs = 0, masksMs = 0, dagMs = 0, writeMs = 0;
  uint32_t regions = 0;
  uint64_t trianglesSubmitted = 0;
  uint32_t peelIterations = 0;       // most iterations any region needed
  uint64_t texelsAtPeelCap = 0;
  uint64_t tileMasks = 0;            // chain entries over all tiles
  std::vector<uint64_t> nodesPerLevel;
  uint64_t uniqueLeaves = 0;
  uint64_t nodesBuilt = 0, nodesReused = 0;
  uint64_t bytes = 0;                // node units + leaf masks as stored
  uint64_t shadowMapBytes = 0;       // a 16-bit shadow map of the same resolution
};

struct LightReport {
  std::string name;
  LightType type = LightType::Directional;
  std::vector<ViewReport> views;
};

struct BakeReport {
  std::string renderer;  // GL_RENDERER of the backend
  std::vector<LightReport> lights;
  uint64_t inputHash = 0;
  std::vector<GroundSheet> groundSheets;  // the height fields spanning the scene, used or not (and why)
  size_t sceneTriangles = 0;              // the scene's own triangles, as flattened for the bake
};

struct BakeCallbacks {
  // Fraction of the whole bake done, in [0, 1].
  std::function<void(double)> progress;
  // Called for each rendered region, e.g. to dump depth maps.
  std::function<void(size_t light, size_t view, const LightView&, const DepthRegion&)> depthRegion;
};

// Hash of what determines a bake's result: the flattened geometry, the lights and the settings.
uint64_t bakeInputHash(const WorldGeometry& world, const std::vector<Light>& lights, const BakeSettings& settings);

// Bytes a region of `regionSize` x `regionSize` texels takes while it is baked (GL buffers, depth maps, tile
// chains), as the memory budget counts it.
uint64_t regionMemoryBytes(uint32_t regionSize);
// The region size `settings` bakes with: its regionSize, halved (down to 64) while regionMemoryBytes exceeds a
// quarter of maxMemoryBytes.
uint32_t regionSizeWithinBudget(const BakeSettings& settings);

// Bakes every light of the scene. Throws Error (NotSupported when the backend is missing).
CpvsContent bakeScene(const Scene& scene, const BakeSettings& settings, BakeReport* report = nullptr,
                      const BakeCallbacks& callbacks = {});

}  // namespace cpvs
