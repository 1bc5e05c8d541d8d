#pragma once
// A triangle as the CPU rasteriser sees it in one region: vertices snapped to 1/256 texel, exact integer edge
// functions, the depth plane, and the row-by-row scan that decides coverage (docs/depth-maps.md, "The CPU
// rasteriser"). Shared by the per-texel passes and the uniform-tile classification, so both decide coverage
// and depth keys with the very same arithmetic.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "libcpvs/raster/triangle_setup.h"
#include "libcpvs/scene/coverage_mask.h"
#include "libcpvs/views/view_geometry.h"
#include "libcpvs/views/view_regions.h"

namespace cpvs {

// Kind ranks: on an exact depth tie the lower rank is the enter surface (the GL renderer draws open, then closed
// back, then closed front faces with GL_LESS), so a tie never makes the exit later.
enum Kind : uint8_t { kOpen = 0, kClosedBack = 1, kClosedFront = 2, kNone = 3 };

// A triangle ready to rasterise in one region: snapped vertices relative to the region's origin (1/256 texel,
// counter-clockwise), the depth plane, and what it is.
struct RasterTriangle {
  int64_t x[3], y[3];
  // q at region texel (i, j), i.e. view texel (X, Y) = (x0 + i, y0 + j): q0 + kv (Y + dv) + ku (X + du), clamped
  // to [qMin, qMax]; evaluated in view coordinates, so a texel's depth does not depend on the region split.
  double q0, ku, kv, du, dv, qMin, qMax;
  int32_t x0, y0;
  Kind kind;
  int32_t i0, i1, j0, j1;         // covered texels lie in [i0, i1] x [j0, j1] (region coordinates)
  int32_t masked = -1;            // alpha-tested: index into the region's MaskedTriangle list
};

// What an alpha-tested triangle is cut by, and where its mask is looked up.
struct MaskedTriangle {
  const CoverageMask* mask;
  MaskInterpolation uv;
  // Whether the triangle blocks light at view texel (X, Y)'s centre.
  bool blocksAt(int64_t x, int64_t y) const {
    double u, v;
    if (!uv.at(double(x) + 0.5, double(y) + 0.5, u, v)) return true;
    return mask->blocksAt(u, v);
  }
};

// Coordinates below 2^29 (in 1/256 texel) keep every edge function within int64.
constexpr int64_t kFastLimit = int64_t(1) << 29;

template <class Wide>
struct Edge {
  Wide a, b, c;  // E(px, py) = a px + b py + c, inside when > 0, or == 0 on a top-left edge
  Wide threshold;  // inside when E >= threshold (E is an integer)
  Edge(int64_t x0, int64_t y0, int64_t x1, int64_t y1) {
    const int64_t dx = x1 - x0, dy = y1 - y0;
    a = -Wide(dy);
    b = Wide(dx);
    c = Wide(dy) * x0 - Wide(dx) * y0;
    // Counter-clockwise in a y-up window: left edges run downward, top edges run toward -x.
    threshold = (dy < 0 || (dy == 0 && dx < 0)) ? 0 : 1;
  }
};

template <class Wide>
Wide floorDiv(Wide num, Wide den) {  // den > 0
  const Wide q = num / den;
  return (num % den != 0 && num < 0) ? q - 1 : q;
}

// Narrows [lo, hi] to the texels i whose centre satisfies the edge on the row where E(i) = w + step i.
template <class Wide>
void clipSpan(Wide w, Wide step, Wide threshold, int64_t& lo, int64_t& hi) {
  if (step == 0) {
    if (w < threshold) hi = lo - 1;
  } else if (step > 0) {  // i >= (threshold - w) / step
    const Wide first = -floorDiv<Wide>(w - threshold, step);
    if (first > Wide(lo)) lo = first > Wide(hi) ? hi + 1 : int64_t(first);
  } else {  // i <= (w - threshold) / -step
    const Wide last = floorDiv<Wide>(w - threshold, -step);
    if (last < Wide(hi)) hi = last < Wide(lo) ? lo - 1 : int64_t(last);
  }
}

// Calls fn(j, iBegin, iEnd, rowQ) for each row j in [rowBegin, rowEnd) the triangle covers: texels (i, j) with i
// in [iBegin, iEnd), each at depth depthAt(t, rowQ, i). Spans come from the edge functions solved exactly in
// integers, so the coverage is the per-texel test's.
template <class Wide, class Fn>
void scanTriangle(const RasterTriangle& t, int32_t rowBegin, int32_t rowEnd, Fn&& fn) {
  const Edge<Wide> edges[3] = {{t.x[0], t.y[0], t.x[1], t.y[1]}, {t.x[1], t.y[1], t.x[2], t.y[2]},
                               {t.x[2], t.y[2], t.x[0], t.y[0]}};
  const int32_t jBegin = std::max(t.j0, rowBegin), jEnd = std::min(t.j1 + 1, rowEnd);
  for (int32_t j = jBegin; j < jEnd; ++j) {
    const Wide py = Wide(256) * j + 128;
    int64_t lo = t.i0, hi = t.i1;
    for (const Edge<Wide>& e : edges) {
      // E at texel i's centre (256 i + 128, py).
      const Wide w = e.a * 128 + e.b * py + e.c;
      clipSpan<Wide>(w, e.a * 256, e.threshold, lo, hi);
    }
    if (lo <= hi) fn(j, int32_t(lo), int32_t(hi) + 1, t.q0 + t.kv * (double(t.y0 + j) + t.dv));
  }
}

inline double depthAt(const RasterTriangle& t, double rowQ, int64_t i) {
  return std::clamp(rowQ + t.ku * (double(t.x0 + i) + t.du), t.qMin, t.qMax);
}

// A triangle's depth keys along one row (depthAt, then the key's sign), held by value: the loops over a row
// store through uint8_t pointers, which may alias anything, so fields read through the triangle would be
// reloaded after every store.
struct RowKeys {
  double rowQ, ku, du, qMin, qMax, sign;
  int64_t x0;
  RowKeys(const RasterTriangle& t, double q, double keySign)
      : rowQ(q), ku(t.ku), du(t.du), qMin(t.qMin), qMax(t.qMax), sign(keySign), x0(t.x0) {}
  float at(int64_t i) const { return float(sign * std::clamp(rowQ + ku * (double(x0 + i) + du), qMin, qMax)); }
};

template <class Fn>
void scan(const RasterTriangle& t, int32_t rowBegin, int32_t rowEnd, Fn&& fn) {
  bool fast = true;
  for (int k = 0; k < 3; ++k) fast = fast && std::llabs(t.x[k]) < kFastLimit && std::llabs(t.y[k]) < kFastLimit;
  if (fast)
    scanTriangle<int64_t>(t, rowBegin, rowEnd, fn);
  else
    scanTriangle<__int128>(t, rowBegin, rowEnd, fn);
}

// The view's triangles that reach `rect`, snapped relative to its origin (perspective ones clipped at near / 2 and
// fanned, as GL clips them); alpha-tested ones get an entry in `masked`. With `dilate` > 0, also those that come
// within that many texels of it, with their texel box [i0, i1] x [j0, j1] grown as much (clamped to `rect`).
std::vector<RasterTriangle> setUpRasterTriangles(const ViewGeometry& geometry, const LightView& view,
                                                 const RegionRect& rect, std::vector<MaskedTriangle>& masked,
                                                 int32_t dilate = 0);

}  // namespace cpvs
