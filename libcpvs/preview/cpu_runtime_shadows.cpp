// --shadows cpu: the CPU runtime's batch lookups (LightShadow::visibility, K x K PCF) on the read-back
// G-buffer, light by light in batches of kLookupBatch points as cpvs-query hands them over; timed on the wall
// clock. The answers go to a buffer kept from frame to frame, zeroed before the timing: a fresh one costs a
// page fault per 4 KiB page (tens of ms per 1080p frame on a VM), which is not the lookups' work, just as the
// GPU technique's buffer is created untimed.
#include <algorithm>

#include <tbb/task_arena.h>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

namespace {

class CpuRuntimeShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    const auto& byLight = p.pairsByLight();
    const std::vector<LightShadow>& lights = p.resources.lights;
    Frame& f = p.frame;
    tbb::task_arena arena(int(std::max(1u, p.resources.threadCount())));
    const size_t slots = size_t(f.lists.offsets.back()) * 64;
    if (answers_.size() < slots) answers_.resize(slots);
    std::fill_n(answers_.begin(), slots, 0.0f);
    float* visibility = answers_.data();
    Stopwatch clock;
    LookupOptions options;
    options.pcfKernel = p.settings.pcfKernel;
    options.biasMargin = p.settings.biasMargin;
    arena.execute([&] {
      std::vector<std::pair<uint32_t, size_t>> batches;  // (light, first point)
      for (uint32_t l = 0; l < byLight.size(); ++l)
        for (size_t first = 0; first < byLight[l].points.size(); first += kLookupBatch) batches.emplace_back(l, first);
      parallelFor(batches.size(), [&](size_t b) {
        const auto [l, first] = batches[b];
        const size_t count = std::min(kLookupBatch, byLight[l].points.size() - first);
        float answers[kLookupBatch];
        const Outcome o = lights[l].visibility(std::span(byLight[l].points).subspan(first, count), options,
                                               std::span(answers, count));
        if (!o) throw Error(o.category(), o.message());
        for (size_t i = 0; i < count; ++i) visibility[byLight[l].pairs[first + i]] = answers[i];
      }, 1);
    });
    f.passes.push_back({"shadows", clock.ms(), false});
    f.visibility.assign(answers_.begin(), answers_.begin() + ptrdiff_t(slots));
    return false;
  }

private:
  std::vector<float> answers_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeCpuRuntimeShadows(RendererResources&) { return std::make_unique<CpuRuntimeShadows>(); }

}  // namespace cpvs
