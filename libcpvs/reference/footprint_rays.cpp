#include "libcpvs/reference/footprint_rays.h"

#include <algorithm>
#include <vector>

#include "libcpvs/runtime/light_view.h"

namespace cpvs {

void footprintVisibility(const ShadowReference& reference, const LightShadow& shadow,
                         std::span<const SurfacePoint> points, const LookupOptions& options, int raysPerSide,
                         std::span<float> out) {
  const int s = std::max(1, raysPerSide);
  const double k = double(options.pcfKernel), h = double(options.pcfKernel / 2), rays = double(s) * s;
  std::vector<SurfacePoint> samples;  // no normal: each ray starts just off its point toward the light
  std::vector<uint32_t> owner;
  std::vector<uint8_t> sampled(points.size(), 0);  // the point's answer is a footprint's fraction
  for (size_t i = 0; i < points.size(); ++i) {
    out[i] = 0.0f;
    const SurfacePoint& p = points[i];
    const int view = shadow.viewIndex(p.position);
    if (view < 0) continue;  // outside the light's influence: 0, as the lookups answer
    const LightView& v = shadow.views()[size_t(view)];
    const LookupCell cell = lookupCell(v, p.position, p.normal, options);
    if (cell.kind != LookupCell::Kind::Voxel) {
      out[i] = cell.kind == LookupCell::Kind::Lit ? 1.0f : 0.0f;
      continue;
    }
    const double n = double(v.resolution);
    sampled[i] = 1;
    for (int b = 0; b < s; ++b)
      for (int a = 0; a < s; ++a) {
        const double u = double(cell.x) - h + (a + 0.5) * k / s, w = double(cell.y) - h + (b + 0.5) * k / s;
        if (u < 0 || w < 0 || u >= n || w >= n) {
          out[i] += 1.0f;  // off the grid: lit
          continue;
        }
        samples.push_back({gridToWorld(v, {u, w, double(cell.z) + 0.5}), glm::dvec3(0.0)});
        owner.push_back(uint32_t(i));
      }
  }
  std::vector<uint8_t> lit;
  reference.visibilityPackets(shadow.light(), samples, lit);
  for (size_t r = 0; r < samples.size(); ++r) out[owner[r]] += float(lit[r]);
  for (size_t i = 0; i < points.size(); ++i)
    if (sampled[i]) out[i] = float(double(out[i]) / rays);
}

}  // namespace cpvs
