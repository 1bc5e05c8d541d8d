#include "libcpvs/preview/shadow_pass.h"

#include <algorithm>

#include <tbb/task_arena.h>

#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"

namespace cpvs {

GpuWorkCounters::GpuWorkCounters(const gl::Context& context, uint32_t count) : context_(context), count_(count) {
  const std::vector<uint32_t> zeros(2 * size_t(count), 0);
  buffer_ = gl::createStorageBuffer(context, zeros.data(), zeros.size() * 4);
}

GpuWorkCounters::~GpuWorkCounters() { context_.gl().DeleteBuffers(1, &buffer_); }

void GpuWorkCounters::bind() const { context_.gl().BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kWorkCounters, buffer_); }

std::vector<uint64_t> GpuWorkCounters::read() const {
  std::vector<uint32_t> words(2 * size_t(count_));
  gl::readStorageBuffer(context_, buffer_, words.data(), words.size() * 4);
  std::vector<uint64_t> out(count_);
  for (size_t i = 0; i < count_; ++i) out[i] = uint64_t(words[2 * i]) | uint64_t(words[2 * i + 1]) << 32;
  return out;
}

std::string GpuWorkCounters::glsl(uint32_t count) {
  return "#define CPVS_WORK_COUNTERS " + std::to_string(count) + "\n" + glsl::work_counters_glsl;
}

void GpuWorkCounters::toFrame(const std::vector<uint64_t>& values, Frame& frame) {
  frame.lookupBytes = values.at(0);
  frame.lookupBytesPerLight.assign(values.begin() + 1, values.end());
  frame.lookupBytesCounted = true;
}

std::vector<PairsOfLight> pairsByLight(const Frame& f, size_t lightCount) {
  std::vector<PairsOfLight> byLight(lightCount);
  f.forEachPair([&](uint32_t, uint32_t, size_t i, uint32_t light, size_t pair) {
    byLight[light].pairs.push_back(pair);
    byLight[light].points.push_back({glm::dvec3(glm::vec3(f.positions[i])), glm::dvec3(glm::vec3(f.normals[i]))});
  });
  return byLight;
}

void forEachPointBatch(const std::vector<PairsOfLight>& byLight, size_t batch, unsigned threads, float* out,
                       const std::function<void(uint32_t light, size_t first, size_t count, float* answers)>& fn) {
  std::vector<std::pair<uint32_t, size_t>> batches;  // (light, first point)
  for (uint32_t l = 0; l < byLight.size(); ++l)
    for (size_t first = 0; first < byLight[l].points.size(); first += batch) batches.emplace_back(l, first);
  tbb::task_arena arena(int(std::max(1u, threads)));
  arena.execute([&] {
    parallelFor(batches.size(), [&](size_t b) {
      const auto [l, first] = batches[b];
      const size_t count = std::min(batch, byLight[l].points.size() - first);
      thread_local std::vector<float> answers;
      answers.resize(batch);
      fn(l, first, count, answers.data());
      for (size_t i = 0; i < count; ++i) out[byLight[l].pairs[first + i]] = answers[i];
    }, 1);
  });
}

void CpuAnswers::timed(Frame& f, const std::function<void(float* answers)>& work) {
  const size_t slots = size_t(f.lists.offsets.back()) * 64;
  if (answers_.size() < slots) answers_.resize(slots);
  std::fill_n(answers_.begin(), slots, 0.0f);
  Stopwatch clock;
  work(answers_.data());
  f.passes.push_back({"shadows", clock.ms(), false});
  f.visibility.assign(answers_.begin(), answers_.begin() + ptrdiff_t(slots));
}

const std::vector<PairsOfLight>& ShadowPassFrame::pairsByLight() {
  if (!pairs_) pairs_ = cpvs::pairsByLight(frame, resources.lights.size());
  return *pairs_;
}

void ShadowPassFrame::bindSceneBuffers(GLuint program) const {
  const gl::Functions& g = resources.gl();
  g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(frame.width), GLint(frame.height));
  g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(frame.lists.tilesX), GLint(frame.lists.tilesY));
  g.Uniform1i(g.GetUniformLocation(program, "tiles"), GLint(frame.lists.tiles()));
  for (GLuint unit = 0; unit < 3; ++unit) {
    g.ActiveTexture(GL_TEXTURE0 + unit);
    g.BindTexture(GL_TEXTURE_2D, resources.targets[unit]);
  }
  const RendererResources& r = resources;
  for (auto [index, buffer] : {std::pair{binding::kLightReals, r.lightReals}, {binding::kLightWords, r.lightWords},
                                 {binding::kTileOffsets, offsets}, {binding::kTileLights, lists}, {binding::kViewReals, r.viewReals},
                                 {binding::kViewWords, r.viewWords}, {binding::kDagNodes, r.dagNodes}, {binding::kDagLeaves, r.dagLeaves},
                                 {binding::kVisibility, visibility}})
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
}

}  // namespace cpvs
