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

Result<std::vector<LightShadow>> lightShadowsOf(const CpvsFile& file, int topGridLevels) {
  std::vector<LightShadow> shadows;
  shadows.reserve(file.lights().size());
  for (const CpvsFile::LightEntry& entry : file.lights()) {
    Result<LightShadow> shadow = lightShadowOf(entry, topGridLevels);
    if (!shadow) return shadow.outcome();
    shadows.push_back(std::move(shadow).value());
  }
  return shadows;
}

}  // namespace cpvs
