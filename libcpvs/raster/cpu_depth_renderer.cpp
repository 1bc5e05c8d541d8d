#include "libcpvs/raster/cpu_depth_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/raster/triangle_setup.h"

namespace cpvs {
namespace {

// Kind ranks: on an exact depth tie the lower rank is the enter surface (the GL renderer draws open, then closed
// back, then closed front faces with GL_LESS), so a tie never makes the exit later.
enum Kind : uint8_t { kOpen = 0, kClosedBack = 1, kClosedFront = 2, kNone = 3 };

// Peel states of a texel (the GL renderer's counts).
enum State : uint8_t { kInactive = 0, kActive = 1, kExitFound = 2, kCapped = 3, kStuck = 4 };

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// The largest float below x (x finite or +infinity).
inline float floatBefore(float x) {
  if (x == 0.0f) return -std::numeric_limits<float>::denorm_min();
  uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits = x > 0.0f ? bits - 1 : bits + 1;
  std::memcpy(&x, &bits, sizeof bits);
  return x;
}

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

// The closed crossings a texel's lockstep peel consumes, kept from the one pass that finds its enter surface: the
// P + 1 nearest distinct closed front keys (the first is the enter surface when it is a closed front; the peel
// consumes F2 .. F(P+1)), the P nearest distinct closed back keys, and per back key whether several closed back
// faces lie exactly there (a repeated back layer is an exit). P = the peel cap.
template <int P>
struct KeptCrossings {
  float front[P + 1];
  float back[P];
  uint8_t backRepeated;  // bit k: back[k] was met more than once

  void clear() {
    for (float& f : front) f = kInfinity;
    for (float& b : back) b = kInfinity;
    backRepeated = 0;
  }
  void addFront(float key) {
    if (!(key < front[P])) return;
    for (int k = 0; k < P; ++k)
      if (key == front[k]) return;  // coincident front faces count once, as the peel's strict "beyond" test
    int at = P;
    for (; at > 0 && key < front[at - 1]; --at) front[at] = front[at - 1];
    front[at] = key;
  }
  void addBack(float key) {
    if (!(key <= back[P - 1])) return;
    for (int k = 0; k < P; ++k)
      if (key == back[k]) {
        backRepeated |= uint8_t(1u << k);
        return;
      }
    int at = P - 1;
    for (; at > 0 && key < back[at - 1]; --at) back[at] = back[at - 1];
    back[at] = key;
    // Flags follow their keys: those from `at` on move up one place, the last one drops out with its key.
    const unsigned below = backRepeated & ((1u << at) - 1u), above = (backRepeated >> at) << (at + 1);
    backRepeated = uint8_t((below | above) & ((1u << P) - 1u));
  }
};

// One texel's lockstep peel over its kept crossings, `iterations` iterations of a peel capped at `cap`: the
// passes' per-texel rule (below) applied to the layers each iteration would find.
struct ReplayedTexel {
  uint8_t state;
  uint8_t finishedAt;  // the iteration (1-based) that found the exit or no back face; cap + 1 when none did
  float frontCursor, backCursor;
};

template <int P>
ReplayedTexel replayTexel(const KeptCrossings<P>& kept, float enterKey, uint32_t iterations, uint32_t cap) {
  ReplayedTexel r{kActive, uint8_t(cap + 1), enterKey, floatBefore(enterKey)};
  for (uint32_t it = 0; it < iterations; ++it) {
    const float f = kept.front[it + 1], b = kept.back[it];
    if (b == kInfinity) {
      r.state = kStuck;
      r.finishedAt = uint8_t(it + 1);
      return r;
    }
    if (f == kInfinity || b <= f || ((kept.backRepeated >> it) & 1u)) {
      r.backCursor = b;
      r.state = kExitFound;
      r.finishedAt = uint8_t(it + 1);
      return r;
    }
    r.frontCursor = f;
    r.backCursor = b;
    if (it + 1 == cap) r.state = kCapped;
  }
  return r;
}

// The peel caps the replay handles; deeper caps (tests resolve nesting completely with 16) peel in passes.
constexpr uint32_t kMaxReplayedPeels = 3;

class CpuDepthRenderer final : public DepthRenderer {
public:
  explicit CpuDepthRenderer(CpuPeel peelMethod) : peelMethod_(peelMethod) {}
  uint32_t maxRegionSize() const override { return 1u << 14; }
  std::string description() const override { return "cpvs CPU rasteriser"; }
  DepthRegion render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                     const PeelSettings& peel, RenderStats* stats, const RowSpans* needed) override;

private:
  CpuPeel peelMethod_;
  SliceTable slices_;
  std::vector<uint8_t> crossings_;  // KeptCrossings<P> per texel (replay)
  // Per-texel state, kept between regions (allocating it anew cost a page fault per 4 KiB every region).
  std::vector<float> enterKey_, frontCursor_, backCursor_, nearestFront_, nearestBack_;
  std::vector<uint8_t> kind_, state_;
  std::vector<uint16_t> backCount_;
  std::vector<RasterTriangle> setUp(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                                    std::vector<MaskedTriangle>& masked) const;
};

// Snaps one (sub)triangle and appends it when it covers part of the region.
void addTriangle(std::vector<RasterTriangle>& out, const double (&u)[3], const double (&v)[3], const TriangleSetup& s,
                 bool closed, bool mirrored, const RegionRect& rect, int32_t masked) {
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
  t.i0 = std::max(0, first(std::min({t.x[0], t.x[1], t.x[2]})));
  t.i1 = std::min(int32_t(rect.width) - 1, last(std::max({t.x[0], t.x[1], t.x[2]})));
  t.j0 = std::max(0, first(std::min({t.y[0], t.y[1], t.y[2]})));
  t.j1 = std::min(int32_t(rect.height) - 1, last(std::max({t.y[0], t.y[1], t.y[2]})));
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

std::vector<RasterTriangle> CpuDepthRenderer::setUp(const ViewGeometry& geometry, const LightView& view,
                                                    const RegionRect& rect, std::vector<MaskedTriangle>& masked) const {
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
      addTriangle(out, s.u, s.v, s, closed, mirrored, rect, maskedIndex);
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
      addTriangle(out, tu, tv, s, closed, mirrored, rect, maskedIndex);
    }
  }
  return out;
}

