#include "libcpvs/eval/shadow_method.h"

#include <algorithm>
#include <vector>

#include "libcpvs/base/parallel.h"
#include "libcpvs/eval/throughput.h"

namespace cpvs {

ErrorStats scoreMethod(const ShadowMethod& method, std::span<const SurfacePoint> points, const LookupOptions& options,
                       std::span<const uint8_t> reference, std::span<const uint8_t> uniform) {
  std::vector<float> values(points.size());
  const size_t batches = (points.size() + kLookupBatch - 1) / kLookupBatch;
  parallelFor(batches, [&](size_t b) {
    const size_t begin = b * kLookupBatch, end = std::min(points.size(), begin + kLookupBatch);
    method.visibility(points.subspan(begin, end - begin), options, std::span<float>(values).subspan(begin, end - begin));
  }, 1);
  ErrorStats stats;
  for (size_t i = 0; i < points.size(); ++i) stats.record(values[i], reference[i], uniform[i] != 0, i);
  return stats;
}

double lookupsPerSecond(std::span<const ShadowMethod* const> methods, std::span<const SurfacePoint> points,
                        const LookupOptions& options, double seconds) {
  std::vector<float> out(std::min(points.size(), kLookupBatch));
  return perSecond(points.size() * methods.size(), seconds, [&] {
    float sum = 0;
    for (const ShadowMethod* method : methods)
      for (size_t b = 0; b < points.size(); b += kLookupBatch) {
        const size_t e = std::min(points.size(), b + kLookupBatch);
        method->visibility(points.subspan(b, e - b), options, std::span<float>(out.data(), e - b));
        sum += out[0];
      }
    consume(sum);
  });
}

}  // namespace cpvs
