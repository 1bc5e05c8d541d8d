#pragma once
// The CPU rasteriser's passes (docs/depth-maps.md, "The CPU rasteriser"), compiled once per instruction set: each
// of cpu_depth_renderer.cpp (the build's baseline) and cpu_depth_renderer_avx2.cpp (AVX2, for the per-texel
// loops) includes this file with CPVS_RASTER_NAMESPACE naming the namespace its copy lives in, so that the two
// copies never share a symbol. The helpers from other headers stay outside the wider target (they are included
// before it): a copy compiled for AVX2 may inline them, but never emits its own definition of them. So every
// header included here must also be included by cpu_depth_renderer_avx2.cpp before its target begins.
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
#include "libcpvs/raster/cpu_depth_renderer.h"
#include "libcpvs/raster/peel_replay.h"
#include "libcpvs/raster/raster_triangle.h"
#include "libcpvs/raster/slice_table.h"
#include "libcpvs/raster/uniform_tiles.h"

namespace cpvs::CPVS_RASTER_NAMESPACE {
namespace {
// Row j's texels [i0, i1) of an alpha-tested (always open) triangle: only those its mask blocks may become the
// enter surface (a lower kind wins an exact tie, as for every triangle).
void enterMaskedSpan(const RasterTriangle& t, const MaskedTriangle& m, double rowQ, double keySign, int32_t j,
                     int32_t i0, int32_t i1, float* keys, uint8_t* kinds) {
  for (int32_t i = i0; i < i1; ++i) {
    const float key = float(keySign * depthAt(t, rowQ, i));
    if ((key < keys[i] || (key == keys[i] && t.kind < kinds[i])) && m.blocksAt(t.x0 + i, t.y0 + j)) {
      keys[i] = key;
      kinds[i] = t.kind;
    }
  }
}

// Row texels [i0, i1) of a triangle of kind `Kind` in the enter pass: the nearest key and its kind per texel (a
// lower kind wins an exact tie), and for a closed triangle the crossing the replay keeps (texel i's at
// kept[i - i0]). Everything comes by value: the uint8_t stores may alias anything, so values read through
// references would be reloaded per texel.
template <uint8_t Kind, class Kept>
void enterSpan(const RowKeys keyAt, float* const keys, uint8_t* const kinds, Kept* const kept, const int32_t i0,
               const int32_t i1) {
  for (int32_t i = i0; i < i1; ++i) {
    const float key = keyAt.at(i);
    if (key < keys[i] || (key == keys[i] && Kind < kinds[i])) {
      keys[i] = key;
      kinds[i] = Kind;
    }
    if constexpr (Kind == kClosedFront) kept[i - i0].addFront(key);
    if constexpr (Kind == kClosedBack) kept[i - i0].addBack(key);
  }
}

// Row bands processed in parallel: every band owns its texels, so the result does not depend on scheduling.
constexpr uint32_t kBandRows = 32;

// Uniform tiles (docs/depth-maps.md, "Uniform tiles"): every texel meets the same planes in the same order, so
// their slices follow from two planes and the per-texel passes skip them. Per tile row, the runs of texels
// [a, b) that take the per-texel path instead, and where their 8 rows' slots start in the replay's kept
// crossings: only those texels have slots, row after row of each run, so a band's crossings stay in cache.
struct PerTexelRun {
  int32_t a, b;
  size_t kept;
};

// Integer slices of one texel: e from its enter key; x from its peel's outcome (state, and the key of the last
// layer consumed). Hints: the row's previous slices. It holds its own copies of the pointers (it was a lambda
// that captured them by value), and each pass takes its own copy of it before its per-texel loops
// (RegionPasses::texelSlicer).
struct TexelSlicer {
  const SliceTable& table;
  uint32_t n;
  float* enterKeyAt;
  uint8_t* kindAt;
  uint32_t* enterOut;
  uint32_t* exitOut;

