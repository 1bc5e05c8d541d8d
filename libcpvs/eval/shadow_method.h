#pragma once
// The "shadow method" every comparison of cpvs goes through: something built for one light (at a byte budget,
// where the method has one) that answers how lit a batch of surface points is, and says how many bytes it
// keeps. The CPVS (cpvs_method.h) and the 16-bit shadow map (shadow_map_method.h) are the first two; each
// further baseline is one more file. Scoring (error_stats.h) and timing (throughput.h) take any of them.
#include <cstdint>
#include <span>
#include <string>

#include "libcpvs/eval/error_stats.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

class ShadowMethod {
public:
  virtual ~ShadowMethod() = default;
  virtual std::string name() const = 0;
  virtual const Light& light() const = 0;
  // Bytes the method keeps for this light (what a renderer would hold in memory).
  virtual uint64_t bytes() const = 0;
  // out[i] for points[i]: 1 lit, 0 shadowed, the PCF fraction in between; 0 outside the light's influence.
  // out.size() == points.size().
  virtual void visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                          std::span<float> out) const = 0;
};

// The method's error on `points` against the reference's answers (reference[i], uniform[i] for points[i];
// rows counted from 0), the points answered in parallel.
ErrorStats scoreMethod(const ShadowMethod& method, std::span<const SurfacePoint> points, const LookupOptions& options,
                       std::span<const uint8_t> reference, std::span<const uint8_t> uniform);

// Lookups per second, one thread: every point with every method, in batches of kLookupBatch points (as
// cpvs-query answers), repeated for at least `seconds`.
double lookupsPerSecond(std::span<const ShadowMethod* const> methods, std::span<const SurfacePoint> points,
                        const LookupOptions& options, double seconds);
inline double lookupsPerSecond(const ShadowMethod& method, std::span<const SurfacePoint> points,
                               const LookupOptions& options, double seconds) {
  const ShadowMethod* one[] = {&method};
  return lookupsPerSecond(one, points, options, seconds);
}

}  // namespace cpvs
