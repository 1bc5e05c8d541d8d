#include "libcpvs/scene/surface_samples.h"

#include <algorithm>
#include <cmath>

namespace cpvs {
namespace {

// SplitMix64: tiny, fast, and fully specified, so the samples are the same everywhere.
struct SplitMix64 {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

}  // namespace

std::vector<SurfaceSample> sampleSurfaces(const WorldGeometry& world, size_t count, uint64_t seed) {
  const size_t triangles = world.triangleCount();
  std::vector<double> cumulative(triangles);
  double total = 0.0;
  for (size_t t = 0; t < triangles; ++t) {
    const glm::dvec3& a = world.positions[world.indices[3 * t]];
    const glm::dvec3& b = world.positions[world.indices[3 * t + 1]];
    const glm::dvec3& c = world.positions[world.indices[3 * t + 2]];
    const double area = world.isClosing(t) ? 0.0 : 0.5 * glm::length(glm::cross(b - a, c - a));
    total += std::isfinite(area) ? area : 0.0;
    cumulative[t] = total;
  }
  std::vector<SurfaceSample> samples;
  if (!(total > 0.0)) return samples;
  samples.reserve(count);
  SplitMix64 rng{seed};
  // Points that fall on a cut-away texel of an alpha-tested triangle are drawn again; a scene whose area is
  // almost all cut away stops after a bounded number of draws with fewer points.
  const uint64_t maxDraws = 64 * uint64_t(count) + 1000000;
  for (uint64_t draws = 0; samples.size() < count && draws < maxDraws; ++draws) {
    const double pick = rng.uniform() * total;
    size_t t = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin());
    t = std::min(t, triangles - 1);
    if (cumulative[t] == (t ? cumulative[t - 1] : 0.0)) continue;  // zero area (rounding at the edge)
    const glm::dvec3& a = world.positions[world.indices[3 * t]];
    const glm::dvec3& b = world.positions[world.indices[3 * t + 1]];
    const glm::dvec3& c = world.positions[world.indices[3 * t + 2]];
    // Uniform in the triangle: the square-root warp of two uniforms.
    const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
    if (!world.masked.blocksAt(t, r1 * (1.0 - r2), r1 * r2)) continue;
    const glm::dvec3 p = (1.0 - r1) * a + r1 * (1.0 - r2) * b + r1 * r2 * c;
    const glm::dvec3 n = glm::cross(b - a, c - a);
    const double length = glm::length(n);
    if (!(length > 0.0)) continue;
    samples.push_back({p, n / length});
  }
  return samples;
}

}  // namespace cpvs