  [[gnu::always_inline]] void operator()(size_t at, uint8_t texelState, float exitKey, uint32_t& enterHint,
                                         uint32_t& exitHint) const {
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
  }
};

// What the passes of one region share (CpuDepthRenderer::render sets it up once per call): the call's
// arguments, the region's triangles, raw pointers to the per-texel state and output, and the per-texel runs of
// its tile rows.
struct RegionPasses {
  RegionPasses(const RegionRect& rect, const PeelSettings& peel, const RowSpans* needed, DepthRegion& region,
               RenderStats& local, const SliceTable& table)
      : rect(rect), peel(peel), needed(needed), region(region), local(local), table(table), n(region.resolution),
        width(rect.width), texels(size_t(rect.width) * rect.height), bands((rect.height + kBandRows - 1) / kBandRows) {}

  const RegionRect& rect;
  const PeelSettings& peel;
  // The texels of each row the caller needs (all of them without `needed`): the replay visits only those.
  const RowSpans* needed;
  DepthRegion& region;
  RenderStats& local;
  const SliceTable& table;
  const uint32_t n, width;
  const size_t texels;
  const uint32_t bands;  // of kBandRows rows
  std::vector<MaskedTriangle> masked;
  std::vector<RasterTriangle> triangles;
  // Comparisons run on a key that grows with depth: q itself (orthographic) or -q (perspective, q = 1/d), in
  // float like the GL renderer's depth buffer, so surfaces that meet (a box standing on another) tie as there.
  double keySign = 1.0;
  // Raw pointers for the per-texel loops: stores through uint8_t may alias anything, so the compiler would
  // reload every vector's data pointer after each of them.
  float* enterKeyAt = nullptr;
  uint8_t* kindAt = nullptr;
  uint8_t* stateAt = nullptr;
  uint32_t* enterOut = nullptr;
  uint32_t* exitOut = nullptr;
  TileClasses classes;  // empty unless the tiles were classified
  std::vector<std::vector<PerTexelRun>> perTexelRuns;  // per tile row
  size_t keptSlots = 0;  // the replay's kept crossings: one per texel of the per-texel runs

  float keyOf(double q) const { return float(keySign * q); }

  template <class Body>
  void forBands(Body&& body) const {
    parallelFor(bands, [&](size_t b) {
      const int32_t r0 = int32_t(b * kBandRows), r1 = int32_t(std::min<size_t>(rect.height, (b + 1) * kBandRows));
      body(r0, r1);
    }, 1);
  }

  void checkNeeded() const {
    if (needed && (needed->begin.size() != rect.height || needed->end.size() != rect.height))
      throw Error(ErrorCategory::InvalidArgument, "depth renderer: needed texels given for " +
                                                      std::to_string(needed->begin.size()) + " rows of a region of " +
                                                      std::to_string(rect.height));
  }
  int32_t spanBegin(int32_t j) const { return needed ? int32_t(std::min(needed->begin[j], width)) : 0; }
  int32_t spanEnd(int32_t j) const {
    return needed ? std::max(spanBegin(j), int32_t(std::min(needed->end[j], width))) : int32_t(width);
  }

  void findPerTexelRuns(bool classify);

  // Calls fn(a, b, slot) for the texels [a, b) of [i0, i1) in row j that are needed and take the per-texel path;
  // texel a's kept crossings are at `slot`, and those of the texels after it follow.
  template <class Fn>
  void forPerTexel(int32_t j, int32_t i0, int32_t i1, Fn&& fn) const {
    i0 = std::max(i0, spanBegin(j));
    i1 = std::min(i1, spanEnd(j));
    for (const PerTexelRun& run : perTexelRuns[size_t(j) / 8]) {
      if (run.b <= i0) continue;
      if (run.a >= i1) break;
      const int32_t a = std::max(run.a, i0);
      fn(a, std::min(run.b, i1), run.kept + size_t(j % 8) * size_t(run.b - run.a) + size_t(a - run.a));
    }
  }

  TexelSlicer texelSlicer() const { return {table, n, enterKeyAt, kindAt, enterOut, exitOut}; }

  // Whether the uniform tiles of a set of planes are entered at a closed front face, and so peel.
  bool peeledSet(int32_t set) const {
    const UniformTile& tile = classes.sets[size_t(set)];
    return tile.planes > 0 && triangles[size_t(tile.plane[0])].kind == kClosedFront;
  }

