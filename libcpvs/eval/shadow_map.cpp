#include "libcpvs/eval/shadow_map.h"

#include <algorithm>
#include <cmath>

#include "libcpvs/base/error.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/views/view_geometry.h"

namespace cpvs {

namespace {
constexpr uint32_t kDepthLevels = 65536;
}  // namespace

uint32_t equalBytesShadowMapSize(uint64_t bytes) {
  uint64_t m = uint64_t(std::sqrt(double(bytes / 2)));
  while (m * m * 2 > bytes && m > 0) --m;
  while ((m + 1) * (m + 1) * 2 <= bytes) ++m;
  return uint32_t(std::clamp<uint64_t>(m, 1, 1u << 20));
}

uint16_t quantizeSlice(double slice, uint32_t resolution) {
  const double q = std::floor(slice * double(kDepthLevels) / double(resolution));
  if (!(q > 0)) return 0;  // also NaN
  return uint16_t(std::min(q, double(ShadowMap16::kFar)));
}

LightView shadowMapView(const LightView& view, uint32_t size) {
  if (size < 1) throw Error(ErrorCategory::InvalidArgument, "shadow map size must be at least 1");
  LightView v = view;
  v.resolution = size;
  return v;
}

ShadowMap16 buildShadowMapEmbree(const EmbreeScene& scene, const LightView& view, uint32_t size, bool parallel) {
  ShadowMap16 map;
  map.view = shadowMapView(view, size);
  map.depth.assign(size_t(size) * size, ShadowMap16::kFar);
  if (view.empty) return map;
  // Rows in batches: bounded memory for the rays whatever the size.
  const uint32_t rowsPerBatch = std::max(1u, (1u << 20) / size);
  std::vector<Ray> rays;
  for (uint32_t y0 = 0; y0 < size; y0 += rowsPerBatch) {
    const uint32_t y1 = std::min(size, y0 + rowsPerBatch);
    rays.clear();
    rays.reserve(size_t(y1 - y0) * size);
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = 0; x < size; ++x) rays.push_back(texelRay(map.view, x + 0.5, y + 0.5));
    const auto hits = scene.firstHits(rays, 0.0, EmbreeScene::kInfinity, parallel);
    for (size_t i = 0; i < hits.size(); ++i) {
      if (!hits[i]) continue;
      const glm::dvec3 p = rays[i].origin + hits[i]->t * rays[i].direction;
      const GridPoint g = toGrid(map.view, p);
      if (!g.inFront) continue;
      map.depth[size_t(y0) * size + i] = quantizeSlice(std::max(g.uvs.z, 0.0), size);
    }
  }
  return map;
}

ShadowMap16 buildShadowMapRaster(DepthRenderer& renderer, const WorldGeometry& world, const LightView& view,
                                 uint32_t size) {
  ShadowMap16 map;
  map.view = shadowMapView(view, size);
  map.depth.assign(size_t(size) * size, ShadowMap16::kFar);
  if (view.empty) return map;
  // The same view at 65536 slices, its lateral extent widened so that texels [0, size) cover the original
  // extent: u' = 65536 (a - xMin) / (65536 / size (xMax - xMin)) = u.
  LightView wide = view;
  wide.resolution = kDepthLevels;
  const double widen = double(kDepthLevels) / double(size);
  wide.xMax = view.xMin + (view.xMax - view.xMin) * widen;
  wide.yMax = view.yMin + (view.yMax - view.yMin) * widen;
  const ViewGeometry geometry = gatherViewGeometry(world, wide);
  if (geometry.triangleCount() == 0) return map;
  PeelSettings peel;
  peel.maxPeels = 1;  // only the enter depth is used
  const uint32_t tile = std::min(renderer.maxRegionSize(), 4096u);
  for (uint32_t y0 = 0; y0 < size; y0 += tile) {
    for (uint32_t x0 = 0; x0 < size; x0 += tile) {
      const RegionRect rect{x0, y0, std::min(tile, size - x0), std::min(tile, size - y0)};
      const DepthRegion region = renderer.render(geometry, wide, rect, peel);
      for (uint32_t y = 0; y < rect.height; ++y)
        for (uint32_t x = 0; x < rect.width; ++x) {
          const uint32_t e = region.enterAt(x, y);
          map.depth[size_t(y0 + y) * size + x0 + x] = uint16_t(std::min<uint32_t>(e, ShadowMap16::kFar));
        }
    }
  }
  return map;
}

float shadowMapVisibility(const ShadowMap16& map, const glm::dvec3& point, const glm::dvec3& normal,
                          const LookupOptions& options) {
  const LookupCell cell = lookupCell(map.view, point, normal, options);
  if (cell.kind == LookupCell::Kind::Lit) return 1.0f;
  if (cell.kind != LookupCell::Kind::Voxel) return 0.0f;  // invalid input, or a back-facing surface
  const uint32_t m = map.size();
  const uint16_t q = quantizeSlice(std::clamp(cell.uvs.z, 0.0, double(m)), m);
  const int k = std::max(1, options.pcfKernel);
  if (k == 1) return q <= map.at(uint32_t(cell.x), uint32_t(cell.y)) ? 1.0f : 0.0f;
  const int r = k / 2;
  uint32_t lit = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const int64_t y = int64_t(cell.y) + dy;
    for (int dx = -r; dx <= r; ++dx) {
      const int64_t x = int64_t(cell.x) + dx;
      if (x < 0 || y < 0 || x >= int64_t(m) || y >= int64_t(m) || q <= map.at(uint32_t(x), uint32_t(y))) ++lit;
    }
  }
  return float(double(lit) / (double(k) * double(k)));
}

ShadowMapLight::ShadowMapLight(const Light& light, std::vector<ShadowMap16> maps)
    : light_(light), maps_(std::move(maps)) {
  for (const ShadowMap16& m : maps_) views_.push_back(m.view);
}

float ShadowMapLight::visibility(const glm::dvec3& point, const glm::dvec3& normal,
                                 const LookupOptions& options) const {
  if (!std::isfinite(point.x) || !std::isfinite(point.y) || !std::isfinite(point.z)) return 0.0f;
  if (!withinInfluence(light_, point)) return 0.0f;
  const auto index = selectView(light_, views_, point);
  if (!index) return 0.0f;
  return shadowMapVisibility(maps_[*index], point, normal, options);
}

uint64_t ShadowMapLight::bytes() const {
  uint64_t b = 0;
  for (const ShadowMap16& m : maps_) b += m.bytes();
  return b;
}

}  // namespace cpvs
