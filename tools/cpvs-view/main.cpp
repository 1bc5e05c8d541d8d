// cpvs-view: renders a baked .cpvs on its scene, headless: G-buffer, tile light lists, CPVS shadows walked on
// the GPU (or the CPU runtime's, or Embree's rays), KHR_lights_punctual shading, to a PNG or EXR, with
// overlays and a timed report (docs/viewer.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/base/error.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/runtime/file_shadows.h"
#include "libcpvs/version.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/cpvs-view/preview_window.h"
#include "tools/cpvs-view/view_report.h"

namespace {

using namespace cpvs;
using cpvs::tools::ViewReport;
using json = nlohmann::ordered_json;

struct Options {
  std::string scene, file, output, cameraName, eye, target, up, report, path, frames, size = "1920x1080";
  std::string shadows = "auto", overlay = "none", backend = "osmesa", casterCulling = "none", maskVariant = "frag";
  uint32_t shadowMapSize = 512, minShadowMapSize = 16, clusters = 10, rays = 1, compareRays = 1;
  double fov = 0, exposure = 0, exposureScale = 0, ambient = Fill{}.strength;
  int pcf = 9, orbit = 0;
  unsigned threads = 0;
  bool compare = false, noSceneCheck = false, quiet = false, window = false;
  std::vector<std::string> excludedMeshes;
  ImportOptions import;
  std::string screenshot;
};

glm::dvec3 vec3Of(const std::string& flag, const std::string& text) {
  const auto v = tools::parseNumbers(flag, text, 3);
  return {v[0], v[1], v[2]};
}

void parseSize(const std::string& text, uint32_t& w, uint32_t& h) {
  unsigned a = 0, b = 0;
  char x = 0, rest = 0;
  if (std::sscanf(text.c_str(), "%u%c%u%c", &a, &x, &b, &rest) != 3 || x != 'x' || a == 0 || b == 0 || a > 16384 ||
      b > 16384)
    throw Error(ErrorCategory::InvalidArgument, "--size '" + text + "': expected WIDTHxHEIGHT, each 1..16384");
  w = a;
  h = b;
}

// The cameras of a --path file: [{"eye": [x, y, z], "target": [x, y, z], "up": [x, y, z]?, "fov": degrees?}, ...].
std::vector<PreviewCamera> readPath(const std::string& path, const PreviewCamera& base) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCategory::InvalidInput, path + ": cannot open the camera path");
  const json j = json::parse(in, nullptr, false);
  if (!j.is_array() || j.empty()) throw Error(ErrorCategory::InvalidInput, path + ": expected a non-empty JSON array of cameras");
  std::vector<PreviewCamera> cameras;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string where = path + ": camera " + std::to_string(i);
    auto vec = [&](const char* key, glm::dvec3 fallback, bool required) {
      if (!j[i].is_object() || !j[i].contains(key)) {
        if (required) throw Error(ErrorCategory::InvalidInput, where + ": \"" + key + "\" is missing");
        return fallback;
      }
      const json& v = j[i][key];
      if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
        throw Error(ErrorCategory::InvalidInput, where + ": \"" + key + "\" is not an array of 3 numbers");
      return glm::dvec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    };
    PreviewCamera c = base;
    c.eye = vec("eye", {}, true);
    c.target = vec("target", {}, true);
    c.up = vec("up", base.up, false);
    if (j[i].contains("fov")) {
      if (!j[i]["fov"].is_number()) throw Error(ErrorCategory::InvalidInput, where + ": \"fov\" is not a number");
      c.yfov = j[i]["fov"].get<double>() * M_PI / 180.0;
    }
    try {
      checkCamera(c);
    } catch (const Error& e) {
      throw Error(ErrorCategory::InvalidInput, where + ": " + e.what());
    }
    cameras.push_back(c);
  }
  return cameras;
}

// N cameras on a circle around the base camera's target, at its distance and height.
std::vector<PreviewCamera> orbit(const PreviewCamera& base, int n) {
  std::vector<PreviewCamera> cameras;
  const glm::dvec3 up = glm::normalize(base.up), offset = base.eye - base.target;
  const glm::dvec3 height = glm::dot(offset, up) * up, radial = offset - height;
  const glm::dvec3 side = glm::cross(up, radial);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    PreviewCamera c = base;
    c.eye = base.target + height + radial * std::cos(a) + side * std::sin(a);
    cameras.push_back(c);
  }
  return cameras;
}

