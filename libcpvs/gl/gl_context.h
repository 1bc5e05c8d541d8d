#pragma once
// An OpenGL core context for off-screen rendering, created without linking libGL: libOSMesa.so.8 or
// libEGL.so.1 is opened with dlopen() at run time and every GL entry point is fetched through the backend's
// GetProcAddress into a Functions table (docs/depth-maps.md). The depth renderer (raster/) and cpvs-view
// (preview/) both draw through it.
#include <memory>
#include <string>

#include <GL/glcorearb.h>

namespace cpvs::gl {

// The GL entry points the depth renderer uses (GL 3.3 core is enough; a 4.5 context is asked for first).
#define CPVS_GL_FUNCTIONS(X)                                                          \
  X(PFNGLGETSTRINGPROC, GetString)                                                    \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                                                \
  X(PFNGLGETERRORPROC, GetError)                                                      \
  X(PFNGLVIEWPORTPROC, Viewport)                                                      \
  X(PFNGLENABLEPROC, Enable)                                                          \
  X(PFNGLDISABLEPROC, Disable)                                                        \
  X(PFNGLDEPTHFUNCPROC, DepthFunc)                                                    \
  X(PFNGLDEPTHMASKPROC, DepthMask)                                                    \
  X(PFNGLCOLORMASKPROC, ColorMask)                                                    \
  X(PFNGLCULLFACEPROC, CullFace)                                                      \
  X(PFNGLFRONTFACEPROC, FrontFace)                                                    \
  X(PFNGLBLENDFUNCPROC, BlendFunc)                                                    \
  X(PFNGLBLENDEQUATIONPROC, BlendEquation)                                            \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                                            \
  X(PFNGLCLEARBUFFERUIVPROC, ClearBufferuiv)                                          \
  X(PFNGLFINISHPROC, Finish)                                                          \
  X(PFNGLREADPIXELSPROC, ReadPixels)                                                  \
  X(PFNGLREADBUFFERPROC, ReadBuffer)                                                  \
  X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                                                \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                \
  X(PFNGLGENTEXTURESPROC, GenTextures)                                                \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                          \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                                                \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                                  \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                            \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                            \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                        \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                  \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                        \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)                              \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                          \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                                                  \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                            \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                                                  \
  X(PFNGLBUFFERDATAPROC, BufferData)                                                  \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                        \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                  \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                        \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                                \
  X(PFNGLVERTEXATTRIBIPOINTERPROC, VertexAttribIPointer)                              \
  X(PFNGLSCISSORPROC, Scissor)                                                        \
  X(PFNGLUNIFORM2IPROC, Uniform2i)                                                    \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                        \
  X(PFNGLDISABLEVERTEXATTRIBARRAYPROC, DisableVertexAttribArray)                      \
  X(PFNGLVERTEXATTRIBI4IPROC, VertexAttribI4i)                                        \
  X(PFNGLTEXBUFFERPROC, TexBuffer)                                                    \
  X(PFNGLDRAWELEMENTSPROC, DrawElements)                                              \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                                                  \
  X(PFNGLCREATESHADERPROC, CreateShader)                                              \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                                              \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                                            \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                      \
  X(PFNGLDELETESHADERPROC, DeleteShader)                                              \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                            \
  X(PFNGLATTACHSHADERPROC, AttachShader)                                              \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                              \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                    \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                            \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                                                  \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                  \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                                                    \
  X(PFNGLUNIFORM1FPROC, Uniform1f)                                                    \
  X(PFNGLUNIFORM4FPROC, Uniform4f)                                                    \
  X(PFNGLGENQUERIESPROC, GenQueries)                                                  \
  X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                            \
  X(PFNGLBEGINQUERYPROC, BeginQuery)                                                  \
  X(PFNGLENDQUERYPROC, EndQuery)                                                      \
  X(PFNGLGETQUERYOBJECTUIVPROC, GetQueryObjectuiv)                                    \
  X(PFNGLBINDBUFFERBASEPROC, BindBufferBase)                                          \
  X(PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData)

// Entry points beyond GL 3.3 (compute shaders: cpvs-view's passes, tests/glsl_walk_test.cpp) and a few the
// depth renderer does not use: left null where the context lacks them, so that a 3.3 context still opens
// for the depth renderer.
#define CPVS_GL_OPTIONAL_FUNCTIONS(X)                                                 \
  X(PFNGLDISPATCHCOMPUTEPROC, DispatchCompute)                                        \
  X(PFNGLMEMORYBARRIERPROC, MemoryBarrier)                                            \
  X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)                                \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                                      \
  X(PFNGLUNIFORM3FPROC, Uniform3f)                                                    \
  X(PFNGLUNIFORM1DPROC, Uniform1d)                                                    \
  X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                                            \
  X(PFNGLTEXIMAGE3DPROC, TexImage3D)                                                  \
  X(PFNGLFRAMEBUFFERTEXTURELAYERPROC, FramebufferTextureLayer)                        \
  X(PFNGLGENERATEMIPMAPPROC, GenerateMipmap)                                          \
  X(PFNGLDISPATCHCOMPUTEINDIRECTPROC, DispatchComputeIndirect)                        \
  X(PFNGLDRAWARRAYSINDIRECTPROC, DrawArraysIndirect)                                  \
  X(PFNGLFRAMEBUFFERTEXTUREPROC, FramebufferTexture)                                  \
  X(PFNGLUNIFORM1UIPROC, Uniform1ui)

// Where a context comes from: Mesa's software OSMesa, or EGL (a GPU, or Mesa's surfaceless platform).
enum class Platform { OSMesa, EGL };

struct Functions {
#define CPVS_GL_MEMBER(type, name) type name = nullptr;
  CPVS_GL_FUNCTIONS(CPVS_GL_MEMBER)
  CPVS_GL_OPTIONAL_FUNCTIONS(CPVS_GL_MEMBER)
#undef CPVS_GL_MEMBER
};

// A context that is current only between makeCurrent() and release() (the depth renderer brackets every
// call with them, so OSMesa and EGL contexts can live in one process: both Mesa libraries share libglapi's
// current-context slot).
class Context {
public:
  virtual ~Context() = default;
  virtual void makeCurrent() = 0;
  virtual void release() = 0;
  const Functions& gl() const { return functions_; }
  Platform platform() const { return platform_; }
  // "OSMesa 4.5 core: llvmpipe (LLVM 15.0.6, 256 bits)" and the like.
  const std::string& description() const { return description_; }
  int majorVersion() const { return major_; }
  int minorVersion() const { return minor_; }

protected:
  Functions functions_;
  Platform platform_ = Platform::OSMesa;
  std::string description_;
  int major_ = 0, minor_ = 0;
};

// Throw Error(NotSupported) when the library or a suitable context is not available.
std::unique_ptr<Context> createOSMesaContext();
std::unique_ptr<Context> createEGLContext();

// makeCurrent() for the lifetime of the guard, release() after.
class CurrentContext {
public:
  explicit CurrentContext(Context& context) : context_(context) { context_.makeCurrent(); }
  ~CurrentContext() { context_.release(); }
  CurrentContext(const CurrentContext&) = delete;
  CurrentContext& operator=(const CurrentContext&) = delete;

private:
  Context& context_;
};

}  // namespace cpvs::gl