  void sliceUniformTile(uint32_t tx, uint32_t ty, const UniformTile& tile, const UniformPeel& tilePeel,
                        uint32_t& enterHint, uint32_t& exitHint) const;
};

// With `classify`, the region's tiles classified (uniform or not); then the per-texel runs of every tile row.
void RegionPasses::findPerTexelRuns(bool classify) {
  const uint32_t tileRows = (rect.height + 7) / 8;
  perTexelRuns.resize(tileRows);
  if (classify) {
    const Stopwatch classifyTime;
    classes = classifyTiles(triangles, rect.width, rect.height, keySign, peel.maxPeels, needed);
    region.tiles.assign(size_t(classes.tilesX) * classes.tilesY, TileSummary{});
    local.uniformTiles = classes.uniformCount;
    local.enterMs += classifyTime.ms();  // the enter pass's coverage, decided tile by tile
  }
  for (uint32_t ty = 0; ty < tileRows; ++ty) {
    if (classes.setOf.empty()) {
      perTexelRuns[ty].push_back({0, int32_t(width), 0});
      continue;
    }
    for (uint32_t tx = 0; tx < classes.tilesX; ++tx) {
      if (classes.uniform(size_t(ty) * classes.tilesX + tx)) continue;
      const int32_t a = int32_t(tx * 8), b = int32_t(std::min(width, tx * 8 + 8));
      auto& runs = perTexelRuns[ty];
      if (!runs.empty() && runs.back().b == a) runs.back().b = b;
      else runs.push_back({a, b, 0});
    }
  }
  // The per-texel passes write the texels where something is met: the others of those runs see nothing (N).
  // Uniform tiles are written by sliceUniformTile or summarised.
  for (uint32_t ty = 0; ty < tileRows; ++ty)
    for (PerTexelRun& run : perTexelRuns[ty]) {
      run.kept = keptSlots;
      keptSlots += size_t(run.b - run.a) * 8;
      for (uint32_t j = ty * 8; j < std::min(rect.height, ty * 8 + 8); ++j) {
        std::fill(enterOut + size_t(j) * width + size_t(run.a), enterOut + size_t(j) * width + size_t(run.b), n);
        std::fill(exitOut + size_t(j) * width + size_t(run.a), exitOut + size_t(j) * width + size_t(run.b), n);
      }
    }
}

// A uniform tile's slices, given its peel: its tile chain's summary where that is all the chain needs (every
// exit past the farthest enter), else every texel's slices, as TexelSlicer would give them.
// Hints: the previous tile's slices in the tile row.
void RegionPasses::sliceUniformTile(uint32_t tx, uint32_t ty, const UniformTile& tile, const UniformPeel& tilePeel,
                                    uint32_t& enterHint, uint32_t& exitHint) const {
  TileSummary& summary = region.tiles[size_t(ty) * classes.tilesX + tx];
  if (tile.planes == 0) {  // nothing there: enter and exit N
    summary = {n, n, true};
    return;
  }
  const RasterTriangle& front = triangles[size_t(tile.plane[0])];
  const bool peeled = front.kind == kClosedFront;
  const bool stuck = peeled && tilePeel.state == kStuck;
  const RasterTriangle& back = triangles[size_t(tile.plane[peeled && !stuck ? tilePeel.exitPlane : 0])];
  const int32_t i0 = int32_t(tx * 8), j0 = int32_t(ty * 8);
  // Slices are monotone in the keys: the extremes lie at the extreme keys' corners.
  enterHint = table.slice(extremeKeyOfTile(front, keySign, i0, j0, true), enterHint);
  const uint32_t maxE = std::min(n - 1, enterHint);
  // x = e + 1 (open or back-face enter), N (stuck), or max(e + 1, sx): past maxE at every texel when sx is.
  if (stuck) {
    summary = {maxE, n, true};
    return;
  }
  if (!peeled) {
    if (std::min(n - 1, table.slice(extremeKeyOfTile(front, keySign, i0, j0, false), enterHint)) == maxE) {
      summary = {maxE, maxE + 1, true};
      return;
    }
  } else {
    exitHint = table.slice(extremeKeyOfTile(back, keySign, i0, j0, false), exitHint);
    if (exitHint > maxE) {
      summary = {maxE, std::min(n, exitHint), true};
      return;
    }
  }
  summary.summarized = false;
  for (int32_t j = j0; j < j0 + 8; ++j) {
    const double rowFront = front.q0 + front.kv * (double(front.y0 + j) + front.dv);
    const double rowBack = back.q0 + back.kv * (double(back.y0 + j) + back.dv);
    const RowKeys frontKeys(front, rowFront, keySign), backKeys(back, rowBack, keySign);
    uint32_t texelEnter = enterHint, texelExit = exitHint;
    for (int32_t i = i0; i < i0 + 8; ++i) {
      const size_t at = size_t(j) * width + size_t(i);
      texelEnter = table.slice(frontKeys.at(i), texelEnter);
      const uint32_t e = std::min(n - 1, texelEnter);
      uint32_t x = e + 1;
      if (peeled) {
        texelExit = table.slice(backKeys.at(i), texelExit);
        x = std::min(n, std::max(e + 1, texelExit));
      }
      enterOut[at] = e;
      exitOut[at] = x;
    }
  }
}

// The replay's first pass over the rows [r0, r1) of a band: at the texels that take the per-texel path, the
// nearest surface, its kind, and the closed crossings behind it (kept: the region's KeptCrossings<P>).
template <int P>
void enterKeepingCrossings(const RegionPasses& c, KeptCrossings<P>* const kept, const int32_t r0, const int32_t r1) {
  using Kept = KeptCrossings<P>;
  const uint32_t width = c.width;
  const double keySign = c.keySign;
  float* const enterKeyAt = c.enterKeyAt;
  uint8_t* const kindAt = c.kindAt;
  const std::vector<MaskedTriangle>& masked = c.masked;
  for (int32_t j = r0; j < r1; ++j)
    c.forPerTexel(j, 0, int32_t(width), [&](int32_t a, int32_t b, size_t slot) {
      const size_t row = size_t(j) * width;
      std::fill(enterKeyAt + row + a, enterKeyAt + row + b, kInfinity);
      std::fill(kindAt + row + a, kindAt + row + b, uint8_t(kNone));
      for (Kept* k = kept + slot; k < kept + slot + size_t(b - a); ++k) k->clear();
    });
  // A triangle whose box meets no per-texel run of the band's tile rows has nothing to do here.
  const auto reachesPerTexel = [&](const RasterTriangle& t) {
    const int32_t ja = std::max(t.j0, r0), jb = std::min(t.j1, r1 - 1);
    for (int32_t ty = ja / 8; ty <= jb / 8 && ja <= jb; ++ty)
      for (const PerTexelRun& run : c.perTexelRuns[size_t(ty)]) {
        if (run.b <= t.i0) continue;
        if (run.a > t.i1) break;
        return true;
      }
    return false;
  };
  for (const RasterTriangle& t : c.triangles) {
    if (!reachesPerTexel(t)) continue;
    scan(t, r0, r1, [&](int32_t j, int32_t spanBegin, int32_t spanEnd, double rowQ) {
      float* const keys = enterKeyAt + size_t(j) * width;
      uint8_t* const kinds = kindAt + size_t(j) * width;
      const RowKeys keyAt(t, rowQ, keySign);
      c.forPerTexel(j, spanBegin, spanEnd, [&](int32_t i0, int32_t i1, size_t slot) {
        if (t.masked >= 0)
          enterMaskedSpan(t, masked[size_t(t.masked)], rowQ, keySign, j, i0, i1, keys, kinds);
        else if (t.kind == kOpen)
          enterSpan<kOpen>(keyAt, keys, kinds, kept + slot, i0, i1);
        else if (t.kind == kClosedFront)
          enterSpan<kClosedFront>(keyAt, keys, kinds, kept + slot, i0, i1);
        else
          enterSpan<kClosedBack>(keyAt, keys, kinds, kept + slot, i0, i1);
      });
    });
  }
}

// The replay's second pass over the rows [r0, r1) of a band, while it is in cache: each texel's peel replayed to
// the cap P, and its integer slices; then the band's uniform tiles (setPeel: the peel of each set of planes).
// counts: the band's texels by the iteration they leave.
template <int P>
void replayBand(const RegionPasses& c, KeptCrossings<P>* const kept, const std::vector<UniformPeel>& setPeel,
                const int32_t r0, const int32_t r1, std::array<uint64_t, P + 2>& counts) {
  const uint32_t width = c.width;
  float* const enterKeyAt = c.enterKeyAt;
  uint8_t* const kindAt = c.kindAt;
  uint8_t* const stateAt = c.stateAt;
  const TexelSlicer sliceTexel = c.texelSlicer();
  for (int32_t j = r0; j < r1; ++j) {
    uint32_t enterHint = 0, exitHint = 0;
    c.forPerTexel(j, 0, int32_t(width), [&](int32_t a, int32_t b, size_t slot) {
      const size_t row = size_t(j) * width;
      for (size_t at = row + size_t(a); at < row + size_t(b); ++at) {
        uint8_t texelState = kInactive;
        float exitKey = 0;
        if (kindAt[at] == kClosedFront) {
          const ReplayedTexel r = replayTexel(kept[slot + (at - row - size_t(a))], enterKeyAt[at], P, P);
          texelState = r.state;
          exitKey = std::max(r.frontCursor, r.backCursor);
          ++counts[r.finishedAt];
          stateAt[at] = r.finishedAt;  // kept for the fix-up (CpuDepthRenderer::fixUpReplay)
        }
        sliceTexel(at, texelState, exitKey, enterHint, exitHint);
      }
    });
  }
  // The band's uniform tiles, each counted for its 64 texels.
  const TileClasses& classes = c.classes;
  for (uint32_t ty = uint32_t(r0) / 8; ty < classes.tilesY && ty * 8 < uint32_t(r1); ++ty) {
    uint32_t enterHint = 0, exitHint = 0;
    for (uint32_t tx = 0; tx < classes.tilesX; ++tx) {
      const int32_t set = classes.setOf[size_t(ty) * classes.tilesX + tx];
      if (set < 0) continue;
      if (c.peeledSet(set)) counts[setPeel[size_t(set)].finishedAt] += 64;
      c.sliceUniformTile(tx, ty, classes.sets[size_t(set)], setPeel[size_t(set)], enterHint, exitHint);
    }
  }
}

// As many iterations as the passes would run: the cap, or fewer when no texel (or only a handful) is still
// inside after one. Fewer changes only the texels still inside then, which the early stop keeps few.
// finishedAt: per band, texels by the iteration they leave. Records the iterations and the texels left at the
// cap in the stats.
template <int P>
uint32_t countReplayedIterations(RegionPasses& c, const std::vector<std::array<uint64_t, P + 2>>& finishedAt) {
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
    if (uint64_t(active) * 1000000u <= uint64_t(c.peel.stopBelowPerMillion) * c.texels) break;
  }
  c.local.peelIterations = iterations;
  for (uint32_t k = iterations + 1; k < uint32_t(P) + 2; ++k) c.local.texelsAtPeelCap += total[k];
  return iterations;
}

class CpuDepthRenderer final : public DepthRenderer {
public:
  explicit CpuDepthRenderer(CpuPeel peelMethod) : peelMethod_(peelMethod) {}
  uint32_t maxRegionSize() const override { return 1u << 14; }
  // Which compilation of these passes runs, so that every report names the instruction set its timings used.
  std::string description() const override { return "cpvs CPU rasteriser (" CPVS_RASTER_ISA_NAME ")"; }
  DepthRegion render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                     const PeelSettings& peel, RenderStats* stats, const RowSpans* needed,
                     bool summarizeTiles) override;

private:
  // The passes of render(): the replay with peel cap P, or the lockstep peel.
  template <int P>
  void replayWith(RegionPasses& c);
  template <int P>
  void fixUpReplay(RegionPasses& c, KeptCrossings<P>* kept, const std::vector<UniformPeel>& setPeel,
                   uint32_t iterations) const;
  void renderLockstep(RegionPasses& c, const Stopwatch& phase);
  void enterLockstep(const RegionPasses& c);
  void peelLockstep(RegionPasses& c);
  void sliceLockstep(RegionPasses& c) const;

