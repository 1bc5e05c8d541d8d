#include "tools/cpvs-view/preview_window.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/io/png_image.h"
#include "libcpvs/base/error.h"
#include "libcpvs/preview/frame_image.h"
#include "tools/common/atomic_file.h"
#include "tools/common/file_watch.h"

#ifdef CPVS_HAVE_GLFW
#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>
#endif

namespace cpvs::tools {

const char* previewWindowKeys() {
  return "Window keys: left drag orbits, scroll zooms; 1 gpu, 2 cpu, 3 raytraced, 4 no shadows; O next overlay;\n"
         "+ / - PCF size; [ / ] select a light, T switch it off or on, A all on; P saves the window as\n"
         "cpvs-view-N.png in the working folder; Esc or Q quits.";
}

#ifndef CPVS_HAVE_GLFW

bool previewWindowBuilt() { return false; }

void runPreviewWindow(WindowSource, PreviewCamera, FrameSettings, const WindowOptions&) {
  throw Error(ErrorCategory::NotSupported, "this cpvs-view was built without GLFW (libglfw3-dev): no --window");
}

#else

bool previewWindowBuilt() { return true; }

namespace {

// The few GL entry points that show an image, fetched from the window's context.
struct DisplayGl {
  PFNGLGENTEXTURESPROC GenTextures;
  PFNGLBINDTEXTUREPROC BindTexture;
  PFNGLTEXIMAGE2DPROC TexImage2D;
  PFNGLTEXPARAMETERIPROC TexParameteri;
  PFNGLGENFRAMEBUFFERSPROC GenFramebuffers;
  PFNGLBINDFRAMEBUFFERPROC BindFramebuffer;
  PFNGLFRAMEBUFFERTEXTURE2DPROC FramebufferTexture2D;
  PFNGLBLITFRAMEBUFFERPROC BlitFramebuffer;
  PFNGLCLEARCOLORPROC ClearColor;
  PFNGLCLEARPROC Clear;
  PFNGLPIXELSTOREIPROC PixelStorei;
  PFNGLREADPIXELSPROC ReadPixels;
  PFNGLREADBUFFERPROC ReadBuffer;
  PFNGLFINISHPROC Finish;

