// The shadow techniques cpvs-view knows, by mode: each is one file; adding one is its file and a line here.
#include "libcpvs/base/error.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

std::unique_ptr<ShadowPass> makeCpvsGpuShadows(RendererResources& resources);
std::unique_ptr<ShadowPass> makeCpuRuntimeShadows(RendererResources& resources);
std::unique_ptr<ShadowPass> makeRayTracedShadows(RendererResources& resources);
std::unique_ptr<ShadowPass> makeNoShadows(RendererResources& resources);
std::unique_ptr<ShadowPass> makeShadowMapShadows(RendererResources& resources, bool clustered);
std::unique_ptr<ShadowPass> makeManyPsmShadows(RendererResources& resources);

std::unique_ptr<ShadowPass> makeShadowPass(ShadowMode mode, RendererResources& resources) {
  switch (mode) {
    case ShadowMode::Gpu: return makeCpvsGpuShadows(resources);
    case ShadowMode::Cpu: return makeCpuRuntimeShadows(resources);
    case ShadowMode::RayTraced: return makeRayTracedShadows(resources);
    case ShadowMode::None: return makeNoShadows(resources);
    case ShadowMode::ShadowMap: return makeShadowMapShadows(resources, false);
    case ShadowMode::LightCluster: return makeShadowMapShadows(resources, true);
    case ShadowMode::ManyPsm: return makeManyPsmShadows(resources);
  }
  throw Error(ErrorCategory::InvalidArgument, "unknown shadow mode");
}

}  // namespace cpvs