  CpuPeel peelMethod_;
  SliceTable slices_;
  std::vector<uint8_t> crossings_;  // KeptCrossings<P> per texel (replay)
  // Per-texel state, kept between regions (allocating it anew cost a page fault per 4 KiB every region).
  std::vector<float> enterKey_, frontCursor_, backCursor_, nearestFront_, nearestBack_;
  std::vector<uint8_t> kind_, state_;
  std::vector<uint16_t> backCount_;
};

DepthRegion CpuDepthRenderer::render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                                     const PeelSettings& peel, RenderStats* stats, const RowSpans* needed,
                                     bool summarizeTiles) {
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
  region.enter.resize(texels);  // uninitialised: what is not written below is a summarised tile's
  region.exit.resize(texels);
  if (view.empty || local.trianglesSubmitted == 0) {
    std::fill(region.enter.begin(), region.enter.end(), n);
    std::fill(region.exit.begin(), region.exit.end(), n);
    if (stats) *stats = local;
    return region;
  }
  RegionPasses passes(rect, peel, needed, region, local, slices_);
  passes.triangles = setUpRasterTriangles(culled, view, rect, passes.masked);
  const DepthFunction depthOf(view);
  passes.keySign = depthOf.mode >= 2 ? -1.0 : 1.0;
  if (!slices_.matches(view, depthOf.mode)) slices_.build(view, depthOf);

  state_.assign(texels, kInactive);
  enterKey_.resize(texels);
  kind_.resize(texels);
  passes.enterKeyAt = enterKey_.data();
  passes.kindAt = kind_.data();
  passes.stateAt = state_.data();
  passes.enterOut = region.enter.data();
  passes.exitOut = region.exit.data();
  passes.checkNeeded();

  const bool replay = peelMethod_ == CpuPeel::Replay && peel.maxPeels >= 1 && peel.maxPeels <= kMaxReplayedPeels;
  passes.findPerTexelRuns(summarizeTiles && replay);
  if (replay) {
    if (peel.maxPeels == 1) replayWith<1>(passes);
    else if (peel.maxPeels == 2) replayWith<2>(passes);
    else replayWith<3>(passes);
  } else {
    renderLockstep(passes, phase);
  }

  for (const TileSummary& summary : region.tiles) local.summarizedTiles += summary.summarized;
  if (stats) *stats = local;
  return region;
}