void writeImage(const std::string& path, const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure,
                const Fill& fill, Overlay overlay) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".exr" || ext == ".EXR") {
    writeExr(path, linearImage(frame, radiance, exposure, fill));
    return;
  }
  tools::AtomicFile out(path);
  out.write(encodePng(withOverlay(frame, toneMapped(frame, radiance, exposure, fill), overlay)));
  out.commit();
}

// s for s * s rays per pair (a square, 1 .. 64^2).
int raysPerSideOf(uint32_t rays) {
  const uint32_t s = uint32_t(std::lround(std::sqrt(double(rays))));
  if (rays < 1 || s * s != rays || s > 64)
    throw Error(ErrorCategory::InvalidArgument, std::to_string(rays) + " rays per pair: 1 or a square s*s up to 4096");
  return int(s);
}

// The frame settings the options ask for (each value checked, the flag named in the error).
FrameSettings frameSettingsOf(const Options& o) {
  FrameSettings settings;
  tools::forFlag("--size", [&] { parseSize(o.size, settings.width, settings.height); });
  settings.pcfKernel = o.pcf;
  if (const Outcome k = checkPcfKernel(o.pcf); !k) throw Error(ErrorCategory::InvalidArgument, "--pcf: " + k.message());
  // "auto" is chosen once the renderer knows its GL (PreviewRenderer::automaticShadows).
  if (o.shadows != "auto") settings.shadows = tools::forFlag("--shadows", [&] { return parseShadowMode(o.shadows); });
  settings.shadowMaps.casterCulling = tools::forFlag("--caster-culling", [&] { return parseCasterCulling(o.casterCulling); });
  settings.shadowMaps.maskVariant = tools::forFlag("--mask-variant", [&] { return parseReceiverMaskVariant(o.maskVariant); });
  if (o.shadowMapSize < 8 || o.shadowMapSize > 8192)
    throw Error(ErrorCategory::InvalidArgument, "--shadow-map-size: 8..8192 texels");
  if (o.clusters < 1 || o.clusters > 100000) throw Error(ErrorCategory::InvalidArgument, "--clusters: 1..100000");
  if (o.minShadowMapSize < 1 || o.minShadowMapSize > o.shadowMapSize)
    throw Error(ErrorCategory::InvalidArgument, "--min-shadow-map-size: 1..--shadow-map-size texels");
  settings.shadowMaps.size = o.shadowMapSize;
  settings.shadowMaps.minSize = o.minShadowMapSize;
  settings.shadowMaps.clusters = o.clusters;
  settings.compareWithRays = o.compare || o.overlay == "difference";
  settings.raysPerSide = tools::forFlag("--rays", [&] { return raysPerSideOf(o.rays); });
  settings.compareRaysPerSide = tools::forFlag("--compare-rays", [&] { return raysPerSideOf(o.compareRays); });
  return settings;
}

// The combinations of outputs, cameras and exposure the options may not ask for.
void checkOutputs(const Options& o) {
  const bool animated = !o.path.empty() || o.orbit > 0;
  if (animated && o.frames.empty()) throw Error(ErrorCategory::InvalidArgument, "--path / --orbit need --frames DIR");
  if (!animated && !o.window && o.output.empty())
    throw Error(ErrorCategory::InvalidArgument, "-o OUT.png or OUT.exr is required (or --window)");
  if (o.window && animated) throw Error(ErrorCategory::InvalidArgument, "--window excludes --path / --orbit");
  if (!o.screenshot.empty() && !o.window) throw Error(ErrorCategory::InvalidArgument, "--screenshot needs --window");
  if (!o.path.empty() && o.orbit > 0) throw Error(ErrorCategory::InvalidArgument, "--path and --orbit exclude each other");
  if (o.orbit < 0 || o.orbit > 100000) throw Error(ErrorCategory::InvalidArgument, "--orbit: N must be in 1..100000");
  if (!o.output.empty()) {
    const std::string ext = std::filesystem::path(o.output).extension().string();
    if (ext != ".png" && ext != ".exr" && ext != ".PNG" && ext != ".EXR")
      throw Error(ErrorCategory::InvalidArgument, "-o '" + o.output + "': the name must end in .png or .exr");
  }
  if (!o.cameraName.empty() && (!o.eye.empty() || !o.target.empty()))
    throw Error(ErrorCategory::InvalidArgument, "--camera excludes --eye / --target");
  if (o.eye.empty() != o.target.empty()) throw Error(ErrorCategory::InvalidArgument, "--eye and --target go together");
  if (o.fov != 0 && !(o.fov > 0 && o.fov < 180)) throw Error(ErrorCategory::InvalidArgument, "--fov: degrees in (0, 180)");
  if (!(std::fabs(o.exposure) <= 64)) throw Error(ErrorCategory::InvalidArgument, "--exposure: stops in -64..64");
  if (!(o.exposureScale >= 0 && o.exposureScale <= 1e30))
    throw Error(ErrorCategory::InvalidArgument, "--exposure-scale: a positive multiplier");
  if (!(o.ambient >= 0 && o.ambient <= 100))
    throw Error(ErrorCategory::InvalidArgument, "--ambient: a strength in 0..100 (0: no fill)");
  if (o.window && !tools::previewWindowBuilt())
    throw Error(ErrorCategory::NotSupported, "this cpvs-view was built without GLFW (libglfw3-dev): no --window");
}

