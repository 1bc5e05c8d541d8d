#include "libcpvs/eval/cpvs_method.h"

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/file_shadows.h"

namespace cpvs {

CpvsMethod CpvsMethod::fromBake(const BakedLight& baked, int topGridLevels) {
  std::vector<LightView> views;
  std::vector<DagView> dags;
  for (const BakedView& v : baked.views) {
    views.push_back(v.view);
    dags.push_back(v.dag.view());
  }
  return CpvsMethod(orThrow(LightShadow::create(baked.light, std::move(views), std::move(dags), topGridLevels)));
}

CpvsMethod CpvsMethod::fromFile(const CpvsFile::LightEntry& entry, int topGridLevels) {
  return CpvsMethod(orThrow(lightShadowOf(entry, topGridLevels)));
}

uint64_t CpvsMethod::bytes() const {
  uint64_t bytes = 0;
  for (const DagView& dag : shadow_.dags()) bytes += dag.bytes();
  return bytes;
}

void CpvsMethod::visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                            std::span<float> out) const {
  for (size_t b = 0; b < points.size(); b += kLookupBatch) {
    const size_t e = std::min(points.size(), b + kLookupBatch);
    orThrow(shadow_.visibility(points.subspan(b, e - b), options, out.subspan(b, e - b)));
  }
}

}  // namespace cpvs