// Replays each texel's lockstep peel from the crossings one pass keeps (same maps as the passes of
// renderLockstep), with the peel cap P.
template <int P>
void CpuDepthRenderer::replayWith(RegionPasses& c) {
  using Kept = KeptCrossings<P>;
  crossings_.resize(c.keptSlots * sizeof(Kept));
  Kept* const kept = reinterpret_cast<Kept*>(crossings_.data());
  std::vector<std::array<uint64_t, P + 2>> finishedAt(c.bands);  // per band: texels by the iteration they leave
  std::vector<std::pair<double, double>> bandMs(c.bands);  // CPU ms per band: scan, replay and slices
  // One peel per set of planes that uniform tiles meet (the same at each of their texels).
  std::vector<UniformPeel> setPeel(c.classes.sets.size());
  for (size_t set = 0; set < c.classes.sets.size(); ++set)
    if (c.peeledSet(int32_t(set))) setPeel[set] = replayUniformTile(c.classes.sets[set], c.triangles, P, P);
  c.forBands([&](int32_t r0, int32_t r1) {
    const Stopwatch scanTime;
    // 1. One pass: the nearest surface, its kind, and the closed crossings behind it.
    enterKeepingCrossings<P>(c, kept, r0, r1);
    Stopwatch replayTime;
    // 2. While the band is in cache: each texel's peel replayed to the cap, and its integer slices.
    auto& counts = finishedAt[size_t(r0) / kBandRows];
    counts.fill(0);
    replayBand<P>(c, kept, setPeel, r0, r1, counts);
    bandMs[size_t(r0) / kBandRows] = {scanTime.ms() - replayTime.ms(), replayTime.ms()};
  });
  // 3. As many iterations as the passes would run, and the texels left inside by fewer than the cap fixed up.
  const uint32_t iterations = countReplayedIterations<P>(c, finishedAt);
  for (const auto& [scanMs, replayMs] : bandMs) {
    c.local.enterMs += scanMs;
    c.local.peelMs += replayMs;
  }
  if (iterations < uint32_t(P)) fixUpReplay<P>(c, kept, setPeel, iterations);
}

