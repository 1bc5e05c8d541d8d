// cpvs-view: renders a baked .cpvs on its scene, headless: G-buffer, tile light lists, CPVS shadows walked on
// the GPU (or the CPU runtime's, or Embree's rays), KHR_lights_punctual shading, to a PNG or EXR, with
// overlays and a timed report (docs/viewer.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/io/exr_image.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/base/error.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/cpvs-view/preview_window.h"
#include "tools/cpvs-view/view_command.h"
#include "tools/cpvs-view/view_report.h"

namespace {

using namespace cpvs;
using cpvs::tools::ViewReport;

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

int run(int argc, char** argv) {
  tools::ViewOptions o;
  CLI::App app{"cpvs-view: render a baked .cpvs on its scene (headless, OpenGL 4.5 through OSMesa or EGL): G-buffer,\n"
               "tile light lists, CPVS shadows walked on the GPU with KxK PCF, KHR_lights_punctual shading. The\n"
               "lights are the file's; the scene gives the geometry and the materials' base colours."};
  o.addTo(app);
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;

  FrameSettings settings = o.frameSettings();
  const Overlay overlay = tools::forFlag("--overlay", [&] { return parseOverlay(o.overlay); });
  const RasterBackend backend = tools::forFlag("--backend", [&] { return parseRasterBackend(o.backend); });
  const bool animated = !o.path.empty() || o.orbit > 0;
  o.checkOutputs();
  std::unique_ptr<tools::AtomicFile> reportFile;
  if (!o.report.empty()) reportFile = std::make_unique<tools::AtomicFile>(o.report);
  if (!o.output.empty()) tools::AtomicFile probe(o.output);  // fails now, before any work, when it cannot be written

  // Both inputs are checked before either is read: swapped, they would fail deep inside the wrong reader.
  tools::expectScene(o.scene, tools::positionalUsage(app));
  tools::expectCpvs(o.file, tools::positionalUsage(app));
  if (animated) {
    std::error_code error;
    std::filesystem::create_directories(o.frames, error);
    if (error || !std::filesystem::is_directory(o.frames))
      throw Error(ErrorCategory::OutputFailed, o.frames + ": cannot create the frames folder (" + error.message() + ")");
  }
  const std::shared_ptr<tools::LoadedView> loaded = tools::loadView(o, backend);
  const Scene& scene = loaded->scene;
  const std::vector<Light>& lightModels = loaded->lightModels;
  const BakedFromCheck& check = loaded->check;
  PreviewRenderer& renderer = *loaded->renderer;

  const PreviewCamera camera = tools::chooseCamera(o, scene, lightModels, double(settings.width) / settings.height);
  // The light whose shadows the report measures (the one the default camera is placed by).
  const std::optional<size_t> strongest = strongestLight(lightModels, sceneBounds(scene));
  const Fill fill{o.ambient, glm::normalize(o.upDirection())};
  std::vector<PreviewCamera> cameras = {camera};
  if (!o.path.empty()) cameras = tools::readPath(o.path, camera);
  if (o.orbit > 0) cameras = tools::orbit(camera, o.orbit);

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
    auto sourceOf = [&](std::shared_ptr<tools::LoadedView> view) {
      std::vector<std::string> files = view->scene.files;
      files.push_back(o.file);
      PreviewRenderer* renderer = view->renderer.get();
      return tools::WindowSource{std::move(view), renderer, std::move(files)};
    };
    window.reload = [&] { return sourceOf(tools::loadView(o, backend)); };
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
