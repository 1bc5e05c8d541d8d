// cpvs-query: .cpvs + points (CSV / PLY / EXR G-buffer) -> visibility per point per light, unfiltered or
// PCF-filtered; with --reference SCENE also Embree shadow rays and the error figures (docs/architecture.md, §5).
// Manual: docs/query.md.
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/gbuffer.h"
#include "libcpvs/io/points.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/peak_memory.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/eval/cpvs_method.h"
#include "libcpvs/eval/error_stats.h"
#include "libcpvs/eval/reference_rays.h"
#include "libcpvs/eval/throughput.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/version.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/common/progress.h"
#include "libcpvs/eval/points_on_surfaces.h"

namespace {

using namespace cpvs;

constexpr size_t kChunk = 1 << 16;  // points per streamed chunk (also the timing set)
constexpr double kRoundSeconds = 0.04;    // per method and round
constexpr const char* kUsage = "cpvs-query FILE.cpvs --points POINTS -o OUT [--reference SCENE]";

struct Options {
  std::string cpvs;
  ImportOptions import;
  std::string points;
  std::string normals;
  std::string output;
  int pcf = 1;
  std::vector<std::string> lights;
  std::string reference;
  std::vector<std::string> excludedMeshes;
  std::string report;
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  bool towardLight = false;
  bool quiet = false;
  int topGrid = kAutomaticTopGrid;
  int timingRounds = 7;
  size_t timingPoints = kChunk;  // the first ones of the input
  double biasMargin = kDefaultBiasMargin;
  bool scoreInside = false;
  double referenceEpsilon = ShadowReference::kDefaultRelativeEpsilon;
};

bool isFinite(const QueryPoint& p) {
  return std::isfinite(p.position.x) && std::isfinite(p.position.y) && std::isfinite(p.position.z) &&
         std::isfinite(p.normal.x) && std::isfinite(p.normal.y) && std::isfinite(p.normal.z);
}

// The CSV output, streamed through a 1 MiB buffer into an AtomicFile (committed with the report at the end).
class AtomicOutput {
public:
  explicit AtomicOutput(const std::string& path) : file_(path) { buffer_.reserve(1 << 20); }
  std::string& buffer() { return buffer_; }
  void flushIfFull() {
    if (buffer_.size() >= (1u << 20)) flush();
  }
  void flush() {
    file_.write(buffer_);
    buffer_.clear();
  }
  tools::AtomicFile& file() { return file_; }

private:

