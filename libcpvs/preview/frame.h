#pragma once
// What cpvs-view renders: the settings of one frame and everything the frame's passes produced (kept for the
// report, the overlays and the tests). Pixel rows are OpenGL's: row 0 is the bottom of the image; the image
// writers flip them.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/preview/caster_culling.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

// Gpu, Cpu, RayTraced: CPVS walked on the GPU, the CPU runtime, Embree rays. ShadowMap, LightCluster: the
// per-frame techniques CPVS replaces (the culling demo, docs/culling-demo.md), and ManyPsm: every light
// view's map in one go by a level-by-level traversal of a scene tree into an atlas. None: no shadows.
enum class ShadowMode : uint8_t { Gpu, Cpu, RayTraced, None, ShadowMap, LightCluster, ManyPsm };
enum class Overlay : uint8_t { None, LightsPerTile, Difference, ShadowCount };
// Parse "gpu" / "cpu" / "raytraced" / "none" / "shadowmap" / "lightcluster" / "manypsm" and "none" / "lights-per-tile" / "difference" / "shadow-count";
// throw Error(InvalidArgument) listing the choices.
ShadowMode parseShadowMode(const std::string& name);
const char* shadowModeName(ShadowMode mode);
Overlay parseOverlay(const std::string& name);
const char* overlayName(Overlay overlay);

inline constexpr uint32_t kTileSize = 8;

// The per-frame shadow-map techniques' own settings (ShadowMap, LightCluster): the maps' edge M (the light's
// views at M texels, eval/shadow_map.h's 16-bit depth and lookup rule), the caster culling, and for
// LightCluster the number of clusters. ManyPsm: `size` is the largest map (and the atlas layers' edge), minSize
// the smallest, each light's by its distance to the camera (many_psm_plan.h).
struct ShadowMapSettings {
  uint32_t size = 512;
  uint32_t minSize = 16;
  CasterCulling casterCulling = CasterCulling::None;
  ReceiverMaskVariant maskVariant = ReceiverMaskVariant::Fragments;
  uint32_t clusters = 10;
  bool keepMaps = false;  // read the maps back (Frame::shadowMaps.texels), for tests
};

struct FrameSettings {
  uint32_t width = 1920, height = 1080;
  int pcfKernel = 9;  // the paper's 9 x 9
  double biasMargin = kDefaultBiasMargin;
  ShadowMode shadows = ShadowMode::Gpu;
  // Also trace every (pixel, light) pair with Embree and shade that frame: the error figures, and the
  // difference overlay (which turns this on).
  bool compareWithRays = false;
  // Rays per pair, as s x s: for --shadows raytraced (raysPerSide) and for the --compare reference
  // (compareRaysPerSide). 1: one hard ray from the surface point; s > 1: s x s rays spread over the pair's
  // K x K PCF footprint at the lookup's slice (reference/footprint_rays.h), the filtered quantity PCF estimates.
  int raysPerSide = 1, compareRaysPerSide = 1;
  // GPU shadows: keep each pair's voxel, verdict and count (Frame::cells), for tests.
  bool recordCells = false;
  // Lights switched off (indices into the renderer's lights): in no tile's list, so neither shaded nor looked up.
  std::vector<uint32_t> disabledLights;
  ShadowMapSettings shadowMaps;  // ShadowMap and LightCluster only
};

// The maps a ShadowMap / LightCluster / ManyPsm frame drew: one per layer, or (ManyPsm) one per atlas cell.
struct ShadowMapFrame {
  uint32_t size = 0;                        // M (ManyPsm: the largest, the atlas layers' edge)
  std::vector<uint32_t> shadowLight;        // per map: the light record (a file light, or a cluster after them)
  std::vector<LightView> views;             // per map: its view at its resolution (M but for ManyPsm)
  std::vector<uint64_t> triangles;          // per map: triangles drawn
  std::vector<uint64_t> trianglesPerLight;  // per file light: triangles drawn into the maps its lookups read
  uint64_t bytes = 0;                       // GPU memory of the maps and the index lists
  // The work the maps cost, in units a GPU's time follows (not llvmpipe's): fragments that passed the depth
  // test while drawing them (GL_SAMPLES_PASSED, per layer and in all), texels cleared, draw calls.
  std::vector<uint64_t> fragments;          // per layer (ManyPsm: per draw, the triangles' and the points')
  uint64_t texelsCleared = 0;
  uint32_t drawCalls = 0;
  uint64_t fragmentsDrawn() const;
  // ManyPsm: the traversal's work: compute dispatches, (node, view) items visited, points splatted (in all and
  // per map); each map's place in the atlas; the atlas's layers.
  uint32_t dispatches = 0;
  uint64_t nodesVisited = 0, points = 0;
  std::vector<uint64_t> pointsPerMap;
  std::vector<glm::uvec3> atlasPlaces;      // layer, x, y
  uint32_t atlasLayers = 0;
  // ManyPsm with keepMaps: every splatted node's box (lo, hi) and the map it went to.
  std::vector<std::pair<glm::vec3, glm::vec3>> pointBoxes;
  std::vector<uint32_t> pointMaps;
  // ShadowMapSettings::keepMaps: per map its resolution^2 16-bit depths, row-major, one map after the other.
  std::vector<uint16_t> texels;
  uint64_t trianglesDrawn() const;
};

