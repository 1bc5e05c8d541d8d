#include "libcpvs/preview/light_clusters.h"

#include <algorithm>
#include <limits>
#include <string>

#include <glm/glm.hpp>

#include "libcpvs/base/error.h"

namespace cpvs {

LightClusters clusterLights(const std::vector<Light>& lights, uint32_t clusters) {
  if (clusters < 1) throw Error(ErrorCategory::InvalidArgument, "the number of light clusters must be at least 1");
  struct Cluster {
    std::vector<uint32_t> members;
    glm::dvec3 centroid{0.0};
  };
  std::vector<Cluster> active;
  for (uint32_t l = 0; l < lights.size(); ++l)
    if (hasPosition(lights[l])) active.push_back({{l}, lights[l].position});
  while (active.size() > clusters) {
    size_t a = 0, b = 1;
    double best = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < active.size(); ++i)
      for (size_t j = i + 1; j < active.size(); ++j) {
        const glm::dvec3 d = active[i].centroid - active[j].centroid;
        const double distance2 = glm::dot(d, d);
        if (distance2 < best) best = distance2, a = i, b = j;
      }
    Cluster merged;
    merged.members = active[a].members;
    merged.members.insert(merged.members.end(), active[b].members.begin(), active[b].members.end());
    std::sort(merged.members.begin(), merged.members.end());
    for (uint32_t m : merged.members) merged.centroid += lights[m].position;
    merged.centroid /= double(merged.members.size());
    active[a] = std::move(merged);
    active.erase(active.begin() + std::ptrdiff_t(b));
  }
  // Clusters in the order of their first member.
  std::sort(active.begin(), active.end(), [](const Cluster& x, const Cluster& y) { return x.members[0] < y.members[0]; });
  LightClusters out;
  out.clusterOf.assign(lights.size(), LightClusters::kAlone);
  for (uint32_t c = 0; c < active.size(); ++c) {
    Light light;
    light.type = LightType::Point;
    light.name = "cluster_" + std::to_string(c);
    light.position = active[c].centroid;
    light.range = 0;
    for (uint32_t m : active[c].members) {
      out.clusterOf[m] = c;
      light.range = std::max(light.range, lights[m].range + glm::length(lights[m].position - active[c].centroid));
    }
    out.lights.push_back(light);
  }
  return out;
}

}  // namespace cpvs
