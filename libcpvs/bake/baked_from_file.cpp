#include "libcpvs/bake/baked_from_file.h"

namespace cpvs {

BakedLight bakedLightOf(const CpvsFile::LightEntry& entry) {
  BakedLight baked;
  baked.light = entry.light;
  for (const CpvsFile::View& v : entry.views) {
    BakedView view{v.view, {}};
    view.dag.resolution = v.view.resolution;
    view.dag.rootCode = v.dag.rootCode;
    view.dag.nodes.assign(v.dag.nodes.begin(), v.dag.nodes.end());
    view.dag.leaves.assign(v.dag.leaves.begin(), v.dag.leaves.end());
    view.dag.nodesPerLevel = v.nodesPerLevel;
    baked.views.push_back(std::move(view));
  }
  return baked;
}

}  // namespace cpvs
