#pragma once
// A frame's shadow technique: given the G-buffer and the tile light lists, the visibility of every listed
// (pixel, light) pair. The renderer runs G-buffer -> tile bounds -> light lists -> the technique -> shading and
// knows no technique by name; each technique is one file (with its shaders), made by makeShadowPass. A new
// one: its file, and one line in shadow_techniques.cpp (docs/architecture.md).
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/preview/frame.h"
#include "libcpvs/preview/renderer_resources.h"

namespace cpvs {

// Every (pixel, listed light) pair of a frame grouped by light: the pair indices and the surface points.
struct PairsOfLight {
  std::vector<size_t> pairs;
  std::vector<SurfacePoint> points;
};
std::vector<PairsOfLight> pairsByLight(const Frame& f, size_t lightCount);

// The CPU-side techniques' loop: a light's points in batches of at most `batch`, all lights' batches spread over
// `threads` threads; fn(light, first, count) answers points [first, first + count) of that light into
// `answers` (room for `batch`), which are then scattered to out[pair index].
void forEachPointBatch(const std::vector<PairsOfLight>& byLight, size_t batch, unsigned threads, float* out,
                       const std::function<void(uint32_t light, size_t first, size_t count, float* answers)>& fn);

// CPU-side answers kept between frames: zeroed for a frame's pairs before the timed work (a fresh buffer would
// put a page fault per 4 KiB into the time: tens of ms per 1080p frame on a VM, not the technique's work, just
// as the GPU technique's buffer is made untimed), then copied into Frame::visibility.
class CpuAnswers {
public:
  // Runs work(answers) timed as the frame's "shadows" pass (wall clock).
  void timed(Frame& frame, const std::function<void(float* answers)>& work);

private:
  std::vector<float> answers_;
};

// The 64-bit work counters of work_counters.glsl (one storage buffer at binding::kWorkCounters, zeroed when
// made): `count` of them, read back after the pass.
class GpuWorkCounters {
public:
  GpuWorkCounters(const gl::Context& context, uint32_t count);
  ~GpuWorkCounters();
  GpuWorkCounters(const GpuWorkCounters&) = delete;
  GpuWorkCounters& operator=(const GpuWorkCounters&) = delete;
  void bind() const;
  std::vector<uint64_t> read() const;
  // "#define CPVS_WORK_COUNTERS n\n" and work_counters.glsl, for a program's source.
  static std::string glsl(uint32_t count);
  // The lookups' counters: the frame's bytes read, then one per light where the workgroup's shared memory
  // holds them (up to 8191 lights), else the frame's alone.
  static uint32_t forLookups(size_t lights) { return lights + 1 <= 8192 ? uint32_t(lights + 1) : 1u; }
  // Frame::lookupBytes (and per light, where counted) from read()'s values.
  static void toFrame(const std::vector<uint64_t>& values, Frame& frame);

private:
  const gl::Context& context_;
  uint32_t count_;
  GLuint buffer_ = 0;
};

// What the renderer hands a technique for one frame.
class ShadowPassFrame {
public:
  using Timed = std::function<void(const std::string& pass, const std::function<void()>& work)>;
  ShadowPassFrame(Frame& frame, const FrameSettings& settings, RendererResources& resources, Timed timed)
      : frame(frame), settings(settings), resources(resources), timed_(std::move(timed)) {}

  Frame& frame;  // G-buffer, lists and sizes filled in; the technique fills visibility (or its GPU buffer)
  const FrameSettings& settings;
  RendererResources& resources;
  // GPU buffers: the tile lists (offsets, lights) and the per-pair visibility the shading pass reads (64
  // slots per list entry, Frame::pairIndex), and the recorded cells when settings.recordCells.
  GLuint offsets = 0, lists = 0, visibility = 0, cells = 0;

  // Runs `work` as a pass named `pass`, timed on the GPU where the context's timers measure work (else the
  // wall clock around glFinish), and records it in the frame.
  void timed(const std::string& pass, const std::function<void()>& work) { timed_(pass, work); }
  // The pairs grouped by light (computed once per frame, on first use).
  const std::vector<PairsOfLight>& pairsByLight();
  // Binds the G-buffer textures, the lights, views, DAGs, lists and visibility buffers and the frame's sizes
  // for a program that includes scene_buffers.glsl.
  void bindSceneBuffers(GLuint program) const;

private:
  Timed timed_;
  std::optional<std::vector<PairsOfLight>> pairs_;
};

class ShadowPass {
public:
  virtual ~ShadowPass() = default;
  // Writes every listed pair's visibility in [0, 1]. Returns true when it is in the GPU buffer
  // frame.visibility (and copied to Frame::visibility), false when it is in Frame::visibility only (the
  // renderer uploads it for the shading pass).
  virtual bool run(ShadowPassFrame& frame) = 0;
};

// The technique of a shadow mode, its programs linked on `resources`' context (which must be current).
std::unique_ptr<ShadowPass> makeShadowPass(ShadowMode mode, RendererResources& resources);

// Embree's answer for every listed pair into out[pair index] (Frame::pairIndex; slots of no pair are left as
// they are), as the ray-traced technique and --compare use it: one hard ray (0 or 1) for raysPerSide 1, else
// the fraction of raysPerSide^2 rays over the pair's PCF footprint that reach the light.
void rayTracedVisibility(ShadowPassFrame& frame, int raysPerSide, float* out);

}  // namespace cpvs
