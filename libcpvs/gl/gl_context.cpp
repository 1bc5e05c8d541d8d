#include "libcpvs/gl/gl_context.h"

#include <dlfcn.h>

#include <cstring>
#include <functional>
#include <map>
#include <mutex>
#include <vector>

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include "libcpvs/base/error.h"

namespace cpvs::gl {
namespace {

// Libraries stay loaded for the life of the process (unloading Mesa while its threads or atexit handlers
// may still run is not safe).
void* openLibrary(const char* name, const char* purpose) {
  static std::mutex mutex;
  static std::map<std::string, void*> handles;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = handles.find(name);
  if (it != handles.end()) return it->second;
  void* handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    throw Error(ErrorCategory::NotSupported, std::string("cannot load ") + name + " (" + purpose +
                                            "): " + (why ? why : "unknown dlopen error"));
  }
  handles.emplace(name, handle);
  return handle;
}

template <typename T>
T librarySymbol(void* library, const char* libraryName, const char* symbol) {
  void* p = dlsym(library, symbol);
  if (!p)
    throw Error(ErrorCategory::NotSupported, std::string(libraryName) + " lacks the symbol " + symbol);
  return reinterpret_cast<T>(p);
}

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  }
  return false;
}

const char* cstr(const GLubyte* s) { return s ? reinterpret_cast<const char*>(s) : "?"; }


using GetProc = std::function<void*(const char*)>;

