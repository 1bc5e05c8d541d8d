// cpvs-sweep: speed against error. For a scene and its lights, bakes a CPVS at each resolution of a
// sweep, answers sampled surface points with the CPVS lookups, measures the error against Embree shadow rays,
// and sets a plain 16-bit shadow map of equal bytes beside it (libcpvs/eval). Writes a markdown table, an
// SVG plot and a JSON file per scene; tools/cpvs-sweep/run_sweeps.py runs the shipped scenes and the city and
// assembles docs/speed-vs-error.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/eval/sweep.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/version.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/cpvs-sweep/svg_plot.h"

namespace {

using namespace cpvs;

struct Options {
  std::string scene;
  std::string resolutions = "1k,2k,4k,8k,16k";
  size_t samples = 100000;
  size_t minLightPoints = 0;
  double referenceEpsilon = ShadowReference::kDefaultRelativeEpsilon;
  uint64_t seed = 1;
  bool allPoints = false;
  bool interiorPoints = false;
  int pcf = 1;
  std::string baselineDepth = "embree";
  std::string undefinedMode = "kampe";
  std::string backend = "cpu";
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  double timing = 0.25;
  std::string name;
  std::string outDir;
  bool quiet = false;
  tools::LightOptions lights;
  ImportOptions import;
};

std::vector<uint32_t> parseResolutions(const std::string& text) {
  std::vector<uint32_t> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ','))
    if (!item.empty()) out.push_back(tools::parseResolution(item));
  if (out.empty()) throw Error(ErrorCategory::InvalidArgument, "--resolutions '" + text + "': no resolution given");
  return out;
}

std::string resolutionName(uint32_t n) {
  return n >= 1024 && n % 1024 == 0 ? std::to_string(n / 1024) + "k" : std::to_string(n);
}

std::string percent(uint64_t count, uint64_t of) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f %% (%llu)", of ? 100.0 * double(count) / double(of) : 0.0,
                static_cast<unsigned long long>(count));
  return b;
}

std::string fixed(double v, int digits) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::string si(double v) {
  char b[64];
  if (v >= 1e9) std::snprintf(b, sizeof b, "%.2f G", v / 1e9);
  else if (v >= 1e6) std::snprintf(b, sizeof b, "%.2f M", v / 1e6);
  else if (v >= 1e3) std::snprintf(b, sizeof b, "%.1f k", v / 1e3);
  else std::snprintf(b, sizeof b, "%.0f", v);
  return b;
}

std::string bytesText(uint64_t b) {
  char s[64];
  if (b >= 1000000) std::snprintf(s, sizeof s, "%.2f MB", double(b) / 1e6);
  else std::snprintf(s, sizeof s, "%.1f kB", double(b) / 1e3);
  return s;
}

std::string msText(double ms) { return ms >= 10000 ? fixed(ms / 1000, 1) + " s" : fixed(ms, 0) + " ms"; }

// Shadow-map error / CPVS error; "≥ x" when the CPVS made no error (counted as one).
std::string ratioText(uint64_t sm, uint64_t cpvs) {
  if (sm == 0 && cpvs == 0) return "— (both 0)";
  if (cpvs == 0) return "≥ " + fixed(double(sm), 0) + "× (CPVS 0)";
  return fixed(double(sm) / double(cpvs), 1) + "×";
}

std::string commandLine(int argc, char** argv) {
  std::string cmd;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (i == 0) a = "cpvs-sweep";
    const bool quote = a.find_first_of(" \t'\"$*?") != std::string::npos;
    cmd += (i ? " " : "") + (quote ? "'" + a + "'" : a);
  }
  return cmd;
}

