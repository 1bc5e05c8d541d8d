#pragma once
// LightCluster (Wiesenhuetter et al. 2013): spot and point lights merged by minimum distance into N clusters,
// each shadowed by one cube map from its centre instead of one map per light (cpvs-view --shadows
// lightcluster). Directional lights stay alone.
#include <cstdint>
#include <vector>

#include "libcpvs/runtime/light.h"

namespace cpvs {

struct LightClusters {
  static constexpr uint32_t kAlone = ~0u;
  std::vector<uint32_t> clusterOf;  // per light: its cluster, or kAlone (a directional light)
  // Per cluster, a point light at the centroid of its members whose range covers every member's range.
  std::vector<Light> lights;
};

// Agglomerative: every spot or point light a cluster, then the two clusters with the nearest centroids
// merged (ties: the lower indices) until at most `clusters` remain. Deterministic. `clusters` >= 1.
LightClusters clusterLights(const std::vector<Light>& lights, uint32_t clusters);

}  // namespace cpvs
