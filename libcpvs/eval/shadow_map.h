#pragma once
// A plain 16-bit shadow map: the baseline the speed-vs-error sweep (tools/cpvs-sweep) sets beside a
// CPVS of the same bytes. Not part of the engine runtime (it needs Embree or GL to build).
//
// The map of one light view is M x M texels over exactly the view's lateral extent, near/far plane and depth
// mapping (linear for orthographic views, logarithmic for perspective ones: the same `LightView` with
// `resolution = M`, any M >= 1, not only powers of two). So it differs from the CPVS only in what it stores:
//  * texel (x, y) holds the depth of the first surface along the ray through the texel centre
//    (u, v) = (x + 0.5, y + 0.5), quantised to 16 bits: q(s) = min(floor(65536 s / M), 65535), where s is
//    the continuous slice coordinate of the view at resolution M (s / M in [0, 1) from near to far);
//    65535 where the ray meets nothing (the texel is lit at every depth);
//  * a lookup uses the CPVS lookup's own voxel mapping and normal bias (lookupCell in
//    libcpvs/runtime/shadow_lookup.h: half the filter width along the grid-space normal plus one voxel, in
//    voxels of this map's resolution M), then compares the biased point's q(s) with the stored value:
//    lit when q(point) <= q(stored). K x K PCF counts the lit texels of the K x K neighbourhood at that depth
//    (texels outside the map are lit), the same footprint as the CPVS PCF.
// The depth comes from Embree rays through the texel centres (exact first hit, double precision mapping) or
// from the GL depth renderer (an ordinary rasterised enter-depth pass, DepthRenderer) rendering the view at
// 65536 slices: both store the same q up to the rasteriser's rounding.
//
// Equal bytes: a CPVS view of B bytes is compared with the map of M = floor(sqrt(B / 2)) (M * M * 2 <= B).
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

class EmbreeScene;
class DepthRenderer;

struct ShadowMap16 {
  static constexpr uint16_t kFar = 65535;  // no caster (or one at the far end): lit at every depth
  LightView view;                          // the CPVS view's mapping with resolution = M
  std::vector<uint16_t> depth;             // M * M, row-major: depth[y * M + x]

  uint32_t size() const { return view.resolution; }
  uint64_t bytes() const { return uint64_t(depth.size()) * sizeof(uint16_t); }
  uint16_t at(uint32_t x, uint32_t y) const { return depth[size_t(y) * view.resolution + x]; }
};

// The edge M of a 16-bit shadow map that takes at most `bytes` bytes (at least 1).
uint32_t equalBytesShadowMapSize(uint64_t bytes);

// 16-bit quantisation of a continuous slice coordinate s of a view of resolution M (see above).
uint16_t quantizeSlice(double slice, uint32_t resolution);

// `view` with its resolution replaced by `size` (everything else, the fitted extent included, kept).
LightView shadowMapView(const LightView& view, uint32_t size);

// Builds the map of `view` at edge `size` from Embree first hits through the texel centres (TBB-parallel
// when `parallel`). A view flagged empty gives a map of kFar.
ShadowMap16 buildShadowMapEmbree(const EmbreeScene& scene, const LightView& view, uint32_t size,
                                 bool parallel = true);

// The same from the GL depth renderer's enter depth: the view is rendered at resolution 65536 over an extent
// widened by 65536 / size, of which the size x size corner is read, so the renderer's integer enter slice is
// the 16-bit value directly. Throws Error like DepthRenderer::render.
ShadowMap16 buildShadowMapRaster(DepthRenderer& renderer, const WorldGeometry& world, const LightView& view,
                                 uint32_t size);

// Visibility of a point in one map (1 lit, 0 shadowed, PCF: lit fraction), with lookupCell's rules for
// invalid input (0), back-facing normals (0) and points outside the map or behind a perspective eye (1).
// Does not check the light's influence.
float shadowMapVisibility(const ShadowMap16& map, const glm::dvec3& point, const glm::dvec3& normal,
                          const LookupOptions& options);

// All views of one light, like LightShadow: the same view selection (cube face by major axis) and 0 outside
// the light's influence.
class ShadowMapLight {
public:
  ShadowMapLight() = default;
  ShadowMapLight(const Light& light, std::vector<ShadowMap16> maps);

  float visibility(const glm::dvec3& point, const glm::dvec3& normal, const LookupOptions& options) const;
  uint64_t bytes() const;
  const std::vector<ShadowMap16>& maps() const { return maps_; }
  const Light& light() const { return light_; }

private:
  Light light_;
  std::vector<ShadowMap16> maps_;
  std::vector<LightView> views_;
};

}  // namespace cpvs
