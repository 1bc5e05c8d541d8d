#pragma once
// Integer slices from depth keys by a per-view table of slice boundaries (docs/depth-maps.md, "The CPU rasteriser").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "libcpvs/raster/triangle_setup.h"
#include "libcpvs/runtime/light_view.h"

namespace cpvs {

// Where each slice of a view begins, as a depth key (see render()): bound[s] is the key at t = s / N for
// s = 1..N, with bound[0] = -inf and bound[N + 1] = +inf. A key lies in slice s when bound[s] <= key < bound[s+1]
// (slice N: at or beyond the far plane). Texels along a row change slice by a few at most, so a walk from the
// previous texel's slice replaces a logarithm per texel.
struct SliceTable {
  uint32_t resolution = 0;
  int mode = -1;
  double nearDepth = 0, farDepth = 0;
  std::vector<double> bound;

  bool matches(const LightView& view, int m) const {
    return resolution == view.resolution && mode == m && nearDepth == view.near && farDepth == view.far;
  }
  void build(const LightView& view, const DepthFunction& depth) {
    resolution = view.resolution;
    mode = depth.mode;
    nearDepth = view.near;
    farDepth = view.far;
    const uint32_t n = resolution;
    bound.assign(size_t(n) + 2, 0.0);
    bound[0] = -std::numeric_limits<double>::infinity();
    bound[n + 1] = std::numeric_limits<double>::infinity();
    for (uint32_t s = 1; s <= n; ++s) {
      const double t = double(s) / n;
      double q;  // the inverse of DepthFunction
      if (mode == 0) q = t;
      else if (mode == 1) q = depth.nearDepth * std::exp2(t / depth.scale);
      else if (mode == 2) q = 1.0 / (depth.nearDepth + t / depth.scale);
      else q = std::exp2(-t / depth.scale) / depth.nearDepth;
      bound[s] = mode >= 2 ? -q : q;
    }
  }
  uint32_t slice(float key, uint32_t hint) const {
    const double k = key;
    const double* b = bound.data();
    const uint32_t n = resolution;
    // From the hint, steps of 1, 2, 4, ... until the key is bracketed, then a binary search inside the bracket:
    // a few compares where the slice changes little from texel to texel, a logarithm of the jump where it
    // changes much (grazing surfaces, discontinuities). Invariant: b[lo] <= k < b[hi].
    if (mode == 0) {
      // Orthographic keys are t itself and bound[s] = s / N: floor(k N) names the slice (confirmed by the table,
      // which holds the only s with b[s] <= k < b[s + 1]; a key it does not confirm takes the walk below).
      const double f = std::floor(k * double(n));
      const uint32_t s = f >= 0 ? (f > double(n) ? n : uint32_t(f)) : 0;  // NaN: 0, unconfirmed
      if (b[s] <= k && k < b[s + 1]) return s;
    }
    uint32_t lo, hi;
    if (k >= b[hint + 1]) {
      lo = hint + 1;
      uint32_t step = 1;
      hi = lo + step;
      while (hi <= n && k >= b[hi]) {
        lo = hi;
        step *= 2;
        hi = lo + step;
      }
      hi = std::min(hi, n + 1);
    } else if (k < b[hint]) {
      hi = hint;
      uint32_t step = 1;
      while (hi > step && k < b[hi - step]) {
        hi -= step;
        step *= 2;
      }
      lo = hi > step ? hi - step : 0;
    } else {
      return hint;
    }
    while (hi - lo > 1) {
      const uint32_t mid = lo + (hi - lo) / 2;
      (k >= b[mid] ? lo : hi) = mid;
    }
    return lo;
  }
};

}  // namespace cpvs
