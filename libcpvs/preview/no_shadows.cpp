// --shadows none: every listed pair fully lit (the shading alone, for comparisons and the overlays).
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

namespace {

class NoShadows final : public ShadowPass {
public:
  bool run(ShadowPassFrame& p) override {
    p.frame.visibility.assign(size_t(p.frame.lists.offsets.back()) * 64, 1.0f);
    return false;
  }
};

}  // namespace

std::unique_ptr<ShadowPass> makeNoShadows(RendererResources&) { return std::make_unique<NoShadows>(); }

}  // namespace cpvs
