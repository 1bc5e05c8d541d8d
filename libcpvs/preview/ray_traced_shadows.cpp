// --shadows raytraced: one Embree shadow ray per listed pair (reference/shadow_reference.h, packets per
// light), the ground truth the other techniques are compared with; timed on the wall clock, the BVH built
// once outside the timing.
#include <tbb/task_arena.h>

#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

std::vector<float> rayTracedVisibility(ShadowPassFrame& p) {
  std::vector<float> out(size_t(p.frame.lists.offsets.back()) * 64, 0.0f);
  const ShadowReference& reference = p.resources.rays();
  const auto& byLight = p.pairsByLight();
  const std::vector<LightShadow>& lights = p.resources.lights;
  tbb::task_arena arena(int(std::max(1u, p.resources.threadCount())));
  arena.execute([&] {
    parallelFor(byLight.size(), [&](size_t l) {
      std::vector<uint8_t> answers;
      reference.visibilityPackets(lights[l].light(), byLight[l].points, answers);
      for (size_t i = 0; i < answers.size(); ++i) out[byLight[l].pairs[i]] = float(answers[i]);
    }, 1);
  });
  return out;
}

namespace {

class RayTracedShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    p.pairsByLight();
    p.resources.rays();  // the BVH is built once, outside the timing
    Stopwatch clock;
    p.frame.visibility = rayTracedVisibility(p);
    p.frame.passes.push_back({"shadows", clock.ms(), false});
    return false;
  }
};

}  // namespace

std::unique_ptr<ShadowPass> makeRayTracedShadows(RendererResources&) { return std::make_unique<RayTracedShadows>(); }

}  // namespace cpvs
