#include "libcpvs/runtime/file_shadows.h"

namespace cpvs {

Result<LightShadow> lightShadowOf(const CpvsFile::LightEntry& entry, int topGridLevels) {
  std::vector<LightView> views;
  std::vector<DagView> dags;
  for (const CpvsFile::View& v : entry.views) {
    views.push_back(v.view);
    dags.push_back(v.dag);
  }
  return LightShadow::create(entry.light, std::move(views), std::move(dags), topGridLevels);
}

}  // namespace cpvs
