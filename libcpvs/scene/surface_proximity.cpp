#include "libcpvs/scene/surface_proximity.h"

#include <algorithm>
#include <vector>

namespace cpvs {

// Ericson, Real-Time Collision Detection (2005), §5.1.5: the closest point by the Voronoi region of p.
double pointTriangleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return glm::length(ap);
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return glm::length(bp);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return glm::length(cp);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
  const double sum = va + vb + vc;
  if (!(sum > 0)) {  // degenerate: the nearest of its three edges
    const auto segment = [&](const glm::dvec3& s, const glm::dvec3& e) {
      const glm::dvec3 d = e - s;
      const double length2 = glm::dot(d, d);
      const double t = length2 > 0 ? glm::clamp(glm::dot(p - s, d) / length2, 0.0, 1.0) : 0.0;
      return glm::length(p - (s + t * d));
    };
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
  }
  const double v = vb / sum, w = vc / sum;
  return glm::length(p - (a + ab * v + ac * w));
}

namespace {

WorldGeometry everySurface(Scene scene) {
  for (Mesh& mesh : scene.meshes) mesh.castsShadows = true, mesh.cutAway = false;
  for (Instance& instance : scene.instances) instance.castsShadows = true;
  return flatten(scene, GroundSheets::Off);
}

}  // namespace

SurfaceProximity::SurfaceProximity(const Scene& scene) : world_(everySurface(scene)), bvh_(world_) {}

bool SurfaceProximity::near(const glm::dvec3& p, double radius) const {
  std::vector<uint32_t> candidates;
  bvh_.overlapping(p - glm::dvec3(radius), p + glm::dvec3(radius), candidates);
  for (uint32_t t : candidates) {
    const glm::dvec3& a = world_.positions[world_.indices[3 * size_t(t)]];
    const glm::dvec3& b = world_.positions[world_.indices[3 * size_t(t) + 1]];
    const glm::dvec3& c = world_.positions[world_.indices[3 * size_t(t) + 2]];
    if (pointTriangleDistance(p, a, b, c) <= radius) return true;
  }
  return false;
}

}  // namespace cpvs
