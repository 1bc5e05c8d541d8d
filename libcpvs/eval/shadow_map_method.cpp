#include "libcpvs/eval/shadow_map_method.h"

#include "libcpvs/base/error.h"
#include "libcpvs/base/named_values.h"

namespace cpvs {

namespace {
// "gl" is the name older scripts used for the rasterised depth.
constexpr Named<BaselineDepth> kBaselineDepths[] = {
    {BaselineDepth::Embree, "embree"}, {BaselineDepth::Raster, "raster"}, {BaselineDepth::Raster, "gl"}};
}  // namespace

BaselineDepth parseBaselineDepth(const std::string& name) { return parseNamed(kBaselineDepths, name, "baseline depth"); }
const char* baselineDepthName(BaselineDepth depth) { return nameOf(kBaselineDepths, depth); }

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