void fillTable(Functions& f, const GetProc& getProc, const char* backendName) {
#define CPVS_GL_LOAD(type, name)                                                                        \
  f.name = reinterpret_cast<type>(getProc("gl" #name));                                                 \
  if (!f.name)                                                                                          \
    throw Error(ErrorCategory::NotSupported,                                                                 \
                std::string(backendName) + ": the GL context does not provide gl" #name);
  CPVS_GL_FUNCTIONS(CPVS_GL_LOAD)
#undef CPVS_GL_LOAD
#define CPVS_GL_LOAD_OPTIONAL(type, name) f.name = reinterpret_cast<type>(getProc("gl" #name));
  CPVS_GL_OPTIONAL_FUNCTIONS(CPVS_GL_LOAD_OPTIONAL)
#undef CPVS_GL_LOAD_OPTIONAL
}

std::string describe(const Functions& f, const std::string& prefix, int& major, int& minor) {
  GLint ma = 0, mi = 0;
  f.GetIntegerv(GL_MAJOR_VERSION, &ma);
  f.GetIntegerv(GL_MINOR_VERSION, &mi);
  major = ma;
  minor = mi;
  return prefix + " GL " + std::to_string(ma) + "." + std::to_string(mi) + " core: " +
         cstr(f.GetString(GL_RENDERER)) + " (" + cstr(f.GetString(GL_VERSION)) + ")";
}

// An API table loaded by `load` on first use, once per process; a failure to load is kept and thrown, as
// NotSupported, on every use.
template <class Api, class Load>
const Api& loadedOnce(const Load& load) {
  static std::once_flag once;
  static Api api;
  static std::string failure;
  std::call_once(once, [&] {
    try {
      load(api);
    } catch (const Error& e) {
      failure = e.what();
    }
  });
  if (!failure.empty()) throw Error(ErrorCategory::NotSupported, failure);
  return api;
}

// ---------------------------------------------------------------------------------------------- OSMesa

constexpr int kOSMesaFormat = 0x22, kOSMesaRGBA = 0x1908 /* GL_RGBA */, kOSMesaDepthBits = 0x30,
              kOSMesaStencilBits = 0x31, kOSMesaAccumBits = 0x32, kOSMesaProfile = 0x33,
              kOSMesaCoreProfile = 0x34, kOSMesaMajor = 0x36, kOSMesaMinor = 0x37;

struct OSMesaApi {
  using CreateContextAttribs = void* (*)(const int*, void*);
  using MakeCurrent = unsigned char (*)(void*, void*, GLenum, GLsizei, GLsizei);
  using DestroyContext = void (*)(void*);
  using GetProcAddress = void (*(*)(const char*))();
  CreateContextAttribs createContextAttribs = nullptr;
  MakeCurrent makeCurrent = nullptr;
  DestroyContext destroyContext = nullptr;
  GetProcAddress getProcAddress = nullptr;

  static const OSMesaApi& get() {
    return loadedOnce<OSMesaApi>([](OSMesaApi& api) {
      const char* name = "libOSMesa.so.8";
      void* lib = openLibrary(name, "OSMesa off-screen OpenGL, package libosmesa6");
      api.createContextAttribs = librarySymbol<CreateContextAttribs>(lib, name, "OSMesaCreateContextAttribs");
      api.makeCurrent = librarySymbol<MakeCurrent>(lib, name, "OSMesaMakeCurrent");
      api.destroyContext = librarySymbol<DestroyContext>(lib, name, "OSMesaDestroyContext");
      api.getProcAddress = librarySymbol<GetProcAddress>(lib, name, "OSMesaGetProcAddress");
    });
  }
};

class OSMesaContext final : public Context {
public:
  OSMesaContext() {
    const OSMesaApi& api = OSMesaApi::get();
    const int versions[][2] = {{4, 5}, {3, 3}};
    for (const auto& v : versions) {
      const int attribs[] = {kOSMesaFormat, kOSMesaRGBA, kOSMesaDepthBits, 0, kOSMesaStencilBits, 0,
                             kOSMesaAccumBits, 0, kOSMesaProfile, kOSMesaCoreProfile, kOSMesaMajor, v[0],
                             kOSMesaMinor, v[1], 0};
      context_ = api.createContextAttribs(attribs, nullptr);
      if (context_) break;
    }
    if (!context_)
      throw Error(ErrorCategory::NotSupported, "OSMesa: cannot create an OpenGL 4.5 or 3.3 core context");
    platform_ = Platform::OSMesa;
    buffer_.assign(kDummySize * kDummySize * 4, 0);
    makeCurrent();
    try {
      fillTable(functions_,
                [&](const char* name) { return reinterpret_cast<void*>(api.getProcAddress(name)); },
                "OSMesa");
      description_ = describe(functions_, "OSMesa", major_, minor_);
    } catch (...) {
      release();
      api.destroyContext(context_);
      throw;
    }
    release();
  }
  ~OSMesaContext() override {
    if (context_) OSMesaApi::get().destroyContext(context_);
  }
  void makeCurrent() override {
    if (!OSMesaApi::get().makeCurrent(context_, buffer_.data(), GL_UNSIGNED_BYTE, kDummySize, kDummySize))
      throw Error(ErrorCategory::RuntimeFailure, "OSMesa: OSMesaMakeCurrent failed");
  }
  void release() override { OSMesaApi::get().makeCurrent(nullptr, nullptr, 0, 0, 0); }

private:
  static constexpr int kDummySize = 16;
  void* context_ = nullptr;
  std::vector<unsigned char> buffer_;
};

// ------------------------------------------------------------------------------------------------- EGL

struct EGLApi {
  PFNEGLGETPROCADDRESSPROC getProcAddress = nullptr;
  PFNEGLQUERYSTRINGPROC queryString = nullptr;
  PFNEGLGETERRORPROC getError = nullptr;
  PFNEGLINITIALIZEPROC initialize = nullptr;
  PFNEGLTERMINATEPROC terminate = nullptr;
  PFNEGLBINDAPIPROC bindAPI = nullptr;
  PFNEGLCHOOSECONFIGPROC chooseConfig = nullptr;
  PFNEGLCREATECONTEXTPROC createContext = nullptr;
  PFNEGLDESTROYCONTEXTPROC destroyContext = nullptr;
  PFNEGLMAKECURRENTPROC makeCurrent = nullptr;
  PFNEGLGETPLATFORMDISPLAYEXTPROC getPlatformDisplay = nullptr;  // EXT or EGL 1.5 (same signature)
  PFNEGLQUERYDEVICESEXTPROC queryDevices = nullptr;
  PFNEGLQUERYDEVICESTRINGEXTPROC queryDeviceString = nullptr;
  const char* clientExtensions = nullptr;

  static const EGLApi& get() {
    return loadedOnce<EGLApi>([](EGLApi& api) {
      const char* name = "libEGL.so.1";
      void* lib = openLibrary(name, "EGL, package libegl1");
      api.getProcAddress = librarySymbol<PFNEGLGETPROCADDRESSPROC>(lib, name, "eglGetProcAddress");
      api.queryString = librarySymbol<PFNEGLQUERYSTRINGPROC>(lib, name, "eglQueryString");
      api.getError = librarySymbol<PFNEGLGETERRORPROC>(lib, name, "eglGetError");
      api.initialize = librarySymbol<PFNEGLINITIALIZEPROC>(lib, name, "eglInitialize");
      api.terminate = librarySymbol<PFNEGLTERMINATEPROC>(lib, name, "eglTerminate");
      api.bindAPI = librarySymbol<PFNEGLBINDAPIPROC>(lib, name, "eglBindAPI");
      api.chooseConfig = librarySymbol<PFNEGLCHOOSECONFIGPROC>(lib, name, "eglChooseConfig");
      api.createContext = librarySymbol<PFNEGLCREATECONTEXTPROC>(lib, name, "eglCreateContext");
      api.destroyContext = librarySymbol<PFNEGLDESTROYCONTEXTPROC>(lib, name, "eglDestroyContext");
      api.makeCurrent = librarySymbol<PFNEGLMAKECURRENTPROC>(lib, name, "eglMakeCurrent");
      api.clientExtensions = api.queryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
      if (!api.clientExtensions) api.getError();  // clear EGL_BAD_DISPLAY from pre-1.5 implementations
      api.getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
          api.getProcAddress("eglGetPlatformDisplayEXT"));
      if (!api.getPlatformDisplay)
        api.getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
            api.getProcAddress("eglGetPlatformDisplay"));
      api.queryDevices =
          reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(api.getProcAddress("eglQueryDevicesEXT"));
      api.queryDeviceString =
          reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(api.getProcAddress("eglQueryDeviceStringEXT"));
    });
  }
};

std::string eglErrorName(EGLint code) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "0x%04X", unsigned(code));
  return buffer;
}

