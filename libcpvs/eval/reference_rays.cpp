#include "libcpvs/eval/reference_rays.h"

#include <vector>

#include "libcpvs/eval/throughput.h"

namespace cpvs {

double raysPerSecond(const ShadowReference& reference, std::span<const Light> lights, std::span<const SurfacePoint> points,
                     double seconds) {
  return perSecond(points.size() * lights.size(), seconds, [&] {
    unsigned sum = 0;
    for (const Light& light : lights)
      for (const SurfacePoint& p : points) sum += reference.visibility(light, p);
    consume(float(sum));
  });
}

double packetRaysPerSecond(const ShadowReference& reference, std::span<const Light> lights,
                           std::span<const SurfacePoint> points, double seconds) {
  const std::vector<SurfacePoint> copy(points.begin(), points.end());
  std::vector<uint8_t> out;
  return perSecond(points.size() * lights.size(), seconds, [&] {
    unsigned sum = 0;
    for (const Light& light : lights) {
      reference.visibilityPackets(light, copy, out);
      sum += out.empty() ? 0 : out[0];
    }
    consume(float(sum));
  });
}

}  // namespace cpvs