// After fewer iterations than the cap P: the texels and uniform tiles still inside after `iterations` replayed
// again with that many, and sliced again.
template <int P>
void CpuDepthRenderer::fixUpReplay(RegionPasses& c, KeptCrossings<P>* const kept,
                                   const std::vector<UniformPeel>& setPeel, const uint32_t iterations) const {
  const std::vector<float>& enterKey = enterKey_;
  const std::vector<uint8_t>& kind = kind_;
  const std::vector<uint8_t>& state = state_;
  const uint32_t width = c.width;
  const TexelSlicer sliceTexel = c.texelSlicer();
  const TileClasses& classes = c.classes;
  const Stopwatch fixUp;
  c.forBands([&](int32_t r0, int32_t r1) {
    for (int32_t j = r0; j < r1; ++j) {
      uint32_t enterHint = 0, exitHint = 0;
      c.forPerTexel(j, 0, int32_t(width), [&](int32_t a, int32_t b, size_t slot) {
        const size_t row = size_t(j) * width;
        for (size_t at = row + size_t(a); at < row + size_t(b); ++at) {
          if (kind[at] != kClosedFront || state[at] <= iterations) continue;
          const ReplayedTexel r = replayTexel(kept[slot + (at - row - size_t(a))], enterKey[at], iterations, P);
          sliceTexel(at, r.state, std::max(r.frontCursor, r.backCursor), enterHint, exitHint);
        }
      });
    }
    for (uint32_t ty = uint32_t(r0) / 8; ty < classes.tilesY && ty * 8 < uint32_t(r1); ++ty) {
      uint32_t enterHint = 0, exitHint = 0;
      for (uint32_t tx = 0; tx < classes.tilesX; ++tx) {
        const int32_t set = classes.setOf[size_t(ty) * classes.tilesX + tx];
        if (set < 0 || !c.peeledSet(set) || setPeel[size_t(set)].finishedAt <= iterations) continue;
        c.sliceUniformTile(tx, ty, classes.sets[size_t(set)],
                           replayUniformTile(classes.sets[size_t(set)], c.triangles, iterations, P), enterHint,
                           exitHint);
      }
    }
  });
  c.local.peelMs += fixUp.ms();
}

