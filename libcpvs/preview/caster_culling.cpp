#include "libcpvs/preview/caster_culling.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "libcpvs/base/error.h"
#include "libcpvs/base/named_values.h"
#include "libcpvs/eval/shadow_map.h"

namespace cpvs {

namespace {
constexpr Named<CasterCulling> kCullings[] = {{CasterCulling::None, "none"},
                                              {CasterCulling::Frustum, "frustum"},
                                              {CasterCulling::VoxelGrid, "voxel-grid"},
                                              {CasterCulling::ReceiverMask, "receiver-mask"}};
constexpr Named<ReceiverMaskVariant> kMaskVariants[] = {{ReceiverMaskVariant::Fragments, "frag"},
                                                        {ReceiverMaskVariant::BoundingVolumes, "bvol"}};
}  // namespace

CasterCulling parseCasterCulling(const std::string& name) { return parseNamed(kCullings, name, "caster culling"); }
const char* casterCullingName(CasterCulling culling) { return nameOf(kCullings, culling); }
ReceiverMaskVariant parseReceiverMaskVariant(const std::string& name) {
  return parseNamed(kMaskVariants, name, "receiver mask variant");
}
const char* receiverMaskVariantName(ReceiverMaskVariant variant) { return nameOf(kMaskVariants, variant); }

double lookupReachTexels(int pcfKernel, double biasMargin) {
  return 0.5 * pcfKernel + pcfKernel / std::sqrt(2.0) + biasMargin + 1.5;
}

namespace {

// A triangle's corners in the map view's grid: lateral (u, v) in texels, s in slices; false when a corner is
// behind a perspective eye (the caller keeps such a triangle: its projection is unbounded).
bool gridCorners(const CasterTriangles& t, uint32_t triangle, const ViewMapping& m, glm::dvec3 g[3]) {
  for (int k = 0; k < 3; ++k) {
    const GridPoint p = toGrid(m, glm::dvec3(t.corners[3 * size_t(triangle) + size_t(k)]));
    if (!p.inFront) return false;
    g[k] = p.uvs;
  }
  return true;
}

// Whether a triangle's projection may cover a texel centre of an M x M map: x + 0.5 in [0, M).
bool mayCoverMap(const glm::dvec3 g[3], double m) {
  const double uMin = std::min({g[0].x, g[1].x, g[2].x}), uMax = std::max({g[0].x, g[1].x, g[2].x});
  const double vMin = std::min({g[0].y, g[1].y, g[2].y}), vMax = std::max({g[0].y, g[1].y, g[2].y});
  return uMax >= 0.5 - 1e-6 && uMin <= m - 0.5 + 1e-6 && vMax >= 0.5 - 1e-6 && vMin <= m - 0.5 + 1e-6;
}

// Every triangle of a perspective view lying wholly behind the eye is culled (GL clips it away); one crossing
// the eye plane is kept.
bool wholyBehind(const CasterTriangles& t, uint32_t triangle, const ViewMapping& m) {
  if (m.orthographic) return false;
  for (int k = 0; k < 3; ++k)
    if (toGrid(m, glm::dvec3(t.corners[3 * size_t(triangle) + size_t(k)])).inFront) return false;
  return true;
}

}  // namespace

std::vector<uint32_t> frustumCull(const CasterTriangles& triangles, const LightView& mapView,
                                  const std::vector<uint32_t>* candidates) {
  const ViewMapping m(mapView);
  std::vector<uint32_t> kept;
  const size_t n = candidates ? candidates->size() : triangles.count();
  for (size_t i = 0; i < n; ++i) {
    const uint32_t t = candidates ? (*candidates)[i] : uint32_t(i);
    glm::dvec3 g[3];
    if (gridCorners(triangles, t, m, g) ? mayCoverMap(g, m.resolution) : !wholyBehind(triangles, t, m)) kept.push_back(t);
  }
  return kept;
}

// ---- Selgrad et al.'s grid ------------------------------------------------------------------------------

CasterGrid::CasterGrid(const CasterTriangles& triangles, const Bounds& bounds) : bounds_(bounds) {
  triangleCount_ = triangles.count();
  const glm::dvec3 extent = glm::max(bounds.extent(), glm::dvec3(1e-9));
  bounds_.min -= extent * 1e-6;
  bounds_.max += extent * 1e-6;
  cellSize_ = (bounds_.max - bounds_.min) / double(kCells);
  const auto cellRange = [&](double lo, double hi, int axis, uint32_t& a, uint32_t& b) {
    a = uint32_t(std::clamp((lo - bounds_.min[axis]) / cellSize_[axis], 0.0, double(kCells - 1)));
    b = uint32_t(std::clamp((hi - bounds_.min[axis]) / cellSize_[axis], 0.0, double(kCells - 1)));
  };
  std::vector<uint32_t> counts(size_t(kCells) * kCells * kCells + 1, 0);
  std::vector<std::pair<uint32_t, uint32_t>> entries;  // (cell, triangle)
  for (uint32_t t = 0; t < triangleCount_; ++t) {
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (int k = 0; k < 3; ++k) {
      lo = glm::min(lo, glm::dvec3(triangles.corners[3 * size_t(t) + size_t(k)]));
      hi = glm::max(hi, glm::dvec3(triangles.corners[3 * size_t(t) + size_t(k)]));
    }
    uint32_t a[3], b[3];
    for (int axis = 0; axis < 3; ++axis) cellRange(lo[axis], hi[axis], axis, a[axis], b[axis]);
    // Spanning more than two cells along an axis: never culled (the paper's list of large triangles).
    if (b[0] - a[0] >= 2 || b[1] - a[1] >= 2 || b[2] - a[2] >= 2) {
      uncullable_.push_back(t);
      continue;
    }
    for (uint32_t z = a[2]; z <= b[2]; ++z)
      for (uint32_t y = a[1]; y <= b[1]; ++y)
        for (uint32_t x = a[0]; x <= b[0]; ++x) entries.emplace_back((z * kCells + y) * kCells + x, t);
  }
  for (const auto& [cell, t] : entries) ++counts[cell + 1];
  for (size_t c = 1; c < counts.size(); ++c) counts[c] += counts[c - 1];
  cellStart_ = counts;
  cellTriangles_.resize(entries.size());
  std::vector<uint32_t> fill(counts.begin(), counts.end() - 1);
  for (const auto& [cell, t] : entries) cellTriangles_[fill[cell]++] = t;  // triangles ascending per cell
}

void CasterGrid::markCellsOfBox(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<uint8_t>& cells) const {
  int a[3], b[3];
  for (int axis = 0; axis < 3; ++axis) {
    const double l = std::floor((lo[axis] - bounds_.min[axis]) / cellSize_[axis]);
    const double h = std::floor((hi[axis] - bounds_.min[axis]) / cellSize_[axis]);
    if (h < 0 || l > double(kCells - 1)) return;  // outside the grid: no caster there
    a[axis] = int(std::max(l, 0.0));
    b[axis] = int(std::min(h, double(kCells - 1)));
  }
  for (int z = a[2]; z <= b[2]; ++z)
    for (int y = a[1]; y <= b[1]; ++y)
      for (int x = a[0]; x <= b[0]; ++x) cells[(size_t(z) * kCells + size_t(y)) * kCells + size_t(x)] = 1;
}

// The box swept toward the light (a point light: shrinking onto its position; the sun: moved against its
// direction until it leaves the grid), in steps of at most half a cell, every cell it overlaps marked.
void CasterGrid::sweepToLight(const Light& light, const glm::dvec3& lo, const glm::dvec3& hi,
                              std::vector<uint8_t>& cells) const {
  const double step = 0.5 * std::min({cellSize_.x, cellSize_.y, cellSize_.z});
  if (!hasPosition(light)) {
    const glm::dvec3 toLight = towardLight(light, lo);
    const double length = glm::length(bounds_.max - bounds_.min);
    for (double t = 0; t <= length + step; t += step) markCellsOfBox(lo + toLight * t, hi + toLight * t, cells);
    return;
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  const double distance = glm::length(light.position - centre) + glm::length(hi - lo);
  const int steps = std::max(1, int(std::ceil(distance / step)));
  for (int i = 0; i <= steps; ++i) {
    const double t = double(i) / steps;
    markCellsOfBox(glm::mix(lo, light.position, t), glm::mix(hi, light.position, t), cells);
  }
}

std::vector<uint32_t> CasterGrid::castersOfCells(const std::vector<uint8_t>& cells) const {
  std::vector<uint8_t> keep(triangleCount_, 0);
  for (uint32_t t : uncullable_) keep[t] = 1;
  for (size_t c = 0; c < cells.size(); ++c)
    if (cells[c])
      for (uint32_t i = cellStart_[c]; i < cellStart_[c + 1]; ++i) keep[cellTriangles_[i]] = 1;
  std::vector<uint32_t> kept;
  for (uint32_t t = 0; t < triangleCount_; ++t)
    if (keep[t]) kept.push_back(t);
  return kept;
}

std::vector<uint32_t> CasterGrid::casters(const Light& light, const std::vector<LightView>& mapViews,
                                          const LightReceivers& receivers) const {
  // Receiver cells: each point widened by the lookup's reach in world units at that point.
  std::vector<uint8_t> receiverCells(size_t(kCells) * kCells * kCells, 0);
  for (const glm::vec3& point : receivers.points) {
    const glm::dvec3 p(point);
    const auto view = selectView(light, mapViews, p);
    if (!view) continue;  // outside the light's influence: no lookup
    const LightView& v = mapViews[*view];
    double texel = std::max(v.xMax - v.xMin, v.yMax - v.yMin) / double(v.resolution);
    if (v.projection == Projection::Perspective) texel *= std::max(toGrid(v, p).depth, 0.0);
    const double r = receivers.reachTexels * texel;
    markCellsOfBox(p - glm::dvec3(r), p + glm::dvec3(r), receiverCells);
  }
  // Each receiver cell joined to the light.
  std::vector<uint8_t> crossed(receiverCells.size(), 0);
  for (uint32_t z = 0; z < kCells; ++z)
    for (uint32_t y = 0; y < kCells; ++y)
      for (uint32_t x = 0; x < kCells; ++x) {
        if (!receiverCells[(size_t(z) * kCells + y) * kCells + x]) continue;
        const glm::dvec3 lo = bounds_.min + glm::dvec3(x, y, z) * cellSize_;
        sweepToLight(light, lo, lo + cellSize_, crossed);
      }
  return castersOfCells(crossed);
}

// ---- Bittner et al.'s receiver mask ----------------------------------------------------------------------

std::vector<uint32_t> receiverMaskCull(const CasterTriangles& triangles, const LightView& mapView,
                                       const LightReceivers& receivers, ReceiverMaskVariant variant) {
  constexpr uint32_t kCellTexels = 8;
  const ViewMapping m(mapView);
  const uint32_t size = mapView.resolution, cells = (size + kCellTexels - 1) / kCellTexels;
  // Per mask cell the farthest receiver's 16-bit depth (the map's quantisation), -1 where none.
  std::vector<int32_t> farthest(size_t(cells) * cells, -1);
  const double reach = receivers.reachTexels;
  auto markRect = [&](double u0, double u1, double v0, double v1, int32_t q) {
    const double lo = 0, hi = double(cells - 1);
    if (u1 + reach < 0 || v1 + reach < 0 || u0 - reach >= size || v0 - reach >= size) return;
    const uint32_t x0 = uint32_t(std::clamp(std::floor((u0 - reach) / kCellTexels), lo, hi));
    const uint32_t x1 = uint32_t(std::clamp(std::floor((u1 + reach) / kCellTexels), lo, hi));
    const uint32_t y0 = uint32_t(std::clamp(std::floor((v0 - reach) / kCellTexels), lo, hi));
    const uint32_t y1 = uint32_t(std::clamp(std::floor((v1 + reach) / kCellTexels), lo, hi));
    for (uint32_t y = y0; y <= y1; ++y)
      for (uint32_t x = x0; x <= x1; ++x) farthest[size_t(y) * cells + x] = std::max(farthest[size_t(y) * cells + x], q);
  };
  const auto quantized = [&](double s) { return int32_t(quantizeSlice(std::clamp(s, 0.0, double(size)), size)); };
  if (variant == ReceiverMaskVariant::Fragments) {
    for (const glm::vec3& point : receivers.points) {
      const GridPoint g = toGrid(m, glm::dvec3(point));
      if (!g.inFront) continue;  // behind the eye: looked up as lit, never shadowed
      markRect(g.uvs.x, g.uvs.x, g.uvs.y, g.uvs.y, quantized(g.uvs.z));
    }
  } else {
    for (size_t b = 0; b + 1 < receivers.boxes.size(); b += 2) {
      const glm::dvec3 lo(receivers.boxes[b]), hi(receivers.boxes[b + 1]);
      glm::dvec3 gMin(std::numeric_limits<double>::infinity()), gMax(-std::numeric_limits<double>::infinity());
      bool behind = false;
      for (int c = 0; c < 8; ++c) {
        const GridPoint g = toGrid(m, glm::dvec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z));
        behind |= !g.inFront;
        gMin = glm::min(gMin, g.uvs);
        gMax = glm::max(gMax, g.uvs);
      }
      // A box reaching behind a perspective eye projects without bound: the whole mask.
      if (behind) markRect(-reach, size + reach, -reach, size + reach, int32_t(ShadowMap16::kFar));
      else markRect(gMin.x, gMax.x, gMin.y, gMax.y, quantized(gMax.z));
    }
  }
  std::vector<uint32_t> kept;
  for (uint32_t t = 0; t < triangles.count(); ++t) {
    glm::dvec3 g[3];
    if (!gridCorners(triangles, t, m, g)) {
      if (!wholyBehind(triangles, t, m)) kept.push_back(t);
      continue;
    }
    if (!mayCoverMap(g, m.resolution)) continue;
    // The nearest point of a triangle is a corner (depth is affine across it, the slice monotonic in depth).
    const int32_t nearest = quantized(std::min({g[0].z, g[1].z, g[2].z}));
    const double lo = 0, hi = double(cells - 1);
    const uint32_t x0 = uint32_t(std::clamp(std::floor(std::min({g[0].x, g[1].x, g[2].x}) / kCellTexels), lo, hi));
    const uint32_t x1 = uint32_t(std::clamp(std::floor(std::max({g[0].x, g[1].x, g[2].x}) / kCellTexels), lo, hi));
    const uint32_t y0 = uint32_t(std::clamp(std::floor(std::min({g[0].y, g[1].y, g[2].y}) / kCellTexels), lo, hi));
    const uint32_t y1 = uint32_t(std::clamp(std::floor(std::max({g[0].y, g[1].y, g[2].y}) / kCellTexels), lo, hi));
    bool meets = false;
    for (uint32_t y = y0; y <= y1 && !meets; ++y)
      for (uint32_t x = x0; x <= x1 && !meets; ++x) meets = farthest[size_t(y) * cells + x] >= nearest;
    if (meets) kept.push_back(t);
  }
  return kept;
}

}  // namespace cpvs
