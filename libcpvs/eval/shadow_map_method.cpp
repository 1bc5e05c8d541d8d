#include "libcpvs/eval/shadow_map_method.h"

#include "libcpvs/base/error.h"

namespace cpvs {

BaselineDepth parseBaselineDepth(const std::string& name) {
  if (name == "embree") return BaselineDepth::Embree;
  if (name == "raster" || name == "gl") return BaselineDepth::Raster;
  throw Error(ErrorCategory::InvalidArgument, "baseline depth '" + name + "': expected embree or raster");
}

const char* baselineDepthName(BaselineDepth depth) { return depth == BaselineDepth::Embree ? "embree" : "raster"; }

ShadowMapMethod ShadowMapMethod::build(const Light& light, const std::vector<LightView>& views,
                                       const std::vector<uint64_t>& viewBudgets, BaselineDepth depth,
                                       const EmbreeScene& embree, const WorldGeometry& world, DepthRenderer* raster) {
  if (views.size() != viewBudgets.size())
    throw Error(ErrorCategory::InvalidArgument, "shadow map of light '" + light.name + "': one budget per view needed");
  if (depth == BaselineDepth::Raster && !raster)
    throw Error(ErrorCategory::InvalidArgument, "shadow map of light '" + light.name + "': no depth renderer given");
  std::vector<ShadowMap16> maps;
  for (size_t v = 0; v < views.size(); ++v) {
    const uint32_t size = equalBytesShadowMapSize(viewBudgets[v]);
    maps.push_back(depth == BaselineDepth::Embree ? buildShadowMapEmbree(embree, views[v], size)
                                                  : buildShadowMapRaster(*raster, world, views[v], size));
  }
  return ShadowMapMethod(ShadowMapLight(light, std::move(maps)));
}

void ShadowMapMethod::visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                                 std::span<float> out) const {
  for (size_t i = 0; i < points.size(); ++i) out[i] = maps_.visibility(points[i].position, points[i].normal, options);
}

}  // namespace cpvs
