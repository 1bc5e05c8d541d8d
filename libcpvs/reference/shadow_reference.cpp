#include "libcpvs/reference/shadow_reference.h"

#include <cstdio>

#include <cmath>

#include "libcpvs/base/error.h"

namespace cpvs {

ShadowReference::ShadowReference(const WorldGeometry& world, NormalOrientation orientation, double relativeEpsilon)
    : orientation_(orientation) {
  // Rays see the scene as authored; the inside-a-solid test also sees the ground sheets' closing triangles,
  // so it finds the ground solid the bake took (libcpvs/scene/ground_sheet.h).
  if (world.closingBegin < world.closingEnd) {
    solids_ = std::make_unique<EmbreeScene>(world);
    WorldGeometry own = world;
    own.indices.erase(own.indices.begin() + long(3 * world.closingBegin), own.indices.begin() + long(3 * world.closingEnd));
    own.closedTriangleCount = world.closingBegin;
    if (own.masked.count()) own.masked.begin -= world.closingEnd - world.closingBegin;  // they follow the closing ones
    own.closingBegin = own.closingEnd = 0;
    scene_ = std::make_unique<EmbreeScene>(own);
  } else {
    scene_ = std::make_unique<EmbreeScene>(world);
  }
  sceneTriangles_ = world.sceneTriangleCount();
  const double diagonal = world.bounds.empty() ? 1.0 : glm::length(world.bounds.extent());
  // Scale-relative, as Embree's float precision is (it stores the scene relative to its centre): the default
  // 1e-6 is ~16x that precision (1e-7 found more errors, self-hits) and a voxel of a view spanning the whole
  // scene only at N ~ 1M; a narrow spot's voxels, and gaps between walls, are smaller than 1e-5 of it.
  epsilon_ = relativeEpsilon * (diagonal > 0 ? diagonal : 1.0);
}

ShadowReference::~ShadowReference() = default;

void ShadowReference::checkRelativeEpsilon(double relativeEpsilon) {
  if (!(relativeEpsilon >= 1e-9 && relativeEpsilon <= 1e-2))
  {
    char value[32];
    std::snprintf(value, sizeof value, "%g", relativeEpsilon);
    throw Error(ErrorCategory::InvalidArgument,
                std::string("reference ray offset ") + value + " of the scene diagonal: expected 1e-9 to 1e-2");
  }
}

bool ShadowReference::shadowRay(const Light& light, const SurfacePoint& point, Ray& ray, double& tmax,
                                uint8_t& known) const {
  known = 0;
  if (!withinInfluence(light, point.position)) return false;
  glm::dvec3 toLight = towardLight(light, point.position);
  if (hasPosition(light)) {
    const double distance = glm::length(toLight);
    known = 1;
    if (!(distance > 0)) return false;
    toLight = toLight / distance;
  }
  glm::dvec3 origin = point.position;
  const double nLength = glm::length(point.normal);
  if (nLength > 0) {
    glm::dvec3 n = point.normal / nLength;
    if (orientation_ == NormalOrientation::TowardLight && glm::dot(n, toLight) < 0) n = -n;
    // A surface facing away from the light (facesLight's rule, on the unit vectors): the ray from the surface
    // point itself enters that surface at once, so the point is in its own shadow. (Moved epsilon off the surface first, a ray that meets an
    // almost edge-on facet would cross the facet's plane epsilon / |n . L| further on, past its edge, and
    // escape: an artefact of the offset, not light.)
    if (glm::dot(n, toLight) < 0) {
      known = 0;
      return false;
    }
    origin += epsilon_ * n;
  } else {
    origin += epsilon_ * toLight;
  }
  tmax = EmbreeScene::kInfinity;
  if (hasPosition(light)) {
    const glm::dvec3 d = light.position - origin;
    const double distance = glm::length(d);
    known = 1;
    if (!(distance > epsilon_)) return false;
    toLight = d / distance;
    tmax = distance - epsilon_;  // stop short of the light itself
  }
  ray = {origin, toLight};
  return true;
}

bool ShadowReference::insideClosedSolid(const SurfacePoint& point) const {
  const double length = glm::length(point.normal);
  const glm::dvec3 offset = length > 0 ? (epsilon_ / length) * point.normal : glm::dvec3(0.0);
  return (solids_ ? *solids_ : *scene_).isInsideClosedSolid(point.position + offset);
}

uint8_t ShadowReference::visibility(const Light& light, const SurfacePoint& point) const {
  Ray ray;
  double tmax = 0;
  uint8_t known = 0;
  if (!shadowRay(light, point, ray, tmax, known)) return known;
  return scene_->occluded(ray.origin, ray.direction, tmax) ? 0 : 1;
}

void ShadowReference::visibilityPackets(const Light& light, const std::vector<SurfacePoint>& points,
                                        std::vector<uint8_t>& out) const {
  out.assign(points.size(), 0);
  std::vector<Ray> rays;
  std::vector<double> tmax;
  std::vector<size_t> index;
  rays.reserve(points.size());
  tmax.reserve(points.size());
  index.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    Ray ray;
    double t = 0;
    uint8_t known = 0;
    if (!shadowRay(light, points[i], ray, t, known)) {
      out[i] = known;
      continue;
    }
    rays.push_back(ray);
    tmax.push_back(t);
    index.push_back(i);
  }
  const std::vector<uint8_t> blocked = scene_->occludedBatch(rays, tmax, false);
  for (size_t r = 0; r < rays.size(); ++r) out[index[r]] = blocked[r] ? 0 : 1;
}