// Per tile (row-major over tilesX x tilesY, tile row 0 at the bottom), the indices of the lights whose bounds
// meet the tile's pixels, in light order: tile t's are lights[offsets[t] .. offsets[t + 1]).
struct TileLists {
  uint32_t tilesX = 0, tilesY = 0;
  std::vector<uint32_t> offsets;  // tiles + 1
  std::vector<uint32_t> lights;
  size_t tiles() const { return size_t(tilesX) * tilesY; }
};

// A (pixel, light) pair's GPU lookup: voxel and verdict (0 zero, 1 lit, 2 voxel) | shadowed count << 2.
struct PairCell {
  int32_t x = 0, y = 0, z = 0, verdictAndCount = 0;
};

struct PassTime {
  std::string pass;
  double milliseconds = 0;
  bool gpuTimer = true;  // GL timer query; false: CPU wall time
};

struct Frame {
  uint32_t width = 0, height = 0;
  // G-buffer: world position (w = 1 covered, 0 background), normal facing the camera, base colour.
  std::vector<glm::vec4> positions, normals, baseColors;
  TileLists lists;
  // Per pair: index (lists.offsets[tile] + slot) * 64 + (y % 8) * 8 + x % 8.
  std::vector<float> visibility;
  std::vector<float> rayVisibility;  // compareWithRays: Embree's answer per pair
  std::vector<PairCell> cells;       // recordCells
  std::vector<glm::vec4> radiance;   // linear, w = covered
  std::vector<glm::vec4> rayRadiance;  // compareWithRays
  std::vector<glm::uvec2> stats;     // per pixel: lights listed, lights reaching it that shadow it
  std::vector<PassTime> passes;
  ShadowMapFrame shadowMaps;
  glm::dvec3 eye{0.0};  // the camera's position (ManyPsm sizes its maps by it)
  // Bytes the shadow lookups read (CPVS: DAG node units and leaves; the map modes: map texels), where the
  // technique counts them (the GPU ones).
  uint64_t lookupBytes = 0;
  std::vector<uint64_t> lookupBytesPerLight;  // per light, where counted (empty beyond 8191 lights)
  bool lookupBytesCounted = false;
  size_t uploadedBytes = 0;  // lights, views, DAGs and geometry (once per renderer) plus this frame's uploads

  size_t pixel(uint32_t x, uint32_t y) const { return size_t(y) * width + x; }
  size_t tileOf(uint32_t x, uint32_t y) const { return size_t(y / kTileSize) * lists.tilesX + x / kTileSize; }
  size_t pairIndex(uint32_t x, uint32_t y, uint32_t slot) const {
    return (size_t(lists.offsets[tileOf(x, y)]) + slot) * 64 + (y % kTileSize) * kTileSize + x % kTileSize;
  }
  double milliseconds(const std::string& pass) const;  // 0 when the pass did not run
  // fn(x, y, pixel index, light, pair index) for every covered pixel and every light its tile lists, in pixel
  // then list order.
  template <class Fn>
  void forEachPair(Fn&& fn) const {
    for (uint32_t y = 0; y < height; ++y)
      for (uint32_t x = 0; x < width; ++x) {
        const size_t i = pixel(x, y);
        if (positions[i].w == 0.0f) continue;
        const size_t tile = tileOf(x, y);
        for (uint32_t slot = 0; slot < lists.offsets[tile + 1] - lists.offsets[tile]; ++slot)
          fn(x, y, i, lists.lights[lists.offsets[tile] + slot], pairIndex(x, y, slot));
      }
  }
};

}  // namespace cpvs
