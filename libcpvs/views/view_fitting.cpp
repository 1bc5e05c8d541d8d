#include "libcpvs/views/view_fitting.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "libcpvs/views/polygon_clip.h"
#include "libcpvs/views/view_geometry.h"

namespace cpvs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Rigid transform whose -Z axis is `travel` (the direction light moves) and whose origin is `origin`.
glm::dmat4 lookAlong(const glm::dvec3& origin, const glm::dvec3& travel, const glm::dvec3& upHint) {
  const glm::dvec3 zAxis = -glm::normalize(travel);
  glm::dvec3 up = upHint;
  if (std::abs(glm::dot(up, zAxis)) > 0.9) up = std::abs(zAxis.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
  const glm::dvec3 xAxis = glm::normalize(glm::cross(up, zAxis));
  const glm::dvec3 yAxis = glm::cross(zAxis, xAxis);
  glm::dmat4 m(1.0);
  for (int i = 0; i < 3; ++i) {
    m[i][0] = xAxis[i];
    m[i][1] = yAxis[i];
    m[i][2] = zAxis[i];
  }
  m[3][0] = -glm::dot(xAxis, origin);
  m[3][1] = -glm::dot(yAxis, origin);
  m[3][2] = -glm::dot(zAxis, origin);
  return m;
}

glm::dvec3 transformPoint(const glm::dmat4& m, const glm::dvec3& p) { return glm::dvec3(m * glm::dvec4(p, 1.0)); }

// Lateral (a, b) and depth d of a view-space point.
glm::dvec3 lateralAndDepth(const LightView& view, const glm::dvec3& v) {
  const double d = -v.z;
  if (view.projection == Projection::Orthographic) return {v.x, v.y, d};
  return {v.x / d, v.y / d, d};
}

// The extent of the geometry inside a view's bounding volume, in (a, b, d).
struct Extent {
  glm::dvec3 min{kInf}, max{-kInf};
  bool empty() const { return !(min.x <= max.x); }
};

// `corners`: the view-space corners of the volume the planes bound (empty: unbounded), for the index.
Extent measureExtent(const WorldGeometry& world, const LightView& view, const std::vector<Plane>& planes,
                     const std::vector<glm::dvec3>& corners, const TriangleBvh* index) {
  Extent extent;
  std::vector<glm::dvec3> poly, scratch;
  const auto toView = [&](uint32_t vertex) { return transformPoint(view.viewFromWorld, world.positions[vertex]); };
  for (const uint32_t t : trianglesNear(world, view, corners, index)) {
    if (world.isClosing(t)) continue;  // a ground's skirt lies under the scene: the view covers the scene
    const glm::dvec3 v[3] = {toView(world.indices[3 * t]), toView(world.indices[3 * t + 1]),
                             toView(world.indices[3 * t + 2])};
    if (!clipTriangle(v, planes, poly, scratch)) continue;
    for (const glm::dvec3& q : poly) {
      const glm::dvec3 abd = lateralAndDepth(view, q);
      extent.min = glm::min(extent.min, abd);
      extent.max = glm::max(extent.max, abd);
    }
  }
  return extent;
}

double sceneScale(const WorldGeometry& world) {
  if (world.bounds.empty()) return 1.0;
  const double s = glm::length(world.bounds.extent());
  return s > 0 ? s : std::max(1.0, glm::length(world.bounds.max));
}

// Grows [lo, hi] to at least `minSize`, centred.
void ensureSize(double& lo, double& hi, double minSize) {
  if (hi - lo >= minSize) return;
  const double c = 0.5 * (lo + hi);
  lo = c - 0.5 * minSize;
  hi = c + 0.5 * minSize;
}

// Fits lateral extent and depth range to the measured geometry, with a margin of one texel on each side and
// two slices before and after, so no surface lands in the last slice (points behind everything clamp there).
void fitView(LightView& view, const Extent& extent, double scale, double lateralLimit) {
  const double n = view.resolution;
  if (extent.empty()) {
    view.empty = true;
    if (view.projection == Projection::Orthographic) {
      view.xMin = view.yMin = -0.5 * scale;
      view.xMax = view.yMax = 0.5 * scale;
      view.near = 0;
      view.far = scale;
    } else {
      view.near = 1e-3 * scale;
      view.far = scale;
    }
    return;
  }
  double xMin = extent.min.x, xMax = extent.max.x, yMin = extent.min.y, yMax = extent.max.y;
  const double minLateral = view.projection == Projection::Orthographic ? 1e-3 * scale : 1e-4;
  ensureSize(xMin, xMax, minLateral);
  ensureSize(yMin, yMax, minLateral);
  const double padX = (xMax - xMin) / n, padY = (yMax - yMin) / n;
  view.xMin = std::max(xMin - padX, -lateralLimit);
  view.xMax = std::min(xMax + padX, lateralLimit);
  view.yMin = std::max(yMin - padY, -lateralLimit);
  view.yMax = std::min(yMax + padY, lateralLimit);

  double dMin = extent.min.z, dMax = extent.max.z;
  if (view.mapping == DepthMapping::Linear) {
    ensureSize(dMin, dMax, 1e-3 * scale);
    const double pad = 2.0 * (dMax - dMin) / n;
    view.near = dMin - pad;
    view.far = dMax + pad;
  } else {
    // Logarithmic depth needs near > 0; a surface touching the light is clamped into slice 0.
    dMax = std::max(dMax, 1e-6 * scale);
    dMin = std::max(dMin, 1e-4 * dMax);
    if (dMax / dMin < 1.01) {
      dMin /= 1.005;
      dMax *= 1.005;
    }
    const double pad = std::pow(dMax / dMin, 2.0 / n);
    view.near = dMin / pad;
    view.far = dMax * pad;
  }
}

std::vector<Plane> perspectivePlanes(double tanHalf, double range, double minDepth) {
  // In view space d = -z. |x| <= tanHalf d, |y| <= tanHalf d, minDepth <= d <= range.
  std::vector<Plane> planes = {
      {{-1, 0, -tanHalf}, 0}, {{1, 0, -tanHalf}, 0}, {{0, -1, -tanHalf}, 0}, {{0, 1, -tanHalf}, 0},
      {{0, 0, -1}, -minDepth},
  };
  if (std::isfinite(range)) planes.push_back({{0, 0, 1}, range});
  return planes;
}

// The corners of the volume perspectivePlanes bounds (none when the range is unlimited).
std::vector<glm::dvec3> perspectiveCorners(double tanHalf, double range, double minDepth) {
  if (!std::isfinite(range)) return {};
  std::vector<glm::dvec3> corners;
  for (const double d : {minDepth, range})
    for (const double a : {-tanHalf, tanHalf})
      for (const double b : {-tanHalf, tanHalf}) corners.push_back({a * d, b * d, -d});
  return corners;
}

}  // namespace

