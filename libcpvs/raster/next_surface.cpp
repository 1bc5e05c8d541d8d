#include "libcpvs/raster/next_surface.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

#include "libcpvs/base/parallel.h"
#include "libcpvs/raster/raster_triangle.h"
#include "libcpvs/raster/slice_table.h"

namespace cpvs {
namespace {

// Calls fn(j, i0, i1, exactBegin, exactEnd, rowQ) for each row j in [rowBegin, rowEnd) of the triangle grown by
// `reach` texels: the texels [i0, i1) whose centre lies within `reach` texels (in x and in y) of a covered texel
// centre, a superset of it, and among them the covered ones [exactBegin, exactEnd) (the coverage scanTriangle
// decides).
template <class Wide, class Fn>
void scanGrown(const RasterTriangle& t, int32_t reach, int32_t rowBegin, int32_t rowEnd, Fn&& fn) {
  const int32_t jBegin = std::max(t.j0, rowBegin), jEnd = std::min(t.j1 + 1, rowEnd);
  if (jBegin >= jEnd) return;  // most triangles miss a band: skip them before setting up their edges
  const Edge<Wide> edges[3] = {{t.x[0], t.y[0], t.x[1], t.y[1]}, {t.x[1], t.y[1], t.x[2], t.y[2]},
                               {t.x[2], t.y[2], t.x[0], t.y[0]}};
  for (int32_t j = jBegin; j < jEnd; ++j) {
    const Wide py = Wide(256) * j + 128;
    int64_t lo = t.i0, hi = t.i1, exactLo = t.i0, exactHi = t.i1;
    for (const Edge<Wide>& e : edges) {
      const Wide w = e.a * 128 + e.b * py + e.c;
      // Moving a texel centre by `reach` texels in x and in y changes E by at most 256 reach (|a| + |b|).
      const Wide slack = Wide(256) * reach * ((e.a < 0 ? -e.a : e.a) + (e.b < 0 ? -e.b : e.b));
      clipSpan<Wide>(w, e.a * 256, e.threshold - slack, lo, hi);
      clipSpan<Wide>(w, e.a * 256, e.threshold, exactLo, exactHi);
    }
    if (lo > hi) continue;
    if (exactLo > exactHi) exactLo = exactHi = lo - 1;  // nothing covered: an empty range
    const double rowQ = t.q0 + t.kv * (double(t.y0 + j) + t.dv);
    fn(j, int32_t(lo), int32_t(hi) + 1, int32_t(exactLo), int32_t(exactHi) + 1, rowQ);
  }
}

// A surface counts for a texel from the first key of its exit slice on (a summarised tile: its minExit).
// Texels whose exit is N (nothing seen, or inside a solid to the far plane) need no next surface. Per row and
// 8 texels, the least threshold (infinite where none is needed): a triangle wholly in front of it there (its
// keys along a row are monotone, so its two ends say) is skipped without visiting the texels, which spares
// most first surfaces their own texels.
// Fills in each texel's threshold and each chunk's least (`chunks` per row); returns whether any texel needs a
// next surface.
bool findThresholds(const DepthRegion& region, const SliceTable& table, uint32_t chunks,
                    std::vector<double>& threshold, std::vector<double>& chunkMin) {
  const RegionRect& rect = region.rect;
  const uint32_t n = region.resolution, width = rect.width;
  const size_t texels = size_t(rect.width) * rect.height;
  constexpr double kNone = std::numeric_limits<double>::infinity();
  threshold.assign(texels, kNone);
  chunkMin.assign(size_t(rect.height) * chunks, kNone);
  bool anyNeeded = false;
  for (uint32_t j = 0; j < rect.height; ++j) {
    for (uint32_t tx = 0; tx < chunks; ++tx) {
      const bool summarized = region.summarized(tx, j / 8);
      const uint32_t tileExit = summarized ? region.tiles[size_t(j / 8) * chunks + tx].minExit : n;
      double least = kNone;
      for (uint32_t i = tx * 8; i < tx * 8 + 8; ++i) {
        const size_t at = size_t(j) * width + i;
        const uint32_t x = summarized ? tileExit : region.exit[at];
        if (x >= n) continue;
        threshold[at] = table.bound[x];
        least = std::min(least, threshold[at]);
      }
      chunkMin[size_t(j) * chunks + tx] = least;
      anyNeeded = anyNeeded || least != kNone;
    }
  }
  return anyNeeded;
}

// The next slices of the rows [r0, r1), from the nearest key each texel found (none: +inf).
void sliceNextSurfaces(const SliceTable& table, const std::vector<float>& nearest, uint32_t width, uint32_t n,
                       int32_t r0, int32_t r1, DepthTexels& next) {
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  for (int32_t j = r0; j < r1; ++j) {
    uint32_t hint = 0;
    for (size_t at = size_t(j) * width; at < size_t(j + 1) * width; ++at) {
      if (nearest[at] == kInfinity) continue;
      hint = table.slice(nearest[at], hint);
      next[at] = std::min(n, hint);
    }
  }
}

}  // namespace

void findNextSurfaces(const ViewGeometry& regionGeometry, const LightView& view, DepthRegion& region) {
  const RegionRect& rect = region.rect;
  const uint32_t n = region.resolution, width = rect.width;
  const size_t texels = size_t(rect.width) * rect.height;
  region.next.resize(texels);
  std::fill(region.next.begin(), region.next.end(), n);
  if (view.empty || regionGeometry.triangleCount() == 0) return;

  // Kept between the regions a thread renders: allocating them anew cost a page fault per 4 KiB every region.
  // Bound to references here: the workers below must see this thread's copies, not their own.
  struct Scratch {
    SliceTable table;
    std::vector<double> threshold, chunkMin;
    std::vector<float> nearest;
  };
  thread_local Scratch scratch;
  SliceTable& table = scratch.table;
  std::vector<double>&threshold = scratch.threshold, &chunkMin = scratch.chunkMin;
  std::vector<float>& nearest = scratch.nearest;
  const DepthFunction depthOf(view);
  if (!table.matches(view, depthOf.mode)) table.build(view, depthOf);
  const double keySign = depthOf.mode >= 2 ? -1.0 : 1.0;  // keys grow with depth, as the renderers compare them
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  const uint32_t chunks = width / 8;
  const bool anyNeeded = findThresholds(region, table, chunks, threshold, chunkMin);
  nearest.assign(texels, kInfinity);
  if (!anyNeeded) return;

  std::vector<MaskedTriangle> masked;
  const std::vector<RasterTriangle> triangles =
      setUpRasterTriangles(regionGeometry, view, rect, masked, kNextSurfaceReach);
  constexpr uint32_t kBandRows = 32;
  const uint32_t bands = (rect.height + kBandRows - 1) / kBandRows;
  parallelFor(bands, [&](size_t b) {
    const int32_t r0 = int32_t(b * kBandRows), r1 = int32_t(std::min<size_t>(rect.height, (b + 1) * kBandRows));
    for (const RasterTriangle& t : triangles) {
      if (t.j1 < r0 || t.j0 >= r1) continue;
      // A lookup from a receiver on this plane reaches texel c at a depth no deeper than the plane's at c's
      // centre (the bias puts every texel centre of its footprint behind the point, docs/query.md "Bias"), and
      // at most `spread` in front of it: half the footprint plus the receiver's own texel, each at the plane's
      // slope, and the margin's quarter voxel scaled by the tilt (under a quarter of the same slope plus one).
      const double spread = (std::abs(t.ku) + std::abs(t.kv)) * (kNextSurfaceReach + 1.25);
      const auto row = [&](int32_t j, int32_t i0, int32_t i1, int32_t exactBegin, int32_t exactEnd, double rowQ) {
        const size_t rowStart = size_t(j) * width;
        const double* least = &chunkMin[size_t(j) * chunks];
        const auto keyAt = [&](int32_t i) {
          return keySign * std::clamp(rowQ + t.ku * (double(t.x0 + i) + t.du), t.qMin, t.qMax);
        };
        for (int32_t c = i0 / 8; c * 8 < i1; ++c) {
          const int32_t a = std::max(i0, c * 8), b = std::min(i1, c * 8 + 8);
          if (std::max(keyAt(a), keyAt(b - 1)) < least[c]) continue;
          if (t.masked < 0) {
            // Without branches (GCC 12 does not vectorise it as written; a SIMD copy is left to do): a candidate
            // in front of the exit is +inf, one reaching in front of it takes the threshold rounded to float,
            // whose slice is at most the exit's and so gives the same window (see the header).
            const double* thresholdAt = &threshold[rowStart];
            float* nearestAt = &nearest[rowStart];
            for (int32_t i = a; i < b; ++i) {
              const double q = rowQ + t.ku * (double(t.x0 + i) + t.du);
              const double centre = keySign * std::clamp(q, t.qMin, t.qMax);
              const float nearKey = float(keySign * std::clamp(q - keySign * spread, t.qMin, t.qMax));
              const double limit = thresholdAt[i];
              float key = double(nearKey) < limit ? float(limit) : nearKey;
              key = centre < limit ? kInfinity : key;
              nearestAt[i] = std::min(nearestAt[i], key);
            }
            continue;
          }
          for (int32_t i = a; i < b; ++i) {
            const size_t at = rowStart + size_t(i);
            const double q = rowQ + t.ku * (double(t.x0 + i) + t.du);
            // In front of the exit at c's centre: its lookups at c land where the chain is exact.
            if (keySign * std::clamp(q, t.qMin, t.qMax) < threshold[at]) continue;
            const float nearKey = float(keySign * std::clamp(q - keySign * spread, t.qMin, t.qMax));
            const float key = double(nearKey) < threshold[at] ? float(threshold[at]) : nearKey;
            if (key >= nearest[at]) continue;
            if (i >= exactBegin && i < exactEnd && !masked[size_t(t.masked)].blocksAt(t.x0 + i, t.y0 + j)) continue;
            nearest[at] = key;
          }
        }
      };
      bool fast = true;
      for (int k = 0; k < 3; ++k) fast = fast && std::llabs(t.x[k]) < kFastLimit && std::llabs(t.y[k]) < kFastLimit;
      if (fast)
        scanGrown<int64_t>(t, kNextSurfaceReach, r0, r1, row);
      else
        scanGrown<__int128>(t, kNextSurfaceReach, r0, r1, row);
    }
    sliceNextSurfaces(table, nearest, width, n, r0, r1, region.next);
  }, 1);
}

}  // namespace cpvs