// The passes without the replay (methods or caps it does not cover). phase: started with the call.
void CpuDepthRenderer::renderLockstep(RegionPasses& c, const Stopwatch& phase) {
  frontCursor_.resize(c.texels);
  backCursor_.resize(c.texels);
  // 1. Enter: the nearest surface and its kind.
  enterLockstep(c);
  c.local.enterMs = phase.ms();
  const Stopwatch peelTime;
  // 2. Lockstep peeling of the closed solids entered at a closed front face (docs/depth-maps.md).
  peelLockstep(c);
  // 3. Integer slices.
  sliceLockstep(c);
  c.local.peelMs = peelTime.ms();
}

void CpuDepthRenderer::enterLockstep(const RegionPasses& c) {
  std::vector<float>& enterKey = enterKey_;
  std::vector<uint8_t>& kind = kind_;
  const uint32_t width = c.width;
  std::fill(enterKey.begin(), enterKey.end(), kInfinity);
  std::fill(kind.begin(), kind.end(), uint8_t(kNone));
  c.forBands([&](int32_t r0, int32_t r1) {
    for (const RasterTriangle& t : c.triangles)
      scan(t, r0, r1, [&](int32_t j, int32_t i0, int32_t i1, double rowQ) {
        float* keys = &enterKey[size_t(j) * width];
        uint8_t* kinds = &kind[size_t(j) * width];
        if (t.masked >= 0) {
          enterMaskedSpan(t, c.masked[size_t(t.masked)], rowQ, c.keySign, j, i0, i1, keys, kinds);
          return;
        }
        for (int32_t i = i0; i < i1; ++i) {
          const float key = c.keyOf(depthAt(t, rowQ, i));
          if (key < keys[i] || (key == keys[i] && t.kind < kinds[i])) {
            keys[i] = key;
            kinds[i] = t.kind;
          }
        }
      });
  });
}

