#pragma once
// cpvs-view's renderer: one GL context (OSMesa or EGL), the scene's triangles and the baked lights uploaded
// once, then frames. A frame runs five GPU passes, each timed with a GL timer query:
//   1. G-buffer: world position, camera-facing normal, base colour (rasterised)
//   2. tile bounds: per 8 x 8 tile, the world bounds of its pixels (compute)
//   3. light lists: per tile, the lights whose bounding volume meets them: count, prefix sum, fill (compute)
//   4. shadows: per pixel and listed light, the visibility from the frame's shadow technique (shadow_pass.h):
//      CPVS walked on the GPU, the CPU runtime, Embree rays, per-frame shadow maps, or none
//   5. shading: KHR_lights_punctual, Lambert + a highlight (compute), read back as linear radiance
// docs/viewer.md describes each pass and what the tests check.
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame.h"
#include "libcpvs/raster/raster_backend.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

class ShadowPass;

class PreviewRenderer {
public:
  // `lights` reference their DAGs (the .cpvs file must outlive the renderer). Throws Error(NotSupported) when
  // the backend has no GL 4.5 context (compute shaders, 64-bit floats), Error(RuntimeFailure) when a
  // shader does not build. `threads` bounds the CPU and ray-traced shadow passes (0: all cores).
  PreviewRenderer(const Scene& scene, std::vector<LightShadow> lights, RasterBackend backend, unsigned threads = 0);
  ~PreviewRenderer();
  PreviewRenderer(const PreviewRenderer&) = delete;
  PreviewRenderer& operator=(const PreviewRenderer&) = delete;

  // Renders one frame with the technique of settings.shadows (shadow_pass.h). Throws Error(InvalidArgument)
  // for a size of 0 or above 16384, or a bad PCF kernel.
  Frame render(const PreviewCamera& camera, const FrameSettings& settings);
  // The same frame with a technique of the caller's (settings.shadows then only names it for --compare).
  Frame render(const PreviewCamera& camera, const FrameSettings& settings, ShadowPass& technique);

  // Renders tiny frames untimed, so that shader compilation on first use stays out of later pass times (with
  // the shadow-map programs when `like` uses them).
  void warmUp(const FrameSettings& like = {});

  const std::string& contextDescription() const;
  const std::vector<LightShadow>& lights() const;
  size_t sceneTriangles() const;
  // Bytes uploaded once: lights, views, DAGs and the scene's vertices.
  size_t staticUploadBytes() const;
  // Of those, the lights' shadow data: their records, views and DAGs (what the shadow lookups read).
  size_t shadowDataBytes() const;
  // cpvs-view's --shadows auto: the GPU walk (Gpu) on a GL that runs on a GPU and whose storage buffers hold the
  // DAGs, else the CPU runtime's lookups (Cpu), with why in words. On a software GL (Mesa's llvmpipe, as OSMesa
  // and EGL give without a GPU) the compute shader's walk takes many times the CPU lookups' time
  // (docs/viewer.md, "Which shadows by default").
  struct ShadowChoice {
    ShadowMode mode = ShadowMode::Gpu;
    std::string reason;
  };
  ShadowChoice automaticShadows() const;

private:
  void checkFrame(const PreviewCamera& camera, const FrameSettings& settings) const;
  class FramePasses;
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace cpvs