glm::dvec3 upOf(const Options& o) {
  return o.up.empty() ? glm::dvec3(0, 1, 0) : tools::forFlag("--up", [&] { return vec3Of("--up", o.up); });
}

// The camera: a glTF camera, the command line's, or a default framing from the side the strongest light lights.
PreviewCamera chooseCamera(const Options& o, const Scene& scene, std::span<const Light> lights, double aspect) {
  const Bounds bounds = sceneBounds(scene);
  const glm::dvec3 up = upOf(o);
  PreviewCamera camera;
  if (!o.cameraName.empty()) {
    const Camera* found = nullptr;
    std::string names;
    for (const Camera& c : scene.cameras) {
      if (c.name == o.cameraName) found = &c;
      names += (names.empty() ? "" : ", ") + c.name;
    }
    if (!found)
      throw Error(ErrorCategory::InvalidArgument, "--camera '" + o.cameraName + "': the scene's cameras are " +
                                                      (names.empty() ? "none" : names));
    camera = cameraFromScene(*found);
  } else if (!o.eye.empty()) {
    camera.eye = vec3Of("--eye", o.eye);
    camera.target = vec3Of("--target", o.target);
    camera.up = up;
  } else {
    camera = defaultCamera(bounds, aspect, up, PreviewCamera{}.yfov, litSide(lights, bounds, up));
  }
  if (o.fov > 0) camera.yfov = o.fov * M_PI / 180.0;
  tools::forFlag("--eye/--target/--up/--fov", [&] { checkCamera(camera); });
  return camera;
}

std::string framePath(const std::string& folder, size_t i) {
  const std::string n = std::to_string(i);
  return (std::filesystem::path(folder) / ("frame_" + std::string(4 - std::min<size_t>(4, n.size()), '0') + n + ".png")).string();
}

void printFrameLine(const std::string& image, const Frame& frame, const FrameSettings& settings, size_t lights,
                    const ViewReport& report) {
  std::string line;
  for (const PassTime& p : frame.passes) {
    char item[64];
    std::snprintf(item, sizeof item, "%s%s %.1f ms", line.empty() ? "" : ", ", p.pass.c_str(), p.milliseconds);
    line += item;
  }
  std::fprintf(stderr, "cpvs-view: %s (%ux%u, %zu lights, %.1f per tile): %s\n", image.c_str(), settings.width,
               settings.height, lights, report.lastLists().meanLightsPerTile, line.c_str());
  if (settings.compareWithRays)
    std::fprintf(stderr, "cpvs-view: against Embree rays: %.4f%% wrong pixels, RMSE %.4f\n",
                 report.lastErrors().wrongPixelPercent(), report.lastErrors().rmse);
}

// What a view renders: the scene, the file baked from it (checked against it), the file's lights, and the
// renderer over them (members in that order: the renderer reads the others and goes first).
struct LoadedView {
  Scene scene;
  std::unique_ptr<CpvsFile> file;
  BakedFromCheck check;
  std::vector<Light> lightModels;
  std::unique_ptr<PreviewRenderer> renderer;
};