  void load() {
    auto get = [](const char* name) {
      GLFWglproc p = glfwGetProcAddress(name);
      if (!p) throw Error(ErrorCategory::NotSupported, std::string("the window's OpenGL lacks ") + name);
      return p;
    };
#define CPVS_LOAD(member, name) member = reinterpret_cast<decltype(member)>(get(name))
    CPVS_LOAD(GenTextures, "glGenTextures");
    CPVS_LOAD(BindTexture, "glBindTexture");
    CPVS_LOAD(TexImage2D, "glTexImage2D");
    CPVS_LOAD(TexParameteri, "glTexParameteri");
    CPVS_LOAD(GenFramebuffers, "glGenFramebuffers");
    CPVS_LOAD(BindFramebuffer, "glBindFramebuffer");
    CPVS_LOAD(FramebufferTexture2D, "glFramebufferTexture2D");
    CPVS_LOAD(BlitFramebuffer, "glBlitFramebuffer");
    CPVS_LOAD(ClearColor, "glClearColor");
    CPVS_LOAD(Clear, "glClear");
    CPVS_LOAD(PixelStorei, "glPixelStorei");
    CPVS_LOAD(ReadPixels, "glReadPixels");
    CPVS_LOAD(ReadBuffer, "glReadBuffer");
    CPVS_LOAD(Finish, "glFinish");
#undef CPVS_LOAD
  }
};

struct WindowState {
  PreviewCamera camera;
  FrameSettings settings;
  Overlay overlay = Overlay::None;
  size_t lightCount = 0;
  uint32_t selectedLight = 0;
  std::vector<bool> off;
  bool dirty = true;
  bool save = false;  // P: write the window's pixels after the next frame
  int saved = 0;
  bool dragging = false;
  // The cursor's position as the event stream last reported it (not queried when the button goes down: by then
  // the pointer may have moved on, and the drag's first motion would turn nothing).
  bool cursorKnown = false;
  double lastX = 0, lastY = 0;
};

WindowState& stateOf(GLFWwindow* window) { return *static_cast<WindowState*>(glfwGetWindowUserPointer(window)); }

// Turns the eye around the target: yaw about `up`, pitch about the camera's right axis (kept off the poles).
void orbitCamera(PreviewCamera& c, double yaw, double pitch) {
  const glm::dvec3 up = glm::normalize(c.up);
  glm::dvec3 offset = c.eye - c.target;
  const double distance = glm::length(offset);
  glm::dvec3 dir = offset / distance;
  auto rotate = [](const glm::dvec3& v, const glm::dvec3& axis, double angle) {
    return v * std::cos(angle) + glm::cross(axis, v) * std::sin(angle) + axis * glm::dot(axis, v) * (1 - std::cos(angle));
  };
  dir = rotate(dir, up, yaw);
  const glm::dvec3 right = glm::normalize(glm::cross(up, dir));
  const glm::dvec3 pitched = rotate(dir, right, pitch);
  if (std::fabs(glm::dot(pitched, up)) < 0.98) dir = pitched;
  c.eye = c.target + dir * distance;
}

void onKey(GLFWwindow* window, int key, int, int action, int) {
  if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
  WindowState& s = stateOf(window);
  switch (key) {
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q: glfwSetWindowShouldClose(window, GLFW_TRUE); return;
    case GLFW_KEY_1: s.settings.shadows = ShadowMode::Gpu; break;
    case GLFW_KEY_2: s.settings.shadows = ShadowMode::Cpu; break;
    case GLFW_KEY_3: s.settings.shadows = ShadowMode::RayTraced; break;
    case GLFW_KEY_4: s.settings.shadows = ShadowMode::None; break;
    case GLFW_KEY_O: s.overlay = Overlay((int(s.overlay) + 1) % 4); break;
    case GLFW_KEY_EQUAL:
    case GLFW_KEY_KP_ADD: s.settings.pcfKernel = std::min(255, s.settings.pcfKernel + 2); break;
    case GLFW_KEY_MINUS:
    case GLFW_KEY_KP_SUBTRACT: s.settings.pcfKernel = std::max(1, s.settings.pcfKernel - 2); break;
    case GLFW_KEY_LEFT_BRACKET:
      if (s.lightCount) s.selectedLight = s.selectedLight == 0 ? uint32_t(s.lightCount - 1) : s.selectedLight - 1;
      break;
    case GLFW_KEY_RIGHT_BRACKET: s.selectedLight = uint32_t((s.selectedLight + 1) % std::max<size_t>(1, s.lightCount)); break;
    case GLFW_KEY_T:
      if (s.lightCount) s.off[s.selectedLight] = !s.off[s.selectedLight];
      break;
    case GLFW_KEY_A: std::fill(s.off.begin(), s.off.end(), false); break;
    case GLFW_KEY_P: s.save = true; break;  // after the keys before it have been drawn (dirty below)
    default: return;
  }
  s.settings.compareWithRays = s.overlay == Overlay::Difference;
  s.settings.disabledLights.clear();
  for (uint32_t l = 0; l < s.off.size(); ++l)
    if (s.off[l]) s.settings.disabledLights.push_back(l);
  s.dirty = true;
}

void onMouseButton(GLFWwindow* window, int button, int action, int) {
  WindowState& s = stateOf(window);
  if (button != GLFW_MOUSE_BUTTON_LEFT) return;
  s.dragging = action == GLFW_PRESS;
  if (s.dragging && !s.cursorKnown) {
    glfwGetCursorPos(window, &s.lastX, &s.lastY);
    s.cursorKnown = true;
  }
}

void onCursor(GLFWwindow* window, double x, double y) {
  WindowState& s = stateOf(window);
  if (s.dragging && s.cursorKnown) {
    orbitCamera(s.camera, -(x - s.lastX) * 0.01, -(y - s.lastY) * 0.01);
    s.dirty = true;
  }
  s.lastX = x;
  s.lastY = y;
  s.cursorKnown = true;
}

void onScroll(GLFWwindow* window, double, double dy) {
  WindowState& s = stateOf(window);
  s.camera.eye = s.camera.target + (s.camera.eye - s.camera.target) * std::pow(0.9, dy);
  s.dirty = true;
}

// The window's own pixels, read back from its back buffer before the swap, as a PNG.
void writeWindowPixels(const DisplayGl& gl, int fw, int fh, const std::string& path) {
  gl.Finish();
  gl.BindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  gl.ReadBuffer(GL_BACK);
  std::vector<uint8_t> back(size_t(fw) * size_t(fh) * 3);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadPixels(0, 0, fw, fh, GL_RGB, GL_UNSIGNED_BYTE, back.data());
  RgbImage screen;
  screen.width = uint32_t(fw);
  screen.height = uint32_t(fh);
  screen.pixels.resize(back.size());
  for (int y = 0; y < fh; ++y)
    std::copy_n(back.begin() + ptrdiff_t(size_t(y) * size_t(fw) * 3), size_t(fw) * 3,
                screen.pixels.begin() + ptrdiff_t(size_t(fh - 1 - y) * size_t(fw) * 3));
  AtomicFile out(path);
  out.write(encodePng(screen));
  out.commit();
}

}  // namespace

void runPreviewWindow(WindowSource source, PreviewCamera camera, FrameSettings settings, const WindowOptions& options) {
  if (!glfwInit()) throw Error(ErrorCategory::NotSupported, "cannot open a window: no display (GLFW could not start)");
  struct Terminate {
    ~Terminate() { glfwTerminate(); }
  } terminate;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(int(settings.width), int(settings.height), options.title.c_str(), nullptr, nullptr);
  if (!window) throw Error(ErrorCategory::NotSupported, "cannot open a " + std::to_string(settings.width) + "x" +
                                                            std::to_string(settings.height) + " OpenGL 3.3 window");
  WindowState state;
  state.camera = camera;
  state.settings = settings;
  state.overlay = options.overlay;
  state.lightCount = source.renderer->lights().size();
  state.off.assign(state.lightCount, false);
  glfwSetWindowUserPointer(window, &state);
  glfwSetKeyCallback(window, onKey);
  glfwSetMouseButtonCallback(window, onMouseButton);
  glfwSetCursorPosCallback(window, onCursor);
  glfwSetScrollCallback(window, onScroll);
  glfwMakeContextCurrent(window);
  DisplayGl gl;
  gl.load();
  GLuint texture = 0, framebuffer = 0;
  gl.GenTextures(1, &texture);
  gl.GenFramebuffers(1, &framebuffer);
  std::optional<ExposedFrame> exposed;
  bool shot = false;
  FileStamps shown = stampsOf(source.files), seen = shown;  // what the frame shows; what the last poll saw
  while (!glfwWindowShouldClose(window)) {
    if (options.reload) {
      const FileStamps now = stampsOf(source.files);
      if (now != shown && now == seen) {  // changed, and held still since the last poll
        shown = now;
        glfwMakeContextCurrent(nullptr);
        try {
          WindowSource next = options.reload();
          source = std::move(next);  // the old renderer, scene and file go
          shown = stampsOf(source.files);  // the files it now reads
          state.lightCount = source.renderer->lights().size();
          state.off.resize(state.lightCount, false);
          state.selectedLight = state.lightCount ? std::min<uint32_t>(state.selectedLight, uint32_t(state.lightCount - 1)) : 0;
          state.dirty = true;
          std::fprintf(stderr, "cpvs-view: reloaded %s\n", source.files.empty() ? "" : source.files.front().c_str());
        } catch (const Error& e) {
          std::fprintf(stderr, "cpvs-view: cannot reload (the window keeps what it shows): %s\n", e.what());
        }
        glfwMakeContextCurrent(window);
      }
      seen = now;
    }
    if (state.dirty) {
      PreviewRenderer& renderer = *source.renderer;
      state.dirty = false;
      // The renderer's context (OSMesa or EGL) is current only inside render(); the window's is made current
      // again afterwards, released first so that the GL dispatch really switches back.
      glfwMakeContextCurrent(nullptr);
      const Frame frame = renderer.render(state.camera, state.settings);
      if (!exposed)  // the first frame's, kept: switching shadows off must not re-expose the image
        exposed = options.exposureScale > 0 ? ExposedFrame{options.exposureScale, options.fill}
                                            : autoExposed(frame, frame.radiance, options.fill, options.exposureStops);
      RgbImage image = withOverlay(frame, toneMapped(frame, frame.radiance, exposed->exposure, exposed->fill),
                                   state.overlay);
      glfwMakeContextCurrent(window);
      // Rows bottom-up for GL.
      std::vector<uint8_t> rows(image.pixels.size());
      for (uint32_t y = 0; y < image.height; ++y)
        std::copy_n(image.at(0, image.height - 1 - y), size_t(image.width) * 3, rows.begin() + ptrdiff_t(size_t(y) * image.width * 3));
      gl.BindTexture(GL_TEXTURE_2D, texture);
      gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
      gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, GLsizei(image.width), GLsizei(image.height), 0, GL_RGB, GL_UNSIGNED_BYTE, rows.data());
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      gl.BindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
      gl.FramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
      gl.BindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
      int fw = 0, fh = 0;
      glfwGetFramebufferSize(window, &fw, &fh);
      gl.ClearColor(0, 0, 0, 1);
      gl.Clear(GL_COLOR_BUFFER_BIT);
      gl.BlitFramebuffer(0, 0, GLint(image.width), GLint(image.height), 0, 0, fw, fh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
      char title[512];
      std::snprintf(title, sizeof title, "%s | shadows %s, PCF %d, overlay %s | light %u of %zu %s | %.0f ms shadows",
                    options.title.c_str(), shadowModeName(state.settings.shadows), state.settings.pcfKernel,
                    overlayName(state.overlay), state.selectedLight, state.lightCount,
                    state.lightCount && state.off[state.selectedLight] ? "(off)" : "(on)", frame.milliseconds("shadows"));
      glfwSetWindowTitle(window, title);
      if (!options.screenshot.empty() && !shot) {
        writeWindowPixels(gl, fw, fh, options.screenshot);
        shot = true;
        glfwSetWindowShouldClose(window, GLFW_TRUE);
      }
      if (state.save) {
        state.save = false;
        const std::string name = "cpvs-view-" + std::to_string(state.saved++) + ".png";
        try {
          writeWindowPixels(gl, fw, fh, name);
          std::fprintf(stderr, "cpvs-view: saved the window as %s\n", name.c_str());
        } catch (const Error& e) {  // a save that fails must not end the session
          std::fprintf(stderr, "cpvs-view: error: %s\n", e.what());
        }
      }
      glfwSwapBuffers(window);
    }
    glfwWaitEventsTimeout(0.1);
  }
  glfwDestroyWindow(window);
}

#endif

}  // namespace cpvs::tools
