#pragma once
// Renders enter and exit depth maps of one region of a light view: on the CPU (cpu_depth_renderer.h, the
// default) or with OpenGL 4.5 core (OSMesa, or EGL on a GPU), docs/depth-maps.md
#include <cstdint>
#include <memory>
#include <string>

#include "libcpvs/raster/depth_maps.h"
#include "libcpvs/raster/raster_backend.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/views/view_geometry.h"

namespace cpvs {


struct PeelSettings {
  // Each peel iteration renders the closed front faces and the closed back faces once and consumes one layer
  // of each (lockstep, Kämpe et al. 2015, §3.3): k iterations resolve k levels of nesting exactly. When the cap is
  // reached the exit is the last back layer consumed: never later than the truth, only less free space.
  // Default 2: on the generated closed city at 4k, 2 peels gave a 0.3 % smaller file than 11 (full) peels
  // in 45 % of the peel time (docs/depth-maps.md); deeper exits rarely help compression.
  uint32_t maxPeels = 2;
  // Peeling also stops once at most this many texels per million of the region are still inside: they get
  // the cap's conservative exit. A few texels where a front and a back face meet within a float step (ridges
  // seen edge-on) would otherwise cost a whole iteration (docs/depth-maps.md: the terrain's sun at 8k, 18 % of
  // its peel time for 18 texels). 0: only the cap and an empty state stop it.
  uint32_t stopBelowPerMillion = 64;
};

struct RenderStats {
  double enterMs = 0;   // enter-depth pass
  double peelMs = 0;    // exit-depth peeling
  uint32_t peelIterations = 0;
  uint64_t texelsAtPeelCap = 0;  // texels whose exit was set conservatively at the cap
  uint64_t trianglesSubmitted = 0;
  uint64_t uniformTiles = 0;     // tiles whose slices came from planes (CPU rasteriser, summarizeTiles)
  uint64_t summarizedTiles = 0;  // of those, the tiles handed over as a summary (DepthRegion::tiles)
};

class DepthRenderer {
public:
  // The CPU rasteriser, or a GL 4.5 core context on the backend. Throws Error(NotSupported) when a GL
  // backend's library or a suitable context is not available on this machine.
  static std::unique_ptr<DepthRenderer> create(RasterBackend backend);
  virtual ~DepthRenderer() = default;

  // Largest region edge this context can render in one go (render-target limit).
  virtual uint32_t maxRegionSize() const = 0;
  // GL_RENDERER / GL_VERSION, for reports.
  virtual std::string description() const = 0;

  // Renders the region's enter and exit slices. `geometry` holds the triangles that reach the view (see
  // view_geometry.h); the renderer submits only those that overlap the region. With `needed`, only those
  // texels' slices count: the rest may hold anything (the CPU rasteriser does not visit them, and the peel's
  // early stop counts only needed texels still inside; GL renders the whole region). With `summarizeTiles`, a
  // renderer may summarise tiles instead of writing their texels (DepthRegion::tiles): for callers that only
  // build tile chains from the result.
  virtual DepthRegion render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                             const PeelSettings& peel, RenderStats* stats = nullptr, const RowSpans* needed = nullptr,
                             bool summarizeTiles = false) = 0;
};

}  // namespace cpvs
