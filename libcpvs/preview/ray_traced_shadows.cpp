// --shadows raytraced: one Embree shadow ray per listed pair (reference/shadow_reference.h, packets per
// light), or s x s rays over the pair's PCF footprint (reference/footprint_rays.h: the filtered quantity PCF
// estimates), the ground truth the other techniques are compared with; timed on the wall clock, the BVH built
// once and the output buffer zeroed outside the timing (as for the CPU runtime's lookups).
#include <algorithm>

#include <tbb/task_arena.h>

#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/preview/shadow_pass.h"
#include "libcpvs/reference/footprint_rays.h"

namespace cpvs {

void rayTracedVisibility(ShadowPassFrame& p, int raysPerSide, float* out) {
  const ShadowReference& reference = p.resources.rays();
  const auto& byLight = p.pairsByLight();
  const std::vector<LightShadow>& lights = p.resources.lights;
  tbb::task_arena arena(int(std::max(1u, p.resources.threadCount())));
  LookupOptions footprint;
  footprint.pcfKernel = p.settings.pcfKernel;
  footprint.biasMargin = p.settings.biasMargin;
  arena.execute([&] {
    if (raysPerSide <= 1) {
      parallelFor(byLight.size(), [&](size_t l) {
        std::vector<uint8_t> answers;
        reference.visibilityPackets(lights[l].light(), byLight[l].points, answers);
        for (size_t i = 0; i < answers.size(); ++i) out[byLight[l].pairs[i]] = float(answers[i]);
      }, 1);
      return;
    }
    // Footprints: batches of a light's points, so that a light with many pairs spreads over the threads.
    constexpr size_t kBatch = 1024;
    std::vector<std::pair<uint32_t, size_t>> batches;  // (light, first point)
    for (uint32_t l = 0; l < byLight.size(); ++l)
      for (size_t first = 0; first < byLight[l].points.size(); first += kBatch) batches.emplace_back(l, first);
    parallelFor(batches.size(), [&](size_t b) {
      const auto [l, first] = batches[b];
      const size_t count = std::min(kBatch, byLight[l].points.size() - first);
      float answers[kBatch];
      footprintVisibility(reference, lights[l], std::span(byLight[l].points).subspan(first, count), footprint,
                          raysPerSide, std::span(answers, count));
      for (size_t i = 0; i < count; ++i) out[byLight[l].pairs[first + i]] = answers[i];
    }, 1);
  });
}

namespace {

class RayTracedShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    p.pairsByLight();
    p.resources.rays();  // the BVH is built once, outside the timing
    const size_t slots = size_t(p.frame.lists.offsets.back()) * 64;
    if (answers_.size() < slots) answers_.resize(slots);
    std::fill_n(answers_.begin(), slots, 0.0f);
    Stopwatch clock;
    rayTracedVisibility(p, p.settings.raysPerSide, answers_.data());
    p.frame.passes.push_back({"shadows", clock.ms(), false});
    p.frame.visibility.assign(answers_.begin(), answers_.begin() + ptrdiff_t(slots));
    return false;
  }

private:
  std::vector<float> answers_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeRayTracedShadows(RendererResources&) { return std::make_unique<RayTracedShadows>(); }

}  // namespace cpvs
