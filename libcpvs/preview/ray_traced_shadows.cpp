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
  LookupOptions footprint;
  footprint.pcfKernel = p.settings.pcfKernel;
  footprint.biasMargin = p.settings.biasMargin;
  if (raysPerSide > 1) {  // footprints: batches of a light's points, so that one light spreads over the threads
    forEachPointBatch(byLight, 1024, p.resources.threadCount(), out,
                      [&](uint32_t l, size_t first, size_t count, float* answers) {
                        footprintVisibility(reference, lights[l], std::span(byLight[l].points).subspan(first, count),
                                            footprint, raysPerSide, std::span(answers, count));
                      });
    return;
  }
  tbb::task_arena arena(int(std::max(1u, p.resources.threadCount())));
  arena.execute([&] {
    parallelFor(byLight.size(), [&](size_t l) {
      std::vector<uint8_t> answers;
      reference.visibilityPackets(lights[l].light(), byLight[l].points, answers);
      for (size_t i = 0; i < answers.size(); ++i) out[byLight[l].pairs[i]] = float(answers[i]);
    }, 1);
  });
}

namespace {

class RayTracedShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    p.pairsByLight();
    p.resources.rays();  // the BVH is built once, outside the timing
    answers_.timed(p.frame, [&](float* visibility) { rayTracedVisibility(p, p.settings.raysPerSide, visibility); });
    return false;
  }

private:
  CpuAnswers answers_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeRayTracedShadows(RendererResources&) { return std::make_unique<RayTracedShadows>(); }

}  // namespace cpvs