std::string markdown(const Options& o, const std::string& name, const Scene& scene, size_t triangles,
                     const std::vector<SweepRow>& rows, const std::string& command, const std::string& renderer) {
  std::string md;
  md += "### " + name + "\n\n";
  md += "* Scene: `" + o.scene + "` (" + std::to_string(triangles) + " triangles";
  size_t closed = 0;
  for (const Mesh& m : scene.meshes) closed += m.closed;
  md += ", " + std::to_string(closed) + " of " + std::to_string(scene.meshes.size()) + " meshes closed)\n";
  for (size_t l = 0; l < scene.lights.size(); ++l) md += "* Light `" + scene.lights[l].name + "`: " + describeLight(scene.lights[l]) + "\n";
  const uint64_t interior = rows.empty() ? 0 : rows[0].interiorSamples;
  md += "* " + std::to_string(o.samples) + " area-weighted surface samples (seed " + std::to_string(o.seed) + "), " +
        (o.interiorPoints ? std::string("including those inside closed solids")
                          : std::to_string(interior) + " of them inside closed solids dropped") +
        "; per light " + (o.allPoints ? "all kept" : "kept where they face the light") + " and inside its influence" +
        (o.minLightPoints ? "; a light left with fewer than " + std::to_string(o.minLightPoints) +
                                " points drew further rounds (seeds " + std::to_string(o.seed + 1) + ", " +
                                std::to_string(o.seed + 2) + ", ...) until it had that many"
                          : std::string()) +
        "; PCF " +
        std::to_string(o.pcf) + "×" + std::to_string(o.pcf) + "; `--undefined " + o.undefinedMode +
        "`; shadow-map depth from " + (o.baselineDepth == "embree" ? "Embree rays" : "the GL enter-depth renderer") +
        "\n";
  if (!renderer.empty()) md += "* Renderer: `" + renderer + "`\n";
  md += "* Command: `" + command + "`\n\n";
  md += "| light | N | bake | bytes | lookups/s | misclassified | misclassified_uniform | uniform points | "
        "equal-bytes shadow map | SM misclassified | SM misclassified_uniform | SM / CPVS error |\n";
  md += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SweepRow& r : rows) {
    md += "| " + r.lightName + " | " + resolutionName(r.resolution) + " | " + msText(r.bakeMs) + " | " +
          bytesText(r.bytes) + " | " + si(r.lookupsPerS) + " (" + (r.raysPerS > 0 ? fixed(r.lookupsPerS / r.raysPerS, 1) : std::string("—")) + "× rays) | " + percent(r.misclassified, r.points) + " | " +
          percent(r.misclassifiedUniform, r.uniform) + " | " + std::to_string(r.uniform) + " of " +
          std::to_string(r.points) + " | " + std::to_string(r.smSize) + "² (" + bytesText(r.smBytes) + ") | " +
          percent(r.smMisclassified, r.points) + " | " + percent(r.smMisclassifiedUniform, r.uniform) + " | **" +
          ratioText(r.smMisclassified, r.misclassified) + "** |\n";
  }
  md += "\n";
  // Throughput beside Embree, one thread each.
  for (size_t l = 0; l < scene.lights.size(); ++l) {
    double lo = 0, hi = 0;
    for (const SweepRow& r : rows)
      if (r.light == l) {
        lo = lo == 0 ? r.raysPerS : std::min(lo, r.raysPerS);
        hi = std::max(hi, r.raysPerS);
      }
    md += "Light `" + scene.lights[l].name + "`: Embree occlusion rays " + si(lo) + "/s to " + si(hi) +
          "/s on the same points, one thread, timed beside the lookups of each row; lookups/s (one thread, "
          "batches of 4096 points as cpvs-query makes them) are followed by their ratio to the rays of that row.\n";
  }
  md += "\n![" + name + "](speed-vs-error/" + name + ".svg)\n\n";
  return md;
}

std::string plot(const std::string& name, const Scene& scene, const std::vector<SweepRow>& rows) {
  static const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  std::vector<sweep::Panel> panels(4);
  panels[0] = {"Misclassified points (fraction)", "fraction of points", true, {}};
  panels[1] = {"Bytes", "bytes", true, {}};
  panels[2] = {"Bake time", "ms", true, {}};
  panels[3] = {"Throughput (one thread)", "per second", true, {}};
  sweep::Series full{"16-bit shadow map of N²", "#888", "6,4", true, {}, {}};
  for (size_t l = 0; l < scene.lights.size(); ++l) {
    const std::string c = colours[l % 6];
    const std::string& n = scene.lights[l].name;
    sweep::Series all{n + " CPVS", c, "", false, {}, {}}, uni{n + " CPVS uniform", c, "2,3", true, {}, {}};
    sweep::Series sm{n + " SM equal bytes", c, "8,4", true, {}, {}};
    sweep::Series bytes{n + " CPVS", c, "", false, {}, {}}, bake{n + " CPVS bake", c, "", false, {}, {}};
    sweep::Series look{n + " CPVS lookups", c, "", false, {}, {}}, smLook{n + " SM lookups", c, "8,4", true, {}, {}};
    sweep::Series rays{n + " Embree rays", c, "2,3", true, {}, {}};
    for (const SweepRow& r : rows) {
      if (r.light != l) continue;
      const double x = r.resolution;
      auto add = [&](sweep::Series& s, double y) {
        s.x.push_back(x);
        s.y.push_back(y);
      };
      add(all, r.rate(r.misclassified, r.points));
      add(uni, r.rate(r.misclassifiedUniform, r.uniform));
      add(sm, r.rate(r.smMisclassified, r.points));
      add(bytes, double(r.bytes));
      add(bake, r.bakeMs);
      add(look, r.lookupsPerS);
      add(smLook, r.smLookupsPerS);
      add(rays, r.raysPerS);
      if (l == 0) {
        full.x.push_back(x);
        full.y.push_back(2.0 * x * x);
      }
    }
    panels[0].series.insert(panels[0].series.end(), {all, uni, sm});
    panels[1].series.push_back(bytes);
    panels[2].series.push_back(bake);
    panels[3].series.insert(panels[3].series.end(), {look, smLook, rays});
  }
  panels[1].series.push_back(full);
  return sweep::renderSvg("Speed against error: " + name, panels, 2);
}

