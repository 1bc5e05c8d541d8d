#include "libcpvs/raster/raster_triangle.h"

#include <cmath>

namespace cpvs {
namespace {

// Snaps one (sub)triangle and appends it when it covers part of the region (or, with `dilate`, comes within that
// many texels of a texel of it).
void addTriangle(std::vector<RasterTriangle>& out, const double (&u)[3], const double (&v)[3], const TriangleSetup& s,
                 bool closed, bool mirrored, const RegionRect& rect, int32_t masked, int32_t dilate) {
  RasterTriangle t;
  t.masked = masked;
  constexpr double kLimit = double(int64_t(1) << 60);
  for (int k = 0; k < 3; ++k) {
    const double su = std::round(u[k] * 256.0), sv = std::round(v[k] * 256.0);
    if (!(std::abs(su) < kLimit && std::abs(sv) < kLimit)) return;  // beyond any view: the GL path clips it too
    t.x[k] = int64_t(su) - int64_t(rect.x0) * 256;
    t.y[k] = int64_t(sv) - int64_t(rect.y0) * 256;
  }
  const __int128 area = __int128(t.x[1] - t.x[0]) * (t.y[2] - t.y[0]) - __int128(t.x[2] - t.x[0]) * (t.y[1] - t.y[0]);
  if (area == 0) return;
  const bool ccw = area > 0;
  if (!ccw) {
    std::swap(t.x[1], t.x[2]);
    std::swap(t.y[1], t.y[2]);
  }
  t.kind = !closed ? kOpen : (ccw != mirrored ? kClosedFront : kClosedBack);
  // Texel i's centre is at 256 i + 128.
  const auto first = [](int64_t lo) { return int32_t(std::clamp<int64_t>((lo - 128 + 255) >> 8, -1, 1 << 24)); };
  const auto last = [](int64_t hi) { return int32_t(std::clamp<int64_t>((hi - 128) >> 8, -1, 1 << 24)); };
  t.i0 = std::max(0, first(std::min({t.x[0], t.x[1], t.x[2]})) - dilate);
  t.i1 = std::min(int32_t(rect.width) - 1, last(std::max({t.x[0], t.x[1], t.x[2]})) + dilate);
  t.j0 = std::max(0, first(std::min({t.y[0], t.y[1], t.y[2]})) - dilate);
  t.j1 = std::min(int32_t(rect.height) - 1, last(std::max({t.y[0], t.y[1], t.y[2]})) + dilate);
  if (t.i0 > t.i1 || t.j0 > t.j1) return;
  t.q0 = s.q0;
  t.ku = s.ku;
  t.kv = s.kv;
  t.du = 0.5 - s.u0;
  t.dv = 0.5 - s.v0;
  t.x0 = int32_t(rect.x0);
  t.y0 = int32_t(rect.y0);
  t.qMin = s.qMin;
  t.qMax = s.qMax;
  out.push_back(t);
}

}  // namespace

std::vector<RasterTriangle> setUpRasterTriangles(const ViewGeometry& geometry, const LightView& view,
                                                    const RegionRect& rect, std::vector<MaskedTriangle>& masked,
                                                    int32_t dilate) {
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  const double nearClip = 0.5 * view.near;
  const bool mirrored = glm::determinant(glm::dmat3(view.viewFromWorld)) < 0;
  const size_t closedCount = geometry.closedIndices.size() / 3;
  const size_t count = closedCount + geometry.openIndices.size() / 3;
  std::vector<RasterTriangle> out;
  out.reserve(count);
  for (size_t t = 0; t < count; ++t) {
    const bool closed = t < closedCount;
    const uint32_t* idx = closed ? &geometry.closedIndices[3 * t] : &geometry.openIndices[3 * (t - closedCount)];
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = glm::dvec3(geometry.positions[idx[k]]);
    const TriangleSetup s = setUpTriangle(view, p[0], p[1], p[2]);
    int32_t maskedIndex = -1;
    if (geometry.hasMasks() && geometry.maskOf[t] >= 0) {
      const glm::dvec2 uv[3] = {glm::dvec2(geometry.maskUvs[idx[0]]), glm::dvec2(geometry.maskUvs[idx[1]]),
                                glm::dvec2(geometry.maskUvs[idx[2]])};
      maskedIndex = int32_t(masked.size());
      masked.push_back({&(*geometry.masks)[size_t(geometry.maskOf[t])], setUpMaskInterpolation(view, p, uv)});
    }
    if (s.safe) {
      addTriangle(out, s.u, s.v, s, closed, mirrored, rect, maskedIndex, dilate);
      continue;
    }
    // Clip at d = near / 2, where the GL renderer's homogeneous clipping cuts it, and fan the polygon.
    glm::dvec3 poly[4];
    int m = 0;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 &a = p[k], &b = p[(k + 1) % 3];
      const double da = -a.z - nearClip, db = -b.z - nearClip;
      if (da >= 0) poly[m++] = a;
      if ((da >= 0) != (db >= 0)) poly[m++] = a + (b - a) * (da / (da - db));
    }
    if (m < 3) continue;
    double u[4], v[4];
    for (int k = 0; k < m; ++k) {
      const double d = -poly[k].z;
      u[k] = n * (poly[k].x / d - view.xMin) / ex;
      v[k] = n * (poly[k].y / d - view.yMin) / ey;
    }
    for (int k = 1; k + 1 < m; ++k) {
      const double tu[3] = {u[0], u[k], u[k + 1]}, tv[3] = {v[0], v[k], v[k + 1]};
      addTriangle(out, tu, tv, s, closed, mirrored, rect, maskedIndex, dilate);
    }
  }
  return out;
}

}  // namespace cpvs
