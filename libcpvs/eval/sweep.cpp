#include "libcpvs/eval/sweep.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "formats/cpvs/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/base/error.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/reference/shadow_reference.h"

namespace cpvs {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Work items per second of `pass` (which does `workPerPass` items), repeated for at least `seconds`.
template <class Fn>
double perSecond(size_t workPerPass, double seconds, Fn&& pass) {
  if (workPerPass == 0) return 0.0;
  uint64_t work = 0;
  const auto start = Clock::now();
  double elapsed = 0;
  do {
    pass();
    work += workPerPass;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < seconds);
  return double(work) / elapsed;
}

volatile float gSink;  // keeps the timed loops from being optimised away
volatile int gIntSink;

glm::dvec3 toLightDirection(const Light& light, const glm::dvec3& point) {
  if (light.type == LightType::Directional) return -light.direction;
  const glm::dvec3 d = light.position - point;
  const double length = glm::length(d);
  return length > 0 ? d / length : glm::dvec3(0.0);
}

struct Errors {
  uint64_t misclassified = 0, misclassifiedUniform = 0;
  double absDiff = 0;
};

Errors compare(const std::vector<float>& values, const std::vector<uint8_t>& reference,
               const std::vector<uint8_t>& uniform) {
  Errors e;
  for (size_t i = 0; i < values.size(); ++i) {
    const bool wrong = (values[i] >= 0.5f) != (reference[i] != 0);
    e.misclassified += wrong;
    e.misclassifiedUniform += wrong && uniform[i];
    e.absDiff += std::abs(double(values[i]) - double(reference[i]));
  }
  return e;
}

template <class Fn>
void parallelFor(size_t count, Fn&& fn) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) fn(i);
  });
}

}  // namespace

BaselineDepth parseBaselineDepth(const std::string& name) {
  if (name == "embree") return BaselineDepth::Embree;
  if (name == "raster" || name == "gl") return BaselineDepth::Raster;
  throw Error(ErrorCategory::InvalidArgument, "baseline depth '" + name + "': expected embree or raster");
}

const char* baselineDepthName(BaselineDepth depth) { return depth == BaselineDepth::Embree ? "embree" : "raster"; }

