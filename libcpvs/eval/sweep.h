#pragma once
// Speed against error: for a scene and its lights, bake a CPVS at each resolution of a sweep, answer
// sampled surface points with the CPVS lookups, and measure the error against Embree shadow rays, beside a
// plain 16-bit shadow map of equal bytes (libcpvs/eval/shadow_map_method.h); both answer through the ShadowMethod interface (shadow_method.h). tools/cpvs-sweep prints and plots
// the rows.
//
// Points: area-weighted surface samples with their geometric normals (sampleSurfaces, deterministic seed),
// without the samples that lie inside a closed solid (faces of intersecting or embedded solids, e.g. a
// building's base inside the ground slab or a fin inside a tower: no camera sees them, and inside closed
// geometry the CPVS is free to answer either way — Kämpe et al. 2015, §3.3), tested at the point moved the reference's
// offset (referenceEpsilon: by default 1e-6 of the scene diagonal) along its normal
// (ShadowReference::insideClosedSolid); per light only those inside the light's influence and, unless
// `allPoints`, facing the light (n . l > 0): a point facing away from the light is in its own surface's shadow,
// which every method answers from the normal alone, so counting those would only dilute the rates.
// Reference: ShadowReference (libcpvs/reference/shadow_reference.h), the one `cpvs-query --reference` uses: a
// shadow ray from the point moved referenceEpsilon of the scene diagonal along its normal, toward the light
// (directional: unbounded; spot/point: up to the light); 0 without a ray for a point facing away from the
// light. A point is *uniform* at resolution N when the reference agrees at 8 points on a circle of radius 2
// voxels of that view around it on its tangent plane and at the point 2 voxels out along its normal;
// misclassifiedUniform counts among those.
// A binary answer is lit when the value is >= 0.5.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "libcpvs/bake/bake.h"
#include "libcpvs/eval/shadow_map_method.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/scene/surface_samples.h"

namespace cpvs {

struct SweepSettings {
  std::vector<uint32_t> resolutions{1024, 2048, 4096, 8192, 16384};
  size_t samples = 100000;  // surface samples drawn (before the per-light influence / facing filter)
  uint64_t seed = 1;
  bool allPoints = false;   // keep points facing away from the light
  bool interiorPoints = false;  // keep samples inside closed solids
  // A light left with fewer points than this (a narrow spot over a large scene) draws further rounds of
  // `samples` (seeds seed + 1, seed + 2, ...; same filters) until it has this many: enough errors to count.
  // The first round is the same for every light, so lights above it keep the same points. 0: off.
  size_t minLightPoints = 0;
  // ShadowReference's ray offset, a fraction of the scene's diagonal.
  double referenceEpsilon = ShadowReference::kDefaultRelativeEpsilon;
  int pcfKernel = 1;        // K for both the CPVS and the shadow map
  BaselineDepth baselineDepth = BaselineDepth::Embree;
  BakeSettings bake;        // resolution is set per sweep step
  double timingSeconds = 0.25;  // minimum duration of each single-threaded throughput measurement
};

struct SweepRow {
  size_t light = 0;
  std::string lightName;
  LightType lightType = LightType::Directional;
  uint32_t resolution = 0;
  double bakeMs = 0;           // the light's views: depth + peel + masks + DAG (bakeScene's report)
  double bakeWallMs = 0;       // the whole bakeScene call at this resolution (all lights)
  uint64_t bytes = 0;          // the light's DAG bytes (node units + leaf masks), all views
  uint64_t fileBytes = 0;      // the whole .cpvs at this resolution (all lights)
  uint64_t points = 0;
  uint64_t interiorSamples = 0;  // samples dropped as inside a closed solid (for the whole scene)
  uint64_t referenceLit = 0;
  uint64_t uniform = 0;
  uint64_t misclassified = 0, misclassifiedUniform = 0;
  double meanAbsDiff = 0;
  double lookupsPerS = 0;      // CPVS lookups, one thread, in batches of 4096 points (as cpvs-query)
  double raysPerS = 0;         // Embree occlusion rays on the same points, one thread, timed beside them
  // The 16-bit shadow map of equal bytes (per view: M = floor(sqrt(view bytes / 2))).
  uint32_t smSize = 0;         // M of the first view
  uint64_t smBytes = 0;
  double smBuildMs = 0;
  uint64_t smMisclassified = 0, smMisclassifiedUniform = 0;
  double smMeanAbsDiff = 0;
  double smLookupsPerS = 0;

  double rate(uint64_t count, uint64_t of) const { return of ? double(count) / double(of) : 0.0; }
};

struct SweepCallbacks {
  std::function<void(const std::string&)> log;  // one line per step
};

// Runs the sweep: rows ordered by resolution, then light. Throws Error (bake or renderer failures).
std::vector<SweepRow> runSweep(const Scene& scene, const SweepSettings& settings, std::string* renderer = nullptr,
                               const SweepCallbacks& callbacks = {});

// The per-light test points of the sweep (influence and facing filter applied to `samples`).
std::vector<SurfaceSample> sweepPoints(const Light& light, const std::vector<SurfaceSample>& samples, bool allPoints);
// The samples that are not inside a closed solid (ShadowReference::insideClosedSolid).
std::vector<SurfaceSample> exteriorSamples(const ShadowReference& reference, const std::vector<SurfaceSample>& samples);

}  // namespace cpvs
