#pragma once
// The 16-bit shadow map (shadow_map.h) as a ShadowMethod, built at a byte budget: each view of the light gets
// the largest map whose texels fit the budget given for it (M = floor(sqrt(budget / 2))).
#include <cstdint>
#include <vector>

#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/eval/shadow_method.h"

namespace cpvs {

enum class BaselineDepth : uint8_t { Embree = 0, Raster = 1 };
// "embree" / "raster"; throws Error(InvalidArgument) for anything else.
BaselineDepth parseBaselineDepth(const std::string& name);
const char* baselineDepthName(BaselineDepth depth);

class ShadowMapMethod : public ShadowMethod {
public:
  explicit ShadowMapMethod(ShadowMapLight maps) : maps_(std::move(maps)) {}
  // One map per view, views[i] at viewBudgets[i] bytes, with depths from Embree's first hits or from the GL
  // depth renderer (`raster`, created by the caller; unused for Embree).
  static ShadowMapMethod build(const Light& light, const std::vector<LightView>& views,
                               const std::vector<uint64_t>& viewBudgets, BaselineDepth depth,
                               const EmbreeScene& embree, const WorldGeometry& world, DepthRenderer* raster);

  std::string name() const override { return "shadow-map-16"; }
  const Light& light() const override { return maps_.light(); }
  uint64_t bytes() const override { return maps_.bytes(); }
  void visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                  std::span<float> out) const override;
  const ShadowMapLight& maps() const { return maps_; }

private:
  ShadowMapLight maps_;
};

}  // namespace cpvs