DepthRegion CpuDepthRenderer::render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                                     const PeelSettings& peel, RenderStats* stats, const RowSpans* needed) {
  const uint32_t n = view.resolution;
  if (n == 0 || rect.width == 0 || rect.height == 0 || uint64_t(rect.x0) + rect.width > n ||
      uint64_t(rect.y0) + rect.height > n || rect.width > maxRegionSize() || rect.height > maxRegionSize())
    throw Error(ErrorCategory::InvalidArgument, "depth renderer: region " + std::to_string(rect.x0) + "," +
                                                    std::to_string(rect.y0) + " " + std::to_string(rect.width) + "x" +
                                                    std::to_string(rect.height) + " is empty, too large or outside the " +
                                                    std::to_string(n) + "^2 view");
  DepthRegion region;
  region.rect = rect;
  region.resolution = n;
  const size_t texels = size_t(rect.width) * rect.height;
  RenderStats local;
  const Stopwatch phase;

  const ViewGeometry culled = cullToRegion(geometry, rect);
  local.trianglesSubmitted = culled.triangleCount();
  region.enter.assign(texels, n);
  region.exit.assign(texels, n);
  if (view.empty || local.trianglesSubmitted == 0) {
    if (stats) *stats = local;
    return region;
  }
  std::vector<MaskedTriangle> masked;
  const std::vector<RasterTriangle> triangles = setUp(culled, view, rect, masked);
  const DepthFunction depthOf(view);
  // Comparisons run on a key that grows with depth: q itself (orthographic) or -q (perspective, q = 1/d), in
  // float like the GL renderer's depth buffer, so surfaces that meet (a box standing on another) tie as there.
  const double keySign = depthOf.mode >= 2 ? -1.0 : 1.0;
  const auto keyOf = [&](double q) { return float(keySign * q); };
  if (!slices_.matches(view, depthOf.mode)) slices_.build(view, depthOf);
  const uint32_t width = rect.width;
  // Row bands processed in parallel: every band owns its texels, so the result does not depend on scheduling.
  constexpr uint32_t kBandRows = 32;
  const uint32_t bands = (rect.height + kBandRows - 1) / kBandRows;
  const auto forBands = [&](auto&& body) {
    parallelFor(bands, [&](size_t b) {
      const int32_t r0 = int32_t(b * kBandRows), r1 = int32_t(std::min<size_t>(rect.height, (b + 1) * kBandRows));
      body(r0, r1);
    }, 1);
  };

  std::vector<float>& enterKey = enterKey_;
  std::vector<uint8_t>& kind = kind_;
  std::vector<uint8_t>& state = state_;
  std::vector<float>&frontCursor = frontCursor_, &backCursor = backCursor_;
  state.assign(texels, kInactive);
  enterKey.resize(texels);
  kind.resize(texels);
  // Raw pointers for the per-texel loops: stores through uint8_t may alias anything, so the compiler would
  // reload every vector's data pointer after each of them.
  float* const enterKeyAt = enterKey.data();
  uint8_t* const kindAt = kind.data();
  uint8_t* const stateAt = state.data();
  uint32_t* const enterOut = region.enter.data();
  uint32_t* const exitOut = region.exit.data();
  const SliceTable& table = slices_;
  // Integer slices of one texel: e from its enter key; x from its peel's outcome (state, and the key of the last
  // layer consumed). Hints: the row's previous slices.
  const auto sliceTexel = [=, &table](size_t at, uint8_t texelState, float exitKey, uint32_t& enterHint,
                                      uint32_t& exitHint) {
    const uint8_t k = kindAt[at];
    if (k == kNone) return;
    enterHint = table.slice(enterKeyAt[at], enterHint);
    const uint32_t e = std::min(n - 1, enterHint);
    enterOut[at] = e;
    uint32_t x = e + 1;
    if (k == kClosedFront && texelState != kInactive) {
      if (texelState == kStuck) {
        x = n;
      } else {
        exitHint = table.slice(exitKey, exitHint);
        x = std::min(n, std::max(e + 1, exitHint));
      }
    }
    exitOut[at] = x;
  };

  // The texels of each row the caller needs (all of them without `needed`): the replay visits only those.
  if (needed && (needed->begin.size() != rect.height || needed->end.size() != rect.height))
    throw Error(ErrorCategory::InvalidArgument, "depth renderer: needed texels given for " +
                                                    std::to_string(needed->begin.size()) + " rows of a region of " +
                                                    std::to_string(rect.height));
  const auto spanBegin = [&](int32_t j) { return needed ? int32_t(std::min(needed->begin[j], width)) : 0; };
  const auto spanEnd = [&](int32_t j) {
    return needed ? std::max(spanBegin(j), int32_t(std::min(needed->end[j], width))) : int32_t(width);
  };

  // Replays each texel's lockstep peel from the crossings one pass keeps (same maps as the passes below).
  const auto replayWith = [&](auto cap) {
    constexpr int P = decltype(cap)::value;
    using Kept = KeptCrossings<P>;
    crossings_.resize(texels * sizeof(Kept));
    Kept* const kept = reinterpret_cast<Kept*>(crossings_.data());
    std::vector<std::array<uint64_t, P + 2>> finishedAt(bands);  // per band: texels by the iteration they leave
    std::vector<std::pair<double, double>> bandMs(bands);  // CPU ms per band: scan, replay and slices
    // 1. One pass: the nearest surface, its kind, and the closed crossings behind it.
    forBands([&](int32_t r0, int32_t r1) {
      const Stopwatch scanTime;
      const size_t b0 = size_t(r0) * width, b1 = size_t(r1) * width;
      std::fill(enterKey.begin() + b0, enterKey.begin() + b1, kInfinity);
      std::fill(kind.begin() + b0, kind.begin() + b1, uint8_t(kNone));
      for (int32_t j = r0; j < r1; ++j) {
        const size_t rowBegin = size_t(j) * width + size_t(spanBegin(j)), rowEnd = size_t(j) * width + size_t(spanEnd(j));
        for (size_t at = rowBegin; at < rowEnd; ++at) kept[at].clear();
      }
      for (const RasterTriangle& t : triangles)
        scan(t, r0, r1, [&](int32_t j, int32_t i0, int32_t i1, double rowQ) {
          i0 = std::max(i0, spanBegin(j));
          i1 = std::min(i1, spanEnd(j));
          float* const keys = enterKeyAt + size_t(j) * width;
          uint8_t* const kinds = kindAt + size_t(j) * width;
          Kept* const row = kept + size_t(j) * width;
          const uint8_t triangleKind = t.kind;
          const RowKeys keyAt(t, rowQ, keySign);
          const auto enter = [=](int32_t i, float key) {
            if (key < keys[i] || (key == keys[i] && triangleKind < kinds[i])) {
              keys[i] = key;
              kinds[i] = triangleKind;
            }
          };
          if (t.masked >= 0) {  // alpha-tested (always open): only texels its mask blocks count
            const MaskedTriangle& m = masked[size_t(t.masked)];
            for (int32_t i = i0; i < i1; ++i) {
              const float key = keyOf(depthAt(t, rowQ, i));
              if ((key < keys[i] || (key == keys[i] && t.kind < kinds[i])) && m.blocksAt(t.x0 + i, t.y0 + j)) {
                keys[i] = key;
                kinds[i] = t.kind;
              }
            }
          } else if (triangleKind == kOpen) {
            for (int32_t i = i0; i < i1; ++i) enter(i, keyAt.at(i));
          } else if (triangleKind == kClosedFront) {
            for (int32_t i = i0; i < i1; ++i) {
              const float key = keyAt.at(i);
              enter(i, key);
              row[i].addFront(key);
            }
          } else {
            for (int32_t i = i0; i < i1; ++i) {
              const float key = keyAt.at(i);
              enter(i, key);
              row[i].addBack(key);
            }
          }
        });
      Stopwatch replayTime;
      // 2. While the band is in cache: each texel's peel replayed to the cap, and its integer slices.
      auto& counts = finishedAt[size_t(r0) / kBandRows];
      counts.fill(0);
      for (int32_t j = r0; j < r1; ++j) {
        uint32_t enterHint = 0, exitHint = 0;
        const size_t rowBegin = size_t(j) * width + size_t(spanBegin(j)), rowEnd = size_t(j) * width + size_t(spanEnd(j));
        for (size_t at = rowBegin; at < rowEnd; ++at) {
          uint8_t texelState = kInactive;
          float exitKey = 0;
          if (kindAt[at] == kClosedFront) {
            const ReplayedTexel r = replayTexel(kept[at], enterKeyAt[at], P, P);
            texelState = r.state;
            exitKey = std::max(r.frontCursor, r.backCursor);
            ++counts[r.finishedAt];
            stateAt[at] = r.finishedAt;  // kept for the fix-up below
          }
          sliceTexel(at, texelState, exitKey, enterHint, exitHint);
        }
      }
      bandMs[size_t(r0) / kBandRows] = {scanTime.ms() - replayTime.ms(), replayTime.ms()};
    });
    // 3. As many iterations as the passes would run: the cap, or fewer when no texel (or only a handful) is
    // still inside after one. Fewer changes only the texels still inside then, which the early stop keeps few.
    std::array<uint64_t, P + 2> total{};
    for (const auto& counts : finishedAt)
      for (int k = 0; k < P + 2; ++k) total[k] += counts[k];
    uint64_t active = 0;
    for (int k = 1; k < P + 2; ++k) active += total[k];
    uint32_t iterations = 0;
    while (iterations < uint32_t(P) && active > 0) {
      ++iterations;
      active -= total[iterations];
      if (iterations == uint32_t(P)) active = 0;  // capped: no longer active
      if (uint64_t(active) * 1000000u <= uint64_t(peel.stopBelowPerMillion) * texels) break;
    }
    local.peelIterations = iterations;
    for (uint32_t k = iterations + 1; k < uint32_t(P) + 2; ++k) local.texelsAtPeelCap += total[k];
    for (const auto& [scanMs, replayMs] : bandMs) {
      local.enterMs += scanMs;
      local.peelMs += replayMs;
    }
    if (iterations < uint32_t(P)) {
      const Stopwatch fixUp;
      forBands([&](int32_t r0, int32_t r1) {
        for (int32_t j = r0; j < r1; ++j) {
          uint32_t enterHint = 0, exitHint = 0;
          for (size_t at = size_t(j) * width; at < size_t(j + 1) * width; ++at) {
            if (kind[at] != kClosedFront || state[at] <= iterations) continue;
            const ReplayedTexel r = replayTexel(kept[at], enterKey[at], iterations, P);
            sliceTexel(at, r.state, std::max(r.frontCursor, r.backCursor), enterHint, exitHint);
          }
        }
      });
      local.peelMs += fixUp.ms();
    }
  };

  if (peelMethod_ == CpuPeel::Replay && peel.maxPeels >= 1 && peel.maxPeels <= kMaxReplayedPeels) {
    if (peel.maxPeels == 1) replayWith(std::integral_constant<int, 1>{});
    else if (peel.maxPeels == 2) replayWith(std::integral_constant<int, 2>{});
    else replayWith(std::integral_constant<int, 3>{});
  } else {
    frontCursor.resize(texels);
    backCursor.resize(texels);
    // 1. Enter: the nearest surface and its kind.
    std::fill(enterKey.begin(), enterKey.end(), kInfinity);
    std::fill(kind.begin(), kind.end(), uint8_t(kNone));
    forBands([&](int32_t r0, int32_t r1) {
      for (const RasterTriangle& t : triangles)
        scan(t, r0, r1, [&](int32_t j, int32_t i0, int32_t i1, double rowQ) {
          float* keys = &enterKey[size_t(j) * width];
          uint8_t* kinds = &kind[size_t(j) * width];
          if (t.masked >= 0) {  // alpha-tested (always open): only texels its mask blocks count
            const MaskedTriangle& m = masked[size_t(t.masked)];
            for (int32_t i = i0; i < i1; ++i) {
              const float key = keyOf(depthAt(t, rowQ, i));
              if ((key < keys[i] || (key == keys[i] && t.kind < kinds[i])) && m.blocksAt(t.x0 + i, t.y0 + j)) {
                keys[i] = key;
                kinds[i] = t.kind;
              }
            }
            return;
          }
          for (int32_t i = i0; i < i1; ++i) {
            const float key = keyOf(depthAt(t, rowQ, i));
            if (key < keys[i] || (key == keys[i] && t.kind < kinds[i])) {
              keys[i] = key;
              kinds[i] = t.kind;
            }
          }
        });
    });
    local.enterMs = phase.ms();
    const Stopwatch peelTime;

    // 2. Lockstep peeling of the closed solids entered at a closed front face (docs/depth-maps.md).
    std::vector<float>&nearestFront = nearestFront_, &nearestBack = nearestBack_;
    std::vector<uint16_t>& backCount = backCount_;
    size_t active = 0;
    // Per row, the texels [activeBegin, activeEnd) hold every active one: later iterations, with few texels
    // left inside, scan only those.
    std::vector<int32_t> activeBegin(rect.height, 0), activeEnd(rect.height, 0);
    const auto findActive = [&](int32_t j) {
      const uint8_t* row = &state[size_t(j) * width];
      int32_t lo = 0, hi = int32_t(width);
      while (lo < hi && row[lo] != kActive) ++lo;
      while (hi > lo && row[hi - 1] != kActive) --hi;
      activeBegin[j] = lo;
      activeEnd[j] = hi;
    };
    for (size_t i = 0; i < texels; ++i)
      if (kind[i] == kClosedFront) {
        state[i] = kActive;
        ++active;
      }
    for (int32_t j = 0; j < int32_t(rect.height); ++j) findActive(j);
    if (active > 0) {  // a texel entered at a closed front face: there are closed triangles to peel
      frontCursor = enterKey;
      backCursor.resize(texels);
      // Back faces at the enter depth itself (silhouettes, zero thickness) still count: the back cursor starts
      // just before it.
      for (size_t i = 0; i < texels; ++i) backCursor[i] = floatBefore(enterKey[i]);
      nearestFront.resize(texels);
      nearestBack.resize(texels);
      backCount.resize(texels);
      for (uint32_t iteration = 0; iteration < peel.maxPeels && active > 0; ++iteration) {
        ++local.peelIterations;
        const bool lastIteration = iteration + 1 == peel.maxPeels;
        forBands([&](int32_t r0, int32_t r1) {
          const size_t b0 = size_t(r0) * width, b1 = size_t(r1) * width;
          std::fill(nearestFront.begin() + b0, nearestFront.begin() + b1, kInfinity);
          std::fill(nearestBack.begin() + b0, nearestBack.begin() + b1, kInfinity);
          std::fill(backCount.begin() + b0, backCount.begin() + b1, 0);
          bool bandActive = false;
          for (int32_t j = r0; j < r1; ++j) bandActive |= activeBegin[j] < activeEnd[j];
          if (!bandActive) return;
          for (const RasterTriangle& t : triangles) {
            if (t.kind == kOpen) continue;
            const bool front = t.kind == kClosedFront;
            scan(t, r0, r1, [&](int32_t j, int32_t i0, int32_t i1, double rowQ) {
              i0 = std::max(i0, activeBegin[j]);
              i1 = std::min(i1, activeEnd[j]);
              const size_t row = size_t(j) * width;
              for (size_t at = row + size_t(i0); at < row + size_t(i1); ++at) {
                if (state[at] != kActive) continue;
                const float key = keyOf(depthAt(t, rowQ, int64_t(at - row)));
                if (front) {
                  if (key > frontCursor[at] && key < nearestFront[at]) nearestFront[at] = key;
                } else if (key > backCursor[at]) {
                  if (key < nearestBack[at]) {
                    nearestBack[at] = key;
                    backCount[at] = 1;
                  } else if (key == nearestBack[at] && backCount[at] < 0xFFFF) {
                    ++backCount[at];
                  }
                }
              }
            });
          }
          // Consume the nearest front and back layer (ties: back first, an earlier exit is the safe side).
          for (size_t at = b0; at < b1; ++at) {
            if (state[at] != kActive) continue;
            const float f = nearestFront[at], b = nearestBack[at];
            if (b == kInfinity) {
              state[at] = kStuck;  // inside, and no closed back face before the far plane
            } else if (f == kInfinity || b <= f || backCount[at] > 1) {
              backCursor[at] = b;
              state[at] = kExitFound;
            } else {
              frontCursor[at] = f;
              backCursor[at] = b;
              if (lastIteration) state[at] = kCapped;
            }
          }
          for (int32_t j = r0; j < r1; ++j) findActive(j);
        });
        active = size_t(std::count(state.begin(), state.end(), uint8_t(kActive)));
        // A handful of texels left is not worth an iteration: they keep the exit consumed so far.
        if (uint64_t(active) * 1000000u <= uint64_t(peel.stopBelowPerMillion) * texels) break;
      }
    }

    // 3. Integer slices.
    forBands([&](int32_t r0, int32_t r1) {
      for (int32_t j = r0; j < r1; ++j) {
        uint32_t enterHint = 0, exitHint = 0;
        for (size_t at = size_t(j) * width; at < size_t(j + 1) * width; ++at)
          sliceTexel(at, state[at], std::max(frontCursor[at], backCursor[at]), enterHint, exitHint);
      }
    });
    for (size_t at = 0; at < texels; ++at)
      local.texelsAtPeelCap += state[at] == kCapped || state[at] == kActive;
    local.peelMs = peelTime.ms();
  }

  if (stats) *stats = local;
  return region;
}

}  // namespace

std::unique_ptr<DepthRenderer> createCpuDepthRenderer(CpuPeel peel) { return std::make_unique<CpuDepthRenderer>(peel); }

}  // namespace cpvs
