#include "tools/cpvs-view/view_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>

#include <nlohmann/json.hpp>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/file_shadows.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/cpvs-view/preview_window.h"

namespace cpvs::tools {
namespace {

using json = nlohmann::ordered_json;

glm::dvec3 vec3Of(const std::string& flag, const std::string& text) {
  const auto v = parseNumbers(flag, text, 3);
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

// s for s * s rays per pair (a square, 1 .. 64^2).
int raysPerSideOf(uint32_t rays) {
  const uint32_t s = uint32_t(std::lround(std::sqrt(double(rays))));
  if (rays < 1 || s * s != rays || s > 64)
    throw Error(ErrorCategory::InvalidArgument, std::to_string(rays) + " rays per pair: 1 or a square s*s up to 4096");
  return int(s);
}

}  // namespace

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


FrameSettings ViewOptions::frameSettings() const {
  const ViewOptions& o = *this;
  FrameSettings settings;
  forFlag("--size", [&] { parseSize(o.size, settings.width, settings.height); });
  settings.pcfKernel = o.pcf;
  if (const Outcome k = checkPcfKernel(o.pcf); !k) throw Error(ErrorCategory::InvalidArgument, "--pcf: " + k.message());
  // "auto" is chosen once the renderer knows its GL (PreviewRenderer::automaticShadows).
  if (o.shadows != "auto") settings.shadows = forFlag("--shadows", [&] { return parseShadowMode(o.shadows); });
  settings.shadowMaps.casterCulling = forFlag("--caster-culling", [&] { return parseCasterCulling(o.casterCulling); });
  settings.shadowMaps.maskVariant = forFlag("--mask-variant", [&] { return parseReceiverMaskVariant(o.maskVariant); });
  if (o.shadowMapSize < 8 || o.shadowMapSize > 8192)
    throw Error(ErrorCategory::InvalidArgument, "--shadow-map-size: 8..8192 texels");
  if (o.clusters < 1 || o.clusters > 100000) throw Error(ErrorCategory::InvalidArgument, "--clusters: 1..100000");
  if (o.minShadowMapSize < 1 || o.minShadowMapSize > o.shadowMapSize)
    throw Error(ErrorCategory::InvalidArgument, "--min-shadow-map-size: 1..--shadow-map-size texels");
  settings.shadowMaps.size = o.shadowMapSize;
  settings.shadowMaps.minSize = o.minShadowMapSize;
  settings.shadowMaps.clusters = o.clusters;
  settings.compareWithRays = o.compare || o.overlay == "difference";
  settings.raysPerSide = forFlag("--rays", [&] { return raysPerSideOf(o.rays); });
  settings.compareRaysPerSide = forFlag("--compare-rays", [&] { return raysPerSideOf(o.compareRays); });
  return settings;
}

void ViewOptions::checkOutputs() const {
  const ViewOptions& o = *this;
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
  checkCameraAndExposure();
  if (o.window && !previewWindowBuilt())
    throw Error(ErrorCategory::NotSupported, "this cpvs-view was built without GLFW (libglfw3-dev): no --window");
}

void ViewOptions::checkCameraAndExposure() const {
  const ViewOptions& o = *this;
  if (!o.cameraName.empty() && (!o.eye.empty() || !o.target.empty()))
    throw Error(ErrorCategory::InvalidArgument, "--camera excludes --eye / --target");
  if (o.eye.empty() != o.target.empty()) throw Error(ErrorCategory::InvalidArgument, "--eye and --target go together");
  if (o.fov != 0 && !(o.fov > 0 && o.fov < 180)) throw Error(ErrorCategory::InvalidArgument, "--fov: degrees in (0, 180)");
  if (!(std::fabs(o.exposure) <= 64)) throw Error(ErrorCategory::InvalidArgument, "--exposure: stops in -64..64");
  if (!(o.exposureScale >= 0 && o.exposureScale <= 1e30))
    throw Error(ErrorCategory::InvalidArgument, "--exposure-scale: a positive multiplier");
  if (!(o.ambient >= 0 && o.ambient <= 100))
    throw Error(ErrorCategory::InvalidArgument, "--ambient: a strength in 0..100 (0: no fill)");
}

glm::dvec3 ViewOptions::upDirection() const {
  const ViewOptions& o = *this;
  return o.up.empty() ? glm::dvec3(0, 1, 0) : forFlag("--up", [&] { return vec3Of("--up", o.up); });
}

PreviewCamera chooseCamera(const ViewOptions& o, const Scene& scene, std::span<const Light> lights, double aspect) {
  const Bounds bounds = sceneBounds(scene);
  const glm::dvec3 up = o.upDirection();
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
  forFlag("--eye/--target/--up/--fov", [&] { checkCamera(camera); });
  return camera;
}

std::shared_ptr<LoadedView> loadView(const ViewOptions& o, RasterBackend backend) {
  auto view = std::make_shared<LoadedView>();
  Scene& scene = view->scene;
  ImportOptions import = o.import;
  import.loadBaseColorTextures = true;  // the viewer shows them; the bake never reads images
  scene = importGltf(o.scene, import);
  if (!o.excludedMeshes.empty()) forFlag("--exclude-mesh", [&] { excludeMeshes(scene, o.excludedMeshes); });
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

void ViewOptions::addTo(CLI::App& app) {
  ViewOptions& o = *this;
  addStandardFlags(app, "cpvs-view");
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
  addImportOptions(app, o.import);
  app.add_flag("--no-scene-check", o.noSceneCheck, "Render even when the file's input hash says it was baked from another scene");
  app.add_flag("--window", o.window, std::string("Show the frames in a window (GLFW; needs a display) instead of writing "
                                                 "them; it reloads the scene and the file when they change (beside "
                                                 "cpvs-bake --watch: the live loop).\n") + previewWindowKeys());
  app.add_option("--screenshot", o.screenshot, "With --window: write the window's pixels (PNG) after the first frame and close");
  app.add_flag("-q,--quiet", o.quiet, "No summary on stderr");
}

RgbImage renderStill(const ViewOptions& o, const std::string& usage, std::string* automatic) {
  FrameSettings settings = o.frameSettings();
  o.checkCameraAndExposure();
  expectScene(o.scene, usage);
  expectCpvs(o.file, usage);
  const Overlay overlay = forFlag("--overlay", [&] { return parseOverlay(o.overlay); });
  const RasterBackend backend = forFlag("--backend", [&] { return parseRasterBackend(o.backend); });
  const std::shared_ptr<LoadedView> loaded = loadView(o, backend);
  PreviewRenderer& renderer = *loaded->renderer;
  const PreviewCamera camera =
      chooseCamera(o, loaded->scene, loaded->lightModels, double(settings.width) / settings.height);
  if (o.shadows == "auto") {
    const PreviewRenderer::ShadowChoice choice = renderer.automaticShadows();
    settings.shadows = choice.mode;
    if (automatic) *automatic = choice.reason;
  }
  renderer.warmUp(settings);
  const Frame frame = renderer.render(camera, settings);
  const Fill fill{o.ambient, glm::normalize(o.upDirection())};
  const ExposedFrame exposed =
      o.exposureScale > 0 ? ExposedFrame{o.exposureScale, fill} : autoExposed(frame, frame.radiance, fill, o.exposure);
  return withOverlay(frame, toneMapped(frame, frame.radiance, exposed.exposure, exposed.fill), overlay);
}

}  // namespace cpvs::tools
