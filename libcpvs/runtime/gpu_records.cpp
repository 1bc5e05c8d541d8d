#include "libcpvs/runtime/gpu_records.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cpvs {

using namespace gpu_layout;

size_t GpuSceneRecords::lightCount() const { return lightWords.size() / kLightWords; }

size_t GpuSceneRecords::bytes() const {
  return lightReals.size() * 8 + lightWords.size() * 4 + viewReals.size() * 8 + viewWords.size() * 4 +
         nodes.size() * 4 + leaves.size() * 8;
}

Outcome appendLightRecords(GpuSceneRecords& r, const Light& light, const std::vector<LightView>& views,
                           const std::vector<DagView>* dags) {
  const size_t firstView = r.viewWords.size() / kViewWords;
  std::vector<double> reals(kLightReals, 0.0);
  for (int i = 0; i < 3; ++i) {
    reals[kLightPosition + i] = light.position[i];
    reals[kLightDirection + i] = light.direction[i];
    reals[kLightColor + i] = light.color[i];
  }
  const SpotInfluence spot = spotInfluence(light);  // the runtime's cone cosine, bit for bit
  reals[kLightRange] = influenceRange(light);
  reals[kLightCosOuter] = hasCone(light) ? spot.cosOuter : -1.0;
  reals[kLightSinOuter] = std::sin(std::min(light.outerConeAngle, 3.14159265358979323846 / 2));
  reals[kLightCosInner] = std::cos(std::min(light.innerConeAngle, light.outerConeAngle));
  reals[kLightIntensity] = light.intensity;
  r.lightReals.insert(r.lightReals.end(), reals.begin(), reals.end());
  std::vector<uint32_t> words(kLightWords, 0);
  words[kLightType] = uint32_t(light.type);
  words[kLightShape] = shapeBits(light);
  words[kLightFirstView] = uint32_t(firstView);
  words[kLightViewCount] = uint32_t(views.size());
  words[kLightShadowLight] = uint32_t(r.lightWords.size() / kLightWords);  // itself
  for (uint32_t f = 0; f < 6; ++f) words[kLightFaceView + f] = ~0u;
  for (size_t v = 0; v < views.size(); ++v) {
    const int face = views[v].face;
    if (face >= 0 && face < 6 && words[kLightFaceView + uint32_t(face)] == ~0u) words[kLightFaceView + uint32_t(face)] = uint32_t(v);
  }
  r.lightWords.insert(r.lightWords.end(), words.begin(), words.end());

  for (size_t v = 0; v < views.size(); ++v) {
    const ViewMapping m(views[v]);
    std::vector<double> map(kMapReals, 0.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) map[size_t(4 * i + j)] = m.row[i][j];
    const double constants[] = {m.xMin, m.yMin, m.uScale, m.vScale, m.uStep, m.vStep,
                                m.near, m.invNear, m.sScale, m.invDs, m.resolution};
    std::copy(std::begin(constants), std::end(constants), map.begin() + kMapXMin);
    r.viewReals.insert(r.viewReals.end(), map.begin(), map.end());
    std::vector<uint32_t> view(kViewWords, 0);
    view[kViewResolution] = views[v].resolution;
    view[kViewLayer] = ~0u;
    bool empty = m.empty;
    if (dags) {
      const DagView& dag = (*dags)[v];
      empty = empty || dag.resolution < 8;  // a DAG without a grid answers lit everywhere
      // A DAG of its own is appended; one that reads a shared pool points into the pool, appended once.
      const bool shared = !dag.sharedNodes.empty();
      const std::span<const uint16_t> nodes = shared ? dag.sharedNodes : dag.nodes;
      auto placed = [](std::vector<GpuSceneRecords::SharedArray>& known, const void* data) -> const uint64_t* {
        for (const GpuSceneRecords::SharedArray& a : known)
          if (a.data == data) return &a.base;
        return nullptr;
      };
      const uint64_t* nodesAt = shared ? placed(r.sharedNodes, nodes.data()) : nullptr;
      const uint64_t* leavesAt = shared ? placed(r.sharedLeaves, dag.leaves.data()) : nullptr;
      const uint64_t nodeBase = nodesAt ? *nodesAt : uint64_t(r.nodes.size()) * 2;
      const uint64_t leafBase = leavesAt ? *leavesAt : r.leaves.size();
      if (nodeBase + nodes.size() > UINT32_MAX || leafBase + dag.leaves.size() > UINT32_MAX)
        return {ErrorCategory::RuntimeFailure, "light '" + light.name + "': the DAGs exceed 2^32 units for the GPU"};
      view[kViewNodeBase] = uint32_t(nodeBase + uint64_t(dag.nodes.data() - nodes.data()));
      view[kViewLeafBase] = uint32_t(leafBase);
      view[kViewRootCode] = uint32_t(dag.rootCode);
      view[kViewResolution] = dag.resolution;
      for (uint32_t l = 0; l < kMaxDagLevels; ++l) view[kViewChildBase + l] = dag.childBase[l];
      if (!nodesAt) {
        for (size_t u = 0; u < nodes.size(); u += 2)
          r.nodes.push_back(uint32_t(nodes[u]) | (u + 1 < nodes.size() ? uint32_t(nodes[u + 1]) << 16 : 0u));
        if (shared) r.sharedNodes.push_back({nodes.data(), nodeBase});
      }
      if (!leavesAt) {
        r.leaves.insert(r.leaves.end(), dag.leaves.begin(), dag.leaves.end());
        if (shared) r.sharedLeaves.push_back({dag.leaves.data(), leafBase});
      }
    }
    view[kViewFlags] = (m.orthographic ? kFlagOrthographic : 0) | (m.linear ? kFlagLinear : 0) | (empty ? kFlagEmpty : 0);
    r.viewWords.insert(r.viewWords.end(), view.begin(), view.end());
  }
  return Outcome::success();
}

Result<GpuSceneRecords> packGpuScene(const std::vector<LightShadow>& lights) {
  GpuSceneRecords r;
  for (const LightShadow& shadow : lights)
    if (Outcome added = appendLightRecords(r, shadow.light(), shadow.views(), &shadow.dags()); !added) return added;
  return r;
}

}  // namespace cpvs