void CpuDepthRenderer::peelLockstep(RegionPasses& c) {
  const uint32_t width = c.width;
  const size_t texels = c.texels;
  const std::vector<float>& enterKey = enterKey_;
  const std::vector<uint8_t>& kind = kind_;
  std::vector<uint8_t>& state = state_;
  std::vector<float>&frontCursor = frontCursor_, &backCursor = backCursor_;
  std::vector<float>&nearestFront = nearestFront_, &nearestBack = nearestBack_;
  std::vector<uint16_t>& backCount = backCount_;
  size_t active = 0;
  // Per row, the texels [activeBegin, activeEnd) hold every active one: later iterations, with few texels
  // left inside, scan only those.
  std::vector<int32_t> activeBegin(c.rect.height, 0), activeEnd(c.rect.height, 0);
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
  for (int32_t j = 0; j < int32_t(c.rect.height); ++j) findActive(j);
  if (active == 0) return;  // no texel entered at a closed front face: no closed triangles to peel
  frontCursor = enterKey;
  backCursor.resize(texels);
  // Back faces at the enter depth itself (silhouettes, zero thickness) still count: the back cursor starts
  // just before it.
  for (size_t i = 0; i < texels; ++i) backCursor[i] = floatBefore(enterKey[i]);
  nearestFront.resize(texels);
  nearestBack.resize(texels);
  backCount.resize(texels);
  for (uint32_t iteration = 0; iteration < c.peel.maxPeels && active > 0; ++iteration) {
    ++c.local.peelIterations;
    const bool lastIteration = iteration + 1 == c.peel.maxPeels;
    c.forBands([&](int32_t r0, int32_t r1) {
      const size_t b0 = size_t(r0) * width, b1 = size_t(r1) * width;
      std::fill(nearestFront.begin() + b0, nearestFront.begin() + b1, kInfinity);
      std::fill(nearestBack.begin() + b0, nearestBack.begin() + b1, kInfinity);
      std::fill(backCount.begin() + b0, backCount.begin() + b1, 0);
      bool bandActive = false;
      for (int32_t j = r0; j < r1; ++j) bandActive |= activeBegin[j] < activeEnd[j];
      if (!bandActive) return;
      for (const RasterTriangle& t : c.triangles) {
        if (t.kind == kOpen) continue;
        const bool front = t.kind == kClosedFront;
        scan(t, r0, r1, [&](int32_t j, int32_t i0, int32_t i1, double rowQ) {
          i0 = std::max(i0, activeBegin[j]);
          i1 = std::min(i1, activeEnd[j]);
          const size_t row = size_t(j) * width;
          for (size_t at = row + size_t(i0); at < row + size_t(i1); ++at) {
            if (state[at] != kActive) continue;
            const float key = c.keyOf(depthAt(t, rowQ, int64_t(at - row)));
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
    if (uint64_t(active) * 1000000u <= uint64_t(c.peel.stopBelowPerMillion) * texels) break;
  }
}

// The integer slices of every texel from its peel's outcome, and the texels left at the cap counted.
void CpuDepthRenderer::sliceLockstep(RegionPasses& c) const {
  const std::vector<uint8_t>& state = state_;
  const std::vector<float>&frontCursor = frontCursor_, &backCursor = backCursor_;
  const uint32_t width = c.width;
  const TexelSlicer sliceTexel = c.texelSlicer();
  c.forBands([&](int32_t r0, int32_t r1) {
    for (int32_t j = r0; j < r1; ++j) {
      uint32_t enterHint = 0, exitHint = 0;
      for (size_t at = size_t(j) * width; at < size_t(j + 1) * width; ++at)
        sliceTexel(at, state[at], std::max(frontCursor[at], backCursor[at]), enterHint, exitHint);
    }
  });
  for (size_t at = 0; at < c.texels; ++at)
    c.local.texelsAtPeelCap += state[at] == kCapped || state[at] == kActive;
}

}  // namespace

std::unique_ptr<DepthRenderer> createCpuDepthRendererHere(CpuPeel peel) { return std::make_unique<CpuDepthRenderer>(peel); }

}  // namespace cpvs::CPVS_RASTER_NAMESPACE
