#pragma once
// Half spaces and Sutherland-Hodgman polygon clipping in view space, shared by view fitting and culling.
#include <vector>

#include <glm/glm.hpp>

namespace cpvs {

// The half space dot(n, v) + w >= 0.
struct Plane {
  glm::dvec3 n;
  double w;
  double distance(const glm::dvec3& v) const { return glm::dot(n, v) + w; }
};

inline void clipPolygon(std::vector<glm::dvec3>& poly, const Plane& plane, std::vector<glm::dvec3>& scratch) {
  scratch.clear();
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3& a = poly[i];
    const glm::dvec3& b = poly[(i + 1) % n];
    const double da = plane.distance(a), db = plane.distance(b);
    if (da >= 0) scratch.push_back(a);
    if ((da >= 0) != (db >= 0)) scratch.push_back(a + (b - a) * (da / (da - db)));
  }
  poly.swap(scratch);
}

// Clips a triangle to the intersection of the half spaces; returns false when nothing is left.
inline bool clipTriangle(const glm::dvec3 (&v)[3], const std::vector<Plane>& planes, std::vector<glm::dvec3>& poly,
                         std::vector<glm::dvec3>& scratch) {
  bool inside = true;
  for (const Plane& p : planes) {
    const double d0 = p.distance(v[0]), d1 = p.distance(v[1]), d2 = p.distance(v[2]);
    if (d0 < 0 && d1 < 0 && d2 < 0) return false;
    inside = inside && d0 >= 0 && d1 >= 0 && d2 >= 0;
  }
  poly.assign(v, v + 3);
  if (inside) return true;
  for (const Plane& p : planes) {
    clipPolygon(poly, p, scratch);
    if (poly.empty()) return false;
  }
  return true;
}

}  // namespace cpvs
