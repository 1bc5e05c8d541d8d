#pragma once
// Whether a point lies near any surface of a scene: the question a query asks of its points before it trusts
// that they were made on that scene (points sampled on one level and scored against another give a
// meaningless error figure).
#include <glm/glm.hpp>

#include "libcpvs/scene/scene.h"
#include "libcpvs/scene/triangle_bvh.h"

namespace cpvs {

// The distance from p to the triangle (a, b, c), degenerate triangles included.
double pointTriangleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

// Every surface of a scene, casting or not: a G-buffer or a point set holds points on glass, on meshes that
// cast no shadow and on meshes a bake excluded as well.
class SurfaceProximity {
public:
  explicit SurfaceProximity(const Scene& scene);

  // Whether some triangle of the scene lies within `radius` of p.
  bool near(const glm::dvec3& p, double radius) const;
  double diagonal() const { return glm::length(world_.bounds.extent()); }

private:
  WorldGeometry world_;
  TriangleBvh bvh_;  // over world_
};

}  // namespace cpvs
