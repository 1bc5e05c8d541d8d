#pragma once
// cpvs-view's options and what a frame needs: the scene and file loaded and checked against each other, the
// camera, the settings. What the command line runs, and what the Python module's cpvs.preview runs from the same
// options (python/), so that both give the same pixels.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/glm.hpp>

#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"
#include "libcpvs/raster/depth_renderer.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace cpvs::tools {

struct ViewOptions {
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

  // Defines cpvs-view's options on `app`, into this.
  void addTo(CLI::App& app);
  // The frame settings the options ask for (each value checked, the flag named in the error).
  FrameSettings frameSettings() const;
  // Throws Error(InvalidArgument) for combinations of outputs, cameras and exposure the options may not ask for.
  void checkOutputs() const;
  // The part of checkOutputs about the camera and the exposure (what a still needs).
  void checkCameraAndExposure() const;
  glm::dvec3 upDirection() const;  // --up, or glTF's +Y
};

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
// Reads the scene and the file as they are on disk (again for each reload of --window). Throws Error naming
// the file and the problem; warnings on stderr unless --quiet.
std::shared_ptr<LoadedView> loadView(const ViewOptions& o, RasterBackend backend);

// The camera: a glTF camera, the command line's, or a default framing from the side the strongest light lights.
PreviewCamera chooseCamera(const ViewOptions& o, const Scene& scene, std::span<const Light> lights, double aspect);
// The cameras of a --path file: [{"eye": [x, y, z], "target": [x, y, z], "up": [x, y, z]?, "fov": degrees?}, ...].
std::vector<PreviewCamera> readPath(const std::string& path, const PreviewCamera& base);
// N cameras on a circle around the base camera's target, at its distance and height.
std::vector<PreviewCamera> orbit(const PreviewCamera& base, int n);

// One frame of the options' camera as cpvs-view -o OUT.png writes it: --shadows auto resolved, the automatic
// exposure (or --exposure-scale), tone-mapped sRGB with the overlay. `usage` is named when the inputs are of the
// wrong kind; `automatic`, when given, says why --shadows auto chose what it chose (left as it was otherwise).
RgbImage renderStill(const ViewOptions& o, const std::string& usage, std::string* automatic = nullptr);

}  // namespace cpvs::tools
