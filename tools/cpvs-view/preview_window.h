#pragma once
// cpvs-view --window: the headless renderer's frames shown in a GLFW window (the window's own GL context
// only displays them), with an orbit camera and keys for the shadow mode, overlay, PCF size and lights.
#include <string>

#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"

namespace cpvs::tools {

struct WindowOptions {
  std::string title;
  Overlay overlay = Overlay::None;
  double exposureStops = 0;
  double exposureScale = 0;  // > 0: fixed, instead of the first frame's automatic exposure
  Fill fill;
  std::string screenshot;  // when set: write the window's pixels (PNG) after the first frame, then close
};

// Runs until the window is closed (Esc, Q). Throws Error(NotSupported) when built without GLFW or when no
// display can be opened.
void runPreviewWindow(PreviewRenderer& renderer, PreviewCamera camera, FrameSettings settings,
                      const WindowOptions& options);

// Whether this build has the window (GLFW).
bool previewWindowBuilt();

// The keys, for --help and docs/viewer.md.
const char* previewWindowKeys();

}  // namespace cpvs::tools
