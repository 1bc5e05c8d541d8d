// --shadows cpu: the CPU runtime's batch lookups (LightShadow::visibility, K x K PCF) on the read-back
// G-buffer, light by light in batches of kLookupBatch points as cpvs-query hands them over; timed on the wall
// clock. The answers go to a buffer kept from frame to frame, zeroed before the timing: a fresh one costs a
// page fault per 4 KiB page (tens of ms per 1080p frame on a VM), which is not the lookups' work, just as the
// GPU technique's buffer is created untimed.
#include "libcpvs/base/error.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

namespace {

class CpuRuntimeShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    const auto& byLight = p.pairsByLight();
    const std::vector<LightShadow>& lights = p.resources.lights;
    LookupOptions options;
    options.pcfKernel = p.settings.pcfKernel;
    options.biasMargin = p.settings.biasMargin;
    answers_.timed(p.frame, [&](float* visibility) {
      forEachPointBatch(byLight, kLookupBatch, p.resources.threadCount(), visibility,
                        [&](uint32_t l, size_t first, size_t count, float* answers) {
                          const Outcome o = lights[l].visibility(std::span(byLight[l].points).subspan(first, count),
                                                                 options, std::span(answers, count));
                          if (!o) throw Error(o.category(), o.message());
                        });
    });
    return false;
  }

private:
  CpuAnswers answers_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeCpuRuntimeShadows(RendererResources&) { return std::make_unique<CpuRuntimeShadows>(); }

}  // namespace cpvs
