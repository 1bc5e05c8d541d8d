#pragma once
// cpvs-view --window: the headless renderer's frames shown in a GLFW window (the window's own GL context
// only displays them), with an orbit camera and keys for the shadow mode, overlay, PCF size and lights.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"

namespace cpvs::tools {

// What the window shows: a renderer and what keeps it valid (the scene and the file it reads), and the files
// whose change reloads them (the scene's files and the .cpvs).
struct WindowSource {
  std::shared_ptr<void> owner;
  PreviewRenderer* renderer = nullptr;
  std::vector<std::string> files;
};

struct WindowOptions {
  std::string title;
  Overlay overlay = Overlay::None;
  double exposureStops = 0;
  double exposureScale = 0;  // > 0: fixed, instead of the first frame's automatic exposure
  Fill fill;
  std::string screenshot;  // when set: write the window's pixels (PNG) after the first frame, then close
  // The live loop: when the source's files change (and hold still), the scene and the file are read again with
  // this, keeping the camera, the settings and the exposure; it throws Error when they cannot be read or do not
  // match (a scene saved before its re-bake is done), and the window keeps what it shows. Empty: no reloads.
  std::function<WindowSource()> reload;
};

// Runs until the window is closed (Esc, Q). Throws Error(NotSupported) when built without GLFW or when no
// display can be opened.
void runPreviewWindow(WindowSource source, PreviewCamera camera, FrameSettings settings, const WindowOptions& options);

// Whether this build has the window (GLFW).
bool previewWindowBuilt();

// The keys, for --help and docs/viewer.md.
const char* previewWindowKeys();

}  // namespace cpvs::tools