std::vector<SurfaceSample> sweepPoints(const Light& light, const std::vector<SurfaceSample>& samples, bool allPoints) {
  std::vector<SurfaceSample> points;
  for (const SurfaceSample& s : samples) {
    if (!withinInfluence(light, s.position)) continue;
    if (!allPoints && !(glm::dot(s.normal, toLightDirection(light, s.position)) > 0)) continue;
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

std::vector<SweepRow> runSweep(const Scene& scene, const SweepSettings& settings, std::string* renderer,
                               const SweepCallbacks& callbacks) {
  auto log = [&](const std::string& line) {
    if (callbacks.log) callbacks.log(line);
  };
  orThrow(checkPcfKernel(settings.pcfKernel));
  const WorldGeometry world = flatten(scene, settings.bake.ground);  // the solids the bakes take
  const ShadowReference referenceRays(world, NormalOrientation::AsGiven, settings.referenceEpsilon);
  const EmbreeScene& embree = referenceRays.scene();
  const LookupOptions lookup{settings.pcfKernel, NormalOrientation::AsGiven};

  // Per light: points and reference values.
  std::vector<SurfaceSample> samples = sampleSurfaces(world, settings.samples, settings.seed);
  const size_t drawn = samples.size();
  if (!settings.interiorPoints) samples = exteriorSamples(referenceRays, samples);
  const uint64_t interior = drawn - samples.size();
  log(std::to_string(interior) + " of " + std::to_string(drawn) + " samples inside closed solids dropped");
  const size_t lightCount = scene.lights.size();
  std::vector<std::vector<SurfaceSample>> points(lightCount);
  std::vector<std::vector<uint8_t>> reference(lightCount);
  for (size_t l = 0; l < lightCount; ++l) {
    const Light& light = scene.lights[l];
    points[l] = sweepPoints(light, samples, settings.allPoints);
    // Top up a light with few points from further rounds; bounded so a light that reaches almost nothing
    // cannot loop for long.
    constexpr uint64_t kMaxRounds = 200;
    uint64_t round = 1;
    for (; points[l].size() < settings.minLightPoints && round <= kMaxRounds; ++round) {
      std::vector<SurfaceSample> more = sweepPoints(light, sampleSurfaces(world, settings.samples, settings.seed + round),
                                                   settings.allPoints);
      if (!settings.interiorPoints) more = exteriorSamples(referenceRays, more);
      const size_t wanted = settings.minLightPoints - points[l].size();
      if (more.size() > wanted) more.resize(wanted);
      points[l].insert(points[l].end(), more.begin(), more.end());
    }
    if (round > 1)
      log("light '" + light.name + "': topped up to " + std::to_string(points[l].size()) + " points from " +
          std::to_string(round - 1) + " more rounds of samples");
    reference[l].resize(points[l].size());
    parallelFor(points[l].size(), [&](size_t i) {
      reference[l][i] = referenceRays.visibility(light, {points[l][i].position, points[l][i].normal});
    });
    log("light '" + light.name + "': " + std::to_string(points[l].size()) + " points");
  }

  std::unique_ptr<DepthRenderer> raster;
  std::vector<SweepRow> rows;
  for (uint32_t resolution : settings.resolutions) {
    BakeSettings bake = settings.bake;
    bake.resolution = resolution;
    BakeReport report;
    const auto t0 = Clock::now();
    const CpvsContent content = bakeScene(scene, bake, &report);
    const double bakeWallMs = msSince(t0);
    if (renderer && !report.renderer.empty()) *renderer = report.renderer;
    const uint64_t fileBytes = writeCpvs(content).size();
    log("N = " + std::to_string(resolution) + ": baked in " + std::to_string(int(bakeWallMs)) + " ms, " +
        std::to_string(fileBytes) + " bytes");

    for (size_t l = 0; l < lightCount; ++l) {
      const Light& light = scene.lights[l];
      const BakedLight& baked = content.lights[l];
      SweepRow row;
      row.light = l;
      row.lightName = light.name;
      row.lightType = light.type;
      row.resolution = resolution;
      row.bakeWallMs = bakeWallMs;
      row.fileBytes = fileBytes;
      for (const ViewReport& v : report.lights[l].views) row.bakeMs += v.depthMs + v.peelMs + v.masksMs + v.dagMs;
      std::vector<LightView> views;
      std::vector<DagView> dags;
      for (const BakedView& v : baked.views) {
        views.push_back(v.view);
        dags.push_back(v.dag.view());
        row.bytes += v.dag.bytes();
      }
      const LightShadow shadow = orThrow(LightShadow::create(light, views, dags));
      const std::vector<SurfaceSample>& pts = points[l];
      const size_t count = pts.size();
      row.points = count;
      row.interiorSamples = interior;
      for (uint8_t r : reference[l]) row.referenceLit += r;

      // Uniformity at this resolution (voxel size of the view the point falls in).
      std::vector<uint8_t> uniform(count);
      parallelFor(count, [&](size_t i) {
        uniform[i] = referenceRays.uniformAround(shadow, {pts[i].position, pts[i].normal}, reference[l][i]);
      });
      for (uint8_t u : uniform) row.uniform += u;

      std::vector<float> values(count);
      parallelFor(count, [&](size_t i) { values[i] = shadow.visibility(pts[i].position, pts[i].normal, lookup); });
      const Errors e = compare(values, reference[l], uniform);
      row.misclassified = e.misclassified;
      row.misclassifiedUniform = e.misclassifiedUniform;
      row.meanAbsDiff = count ? e.absDiff / double(count) : 0.0;
      // Lookups as cpvs-query makes them (batches of 4096 points) and Embree rays on the same points, one
      // thread each, interleaved over three rounds so that a change in machine load hits both alike; each
      // figure is the best of its rounds.
      std::vector<SurfacePoint> batchPoints(count);
      for (size_t i = 0; i < count; ++i) batchPoints[i] = {pts[i].position, pts[i].normal};
      std::vector<float> batchOut(std::min<size_t>(count, kLookupBatch));
      for (int round = 0; round < 3; ++round) {
        row.lookupsPerS = std::max(row.lookupsPerS, perSecond(count, settings.timingSeconds, [&] {
          float sum = 0;
          for (size_t b = 0; b < count; b += kLookupBatch) {
            const size_t e = std::min(count, b + kLookupBatch);
            orThrow(shadow.visibility(std::span<const SurfacePoint>(batchPoints.data() + b, e - b), lookup,
                              std::span<float>(batchOut.data(), e - b)));
            sum += batchOut[0];
          }
          gSink = sum;
        }));
        row.raysPerS = std::max(row.raysPerS, perSecond(count, settings.timingSeconds, [&] {
          int sum = 0;
          for (const SurfaceSample& p : pts) sum += referenceRays.visibility(light, {p.position, p.normal});
          gIntSink = sum;
        }));
      }

      // The shadow map of equal bytes, view by view.
      const auto s0 = Clock::now();
      std::vector<ShadowMap16> maps;
      for (const BakedView& v : baked.views) {
        const uint32_t size = equalBytesShadowMapSize(v.dag.bytes());
        if (settings.baselineDepth == BaselineDepth::Embree) {
          maps.push_back(buildShadowMapEmbree(embree, v.view, size));
        } else {
          if (!raster) raster = DepthRenderer::create(bake.backend);
          maps.push_back(buildShadowMapRaster(*raster, world, v.view, size));
        }
      }
      row.smBuildMs = msSince(s0);
      const ShadowMapLight sm(light, std::move(maps));
      row.smSize = sm.maps().empty() ? 0 : sm.maps()[0].size();
      row.smBytes = sm.bytes();
      parallelFor(count, [&](size_t i) { values[i] = sm.visibility(pts[i].position, pts[i].normal, lookup); });
      const Errors se = compare(values, reference[l], uniform);
      row.smMisclassified = se.misclassified;
      row.smMisclassifiedUniform = se.misclassifiedUniform;
      row.smMeanAbsDiff = count ? se.absDiff / double(count) : 0.0;
      row.smLookupsPerS = perSecond(count, settings.timingSeconds, [&] {
        float sum = 0;
        for (const SurfaceSample& p : pts) sum += sm.visibility(p.position, p.normal, lookup);
        gSink = sum;
      });
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
