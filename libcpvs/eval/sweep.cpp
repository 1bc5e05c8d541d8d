#include "libcpvs/eval/sweep.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/eval/cpvs_method.h"
#include "libcpvs/eval/error_stats.h"
#include "libcpvs/eval/reference_rays.h"
#include "libcpvs/eval/throughput.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/reference/shadow_reference.h"

namespace cpvs {

std::vector<SurfaceSample> sweepPoints(const Light& light, const std::vector<SurfaceSample>& samples, bool allPoints) {
  std::vector<SurfaceSample> points;
  for (const SurfaceSample& s : samples) {
    if (!withinInfluence(light, s.position)) continue;
    if (!allPoints && !facesLight(light, s.position, s.normal)) continue;
    points.push_back(s);
  }
  return points;
}

std::vector<SurfaceSample> exteriorSamples(const ShadowReference& reference, const std::vector<SurfaceSample>& samples) {
  std::vector<uint8_t> keep(samples.size());
  parallelFor(samples.size(), [&](size_t i) { keep[i] = !reference.insideClosedSolid({samples[i].position, samples[i].normal}); });
  std::vector<SurfaceSample> out;
  for (size_t i = 0; i < samples.size(); ++i)
    if (keep[i]) out.push_back(samples[i]);
  return out;
}

namespace {

using SweepLog = std::function<void(const std::string&)>;

// One light's scoring points (surface samples it reaches, topped up from further rounds where there are few)
// and the reference's answer at each.
struct LightPoints {
  std::vector<SurfaceSample> points;
  std::vector<uint8_t> reference;
};

LightPoints gatherLightPoints(const Light& light, const WorldGeometry& world, const ShadowReference& referenceRays,
                              const std::vector<SurfaceSample>& samples, const SweepSettings& settings,
                              const SweepLog& log) {
  LightPoints out;
  out.points = sweepPoints(light, samples, settings.allPoints);
  // Top up a light with few points from further rounds; bounded so a light that reaches almost nothing
  // cannot loop for long.
  constexpr uint64_t kMaxRounds = 200;
  uint64_t round = 1;
  for (; out.points.size() < settings.minLightPoints && round <= kMaxRounds; ++round) {
    std::vector<SurfaceSample> more =
        sweepPoints(light, sampleSurfaces(world, settings.samples, settings.seed + round), settings.allPoints);
    if (!settings.interiorPoints) more = exteriorSamples(referenceRays, more);
    const size_t wanted = settings.minLightPoints - out.points.size();
    if (more.size() > wanted) more.resize(wanted);
    out.points.insert(out.points.end(), more.begin(), more.end());
  }
  if (round > 1)
    log("light '" + light.name + "': topped up to " + std::to_string(out.points.size()) + " points from " +
        std::to_string(round - 1) + " more rounds of samples");
  out.reference.resize(out.points.size());
  parallelFor(out.points.size(), [&](size_t i) {
    out.reference[i] = referenceRays.visibility(light, {out.points[i].position, out.points[i].normal});
  });
  log("light '" + light.name + "': " + std::to_string(out.points.size()) + " points");
  return out;
}

// The baked CPVS of one light scored against the reference, and its lookups timed against Embree's rays on the
// same points (one thread each, interleaved over three rounds).
void scoreCpvs(const CpvsMethod& cpvs, const Light& light, const ShadowReference& referenceRays,
               const std::vector<SurfacePoint>& queries, const std::vector<uint8_t>& reference,
               const std::vector<uint8_t>& uniform, const LookupOptions& lookup, const SweepSettings& settings,
               SweepRow& row) {
  row.bytes = cpvs.bytes();
  const ErrorStats e = scoreMethod(cpvs, queries, lookup, reference, uniform);
  row.misclassified = e.misclassified;
  row.misclassifiedUniform = e.misclassifiedUniform;
  row.meanAbsDiff = e.meanAbsDiff();
  Throughput throughput;
  throughput.add("lookups", [&] { return lookupsPerSecond(cpvs, queries, lookup, settings.timingSeconds); });
  throughput.add("rays", [&] { return raysPerSecond(referenceRays, {&light, 1}, queries, settings.timingSeconds); });
  throughput.run(3);
  row.lookupsPerS = throughput.best("lookups");
  row.raysPerS = throughput.best("rays");
}

// The shadow map of equal bytes, view by view, scored on the same points.
void scoreShadowMap(const BakedLight& baked, const Light& light, const ShadowReference& referenceRays,
                    const WorldGeometry& world, const std::vector<SurfacePoint>& queries,
                    const std::vector<uint8_t>& reference, const std::vector<uint8_t>& uniform,
                    const LookupOptions& lookup, const SweepSettings& settings, std::unique_ptr<DepthRenderer>& raster,
                    SweepRow& row) {
  const Stopwatch smClock;
  std::vector<LightView> views;
  std::vector<uint64_t> budgets;
  for (const BakedView& v : baked.views) {
    views.push_back(v.view);
    budgets.push_back(v.dag.bytes());
  }
  if (settings.baselineDepth == BaselineDepth::Raster && !raster) raster = DepthRenderer::create(settings.bake.backend);
  const ShadowMapMethod sm = ShadowMapMethod::build(light, views, budgets, settings.baselineDepth,
                                                    referenceRays.scene(), world, raster.get());
  row.smBuildMs = smClock.ms();
  row.smSize = sm.maps().maps().empty() ? 0 : sm.maps().maps()[0].size();
  row.smBytes = sm.bytes();
  const ErrorStats se = scoreMethod(sm, queries, lookup, reference, uniform);
  row.smMisclassified = se.misclassified;
  row.smMisclassifiedUniform = se.misclassifiedUniform;
  row.smMeanAbsDiff = se.meanAbsDiff();
  row.smLookupsPerS = lookupsPerSecond(sm, queries, lookup, settings.timingSeconds);
}

}  // namespace

std::vector<SweepRow> runSweep(const Scene& scene, const SweepSettings& settings, std::string* renderer,
                               const SweepCallbacks& callbacks) {
  const SweepLog log = [&](const std::string& line) {
    if (callbacks.log) callbacks.log(line);
  };
  orThrow(checkPcfKernel(settings.pcfKernel));
  const WorldGeometry world = flatten(scene, settings.bake.ground);  // the solids the bakes take
  const ShadowReference referenceRays(world, NormalOrientation::AsGiven, settings.referenceEpsilon);
  const LookupOptions lookup{settings.pcfKernel, NormalOrientation::AsGiven};

  // Per light: points and reference values.
  std::vector<SurfaceSample> samples = sampleSurfaces(world, settings.samples, settings.seed);
  const size_t drawn = samples.size();
  if (!settings.interiorPoints) samples = exteriorSamples(referenceRays, samples);
  const uint64_t interior = drawn - samples.size();
  log(std::to_string(interior) + " of " + std::to_string(drawn) + " samples inside closed solids dropped");
  const size_t lightCount = scene.lights.size();
  std::vector<LightPoints> lightPoints;
  for (const Light& light : scene.lights)
    lightPoints.push_back(gatherLightPoints(light, world, referenceRays, samples, settings, log));

  std::unique_ptr<DepthRenderer> raster;
  std::vector<SweepRow> rows;
  for (uint32_t resolution : settings.resolutions) {
    BakeSettings bake = settings.bake;
    bake.resolution = resolution;
    BakeReport report;
    const Stopwatch bakeClock;
    const CpvsContent content = bakeScene(scene, bake, &report);
    const double bakeWallMs = bakeClock.ms();
    if (renderer && !report.renderer.empty()) *renderer = report.renderer;
    const uint64_t fileBytes = writeCpvs(content).size();
    log("N = " + std::to_string(resolution) + ": baked in " + std::to_string(int(bakeWallMs)) + " ms, " +
        std::to_string(fileBytes) + " bytes");

    for (size_t l = 0; l < lightCount; ++l) {
      const Light& light = scene.lights[l];
      const BakedLight& baked = content.lights[l];
      const std::vector<uint8_t>& reference = lightPoints[l].reference;
      SweepRow row;
      row.light = l;
      row.lightName = light.name;
      row.lightType = light.type;
      row.resolution = resolution;
      row.bakeWallMs = bakeWallMs;
      row.fileBytes = fileBytes;
      for (const ViewReport& v : report.lights[l].views) row.bakeMs += v.depthMs + v.peelMs + v.masksMs + v.dagMs;
      const CpvsMethod cpvs = CpvsMethod::fromBake(baked);
      const std::vector<SurfaceSample>& pts = lightPoints[l].points;
      const size_t count = pts.size();
      row.points = count;
      row.interiorSamples = interior;
      for (uint8_t r : reference) row.referenceLit += r;
      std::vector<SurfacePoint> queries(count);
      for (size_t i = 0; i < count; ++i) queries[i] = {pts[i].position, pts[i].normal};
      // Uniformity at this resolution (voxel size of the view the point falls in).
      std::vector<uint8_t> uniform(count);
      parallelFor(count, [&](size_t i) { uniform[i] = referenceRays.uniformAround(cpvs.shadow(), queries[i], reference[i]); });
      for (uint8_t u : uniform) row.uniform += u;
      scoreCpvs(cpvs, light, referenceRays, queries, reference, uniform, lookup, settings, row);
      scoreShadowMap(baked, light, referenceRays, world, queries, reference, uniform, lookup, settings, raster, row);
      char line[256];
      std::snprintf(line, sizeof line,
                    "  light '%s': %llu bytes, misclassified %.4f%% (uniform %.4f%%); shadow map %ux%u: %.4f%%",
                    light.name.c_str(), static_cast<unsigned long long>(row.bytes),
                    100.0 * row.rate(row.misclassified, row.points),
                    100.0 * row.rate(row.misclassifiedUniform, row.uniform), row.smSize, row.smSize,
                    100.0 * row.rate(row.smMisclassified, row.points));
      log(line);
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

}  // namespace cpvs
