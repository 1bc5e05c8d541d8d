#include "libcpvs/gl/gl_program.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "libcpvs/base/error.h"

namespace cpvs::gl {

void checkError(const Context& context, const std::string& what) {
  const GLenum e = context.gl().GetError();
  if (e == GL_NO_ERROR) return;
  char code[16];
  std::snprintf(code, sizeof code, "0x%04X", unsigned(e));
  throw Error(ErrorCategory::RuntimeFailure, std::string("OpenGL error ") + code +
                                                 (e == GL_OUT_OF_MEMORY ? " (out of memory)" : "") + " while " + what +
                                                 " on " + context.description());
}

namespace {

const char* stageName(GLenum type) {
  switch (type) {
    case GL_VERTEX_SHADER: return "vertex";
    case GL_FRAGMENT_SHADER: return "fragment";
    case GL_COMPUTE_SHADER: return "compute";
    default: return "other";
  }
}

// The info log of a shader or program (getLog: GetShaderInfoLog or GetProgramInfoLog), up to 16 KiB.
template <class GetLog>
std::string infoLog(GetLog getLog, GLuint object) {
  std::string log(16384, '\0');
  getLog(object, GLsizei(log.size()), nullptr, log.data());
  return std::string(log.c_str());
}

GLuint compile(const Context& context, GLenum type, const std::string& source, const std::string& name) {
  const Functions& g = context.gl();
  const GLuint shader = g.CreateShader(type);
  const char* text = source.c_str();
  g.ShaderSource(shader, 1, &text, nullptr);
  g.CompileShader(shader);
  GLint ok = 0;
  g.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    const std::string log = infoLog(g.GetShaderInfoLog, shader);
    g.DeleteShader(shader);
    throw Error(ErrorCategory::RuntimeFailure, "cannot compile the " + name + " " + stageName(type) + " shader: " + log);
  }
  return shader;
}

}  // namespace

GLuint linkProgram(const Context& context, const std::vector<std::pair<GLenum, std::string>>& shaders,
                   const std::string& name) {
  const Functions& g = context.gl();
  std::vector<GLuint> compiled;
  try {
    for (const auto& [type, source] : shaders) compiled.push_back(compile(context, type, source, name));
  } catch (...) {
    for (GLuint s : compiled) g.DeleteShader(s);
    throw;
  }
  const GLuint program = g.CreateProgram();
  for (GLuint s : compiled) g.AttachShader(program, s);
  g.LinkProgram(program);
  for (GLuint s : compiled) g.DeleteShader(s);
  GLint ok = 0;
  g.GetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    const std::string log = infoLog(g.GetProgramInfoLog, program);
    g.DeleteProgram(program);
    throw Error(ErrorCategory::RuntimeFailure, "cannot link the " + name + " program: " + log);
  }
  return program;
}

bool hasComputeShaders(const Context& context) {
  const Functions& g = context.gl();
  return context.majorVersion() * 10 + context.minorVersion() >= 45 && g.DispatchCompute && g.MemoryBarrier &&
         g.BufferSubData && g.UniformMatrix4fv && g.Uniform3f && g.Uniform1d &&
         g.TexImage3D && g.FramebufferTextureLayer && g.GenerateMipmap;
}

GLuint createStorageBuffer(const Context& context, const void* data, size_t bytes) {
  const Functions& g = context.gl();
  GLuint buffer = 0;
  g.GenBuffers(1, &buffer);
  g.BindBuffer(GL_SHADER_STORAGE_BUFFER, buffer);
  const size_t size = std::max<size_t>((bytes + 15) / 16 * 16, 16);
  g.BufferData(GL_SHADER_STORAGE_BUFFER, GLsizeiptr(size), nullptr, GL_DYNAMIC_DRAW);
  if (data && bytes) g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(bytes), data);
  if (!data) {
    const std::vector<unsigned char> zeros(size, 0);
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(size), zeros.data());
  }
  checkError(context, "creating a storage buffer of " + std::to_string(size) + " bytes");
  return buffer;
}

void readStorageBuffer(const Context& context, GLuint buffer, void* out, size_t bytes) {
  const Functions& g = context.gl();
  g.BindBuffer(GL_SHADER_STORAGE_BUFFER, buffer);
  g.GetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(bytes), out);
  checkError(context, "reading back a storage buffer");
}

namespace {
double nowMilliseconds() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

bool gpuTimersMeasureWork(const Context& context) {
  return context.gl().GetQueryObjectui64v && context.description().find("llvmpipe") == std::string::npos &&
         context.description().find("softpipe") == std::string::npos;
}

PassTimer::PassTimer(const Context& context) : context_(context) {
  if (gpuTimersMeasureWork(context_)) context_.gl().GenQueries(1, &query_);
}

PassTimer::~PassTimer() {
  if (query_) context_.gl().DeleteQueries(1, &query_);
}

void PassTimer::begin() {
  if (query_) {
    context_.gl().BeginQuery(GL_TIME_ELAPSED, query_);
  } else {
    context_.gl().Finish();
    cpuStart_ = nowMilliseconds();
  }
}

void PassTimer::end() {
  if (query_) {
    context_.gl().EndQuery(GL_TIME_ELAPSED);
  } else {
    context_.gl().Finish();
    cpuMilliseconds_ = nowMilliseconds() - cpuStart_;
  }
}

double PassTimer::milliseconds() {
  if (!query_) return cpuMilliseconds_;
  GLuint64 nanoseconds = 0;
  context_.gl().GetQueryObjectui64v(query_, GL_QUERY_RESULT, &nanoseconds);
  return double(nanoseconds) * 1e-6;
}

}  // namespace cpvs::gl
