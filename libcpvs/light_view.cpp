#include "libcpvs/light_view.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "libcpvs/error.h"
#include "libcpvs/polygon_clip.h"

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

Extent measureExtent(const WorldGeometry& world, const LightView& view, const std::vector<Plane>& planes) {
  Extent extent;
  std::vector<glm::dvec3> poly, scratch;
  std::vector<glm::dvec3> viewPositions(world.positions.size());
  for (size_t i = 0; i < world.positions.size(); ++i) viewPositions[i] = transformPoint(view.viewFromWorld, world.positions[i]);
  for (size_t t = 0; t < world.triangleCount(); ++t) {
    if (world.isClosing(t)) continue;  // a ground's skirt lies under the scene: the view covers the scene
    const glm::dvec3 v[3] = {viewPositions[world.indices[3 * t]], viewPositions[world.indices[3 * t + 1]],
                             viewPositions[world.indices[3 * t + 2]]};
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

}  // namespace

GridPoint toGrid(const ViewMapping& mapping, const glm::dvec3& world) {
  const GridLanes<double, bool> lanes = mapToGrid<double, bool>(mapping, world.x, world.y, world.z);
  GridPoint g;
  g.uvs = {lanes.u, lanes.v, lanes.s};
  g.depth = lanes.depth;
  g.inFront = lanes.inFront;
  return g;
}

GridPoint toGrid(const LightView& view, const glm::dvec3& world) { return toGrid(ViewMapping(view), world); }

Voxel toVoxel(const LightView& view, const glm::dvec3& uvs) {
  const double maxIndex = double(view.resolution) - 1.0;
  auto cell = [maxIndex](double c) {
    // NaN compares false everywhere and lands in cell 0; callers reject NaN points before this.
    const double f = std::floor(c);
    return int32_t(f < 0 ? 0 : (f > maxIndex ? maxIndex : f));
  };
  return {cell(uvs.x), cell(uvs.y), cell(uvs.z)};
}

double depthToSlice(const LightView& view, double depth) { return sliceOfDepth<double, bool>(ViewMapping(view), depth); }

double sliceToDepth(const LightView& view, double slice) {
  const double t = slice / double(view.resolution);
  if (view.mapping == DepthMapping::Linear) return view.near + t * (view.far - view.near);
  return view.near * std::exp(t * std::log(view.far / view.near));
}

glm::dvec3 gridToWorld(const LightView& view, const glm::dvec3& uvs) {
  const double n = view.resolution;
  const double a = view.xMin + (view.xMax - view.xMin) * uvs.x / n;
  const double b = view.yMin + (view.yMax - view.yMin) * uvs.y / n;
  const double d = sliceToDepth(view, uvs.z);
  const glm::dvec3 v = view.projection == Projection::Orthographic ? glm::dvec3(a, b, -d) : glm::dvec3(a * d, b * d, -d);
  return transformPoint(glm::inverse(view.viewFromWorld), v);
}

glm::dvec3 viewEye(const LightView& view) {
  const glm::dmat4 worldFromView = glm::inverse(view.viewFromWorld);
  if (view.projection == Projection::Perspective) return transformPoint(worldFromView, glm::dvec3(0.0));
  return transformPoint(worldFromView, glm::dvec3(0, 0, -(view.near - (view.far - view.near))));
}

Ray texelRay(const LightView& view, double u, double v) {
  const glm::dmat4 worldFromView = glm::inverse(view.viewFromWorld);
  const double n = view.resolution;
  const double a = view.xMin + (view.xMax - view.xMin) * u / n;
  const double b = view.yMin + (view.yMax - view.yMin) * v / n;
  if (view.projection == Projection::Perspective) {
    const glm::dvec3 origin = transformPoint(worldFromView, glm::dvec3(0.0));
    const glm::dvec3 dir = glm::normalize(glm::dvec3(worldFromView * glm::dvec4(a, b, -1.0, 0.0)));
    return {origin, dir};
  }
  const double d0 = view.near - (view.far - view.near);
  const glm::dvec3 origin = transformPoint(worldFromView, glm::dvec3(a, b, -d0));
  const glm::dvec3 dir = glm::normalize(glm::dvec3(worldFromView * glm::dvec4(0, 0, -1, 0)));
  return {origin, dir};
}

std::vector<LightView> makeLightViews(const Light& light, const WorldGeometry& world, uint32_t resolution) {
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
      fitView(view, measureExtent(world, view, {}), scale, kInf);
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
      fitView(view, measureExtent(world, view, perspectivePlanes(tanHalf, light.range, 1e-9 * scale)), scale, tanHalf);
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
        fitView(view, measureExtent(world, view, perspectivePlanes(1.0, light.range, 1e-9 * scale)), scale, 1.0);
        views.push_back(view);
      }
      break;
    }
  }
  return views;
}

std::optional<size_t> selectView(const Light& light, const std::vector<LightView>& views, const glm::dvec3& world) {
  if (views.empty()) return std::nullopt;
  if (light.type == LightType::Directional) return 0;
  const glm::dvec3 toPoint = world - light.position;
  const double distance = glm::length(toPoint);
  if (!(distance <= light.range)) return std::nullopt;
  if (light.type == LightType::Spot) {
    if (distance == 0) return std::nullopt;
    const double cosAngle = glm::dot(toPoint, light.direction) / distance;
    if (cosAngle < std::cos(std::min(light.outerConeAngle, 3.14159265358979323846 / 2))) return std::nullopt;
    return 0;
  }
  // Point light: the cube face of the major axis (ties go to the lower face index).
  const glm::dvec3 m = glm::abs(toPoint);
  int axis = m.x >= m.y && m.x >= m.z ? 0 : (m.y >= m.z ? 1 : 2);
  const int face = 2 * axis + (toPoint[axis] < 0 ? 1 : 0);
  for (size_t i = 0; i < views.size(); ++i)
    if (views[i].face == face) return i;
  return std::nullopt;
}

uint32_t parseResolution(const std::string& text) {
  std::string digits = text;
  uint64_t multiplier = 1;
  if (!digits.empty() && (digits.back() == 'k' || digits.back() == 'K')) {
    multiplier = 1024;
    digits.pop_back();
  }
  const bool numeric = !digits.empty() && digits.size() <= 7 && std::all_of(digits.begin(), digits.end(), ::isdigit);
  const uint64_t value = numeric ? std::stoull(digits) * multiplier : 0;
  if (value < 8 || value > 262144 || (value & (value - 1)) != 0)
    throw Error(ExitCode::Usage, "resolution '" + text + "': expected a power of two from 8 to 256k (e.g. 512, 4k, 16k, 64k)");
  return uint32_t(value);
}

}  // namespace cpvs
