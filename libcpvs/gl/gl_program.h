#pragma once
// Shader programs, GL error checks, storage buffers and GPU timers on a gl::Context: what the depth renderer
// and cpvs-view's passes share. Every function expects the context to be current.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "libcpvs/gl/gl_context.h"

namespace cpvs::gl {

// Throws Error(RuntimeFailure) naming `what` and the context when GL has recorded an error.
void checkError(const Context& context, const std::string& what);

// A program from shader sources ((GL_VERTEX_SHADER, text), ...; a compute program has one). Throws
// Error(RuntimeFailure) with the compiler's log and `name` when a shader does not compile or link.
GLuint linkProgram(const Context& context, const std::vector<std::pair<GLenum, std::string>>& shaders,
                   const std::string& name);

// Whether the context runs cpvs-view's GLSL 4.50 compute shaders with 64-bit floats (GL 4.5, entry points loaded).
bool hasComputeShaders(const Context& context);

// Whether GL_TIME_ELAPSED queries cover a pass's work on this context: not on llvmpipe, which rasterises in
// worker threads after the draw call returns (its queries measured 0.0 ms for a 1080p G-buffer, and a first
// query read back as hours), nor without the entry point.
bool gpuTimersMeasureWork(const Context& context);

// A shader storage buffer of `bytes` (at least 16; contents from `data` when given, zeros otherwise).
GLuint createStorageBuffer(const Context& context, const void* data, size_t bytes);
// Reads `bytes` from the start of a buffer.
void readStorageBuffer(const Context& context, GLuint buffer, void* out, size_t bytes);

// GL_TIME_ELAPSED around a pass: begin(), end(), then milliseconds() (waits for the result). Without timer
// queries (GetQueryObjectui64v missing), or when they do not measure the work (gpuTimersMeasureWork), the time
// is the CPU's wall time between two glFinish calls.
class PassTimer {
public:
  explicit PassTimer(const Context& context);
  bool usesGpuTimer() const { return query_ != 0; }
  ~PassTimer();
  PassTimer(const PassTimer&) = delete;
  PassTimer& operator=(const PassTimer&) = delete;
  void begin();
  void end();
  double milliseconds();

private:
  const Context& context_;
  GLuint query_ = 0;
  double cpuStart_ = 0, cpuMilliseconds_ = 0;
};

}  // namespace cpvs::gl
