#include "libcpvs/eval/points_on_surfaces.h"

#include <algorithm>
#include <cmath>

namespace cpvs {

double voxelEdgeAt(const LightView& view, const glm::dvec3& world) {
  const glm::dvec3 g = toGrid(view, world).uvs;
  const glm::dvec3 origin = gridToWorld(view, g);
  double edge = 0;
  for (int axis = 0; axis < 3; ++axis) {
    glm::dvec3 step(0.0);
    step[axis] = 1.0;
    edge = std::max(edge, glm::length(gridToWorld(view, g + step) - origin));
  }
  return edge;
}

SurfaceCheck checkPointsOnSurfaces(const SurfaceProximity& scene, const std::vector<const LightShadow*>& lights,
                                   std::span<const SurfacePoint> points, size_t most) {
  SurfaceCheck check;
  if (points.empty() || most == 0) return check;
  const size_t stride = std::max<size_t>(1, points.size() / most);
  const double floor = kOffSurfaceFloor * scene.diagonal(), ceiling = kOffSurfaceCeiling * scene.diagonal();
  for (size_t i = 0; i < points.size() && check.checked < most; i += stride) {
    const glm::dvec3& p = points[i].position;
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) continue;
    double radius = floor;
    for (const LightShadow* light : lights) {
      const int view = light->viewIndex(p);
      if (view < 0) continue;
      const double edge = voxelEdgeAt(light->views()[size_t(view)], p);
      if (std::isfinite(edge)) radius = std::max(radius, kOffSurfaceVoxels * edge);
      break;
    }
    ++check.checked;
    check.offSurface += !scene.near(p, std::min(radius, ceiling));
  }
  return check;
}

}  // namespace cpvs