  tools::AtomicFile file_;
  std::string buffer_;
};

std::string csvField(const std::string& name) {
  if (name.find_first_of(",\"\r\n") == std::string::npos) return name;
  std::string out = "\"";
  for (char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

void appendValue(std::string& out, float v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  out.append(buffer, result.ptr);
}

bool endsWith(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t i = 0; i < suffix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i]) return false;
  return true;
}

// ---- the selected lights -----------------------------------------------------------------------------

struct SelectedLight {
  size_t index = 0;       // in the file
  std::string column;     // output column / channel name
  std::unique_ptr<CpvsMethod> method;
  const LightShadow& shadow() const { return method->shadow(); }
};

std::vector<SelectedLight> selectLights(const CpvsFile& file, const std::vector<std::string>& wanted,
                                       int topGrid) {
  const auto& lights = file.lights();
  std::vector<size_t> indices;
  if (wanted.empty()) {
    for (size_t i = 0; i < lights.size(); ++i) indices.push_back(i);
  } else {
    for (const std::string& w : wanted) {
      size_t found = lights.size();
      for (size_t i = 0; i < lights.size() && found == lights.size(); ++i)
        if (lights[i].light.name == w) found = i;
      if (found == lights.size() && !w.empty() && std::all_of(w.begin(), w.end(), ::isdigit) && w.size() < 9) {
        const size_t i = std::stoul(w);
        if (i < lights.size()) found = i;
      }
      if (found == lights.size()) {
        std::string names;
        for (size_t i = 0; i < lights.size(); ++i)
          names += (i ? ", " : "") + std::to_string(i) + " '" + lights[i].light.name + "'";
        throw Error(ErrorCategory::InvalidArgument, "--light '" + w + "': no such light (the file has " +
                                         (names.empty() ? std::string("none") : names) + ")");
      }
      indices.push_back(found);
    }
  }
  if (indices.empty()) throw Error(ErrorCategory::InvalidInput, "the .cpvs file holds no lights");
  std::vector<SelectedLight> selected;
  for (size_t i : indices) {
    SelectedLight s;
    s.index = i;
    s.column = lights[i].light.name.empty() ? "light" + std::to_string(i) : lights[i].light.name;
    for (const SelectedLight& other : selected)
      if (other.column == s.column) s.column += "#" + std::to_string(i);
    s.method = std::make_unique<CpvsMethod>(CpvsMethod::fromFile(lights[i], topGrid));
    selected.push_back(std::move(s));
  }
  return selected;
}

// ---- evaluation --------------------------------------------------------------------------------------

struct Totals {
  uint64_t points = 0;
  uint64_t invalid = 0;
  uint64_t insideClosed = 0;           // valid points inside a closed solid of the reference (not scored)
  std::vector<uint64_t> firstInvalid;  // indices of the first few invalid points
  std::vector<double> visibilitySum;   // per light
  std::vector<ErrorStats> errors;  // per light
};

// Lookups of points[begin, end) for every light into values[i * L + l], in batches (LightShadow's
// interleaved walks).
void lookupRange(const std::vector<QueryPoint>& points, size_t begin, size_t end,
                 const std::vector<SelectedLight>& lights, const LookupOptions& lookup, std::vector<float>& scratch,
                 float* values) {
  const size_t nl = lights.size();
  for (size_t b = begin; b < end; b += kLookupBatch) {
    const size_t e = std::min(end, b + kLookupBatch);
    scratch.resize(e - b);
    for (size_t l = 0; l < nl; ++l) {
      lights[l].method->visibility(std::span<const QueryPoint>(points.data() + b, e - b), lookup, scratch);
      for (size_t i = b; i < e; ++i) values[i * nl + l] = scratch[i - b];
    }
  }
}

// values[i * L + l] for the chunk; reference stats accumulated into totals.
void evaluateChunk(const std::vector<QueryPoint>& points, const std::vector<SelectedLight>& lights,
                   const LookupOptions& lookup, const ShadowReference* reference, bool scoreInside,
                   unsigned threads, std::vector<float>& values, Totals& totals) {
  const size_t count = points.size(), nl = lights.size();
  values.assign(count * nl, 0.0f);
  std::vector<uint8_t> valid(count);
  std::vector<uint8_t> refValues(reference ? count * nl : 0), uniform(reference ? count * nl : 0),
      facing(reference ? count * nl : 0);
  const unsigned parts = unsigned(std::min<size_t>(threads, std::max<size_t>(1, count / 1024)));
  parallelParts(count, parts, [&](unsigned, size_t begin, size_t end) {
    std::vector<float> scratch;
    lookupRange(points, begin, end, lights, lookup, scratch, values.data());
    for (size_t i = begin; i < end; ++i) {
      valid[i] = isFinite(points[i]);
      if (!valid[i] || !reference) continue;
      if (!scoreInside && reference->insideClosedSolid(points[i])) {
        valid[i] = 2;  // valid, but not scored
        continue;
      }
      for (size_t l = 0; l < nl; ++l) {
        bool isUniform = false;
        refValues[i * nl + l] = reference->visibility(lights[l].shadow(), points[i], isUniform);
        uniform[i * nl + l] = isUniform;
        const Light& light = lights[l].shadow().light();
        facing[i * nl + l] = receivesLight(light, points[i].position, points[i].normal, lookup.orientation);
      }
    }
  });
  for (size_t i = 0; i < count; ++i) {
    if (!valid[i]) {
      if (totals.firstInvalid.size() < 10) totals.firstInvalid.push_back(totals.points + i);
      ++totals.invalid;
      continue;
    }
    totals.insideClosed += valid[i] == 2;
    for (size_t l = 0; l < nl; ++l) {
      const float v = values[i * nl + l];
      totals.visibilitySum[l] += v;
      if (!reference || valid[i] == 2) continue;
      totals.errors[l].record(v, refValues[i * nl + l], uniform[i * nl + l] != 0, totals.points + i,
                              facing[i * nl + l] != 0);
    }
  }
  totals.points += count;
}

std::vector<QueryPoint> validPoints(const std::vector<QueryPoint>& points) {
  std::vector<QueryPoint> valid;
  for (const QueryPoint& p : points)
    if (isFinite(p)) valid.push_back(p);
  return valid;
}

// ---- main --------------------------------------------------------------------------------------------

nlohmann::json errorJson(const ErrorStats& e) {
  return {{"samples", e.samples},
          {"misclassified", e.rate(e.misclassified, e.samples)},
          {"misclassified_count", e.misclassified},
          {"facing_points", e.facing},
          {"misclassified_facing", e.rate(e.misclassifiedFacing, e.facing)},
          {"uniform_points", e.uniform},
          {"uniform_fraction", e.rate(e.uniform, e.samples)},
          {"misclassified_uniform", e.rate(e.misclassifiedUniform, e.uniform)},
          {"misclassified_uniform_count", e.misclassifiedUniform},
          {"first_misclassified_uniform_points", e.firstMisclassifiedUniform},
          {"first_misclassified_points", e.firstMisclassified},
          {"mean_abs_diff", e.samples ? e.absDiffSum / double(e.samples) : 0.0},
          {"mean_abs_diff_uniform", e.uniform ? e.absDiffSumUniform / double(e.uniform) : 0.0},
          {"reference_lit_fraction", e.rate(e.referenceLit, e.samples)},
          {"cpvs_lit_fraction", e.rate(e.cpvsLit, e.samples)}};
}

void checkOptions(const Options& options) {
  tools::forFlag("--pcf", [&] { orThrow(checkPcfKernel(options.pcf)); });
  if (!options.excludedMeshes.empty() && options.reference.empty())
    throw Error(ErrorCategory::InvalidArgument, "--exclude-mesh only applies to the --reference scene");
  if (options.threads == 0) throw Error(ErrorCategory::InvalidArgument, "--threads must be at least 1");
  tools::forFlag("--reference-epsilon", [&] { ShadowReference::checkRelativeEpsilon(options.referenceEpsilon); });
  if (options.topGrid < -1 || options.topGrid > 8) throw Error(ErrorCategory::InvalidArgument, "--top-grid must be -1 to 8");
  if (options.timingRounds < 0) throw Error(ErrorCategory::InvalidArgument, "--timing-rounds must be 0 or more");
  if (options.timingPoints < 1 || options.timingPoints > (size_t(1) << 30))
    throw Error(ErrorCategory::InvalidArgument, "--timing-points must be 1 to 2^30");
  if (!(options.biasMargin >= 0 && options.biasMargin <= 64))
    throw Error(ErrorCategory::InvalidArgument, "--bias-margin must be between 0 and 64 voxels");
}

// The --reference scene: its ray tracer, and the test of whether the points lie on it (freed once done).
struct ReferenceScene {
  std::unique_ptr<ShadowReference> rays;
  std::unique_ptr<SurfaceProximity> surfaces;
};

// The --reference scene (null without one), its warnings printed unless --quiet.
std::unique_ptr<ReferenceScene> loadReference(const Options& options, NormalOrientation orientation) {
  if (options.reference.empty()) return nullptr;
  tools::expectScene(options.reference, kUsage);
  Scene scene = importGltf(options.reference, options.import);
  auto reference = std::make_unique<ReferenceScene>();
  reference->surfaces = std::make_unique<SurfaceProximity>(scene);  // excluded meshes are surfaces too
  if (!options.excludedMeshes.empty())
    tools::forFlag("--exclude-mesh", [&] { excludeMeshes(scene, options.excludedMeshes); });
  reference->rays = std::make_unique<ShadowReference>(flatten(scene), orientation, options.referenceEpsilon);
  if (!options.quiet)
    for (const std::string& w : scene.warnings) std::cerr << "cpvs-query: warning: " << w << "\n";
  return reference;
}

// Points made on another scene than the reference are scored against surfaces they are not on: the figures
// then mean nothing (often 0 %), so most of them off the scene is worth a warning.
SurfaceCheck checkPointsOnReference(const Options& options, ReferenceScene& reference,
                                    const std::vector<SelectedLight>& lights, const std::vector<QueryPoint>& points) {
  std::vector<const LightShadow*> shadows;
  for (const SelectedLight& l : lights) shadows.push_back(&l.shadow());
  const SurfaceCheck check = checkPointsOnSurfaces(*reference.surfaces, shadows, points);
  reference.surfaces.reset();
  if (check.mostOff())
    std::fprintf(stderr,
                 "cpvs-query: warning: %s: %zu of the %zu points checked lie farther than %g voxels from every surface "
                 "of the reference scene %s: were they made on another scene? Their error figures compare answers "
                 "off its surfaces and mean little\n",
                 options.points.c_str(), check.offSurface, check.checked, kOffSurfaceVoxels, options.reference.c_str());
  return check;
}

void appendCsvHeader(std::string& out, const std::vector<SelectedLight>& lights) {
  for (size_t l = 0; l < lights.size(); ++l) out += (l ? "," : "") + csvField(lights[l].column);
  out += '\n';
}

// Points [0, count) of `values` (one value per light and point) as CSV rows.
void appendCsvRows(AtomicOutput& csv, const std::vector<float>& values, size_t count, size_t lights) {
  for (size_t i = 0; i < count; ++i) {
    for (size_t l = 0; l < lights; ++l) {
      if (l) csv.buffer() += ',';
      appendValue(csv.buffer(), values[i * lights + l]);
    }
    csv.buffer() += '\n';
    csv.flushIfFull();
  }
}

// What the evaluation of every point gathered besides the output: the figures, the set of points the throughput
// is timed on, whether the points had normals, and the time spent.
struct Evaluation {
  Totals totals;
  std::vector<QueryPoint> timingSet;
  std::vector<QueryPoint> surfaceSample;  // checked against the reference's surfaces
  bool hasNormals = false;
  double evalMs = 0;
};

// The throughput's points: the input's first `wanted` ones, gathered chunk by chunk.
void addTimingPoints(const std::vector<QueryPoint>& chunk, size_t wanted, std::vector<QueryPoint>& timingSet) {
  const size_t take = std::min(chunk.size(), wanted - std::min(wanted, timingSet.size()));
  timingSet.insert(timingSet.end(), chunk.begin(), chunk.begin() + ptrdiff_t(take));
}

// An EXR G-buffer: evaluated in chunks, then written whole, as an EXR (one channel per light) or a CSV.
void queryGBuffer(const Options& options, const std::vector<SelectedLight>& lights, const LookupOptions& lookup,
                  const ShadowReference* reference, std::optional<AtomicOutput>& csvFile, tools::ProgressBar& progress,
                  Evaluation& eval) {
  const size_t nl = lights.size();
  uint32_t width = 0, height = 0;
  std::vector<QueryPoint> points = readGBuffer(options.points, options.normals, width, height, eval.hasNormals);
  // Spread over the whole image, not its top rows (often sky).
  for (size_t i = 0, stride = std::max<size_t>(1, points.size() / kSurfaceCheckPoints); i < points.size(); i += stride)
    eval.surfaceSample.push_back(points[i]);
  std::vector<float> values, chunkValues;
  values.resize(points.size() * nl);
  std::vector<QueryPoint> chunk;
  for (size_t begin = 0; begin < points.size(); begin += kChunk) {
    const size_t end = std::min(points.size(), begin + kChunk);
    chunk.assign(points.begin() + ptrdiff_t(begin), points.begin() + ptrdiff_t(end));
    const Stopwatch chunkClock;
    evaluateChunk(chunk, lights, lookup, reference, options.scoreInside, options.threads, chunkValues, eval.totals);
    eval.evalMs += chunkClock.ms();
    std::copy(chunkValues.begin(), chunkValues.end(), values.begin() + ptrdiff_t(begin * nl));
    addTimingPoints(chunk, options.timingPoints, eval.timingSet);
    progress.update(double(end) / double(points.size()));
  }
  if (!csvFile) {
    ExrImage out;
    out.width = width;
    out.height = height;
    for (const SelectedLight& l : lights) out.channels.push_back(l.column);
    out.pixels = std::move(values);
    writeExr(options.output, out);
    return;
  }
  appendCsvHeader(csvFile->buffer(), lights);
  appendCsvRows(*csvFile, values, points.size(), nl);
  csvFile->flush();
}

// CSV or PLY points: read, evaluated and written chunk by chunk (inputs larger than memory work).
void queryPointFile(const Options& options, const std::vector<SelectedLight>& lights, const LookupOptions& lookup,
                    const ShadowReference* reference, AtomicOutput& csv, tools::ProgressBar& progress,
                    Evaluation& eval) {
  std::unique_ptr<PointReader> reader = PointReader::open(options.points);
  eval.hasNormals = reader->hasNormals();
  appendCsvHeader(csv.buffer(), lights);
  std::vector<QueryPoint> chunk;
  std::vector<float> values;
  while (reader->next(chunk, kChunk)) {
    const Stopwatch chunkClock;
    evaluateChunk(chunk, lights, lookup, reference, options.scoreInside, options.threads, values, eval.totals);
    eval.evalMs += chunkClock.ms();
    if (eval.surfaceSample.empty()) eval.surfaceSample = chunk;
    addTimingPoints(chunk, options.timingPoints, eval.timingSet);
    appendCsvRows(csv, values, chunk.size(), lights.size());
    progress.update(reader->progress());
  }
  csv.flush();
}

void warnAboutInvalidPoints(const Options& options, const Totals& totals) {
  if (totals.invalid == 0) return;
  std::string first;
  for (uint64_t i : totals.firstInvalid) first += (first.empty() ? "" : ", ") + std::to_string(i);
  std::cerr << "cpvs-query: warning: " << options.points << ": " << totals.invalid << " of " << totals.points
            << " points have a NaN or infinite coordinate or normal and were answered 0 (first, counting from 0: "
            << first << (totals.invalid > totals.firstInvalid.size() ? ", ..." : "") << ")\n";
}

// The headline first: the error rate over the pairs where an error is possible (the point faces the light and
// lies within its reach; everywhere else both answer 0 by rule). Then the breakdown docs/query.md defines.
void printReferenceSummary(const ErrorStats& pooled, const Totals& totals) {
  const auto count = [](uint64_t n) { return static_cast<unsigned long long>(n); };
  if (pooled.facing == 0)
    std::fprintf(stderr, "cpvs-query: no (point, light) pair where a shadow can be wrong: no point faces a light "
                         "within its reach\n");
  else
    std::fprintf(stderr,
               "cpvs-query: %.4f%% misclassified against Embree rays: %llu of the %llu (point, light) pairs where a "
               "shadow can be wrong (the point faces the light, within its reach)\n",
               100.0 * pooled.rate(pooled.misclassifiedFacing, pooled.facing), count(pooled.misclassifiedFacing),
               count(pooled.facing));
  std::fprintf(stderr,
               "cpvs-query:   breakdown: %.4f%% of all %llu scored pairs; %.4f%% of the %llu uniform pairs (the rays "
               "agree within 2 voxels: should be ~0); mean |difference| %.5f; %llu points inside closed solids not "
               "scored (docs/query.md)\n",
               100.0 * pooled.rate(pooled.misclassified, pooled.samples), count(pooled.samples),
               100.0 * pooled.rate(pooled.misclassifiedUniform, pooled.uniform), count(pooled.uniform),
               pooled.samples ? pooled.absDiffSum / double(pooled.samples) : 0.0, count(totals.insideClosed));
}

// What the report gives of the throughput: best and median lookups, rays and one figure per light.
struct ThroughputFigures {
  double lookups = 0, lookupsMedian = 0, unfiltered = 0, single = 0, rays = 0, raysMedian = 0, packets = 0;
  std::vector<double> perLight;  // with more than one light
};

// Throughput, one thread each, over the first chunk of points (the whole set when it fits in one).
ThroughputFigures measureThroughput(const Options& options, const std::vector<SelectedLight>& lights,
                             const LookupOptions& lookup, const ShadowReference* reference,
                             const std::vector<QueryPoint>& timing) {
  const size_t nl = lights.size();
  LookupOptions unfiltered = lookup;
  unfiltered.pcfKernel = 1;
  std::vector<const ShadowMethod*> all;
  std::vector<Light> lightList;
  for (const SelectedLight& l : lights) {
    all.push_back(l.method.get());
    lightList.push_back(l.method->light());
  }
  Throughput throughput;
  throughput.add("lookups", [&] { return lookupsPerSecond(all, timing, lookup, kRoundSeconds); });
  if (options.pcf > 1)
    throughput.add("unfiltered", [&] { return lookupsPerSecond(all, timing, unfiltered, kRoundSeconds); });
  // One point at a time (LightShadow::visibility of a single point: what a shader-style caller does).
  throughput.add("single", [&] {
    return perSecond(timing.size() * nl, kRoundSeconds, [&] {
      float sum = 0;
      for (const SelectedLight& light : lights)
        for (const QueryPoint& p : timing) sum += light.shadow().visibility(p.position, p.normal, lookup);
      consume(sum);
    });
  });
  if (reference) {
    throughput.add("rays", [&] { return raysPerSecond(*reference, lightList, timing, kRoundSeconds); });
    throughput.add("packets", [&] { return packetRaysPerSecond(*reference, lightList, timing, kRoundSeconds); });
  }
  if (nl > 1)
    for (size_t l = 0; l < nl; ++l)
      throughput.add("light" + std::to_string(l),
                     [&, l] { return lookupsPerSecond(*lights[l].method, timing, lookup, kRoundSeconds / 2); });
  throughput.run(options.timingRounds);
  ThroughputFigures figures;
  figures.lookups = throughput.best("lookups");
  figures.lookupsMedian = throughput.median("lookups");
  figures.unfiltered = options.pcf > 1 ? throughput.best("unfiltered") : figures.lookups;
  figures.single = throughput.best("single");
  if (reference) {
    figures.rays = throughput.best("rays");
    figures.raysMedian = throughput.median("rays");
    figures.packets = throughput.best("packets");
  }
  if (nl > 1)
    for (size_t l = 0; l < nl; ++l) figures.perLight.push_back(throughput.best("light" + std::to_string(l)));
  return figures;
}

nlohmann::json lightsJson(const CpvsFile& file, const std::vector<SelectedLight>& lights, const Totals& totals,
                          const ThroughputFigures& throughput, bool withReference) {
  const size_t nl = lights.size();
  nlohmann::json out = nlohmann::json::array();
  const uint64_t valid = totals.points - totals.invalid;
  for (size_t l = 0; l < nl; ++l) {
    const CpvsFile::LightEntry& entry = file.lights()[lights[l].index];
    nlohmann::json j = {{"index", lights[l].index},
                        {"name", entry.light.name},
                        {"column", lights[l].column},
                        {"type", lightTypeName(entry.light.type)},
                        {"views", entry.views.size()},
                        {"resolution", entry.views.empty() ? 0u : entry.views[0].view.resolution},
                        {"mean_visibility", valid ? totals.visibilitySum[l] / double(valid) : 0.0}};
    if (nl > 1) j["lookups_per_s"] = throughput.perLight[l];
    if (withReference) j["reference"] = errorJson(totals.errors[l]);
    out.push_back(j);
  }
  return out;
}

nlohmann::json referenceJson(const Options& options, const ShadowReference& reference, const ErrorStats& pooled,
                             const Totals& totals, const ThroughputFigures& throughput) {
  nlohmann::json r = errorJson(pooled);
  const double raysPerS = throughput.rays;
  r["rays_per_s"] = raysPerS;
  r["rays_per_s_median"] = throughput.raysMedian;
  r["rays_per_s_packets"] = throughput.packets;
  r["lookup_speedup"] = raysPerS > 0 ? throughput.lookups / raysPerS : 0.0;
  r["unfiltered_speedup"] = raysPerS > 0 ? throughput.unfiltered / raysPerS : 0.0;
  r["epsilon"] = reference.epsilon();
  r["relative_epsilon"] = options.referenceEpsilon;
  r["triangles"] = reference.triangles();
  r["uniform_offset_voxels"] = 2;
  r["inside_closed_points"] = totals.insideClosed;
  r["score_inside_closed"] = options.scoreInside;
  return r;
}

int run(const Options& options) {
  const Stopwatch total;
  checkOptions(options);
  const LookupOptions lookup{options.pcf,
                             options.towardLight ? NormalOrientation::TowardLight : NormalOrientation::AsGiven,
                             options.biasMargin};

  tools::expectCpvs(options.cpvs, kUsage);
  tools::expectPoints("--points", options.points, kUsage);
  const std::unique_ptr<CpvsFile> file = orThrow(CpvsFile::open(options.cpvs));
  const std::vector<SelectedLight> lights = selectLights(*file, options.lights, options.topGrid);
  const size_t nl = lights.size();

  const PointFormat format = detectPointFormat(options.points);
  if (!options.normals.empty() && format != PointFormat::Exr)
    throw Error(ErrorCategory::InvalidArgument, "--normals applies to EXR position images only; CSV and PLY carry nx, ny, nz");
  const bool exrOutput = endsWith(options.output, ".exr");
  // The outputs are opened before the work, so a path that cannot be written fails at once; the CSV and the
  // report are committed together at the end.
  std::optional<AtomicOutput> csvFile;
  if (!exrOutput) csvFile.emplace(options.output);
  std::optional<tools::AtomicFile> reportFile;
  if (!options.report.empty()) reportFile.emplace(options.report);
  if (exrOutput && format != PointFormat::Exr)
    throw Error(ErrorCategory::InvalidArgument, "-o " + options.output + ": EXR output needs an EXR G-buffer input (use a .csv output)");

  const Stopwatch load;
  const std::unique_ptr<ReferenceScene> referenceScene = loadReference(options, lookup.orientation);
  const ShadowReference* reference = referenceScene ? referenceScene->rays.get() : nullptr;
  const double referenceLoadMs = reference ? load.ms() : 0.0;

  Evaluation eval;
  Totals& totals = eval.totals;
  totals.visibilitySum.assign(nl, 0.0);
  totals.errors.assign(nl, {});
  tools::ProgressBar progress("query", options.quiet);
  if (format == PointFormat::Exr)
    queryGBuffer(options, lights, lookup, reference, csvFile, progress, eval);
  else
    queryPointFile(options, lights, lookup, reference, *csvFile, progress, eval);
  progress.finish();
  warnAboutInvalidPoints(options, totals);
  const SurfaceCheck surfaceCheck =
      referenceScene ? checkPointsOnReference(options, *referenceScene, lights, eval.surfaceSample) : SurfaceCheck{};

  ErrorStats pooled;
  for (const ErrorStats& e : totals.errors) pooled.add(e);
  if (reference && !options.quiet) printReferenceSummary(pooled, totals);
  if (!reportFile) {
    if (csvFile) csvFile->file().commit();
    return 0;
  }

  const std::vector<QueryPoint> timing = validPoints(eval.timingSet);
  const ThroughputFigures throughput = measureThroughput(options, lights, lookup, reference, timing);
  const double lookupsPerS = throughput.lookups, unfilteredPerS = throughput.unfiltered;
  size_t topGridBytes = 0;
  for (const SelectedLight& l : lights) topGridBytes += l.shadow().topGridBytes();

  nlohmann::json report = {
      {"tool", "cpvs-query"},
      {"version", kVersion},
      {"inputs",
       {{"cpvs", options.cpvs},
        {"points", options.points},
        {"format", pointFormatName(format)},
        {"normals", eval.hasNormals},
        {"reference_scene", options.reference.empty() ? nlohmann::json(nullptr) : nlohmann::json(options.reference)}}},
      {"settings",
       {{"pcf", options.pcf},
        {"bias_margin_voxels", options.biasMargin},
        {"normal_orientation", options.towardLight ? "toward-light" : "as-given"},
        {"threads", options.threads},
        {"lights", nl}}},
      {"output", options.output},
      {"points", totals.points},
      {"invalid_points", totals.invalid},
      {"first_invalid_points", totals.firstInvalid},
      {"lookups_per_s", lookupsPerS},
      {"lookups_per_s_unfiltered", unfilteredPerS},
      {"lookups_per_s_single", throughput.single},
      {"lookups_per_s_median", throughput.lookupsMedian},
      {"pcf_cost", lookupsPerS > 0 ? unfilteredPerS / lookupsPerS : 0.0},
      {"timing_rounds", options.timingRounds},
      {"timing_points", timing.size()},
      {"timing_threads", 1},
      {"top_grid_levels", options.topGrid < 0 ? nlohmann::json("automatic") : nlohmann::json(options.topGrid)},
      {"top_grid_bytes", topGridBytes},
      {"peak_rss_bytes", peakRssBytes()},
      {"timings_ms", {{"evaluate", eval.evalMs}, {"reference_load", referenceLoadMs}, {"total", total.ms()}}},
      {"lights", lightsJson(*file, lights, totals, throughput, reference != nullptr)}};
  if (reference) {
    report["reference"] = referenceJson(options, *reference, pooled, totals, throughput);
    report["reference"]["points_checked_on_surfaces"] = surfaceCheck.checked;
    report["reference"]["points_off_surfaces"] = surfaceCheck.offSurface;
  }
  reportFile->write(report.dump(2) + "\n");
  tools::commitTogether({csvFile ? &csvFile->file() : nullptr, &*reportFile});
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{"cpvs-query: shadow visibility of points from a baked .cpvs (1 = lit, 0 = shadowed, PCF fraction "
               "in between), optionally compared with Embree shadow rays.\nManual: docs/query.md",
               "cpvs-query"};
  app.add_option("file", options.cpvs, "Baked shadows (.cpvs)")->required()->type_name("FILE.cpvs");
  app.add_option("--points", options.points,
                 "Query points: CSV (header x,y,z[,nx,ny,nz]), PLY (ascii / binary_little_endian) or an EXR "
                 "G-buffer (P.X,P.Y,P.Z[,N.X,N.Y,N.Z] or R,G,B)")
      ->required()
      ->type_name("POINTS");
  app.add_option("--normals", options.normals, "Normals for an EXR position image (N.X,N.Y,N.Z or R,G,B)")
      ->type_name("NORMALS.exr");
  app.add_option("-o,--output", options.output,
                 "Visibility: CSV (one column per light, one row per point in input order), or EXR (one channel per "
                 "light) when the name ends in .exr and the input is an EXR")
      ->required()
      ->type_name("OUT");
  app.add_option("--pcf", options.pcf, "PCF kernel K (odd, 1 = unfiltered, up to 255)")->type_name("K");
  app.add_option("--light", options.lights, "Only this light: name or 0-based index, a name wins (repeatable; "
                                            "columns follow this order)")
      ->type_name("NAME|INDEX");
  app.add_flag("--normals-toward-light", options.towardLight,
               "Flip normals that face away from the light before biasing (unoriented normals, two-sided foliage)");
  app.add_option("--bias-margin", options.biasMargin,
                 "Voxels added to the normal bias beyond half the filter footprint (docs/query.md)")
      ->type_name("VOXELS")
      ->capture_default_str();
  app.add_option("--reference", options.reference,
                 "Also ray-trace the points in this glTF scene with Embree and report the error")
      ->type_name("SCENE");
  app.add_flag("--score-inside-closed", options.scoreInside,
               "Also score points that lie inside a closed solid of the reference scene (left out by default: "
               "no surface there can be seen, and the bake may answer either way)");
  app.add_option("--reference-epsilon", options.referenceEpsilon,
                 "Offset of the reference's shadow rays off the surface, as a fraction of the scene's diagonal; keep "
                 "it under a voxel of the views and under the gaps between surfaces (docs/query.md)")
      ->capture_default_str();
  app.add_option("--exclude-mesh", options.excludedMeshes, "Drop a mesh from the reference scene (repeatable)")
      ->type_name("NAME");
  app.add_option("--report", options.report, "Write a JSON report: counts, throughput, error figures")
      ->type_name("R.json");
  app.add_option("--threads", options.threads, "Worker threads for the lookups and the reference (default: all cores)")
      ->type_name("N");
  app.add_option("--top-grid", options.topGrid,
                 "Start lookups from a dense pointer grid of the DAG's first L levels (8^L entries of 4 bytes per "
                 "view; 0 = off; -1 = automatic: up to 6 levels while the grid takes no more bytes than the DAG)")
      ->type_name("L")
      ->capture_default_str();
  app.add_option("--timing-rounds", options.timingRounds,
                 "Rounds of the --report throughput measurement (best of them is reported; 0 = skip it)")
      ->type_name("N")
      ->capture_default_str();
  app.add_option("--timing-points", options.timingPoints,
                 "Points the --report throughput is measured on: the valid ones of the input's first N (more than the "
                 "caches hold measures lookups spread over more of the DAG)")
      ->type_name("N")
      ->capture_default_str();
  app.add_flag("-q,--quiet", options.quiet, "No progress bar");
  tools::addImportOptions(app, options.import);
  tools::addStandardFlags(app, "cpvs-query",
             "\nPoints with a NaN or infinite coordinate or normal are answered 0 and counted in a warning and in the "
             "report (invalid_points). Points outside a light's range or cone are answered 0; points whose normal "
             "faces away from the light are answered 0 (in their own surface's shadow).");
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;
  return tools::runMain("cpvs-query", [&] { return run(options); });
}