uint8_t ShadowReference::visibility(const LightShadow& shadow, const SurfacePoint& point, bool& uniform) const {
  const uint8_t centre = visibility(shadow.light(), point);
  uniform = uniformAround(shadow, point, centre);
  return centre;
}

bool ShadowReference::uniformAround(const LightShadow& shadow, const SurfacePoint& point, uint8_t centre) const {
  const int index = shadow.viewIndex(point.position);
  if (index < 0) return true;  // outside the light's influence: 0 here and, as far as we know, around it
  const LightView& view = shadow.views()[size_t(index)];
  const GridPoint g = toGrid(view, point.position);
  if (!g.inFront) return true;
  glm::dvec3 m = gridNormal(view, point.position, point.normal);
  const double length = glm::length(m);
  m = length > 0 && std::isfinite(length) ? m / length : glm::dvec3(0.0);
  if (orientation_ == NormalOrientation::TowardLight && m.z > 0) m = -m;
  // The neighbourhood, in grid units: a circle of radius 2 on the tangent plane (8 points) and the point 2
  // voxels out along the normal (the side the lookup's bias moves to). Without a normal: a circle of radius 2
  // in (u, v) at the same depth.
  glm::dvec3 t1(1, 0, 0), t2(0, 1, 0);
  if (m != glm::dvec3(0.0)) {
    const glm::dvec3 axis = std::abs(m.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    t1 = glm::normalize(glm::cross(m, axis));
    t2 = glm::cross(m, t1);
  }
  constexpr double kRadius = 2.0, kDiagonal = 0.70710678118654752;
  const glm::dvec3 offsets[9] = {kRadius * t1,
                                 -kRadius * t1,
                                 kRadius * t2,
                                 -kRadius * t2,
                                 kRadius * kDiagonal * (t1 + t2),
                                 kRadius * kDiagonal * (t1 - t2),
                                 kRadius * kDiagonal * (-t1 + t2),
                                 kRadius * kDiagonal * (-t1 - t2),
                                 kRadius * m};
  for (const glm::dvec3& o : offsets) {
    if (o == glm::dvec3(0.0)) continue;
    const SurfacePoint sample{gridToWorld(view, g.uvs + o), point.normal};
    if (visibility(shadow.light(), sample) != centre) return false;
  }
  return true;
}

}  // namespace cpvs