// Reads the scene and the file as they are on disk (again for each reload of --window). Throws Error naming
// the file and the problem; warnings on stderr unless --quiet.
std::shared_ptr<LoadedView> loadView(const Options& o, RasterBackend backend) {
  auto view = std::make_shared<LoadedView>();
  Scene& scene = view->scene;
  scene = importGltf(o.scene, o.import);
  if (!o.excludedMeshes.empty()) tools::forFlag("--exclude-mesh", [&] { excludeMeshes(scene, o.excludedMeshes); });
  if (!o.quiet)
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "cpvs-view: warning: %s\n", w.c_str());
  view->file = orThrow(CpvsFile::open(o.file));
  const BakedFromCheck check = checkBakedFrom(scene, *view->file);
  view->check = check;
  if (check.checked && !check.matches && !o.noSceneCheck)
    throw Error(ErrorCategory::InvalidInput,
                o.file + " was not baked from " + o.scene + ": the file records input hash " + hex64(check.recordedHash) +
                    ", the scene with the file's lights and settings gives " + hex64(check.sceneHash) +
                    " (the same --exclude-mesh options as the bake? else rebake, or pass --no-scene-check to "
                    "render anyway)");
  if (!check.checked && !o.quiet)
    std::fprintf(stderr, "cpvs-view: warning: cannot check that %s was baked from %s: %s\n", o.file.c_str(),
                 o.scene.c_str(), check.reason.c_str());
  std::vector<LightShadow> lights;
  for (const CpvsFile::LightEntry& entry : view->file->lights()) {
    lights.push_back(orThrow(lightShadowOf(entry)));
    view->lightModels.push_back(lights.back().light());
  }
  view->renderer = std::make_unique<PreviewRenderer>(scene, std::move(lights), backend, o.threads);
  return view;
}

