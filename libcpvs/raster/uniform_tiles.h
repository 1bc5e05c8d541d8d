#pragma once
// Coverage-first classification of a region's 8x8 tiles (docs/depth-maps.md, "Uniform tiles"): a tile is
// uniform when every texel of it meets the same surfaces in the same depth order, with no tie, as far as its
// enter slice and its peel can tell. Its enter and exit slices then follow from two depth planes, and the
// per-texel passes (coverage, crossings, replay) can skip it.
#include <cstdint>
#include <vector>

#include "libcpvs/raster/peel_replay.h"
#include "libcpvs/raster/raster_triangle.h"

namespace cpvs {

// What every texel of a uniform tile meets, nearest first.
struct UniformTile {
  static constexpr int kMaxPlanes = 12;
  // Triangle indices: [0] the enter surface, then the closed triangles behind it that the peel may consume, in
  // depth order. Triangles past those (or, behind an open or back-face enter surface, every other one) lie
  // behind them at every texel and change nothing.
  int32_t plane[kMaxPlanes];
  uint8_t planes = 0;  // 0: no triangle covers any texel of the tile
};

// The outcome of a uniform tile's peel, the same at each of its texels (replayTexel on the planes' depth order).
struct UniformPeel {
  uint8_t state = kInactive;  // kInactive when the enter surface is not a closed front face
  uint8_t finishedAt = 0;     // as ReplayedTexel::finishedAt
  int8_t exitPlane = -1;      // index into UniformTile::plane of the layer whose depth is the exit key; -1: none
};

// Replays the peel of a uniform tile whose enter surface is a closed front face, `iterations` iterations of a
// peel capped at `cap` (<= kMaxReplayedPeels).
UniformPeel replayUniformTile(const UniformTile& tile, const std::vector<RasterTriangle>& triangles,
                              uint32_t iterations, uint32_t cap);

struct TileClasses {
  uint32_t tilesX = 0, tilesY = 0;  // tiles starting in the region (a partial last column or row is never uniform)
  // Per tile, the index of what it meets in `sets`, or -1: not uniform. Tiles of a block that is uniform as a
  // whole (and neighbours that meet the same planes) share one set.
  std::vector<int32_t> setOf;
  std::vector<UniformTile> sets;
  uint64_t uniformCount = 0;
  bool uniform(size_t tile) const { return setOf[tile] >= 0; }
};

// Classifies the tiles of a width x height region: triangles are binned to 64 x 64 blocks, then tiles, with the
// exact integer edge functions (a block or tile is covered, missed, or crossed); only tiles whose every texel
// is `needed` can be uniform. `keySign` and `peelCap` are the renderer's (depth keys, replayed peel cap 1..3).
TileClasses classifyTiles(const std::vector<RasterTriangle>& triangles, uint32_t width, uint32_t height,
                          double keySign, uint32_t peelCap, const RowSpans* needed);

// The depth key of triangle t at region texel (i, j), evaluated exactly as the per-texel passes do.
inline float keyAtTexel(const RasterTriangle& t, double keySign, int32_t i, int32_t j) {
  return RowKeys(t, t.q0 + t.kv * (double(t.y0 + j) + t.dv), keySign).at(i);
}

// The largest (or smallest) key of triangle t over the tile whose first texel is (i0, j0). Along a row the key
// never decreases when ku keySign >= 0 and never increases otherwise (each step of its evaluation is monotone),
// and the same holds along a column with kv: the extreme lies at one corner, known from the signs alone.
inline float extremeKeyOfTile(const RasterTriangle& t, double keySign, int32_t i0, int32_t j0, bool largest) {
  const int32_t i = ((t.ku * keySign >= 0) == largest) ? i0 + 7 : i0;
  const int32_t j = ((t.kv * keySign >= 0) == largest) ? j0 + 7 : j0;
  return keyAtTexel(t, keySign, i, j);
}

}  // namespace cpvs
