#include "libcpvs/views/view_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "libcpvs/views/polygon_clip.h"

namespace cpvs {
namespace {

// The view's volume as half spaces in view space (d = -z).
std::vector<Plane> viewPlanes(const LightView& view) {
  if (view.projection == Projection::Orthographic) {
    return {{{1, 0, 0}, -view.xMin}, {{-1, 0, 0}, view.xMax}, {{0, 1, 0}, -view.yMin},
            {{0, -1, 0}, view.yMax}, {{0, 0, -1}, -view.near}, {{0, 0, 1}, view.far}};
  }
  // x >= xMin d  <=>  x + xMin z >= 0 (d = -z), and so on. Depth from a small fraction of near (geometry
  // closer than near is clamped into slice 0 by the renderer) to far.
  return {{{1, 0, view.xMin}, 0}, {{-1, 0, -view.xMax}, 0}, {{0, 1, view.yMin}, 0},
          {{0, -1, -view.yMax}, 0}, {{0, 0, -1}, -0.5 * view.near}, {{0, 0, 1}, view.far}};
}

// The corners of the volume viewPlanes bounds, in view space.
std::vector<glm::dvec3> viewCorners(const LightView& view) {
  std::vector<glm::dvec3> corners;
  const bool perspective = view.projection == Projection::Perspective;
  for (const double d : {perspective ? 0.5 * view.near : view.near, view.far})
    for (const double a : {view.xMin, view.xMax})
      for (const double b : {view.yMin, view.yMax})
        corners.push_back(perspective ? glm::dvec3(a * d, b * d, -d) : glm::dvec3(a, b, -d));
  return corners;
}

}  // namespace

void worldBoxOf(const LightView& view, const std::vector<glm::dvec3>& corners, double margin, glm::dvec3& lo,
                glm::dvec3& hi) {
  const glm::dmat4 worldFromView = glm::inverse(view.viewFromWorld);
  lo = glm::dvec3(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (const glm::dvec3& c : corners) {
    const glm::dvec3 p(worldFromView * glm::dvec4(c, 1.0));
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  lo -= glm::dvec3(margin);
  hi += glm::dvec3(margin);
}

std::vector<uint32_t> trianglesNear(const WorldGeometry& world, const LightView& view,
                                    const std::vector<glm::dvec3>& corners, const TriangleBvh* index) {
  std::vector<uint32_t> out;
  bool bounded = index && !corners.empty();
  for (const glm::dvec3& c : corners) bounded = bounded && std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z);
  if (!bounded) {
    out.resize(world.triangleCount());
    for (size_t t = 0; t < out.size(); ++t) out[t] = uint32_t(t);
    return out;
  }
  // Far more than rounding in the clip tests, far less than anything a view resolves: a triangle this far
  // outside the box clips to nothing, with or without the index.
  double extent = world.bounds.empty() ? 1.0 : glm::length(world.bounds.extent());
  for (const glm::dvec3& c : corners) extent = std::max(extent, glm::length(c));
  glm::dvec3 lo, hi;
  worldBoxOf(view, corners, 1e-6 * extent, lo, hi);
  index->overlapping(lo, hi, out);
  return out;
}

ViewGeometry gatherViewGeometry(const WorldGeometry& world, const LightView& view, const TriangleBvh* index) {
  ViewGeometry out;
  if (view.empty) return out;
  const std::vector<Plane> planes = viewPlanes(view);
  const auto toView = [&](uint32_t vertex) { return glm::dvec3(view.viewFromWorld * glm::dvec4(world.positions[vertex], 1.0)); };

  const double n = view.resolution;
  const double uScale = n / (view.xMax - view.xMin), vScale = n / (view.yMax - view.yMin);
  const bool perspective = view.projection == Projection::Perspective;
  std::vector<glm::dvec3> poly, scratch;
  std::vector<glm::vec3> openPositions;
  std::vector<glm::vec4> openBounds;
  std::vector<int32_t> openMasks;  // closed triangles are never masked
  std::vector<glm::vec2> openUvs;

  for (const uint32_t t : trianglesNear(world, view, viewCorners(view), index)) {
    const glm::dvec3 v[3] = {toView(world.indices[3 * t]), toView(world.indices[3 * t + 1]),
                             toView(world.indices[3 * t + 2])};
    if (!clipTriangle(v, planes, poly, scratch)) continue;
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& q : poly) {
      const double d = -q.z;
      const glm::dvec2 ab = perspective ? glm::dvec2(q.x / d, q.y / d) : glm::dvec2(q.x, q.y);
      lo = glm::min(lo, ab);
      hi = glm::max(hi, ab);
    }
    const glm::vec4 bounds(float((lo.x - view.xMin) * uScale), float((hi.x - view.xMin) * uScale),
                           float((lo.y - view.yMin) * vScale), float((hi.y - view.yMin) * vScale));
    const bool closed = world.isClosed(t);
    auto& positions = closed ? out.positions : openPositions;
    for (int k = 0; k < 3; ++k) positions.push_back(glm::vec3(v[k]));
    (closed ? out.gridBounds : openBounds).push_back(bounds);
    if (closed) continue;
    if (world.isMasked(t)) {
      const size_t m = t - world.masked.begin;
      if (openMasks.empty()) {  // the first alpha-tested triangle of this view
        openMasks.assign(openBounds.size() - 1, -1);
        openUvs.assign(openPositions.size() - 3, glm::vec2(0.0f));
      }
      openMasks.push_back(int32_t(world.masked.maskOf[m]));
      openUvs.insert(openUvs.end(), &world.masked.uvs[3 * m], &world.masked.uvs[3 * m] + 3);
    } else if (!openMasks.empty()) {
      openMasks.push_back(-1);
      openUvs.insert(openUvs.end(), 3, glm::vec2(0.0f));
    }
  }

  // Closed triangles first, then open ones; every triangle has its own three vertices.
  const size_t closedCount = out.positions.size() / 3;
  out.positions.insert(out.positions.end(), openPositions.begin(), openPositions.end());
  out.gridBounds.insert(out.gridBounds.end(), openBounds.begin(), openBounds.end());
  out.closedIndices.resize(3 * closedCount);
  out.openIndices.resize(out.positions.size() - 3 * closedCount);
  for (uint32_t i = 0; i < out.closedIndices.size(); ++i) out.closedIndices[i] = i;
  for (uint32_t i = 0; i < out.openIndices.size(); ++i) out.openIndices[i] = uint32_t(3 * closedCount) + i;
  if (!openMasks.empty()) {
    out.maskOf.assign(closedCount, -1);
    out.maskOf.insert(out.maskOf.end(), openMasks.begin(), openMasks.end());
    out.maskUvs.assign(3 * closedCount, glm::vec2(0.0f));
    out.maskUvs.insert(out.maskUvs.end(), openUvs.begin(), openUvs.end());
    out.masks = &world.masked.masks;
  }
  return out;
}

namespace {

// Whether triangle bounds b = (uMin, uMax, vMin, vMax) overlap the region grown by one texel.
bool overlapsRegion(const glm::vec4& b, const RegionRect& rect) {
  const float x0 = float(rect.x0) - 1.0f, x1 = float(rect.x0 + rect.width) + 1.0f;
  const float y0 = float(rect.y0) - 1.0f, y1 = float(rect.y0 + rect.height) + 1.0f;
  return !(b.y < x0 || b.x > x1 || b.w < y0 || b.z > y1);
}

// Appends triangle t (an index over closed, then open triangles) of `geometry` to `out`.
void keepTriangle(const ViewGeometry& geometry, size_t t, ViewGeometry& out) {
  const size_t closedCount = geometry.closedIndices.size() / 3;
  const bool closed = t < closedCount;
  const uint32_t* idx = closed ? &geometry.closedIndices[3 * t] : &geometry.openIndices[3 * (t - closedCount)];
  std::vector<uint32_t>& outIndices = closed ? out.closedIndices : out.openIndices;
  for (int k = 0; k < 3; ++k) {
    outIndices.push_back(uint32_t(out.positions.size()));
    out.positions.push_back(geometry.positions[idx[k]]);
    if (geometry.hasMasks()) out.maskUvs.push_back(geometry.maskUvs[idx[k]]);
  }
  out.gridBounds.push_back(geometry.gridBounds[t]);
  if (geometry.hasMasks()) out.maskOf.push_back(geometry.maskOf[t]);
}

}  // namespace

ViewGeometry cullToRegion(const ViewGeometry& geometry, const RegionRect& rect) {
  ViewGeometry out;
  for (size_t t = 0; t < geometry.triangleCount(); ++t)
    if (overlapsRegion(geometry.gridBounds[t], rect)) keepTriangle(geometry, t, out);
  if (geometry.hasMasks()) out.masks = geometry.masks;
  return out;
}

ViewGeometry cullToRegion(const ViewGeometry& geometry, const RegionRect& rect, const std::vector<uint32_t>& candidates) {
  ViewGeometry out;
  for (uint32_t t : candidates)
    if (overlapsRegion(geometry.gridBounds[t], rect)) keepTriangle(geometry, t, out);
  if (geometry.hasMasks()) out.masks = geometry.masks;
  return out;
}

std::vector<std::vector<uint32_t>> binToRegions(const ViewGeometry& geometry, uint32_t resolution, uint32_t regionSize) {
  const uint32_t perSide = (resolution + regionSize - 1) / regionSize;
  std::vector<std::vector<uint32_t>> bins(size_t(perSide) * perSide);
  // The regions whose guard-banded rectangle [x0 - 1, x0 + size + 1] may meet [lo, hi] (float bounds; NaN-free).
  const auto range = [&](float lo, float hi, uint32_t& first, uint32_t& last) {
    if (std::isnan(lo)) lo = -std::numeric_limits<float>::infinity();  // cullToRegion cannot exclude it by a NaN
    if (std::isnan(hi)) hi = std::numeric_limits<float>::infinity();
    const double a = std::floor((double(lo) - 1.0) / regionSize), b = std::floor((double(hi) + 1.0) / regionSize);
    if (!(b >= 0) || !(a < perSide)) return false;
    first = uint32_t(std::max(0.0, a));
    last = uint32_t(std::min(double(perSide - 1), b));
    return true;
  };
  for (size_t t = 0; t < geometry.triangleCount(); ++t) {
    const glm::vec4& b = geometry.gridBounds[t];
    uint32_t rx0, rx1, ry0, ry1;
    if (!range(b.x, b.y, rx0, rx1) || !range(b.z, b.w, ry0, ry1)) continue;
    for (uint32_t ry = ry0; ry <= ry1; ++ry)
      for (uint32_t rx = rx0; rx <= rx1; ++rx) bins[size_t(ry) * perSide + rx].push_back(uint32_t(t));
  }
  return bins;
}

}  // namespace cpvs
