#include "libcpvs/runtime/light_view.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>


namespace cpvs {
namespace {

glm::dvec3 transformPoint(const glm::dmat4& m, const glm::dvec3& p) { return glm::dvec3(m * glm::dvec4(p, 1.0)); }

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

std::optional<size_t> selectView(const Light& light, const std::vector<LightView>& views, const glm::dvec3& world) {
  if (views.empty()) return std::nullopt;
  if (!hasCubeFaces(light)) return withinInfluence(light, world) ? std::optional<size_t>(0) : std::nullopt;
  // Cube faces (lights with a range, no cone): the face of the major axis (ties go to the lower face index).
  const glm::dvec3 toPoint = world - light.position;
  if (!withinRange(light, toPoint)) return std::nullopt;
  const glm::dvec3 m = glm::abs(toPoint);
  int axis = m.x >= m.y && m.x >= m.z ? 0 : (m.y >= m.z ? 1 : 2);
  const int face = 2 * axis + (toPoint[axis] < 0 ? 1 : 0);
  for (size_t i = 0; i < views.size(); ++i)
    if (views[i].face == face) return i;
  return std::nullopt;
}

}  // namespace cpvs