// A method's error figures on a row's points (nlohmann::json keeps keys sorted, so merged objects print alike).
nlohmann::json errorJson(const SweepRow& r, uint64_t misclassified, uint64_t misclassifiedUniform,
                         double meanAbsDiff) {
  return {{"misclassified", r.rate(misclassified, r.points)},
          {"misclassified_count", misclassified},
          {"misclassified_uniform", r.rate(misclassifiedUniform, r.uniform)},
          {"misclassified_uniform_count", misclassifiedUniform},
          {"mean_abs_diff", meanAbsDiff}};
}

nlohmann::json rowsJson(const std::vector<SweepRow>& rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const SweepRow& r : rows) {
    a.push_back({{"light", r.lightName},
                 {"light_type", lightTypeName(r.lightType)},
                 {"resolution", r.resolution},
                 {"bake_ms", r.bakeMs},
                 {"bake_wall_ms", r.bakeWallMs},
                 {"bytes", r.bytes},
                 {"file_bytes", r.fileBytes},
                 {"points", r.points},
                 {"reference_lit", r.referenceLit},
                 {"uniform", r.uniform},
                 {"lookups_per_s", r.lookupsPerS},
                 {"rays_per_s", r.raysPerS}});
    nlohmann::json shadowMap = {
        {"size", r.smSize}, {"bytes", r.smBytes}, {"build_ms", r.smBuildMs}, {"lookups_per_s", r.smLookupsPerS}};
    shadowMap.update(errorJson(r, r.smMisclassified, r.smMisclassifiedUniform, r.smMeanAbsDiff));
    a.back().update(errorJson(r, r.misclassified, r.misclassifiedUniform, r.meanAbsDiff));
    a.back()["shadow_map"] = shadowMap;
  }
  return a;
}