void addOptions(CLI::App& app, Options& o) {
  tools::addStandardFlags(app, "cpvs-view");
  app.add_option("scene", o.scene, "The glTF scene the file was baked from (.gltf / .glb)")->required()->type_name("SCENE");
  app.add_option("cpvs", o.file, "The baked shadows (.cpvs)")->required()->type_name("FILE.cpvs");
  app.add_option("-o,--output", o.output, "Image to write: .png (tone-mapped sRGB, with the overlay) or .exr (linear)");
  app.add_option("--camera", o.cameraName, "A camera of the glTF file, by name");
  app.add_option("--eye", o.eye, "Camera position X,Y,Z (with --target; default: a view framing the scene)")->type_name("X,Y,Z");
  app.add_option("--target", o.target, "The point the camera looks at X,Y,Z")->type_name("X,Y,Z");
  app.add_option("--up", o.up, "Up direction X,Y,Z (default 0,1,0, glTF's)")->type_name("X,Y,Z");
  app.add_option("--fov", o.fov, "Vertical field of view in degrees (default 45.8, or the glTF camera's)");
  app.add_option("--size", o.size, "Image size WIDTHxHEIGHT (default 1920x1080)");
  app.add_option("--pcf", o.pcf, "PCF kernel K (odd, 1..255; default 9, the paper's 9x9)");
  app.add_option("--shadows", o.shadows, "auto (default: gpu where the GL runs on a GPU and holds the DAGs, else cpu; "
                                         "said on stderr and in the report), gpu (CPVS walked in a compute shader), "
                                         "cpu (the CPU runtime's batch lookups), raytraced (Embree shadow rays), none, or a per-frame technique "
                                         "CPVS replaces: shadowmap (a map per light view, drawn every frame) or "
                                         "lightcluster (a cube map per cluster of lights) or manypsm (ManyPSMs: every "
                                         "light view's map in one go by a level-by-level BVH traversal into an atlas, "
                                         "sized by distance; point splats make it approximate)");
  app.add_option("--caster-culling", o.casterCulling, "shadowmap / lightcluster: none, frustum, voxel-grid (Selgrad et al. "
                                                      "2016) or receiver-mask (Bittner et al. 2011); default none");
  app.add_option("--mask-variant", o.maskVariant, "receiver-mask: frag (every covered pixel; default) or bvol (8x8 tile boxes)");
  app.add_option("--shadow-map-size", o.shadowMapSize, "shadowmap / lightcluster: the maps' edge in texels (8..8192; "
                                                      "default 512); manypsm: the largest (a power of two)");
  app.add_option("--min-shadow-map-size", o.minShadowMapSize, "manypsm: the smallest map, for lights far from the camera "
                                                              "(a power of two; default 16)");
  app.add_option("--clusters", o.clusters, "lightcluster: how many clusters (default 10)");
  app.add_option("--overlay", o.overlay, "none, lights-per-tile, difference (against Embree) or shadow-count");
  app.add_flag("--compare", o.compare, "Also render the ray-traced frame: RMSE, % wrong pixels and the mean visibility "
                                       "difference in the report");
  app.add_option("--rays", o.rays, "raytraced: rays per (pixel, light) pair: 1 (default) one hard ray from the surface "
                                   "point; a square s*s (e.g. 16, 81) spread over the pair's KxK PCF footprint, the "
                                   "filtered quantity PCF estimates");
  app.add_option("--compare-rays", o.compareRays, "--compare's reference: rays per pair as for --rays (default 1)");
  app.add_option("--exposure", o.exposure, "Exposure in stops over the automatic one (default 0)");
  app.add_option("--ambient", o.ambient, "Strength of the fill (a sky over a grey ground and a light at the eye, "
                                         "never shadowed) as a fraction of the base colour after exposure; 0 "
                                         "turns it off, showing the lights alone (default 0.3)");
  app.add_option("--exposure-scale", o.exposureScale,
                 "A fixed exposure (radiance multiplier) instead of the automatic one, e.g. to compare views");
  app.add_option("--path", o.path, "Render a camera path: a JSON array of {\"eye\", \"target\", \"up\"?, \"fov\"?}");
  app.add_option("--orbit", o.orbit, "Render N frames orbiting the camera's target (instead of --path)");
  app.add_option("--frames", o.frames, "Folder for the numbered frames of --path / --orbit (frame_0000.png, ...)");
  app.add_option("--report", o.report, "JSON report: pass times, light-list figures, bytes uploaded, error against rays");
  app.add_option("--backend", o.backend, "osmesa (default; llvmpipe on the CPU) or egl (a GPU)");
  app.add_option("--threads", o.threads, "Threads for --shadows cpu / raytraced (default: all cores)");
  app.add_option("--exclude-mesh", o.excludedMeshes,
                 "A mesh the bake excluded (cpvs-bake --exclude-mesh): left out here too (repeatable)")->type_name("NAME");
  tools::addImportOptions(app, o.import);
  app.add_flag("--no-scene-check", o.noSceneCheck, "Render even when the file's input hash says it was baked from another scene");
  app.add_flag("--window", o.window, std::string("Show the frames in a window (GLFW; needs a display) instead of writing "
                                                 "them; it reloads the scene and the file when they change (beside "
                                                 "cpvs-bake --watch: the live loop).\n") + tools::previewWindowKeys());
  app.add_option("--screenshot", o.screenshot, "With --window: write the window's pixels (PNG) after the first frame and close");
  app.add_flag("-q,--quiet", o.quiet, "No summary on stderr");
}