std::vector<LightView> makeLightViews(const Light& light, const WorldGeometry& world, uint32_t resolution,
                                      const TriangleBvh* index) {
  const double scale = sceneScale(world);
  std::vector<LightView> views;
  const glm::dvec3 yUp(0, 1, 0);
  switch (light.type) {
    case LightType::Directional: {
      LightView view;
      view.projection = Projection::Orthographic;
      view.mapping = DepthMapping::Linear;
      view.resolution = resolution;
      const glm::dvec3 origin = world.bounds.empty() ? glm::dvec3(0.0) : world.bounds.center();
      view.viewFromWorld = lookAlong(origin, light.direction, yUp);
      fitView(view, measureExtent(world, view, {}, {}, index), scale, kInf);
      views.push_back(view);
      break;
    }
    case LightType::Spot: {
      LightView view;
      view.projection = Projection::Perspective;
      view.mapping = DepthMapping::Logarithmic;
      view.resolution = resolution;
      view.viewFromWorld = lookAlong(light.position, light.direction, yUp);
      // A square frustum around the cone; wider than ~170 degrees degenerates, so the cone is capped there.
      const double outer = std::clamp(light.outerConeAngle, 1e-4, 85.0 * 3.14159265358979323846 / 180.0);
      const double tanHalf = std::tan(outer);
      fitView(view,
              measureExtent(world, view, perspectivePlanes(tanHalf, light.range, 1e-9 * scale),
                            perspectiveCorners(tanHalf, light.range, 1e-9 * scale), index),
              scale, tanHalf);
      views.push_back(view);
      break;
    }
    case LightType::Point: {
      static const std::array<glm::dvec3, 6> axes = {glm::dvec3(1, 0, 0), glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0),
                                                      glm::dvec3(0, -1, 0), glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1)};
      for (int face = 0; face < 6; ++face) {
        LightView view;
        view.projection = Projection::Perspective;
        view.mapping = DepthMapping::Logarithmic;
        view.resolution = resolution;
        view.face = face;
        const glm::dvec3 up = face == 2 || face == 3 ? glm::dvec3(0, 0, 1) : yUp;
        view.viewFromWorld = lookAlong(light.position, axes[face], up);
        fitView(view,
                measureExtent(world, view, perspectivePlanes(1.0, light.range, 1e-9 * scale),
                              perspectiveCorners(1.0, light.range, 1e-9 * scale), index),
                scale, 1.0);
        views.push_back(view);
      }
      break;
    }
  }
  return views;
}

double largestVoxelSize(const LightView& view) {
  const double n = view.resolution;
  const double lateral = std::max(view.xMax - view.xMin, view.yMax - view.yMin);
  if (view.projection == Projection::Orthographic) return std::max(lateral, view.far - view.near) / n;
  const double depth = view.mapping == DepthMapping::Logarithmic ? view.far * std::log(view.far / view.near)
                                                                 : view.far - view.near;
  return std::max(view.far * lateral, depth) / n;
}

uint32_t resolutionForVoxelSize(const std::vector<LightView>& views, double voxelSize, uint32_t maxResolution) {
  uint32_t needed = 8;
  for (const LightView& view : views) {
    if (view.empty) continue;
    // Voxels shrink in proportion to 1/N: N * largestVoxelSize is the same at every resolution (up to the
    // one-texel padding of the fit).
    const double edges = largestVoxelSize(view) * view.resolution / voxelSize;
    while (needed < maxResolution && double(needed) < edges) needed *= 2;
  }
  return std::min(needed, maxResolution);
}

}  // namespace cpvs