int run(int argc, char** argv) {
  Options o;
  CLI::App app{"cpvs-sweep: speed against error. Bakes a scene's lights at each resolution of a sweep, answers\n"
               "sampled surface points with the CPVS lookups and with a 16-bit shadow map of equal bytes, and\n"
               "compares both with Embree shadow rays. Writes NAME.md (table), NAME.svg (plots) and NAME.json."};
  tools::addStandardFlags(app, "cpvs-sweep");
  app.add_option("scene", o.scene, "Input scene (.gltf or .glb)")->required()->type_name("SCENE");
  o.lights.addTo(app);
  tools::addImportOptions(app, o.import);
  app.add_option("--resolutions", o.resolutions, "Comma-separated resolutions to bake (powers of two)")
      ->capture_default_str();
  app.add_option("--points", o.samples, "Surface samples drawn (then filtered per light)")->capture_default_str();
  app.add_option("--reference-epsilon", o.referenceEpsilon,
                 "Offset of the reference's shadow rays off the surface, as a fraction of the scene's diagonal (as "
                 "cpvs-query --reference-epsilon)")
      ->capture_default_str();
  app.add_option("--min-light-points", o.minLightPoints,
                 "A light with fewer points draws further rounds of samples (next seeds) until it has this many "
                 "(0 = off): a narrow spot over a large scene gets enough errors to count")
      ->capture_default_str();
  app.add_option("--seed", o.seed, "Sampling seed")->capture_default_str();
  app.add_flag("--all-points", o.allPoints, "Keep the points that face away from the light");
  app.add_flag("--interior-points", o.interiorPoints, "Keep the samples inside closed solids (hidden surfaces)");
  app.add_option("--pcf", o.pcf, "PCF kernel K (odd) for the CPVS and the shadow map")->capture_default_str();
  app.add_option("--baseline-depth", o.baselineDepth,
                 "Depth of the equal-bytes shadow map: embree (rays through texel centres) or raster (GL)")
      ->capture_default_str();
  app.add_option("--undefined", o.undefinedMode, "Bake mode for free voxels: kampe, sintorn, none")->capture_default_str();
  app.add_option("--backend", o.backend, "Depth rendering: cpu (default), osmesa or egl")->capture_default_str();
  app.add_option("-j,--threads", o.threads, "Bake threads")->capture_default_str();
  app.add_option("--timing", o.timing, "Seconds per throughput measurement")->capture_default_str();
  app.add_option("--name", o.name, "Name of the outputs (default: the scene file's stem)");
  app.add_option("--out-dir", o.outDir, "Folder for NAME.md, NAME.svg and NAME.json (none: table to stdout only)");
  app.add_flag("-q,--quiet", o.quiet, "No progress lines; with --out-dir, no table on stdout either");
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;
  if (o.samples < 1 || o.samples > 100000000) throw Error(ErrorCategory::InvalidArgument, "--points must be in 1..1e8");
  tools::forFlag("--reference-epsilon", [&] { ShadowReference::checkRelativeEpsilon(o.referenceEpsilon); });
  if (o.minLightPoints > 100000000) throw Error(ErrorCategory::InvalidArgument, "--min-light-points must be in 0..1e8");
  if (o.threads < 1 || o.threads > 256) throw Error(ErrorCategory::InvalidArgument, "--threads must be in 1..256");
  if (!(o.timing > 0 && o.timing <= 60)) throw Error(ErrorCategory::InvalidArgument, "--timing must be in (0, 60] seconds");

  SweepSettings settings;
  settings.resolutions = tools::forFlag("--resolutions", [&] { return parseResolutions(o.resolutions); });
  settings.samples = o.samples;
  settings.minLightPoints = o.minLightPoints;
  settings.referenceEpsilon = o.referenceEpsilon;
  settings.seed = o.seed;
  settings.allPoints = o.allPoints;
  settings.interiorPoints = o.interiorPoints;
  settings.pcfKernel = o.pcf;
  tools::forFlag("--pcf", [&] { orThrow(checkPcfKernel(o.pcf)); });
  settings.baselineDepth = tools::forFlag("--baseline-depth", [&] { return parseBaselineDepth(o.baselineDepth); });
  settings.bake.undefinedMode = tools::forFlag("--undefined", [&] { return parseUndefinedMode(o.undefinedMode); });
  settings.bake.backend = tools::forFlag("--backend", [&] { return parseRasterBackend(o.backend); });
  settings.bake.threads = o.threads;
  settings.timingSeconds = o.timing;

  tools::expectScene(o.scene, tools::positionalUsage(app));
  Scene scene = importGltf(o.scene, o.import);
  o.lights.applyTo(scene);
  if (scene.lights.empty())
    throw Error(ErrorCategory::InvalidArgument, o.scene + ": the scene has no KHR_lights_punctual lights; give --sun, --spot or --point");
  const std::string name = o.name.empty() ? std::filesystem::path(o.scene).stem().string() : o.name;
  const size_t triangles = flatten(scene).sceneTriangleCount();

  SweepCallbacks callbacks;
  if (!o.quiet) callbacks.log = [](const std::string& line) { std::fprintf(stderr, "cpvs-sweep: %s\n", line.c_str()); };
  std::string renderer;
  const std::vector<SweepRow> rows = runSweep(scene, settings, &renderer, callbacks);

  const std::string command = commandLine(argc, argv);
  const std::string md = markdown(o, name, scene, triangles, rows, command, renderer);
  if (!o.quiet || o.outDir.empty()) std::fputs(md.c_str(), stdout);
  if (!o.outDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.outDir, ec);
    if (ec) throw Error(ErrorCategory::OutputFailed, o.outDir + ": cannot create folder: " + ec.message());
    const std::filesystem::path dir(o.outDir);
    tools::writeFileAtomically((dir / (name + ".md")).string(), md);
    tools::writeFileAtomically((dir / (name + ".svg")).string(), plot(name, scene, rows));
    nlohmann::json lights = nlohmann::json::array();
    for (const Light& l : scene.lights) lights.push_back({{"name", l.name}, {"description", describeLight(l)}});
    const nlohmann::json j = {{"tool", "cpvs-sweep"},
                              {"version", kVersion},
                              {"command", command},
                              {"scene", o.scene},
                              {"name", name},
                              {"triangles", triangles},
                              {"renderer", renderer},
                              {"samples", o.samples},
                              {"min_light_points", o.minLightPoints},
                              {"reference_epsilon", o.referenceEpsilon},
                              {"seed", o.seed},
                              {"all_points", o.allPoints},
                              {"interior_points", o.interiorPoints},
                              {"interior_samples", rows.empty() ? 0 : rows[0].interiorSamples},
                              {"pcf", o.pcf},
                              {"undefined", o.undefinedMode},
                              {"baseline_depth", o.baselineDepth},
                              {"lights", lights},
                              {"rows", rowsJson(rows)}};
    tools::writeFileAtomically((dir / (name + ".json")).string(), j.dump(1) + "\n");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runMain("cpvs-sweep", [&] { return run(argc, argv); });
}