int run(int argc, char** argv) {
  Options o;
  CLI::App app{"cpvs-view: render a baked .cpvs on its scene (headless, OpenGL 4.5 through OSMesa or EGL): G-buffer,\n"
               "tile light lists, CPVS shadows walked on the GPU with KxK PCF, KHR_lights_punctual shading. The\n"
               "lights are the file's; the scene gives the geometry and the materials' base colours."};
  addOptions(app, o);
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;

  FrameSettings settings = frameSettingsOf(o);
  const Overlay overlay = tools::forFlag("--overlay", [&] { return parseOverlay(o.overlay); });
  const RasterBackend backend = tools::forFlag("--backend", [&] { return parseRasterBackend(o.backend); });
  const bool animated = !o.path.empty() || o.orbit > 0;
  checkOutputs(o);
  std::unique_ptr<tools::AtomicFile> reportFile;
  if (!o.report.empty()) reportFile = std::make_unique<tools::AtomicFile>(o.report);
  if (!o.output.empty()) tools::AtomicFile probe(o.output);  // fails now, before any work, when it cannot be written

  // Both inputs are checked before either is read: swapped, they would fail deep inside the wrong reader.
  tools::expectScene(o.scene, tools::positionalUsage(app));
  tools::expectCpvs(o.file, tools::positionalUsage(app));
  o.import.loadBaseColorTextures = true;  // the viewer shows them; the bake never reads images
  if (animated) {
    std::error_code error;
    std::filesystem::create_directories(o.frames, error);
    if (error || !std::filesystem::is_directory(o.frames))
      throw Error(ErrorCategory::OutputFailed, o.frames + ": cannot create the frames folder (" + error.message() + ")");
  }
  const std::shared_ptr<LoadedView> loaded = loadView(o, backend);
  const Scene& scene = loaded->scene;
  const std::vector<Light>& lightModels = loaded->lightModels;
  const BakedFromCheck& check = loaded->check;
  PreviewRenderer& renderer = *loaded->renderer;

  const PreviewCamera camera = chooseCamera(o, scene, lightModels, double(settings.width) / settings.height);
  // The light whose shadows the report measures (the one the default camera is placed by).
  const std::optional<size_t> strongest = strongestLight(lightModels, sceneBounds(scene));
  const Fill fill{o.ambient, glm::normalize(upOf(o))};
  std::vector<PreviewCamera> cameras = {camera};
  if (!o.path.empty()) cameras = readPath(o.path, camera);
  if (o.orbit > 0) cameras = orbit(camera, o.orbit);

  std::string automatic;  // why --shadows auto chose what it chose
  if (o.shadows == "auto") {
    const PreviewRenderer::ShadowChoice choice = renderer.automaticShadows();
    settings.shadows = choice.mode;
    automatic = choice.reason;
    if (!o.quiet)
      std::fprintf(stderr, "cpvs-view: shadows %s (auto: %s)\n", shadowModeName(choice.mode), choice.reason.c_str());
  }
  if (o.window) {
    tools::WindowOptions window;
    window.title = "cpvs-view " + std::filesystem::path(o.scene).filename().string();
    window.overlay = overlay;
    window.exposureStops = o.exposure;
    window.exposureScale = o.exposureScale;
    window.screenshot = o.screenshot;
    window.fill = fill;
    // The live loop: a change to the scene or the file reads both again (with cpvs-bake --watch beside it,
    // an edit is in the window a re-bake later).
    auto sourceOf = [&](std::shared_ptr<LoadedView> view) {
      std::vector<std::string> files = view->scene.files;
      files.push_back(o.file);
      PreviewRenderer* renderer = view->renderer.get();
      return tools::WindowSource{std::move(view), renderer, std::move(files)};
    };
    window.reload = [&] { return sourceOf(loadView(o, backend)); };
    tools::runPreviewWindow(sourceOf(loaded), camera, settings, window);
    return 0;
  }
  renderer.warmUp(settings);
  ViewReport report(o.scene, o.file, renderer, settings, overlay, o.ambient, check, automatic);
  ExposedFrame exposed{o.exposureScale, fill};
  for (size_t i = 0; i < cameras.size(); ++i) {
    const Frame frame = renderer.render(cameras[i], settings);
    if (i == 0 && o.exposureScale <= 0)  // one exposure per path
      exposed = autoExposed(frame, frame.radiance, fill, o.exposure);
    const std::string image = animated ? framePath(o.frames, i) : o.output;
    writeImage(image, frame, frame.radiance, exposed.exposure, exposed.fill, overlay);
    std::optional<ViewReport::Coverage> coverage;
    if (strongest)
      coverage = ViewReport::Coverage{lightModels[*strongest].name,
                                      shadowCoverage(frame, uint32_t(*strongest),
                                                     toneMapped(frame, frame.radiance, exposed.exposure, exposed.fill))};
    report.addFrame(image, cameras[i], frame, exposed.exposure, coverage);
    if (!o.quiet) printFrameLine(image, frame, settings, renderer.lights().size(), report);
    if (!o.quiet && coverage)
      std::fprintf(stderr, "cpvs-view: %.1f%% of the geometry's pixels in the shadow of '%s', %.1f%% near black\n",
                   100.0 * coverage->figures.inShadow, coverage->light.c_str(), 100.0 * coverage->figures.nearBlack);
  }
  if (reportFile) {
    reportFile->write(report.text());
    reportFile->commit();
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return cpvs::tools::runMain("cpvs-view", [&] { return run(argc, argv); }); }