// eglTerminate is per display, not per context: several renderers can share a display, so count them.
class DisplayRefs {
public:
  static void acquire(EGLDisplay d) {
    std::lock_guard<std::mutex> lock(mutex());
    ++counts()[d];
  }
  static void releaseDisplay(EGLDisplay d) {
    std::lock_guard<std::mutex> lock(mutex());
    if (--counts()[d] == 0) {
      counts().erase(d);
      EGLApi::get().terminate(d);
    }
  }

private:
  // Never destroyed: contexts held in static objects may be released during exit, after function-local
  // statics constructed later than them are gone.
  static std::mutex& mutex() {
    static std::mutex* m = new std::mutex;
    return *m;
  }
  static std::map<EGLDisplay, int>& counts() {
    static std::map<EGLDisplay, int>* c = new std::map<EGLDisplay, int>;
    return *c;
  }
};

class EGLContextImpl final : public Context {
public:
  EGLContextImpl() {
    const EGLApi& api = EGLApi::get();
    platform_ = Platform::EGL;
    std::string reasons;
    auto attempt = [&](EGLenum platform, void* native, const std::string& label) -> bool {
      std::string why;
      if (tryDisplay(platform, native, label, why)) return true;
      reasons += "\n  " + label + ": " + why;
      return false;
    };
    const char* ce = api.clientExtensions;
    const bool devices = api.getPlatformDisplay && api.queryDevices && api.queryDeviceString &&
                         hasExtension(ce, "EGL_EXT_platform_device");
    std::vector<EGLDeviceEXT> hardware, software;
    if (devices) {
      EGLint count = 0;
      if (api.queryDevices(0, nullptr, &count) && count > 0) {
        std::vector<EGLDeviceEXT> all(static_cast<size_t>(count));
        if (api.queryDevices(count, all.data(), &count)) {
          all.resize(size_t(count));
          for (EGLDeviceEXT d : all) {
            const char* ext = api.queryDeviceString(d, EGL_EXTENSIONS);
            (hasExtension(ext, "EGL_MESA_device_software") ? software : hardware).push_back(d);
          }
        }
      }
      api.getError();
    }
    bool ok = false;
    for (size_t i = 0; i < hardware.size() && !ok; ++i)
      ok = attempt(EGL_PLATFORM_DEVICE_EXT, hardware[i], "EGL device " + std::to_string(i));
    if (!ok && api.getPlatformDisplay && hasExtension(ce, "EGL_MESA_platform_surfaceless"))
      ok = attempt(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, "EGL surfaceless");
    for (size_t i = 0; i < software.size() && !ok; ++i)
      ok = attempt(EGL_PLATFORM_DEVICE_EXT, software[i], "EGL software device " + std::to_string(i));
    if (!ok) {
      if (reasons.empty())
        reasons = "\n  no EGL device (EGL_EXT_platform_device) or surfaceless platform "
                  "(EGL_MESA_platform_surfaceless) is offered; client extensions: " +
                  std::string(ce ? ce : "(none)");
      throw Error(ErrorCategory::NotSupported, "EGL: cannot create an OpenGL core context:" + reasons);
    }
  }
  ~EGLContextImpl() override {
    if (context_ != EGL_NO_CONTEXT) EGLApi::get().destroyContext(display_, context_);
    if (display_ != EGL_NO_DISPLAY) DisplayRefs::releaseDisplay(display_);
  }
  void makeCurrent() override {
    const EGLApi& api = EGLApi::get();
    api.bindAPI(EGL_OPENGL_API);
    if (!api.makeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
      throw Error(ErrorCategory::RuntimeFailure, "EGL: eglMakeCurrent failed (" + eglErrorName(api.getError()) + ")");
  }
  void release() override {
    EGLApi::get().makeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }

private:
  bool tryDisplay(EGLenum platform, void* native, const std::string& label, std::string& why) {
    const EGLApi& api = EGLApi::get();
    EGLDisplay display = api.getPlatformDisplay(platform, native, nullptr);
    if (display == EGL_NO_DISPLAY) {
      why = "no display (" + eglErrorName(api.getError()) + ")";
      return false;
    }
    EGLint major = 0, minor = 0;
    if (!api.initialize(display, &major, &minor)) {
      why = "eglInitialize failed (" + eglErrorName(api.getError()) + ")";
      return false;
    }
    DisplayRefs::acquire(display);
    const char* ext = api.queryString(display, EGL_EXTENSIONS);
    auto fail = [&](const std::string& reason) {
      why = reason;
      DisplayRefs::releaseDisplay(display);
      return false;
    };
    if (!hasExtension(ext, "EGL_KHR_surfaceless_context"))
      return fail("EGL_KHR_surfaceless_context is missing");
    if (major == 1 && minor < 5 && !hasExtension(ext, "EGL_KHR_create_context"))
      return fail("EGL_KHR_create_context is missing");
    if (!api.bindAPI(EGL_OPENGL_API)) return fail("eglBindAPI(EGL_OPENGL_API) failed: no desktop OpenGL");
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!hasExtension(ext, "EGL_KHR_no_config_context")) {
      const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
      EGLint n = 0;
      if (!api.chooseConfig(display, want, &config, 1, &n) || n < 1)
        return fail("no EGLConfig with EGL_OPENGL_BIT");
    }
    EGLContext context = EGL_NO_CONTEXT;
    const int versions[][2] = {{4, 5}, {3, 3}};
    for (const auto& v : versions) {
      const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION, v[0], EGL_CONTEXT_MINOR_VERSION, v[1],
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                EGL_NONE};
      context = api.createContext(display, config, EGL_NO_CONTEXT, attribs);
      if (context != EGL_NO_CONTEXT) break;
    }
    if (context == EGL_NO_CONTEXT)
      return fail("cannot create a 4.5 or 3.3 core context (" + eglErrorName(api.getError()) + ")");
    if (!api.makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
      api.destroyContext(display, context);
      return fail("eglMakeCurrent without a surface failed (" + eglErrorName(api.getError()) + ")");
    }
    try {
      fillTable(functions_, [&](const char* name) { return reinterpret_cast<void*>(api.getProcAddress(name)); },
                "EGL");
      description_ = describe(functions_, label, major_, minor_);
    } catch (const Error& e) {
      api.makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      api.destroyContext(display, context);
      return fail(e.what());
    }
    api.makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    display_ = display;
    context_ = context;
    return true;
  }

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
};

}  // namespace

std::unique_ptr<Context> createOSMesaContext() { return std::make_unique<OSMesaContext>(); }
std::unique_ptr<Context> createEGLContext() { return std::make_unique<EGLContextImpl>(); }

}  // namespace cpvs::gl
