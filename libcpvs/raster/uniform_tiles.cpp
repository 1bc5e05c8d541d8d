#include "libcpvs/raster/uniform_tiles.h"

#include <algorithm>
#include <cmath>

#include "libcpvs/base/parallel.h"

namespace cpvs {
namespace {

constexpr int32_t kTile = 8, kBlock = 64;
// Blocks crossed by more triangles than this are not classified tile by tile (see classifyTiles).
constexpr uint32_t kMostCrossingPerBlock = 48;

enum class Coverage : uint8_t { None, Crossed, Full };

// Whether the triangle covers every, no or some texel centre of [ia, ib] x [ja, jb] (region texels). Each edge
// function is affine, so its extremes over the rectangle's centres lie at the corner centres: an edge that
// passes all four passes every centre, one that fails all four fails every centre. "Crossed" may still cover
// none (a conservative answer: the tile then takes the per-texel path).
template <class Wide>
Coverage coverageOf(const RasterTriangle& t, int32_t ia, int32_t ib, int32_t ja, int32_t jb) {
  if (ib < t.i0 || ia > t.i1 || jb < t.j0 || ja > t.j1) return Coverage::None;
  const Edge<Wide> edges[3] = {{t.x[0], t.y[0], t.x[1], t.y[1]}, {t.x[1], t.y[1], t.x[2], t.y[2]},
                               {t.x[2], t.y[2], t.x[0], t.y[0]}};
  const Wide xa = Wide(256) * ia + 128, xb = Wide(256) * ib + 128, ya = Wide(256) * ja + 128,
             yb = Wide(256) * jb + 128;
  bool full = true;
  for (const Edge<Wide>& e : edges) {
    const Wide ax = e.a * xa, bx = e.a * xb, ay = e.b * ya, by = e.b * yb;
    const Wide lo = std::min(ax, bx) + std::min(ay, by) + e.c, hi = std::max(ax, bx) + std::max(ay, by) + e.c;
    if (hi < e.threshold) return Coverage::None;
    if (lo < e.threshold) full = false;
  }
  return full ? Coverage::Full : Coverage::Crossed;
}

Coverage coverage(const RasterTriangle& t, int32_t ia, int32_t ib, int32_t ja, int32_t jb) {
  bool fast = true;
  for (int k = 0; k < 3; ++k) fast = fast && std::llabs(t.x[k]) < kFastLimit && std::llabs(t.y[k]) < kFastLimit;
  return fast ? coverageOf<int64_t>(t, ia, ib, ja, jb) : coverageOf<__int128>(t, ia, ib, ja, jb);
}

struct Candidate {
  float keyMin, keyMax;  // over the rectangle's texels (its corners: keys are monotone along rows and columns)
  int32_t triangle;
  bool full;
};

// A triangle's depth key range over [ia, ib] x [ja, jb]. Along a row the key is q(i) = rowQ + ku (x + du) in
// double, clamped, signed and rounded to float: each step is monotone (non-decreasing or non-increasing) in i,
// and rowQ is monotone in j, so every texel's key lies between the corners' smallest and largest.
void keyRange(const RasterTriangle& t, double keySign, int32_t ia, int32_t ib, int32_t ja, int32_t jb, float& lo,
              float& hi) {
  const RowKeys rowA(t, t.q0 + t.kv * (double(t.y0 + ja) + t.dv), keySign),
      rowB(t, t.q0 + t.kv * (double(t.y0 + jb) + t.dv), keySign);
  const float k0 = rowA.at(ia), k1 = rowA.at(ib), k2 = rowB.at(ia), k3 = rowB.at(ib);
  lo = std::min(std::min(k0, k1), std::min(k2, k3));
  hi = std::max(std::max(k0, k1), std::max(k2, k3));
}

// Decides whether the candidates (every triangle that may cover a texel of the rectangle) make it uniform, and
// fills `tile` when they do. In depth order: the nearest must cover every texel and lie strictly in front of all
// the others; behind a closed front face, the closed triangles the peel may consume (the P + 1 nearest fronts and
// the P nearest backs) must each cover every texel and lie strictly behind the previous one; everything else
// must lie strictly behind what it could change (the enter surface, or the last of those crossings).
bool resolve(std::vector<Candidate>& candidates, const std::vector<RasterTriangle>& triangles, double keySign,
             uint32_t peelCap, int32_t ia, int32_t ib, int32_t ja, int32_t jb, UniformTile& tile) {
  tile.planes = 0;
  if (candidates.empty()) return true;
  for (Candidate& c : candidates) keyRange(triangles[size_t(c.triangle)], keySign, ia, ib, ja, jb, c.keyMin, c.keyMax);
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.keyMin < b.keyMin || (a.keyMin == b.keyMin && a.triangle < b.triangle);
  });
  const Candidate& enter = candidates[0];
  const RasterTriangle& enterTriangle = triangles[size_t(enter.triangle)];
  if (!enter.full || enterTriangle.masked >= 0) return false;
  tile.plane[tile.planes++] = enter.triangle;
  // Crossings the replay keeps: P + 1 fronts (the enter surface is the first) and P backs.
  const bool peeled = enterTriangle.kind == kClosedFront;
  uint32_t fronts = peeled ? 1 : 0, backs = 0;
  bool complete = !peeled;
  float frontier = enter.keyMax;  // the farthest key of the planes kept so far
  for (size_t k = 1; k < candidates.size(); ++k) {
    const Candidate& c = candidates[k];
    const RasterTriangle& t = triangles[size_t(c.triangle)];
    if (!(c.keyMin > enter.keyMax)) return false;  // it might tie with or hide the enter surface somewhere
    if (t.kind == kOpen) continue;                  // behind the enter surface, open triangles change nothing
    if (complete) {
      if (!(c.keyMin > frontier)) return false;
      continue;
    }
    if (!c.full || !(c.keyMin > frontier) || tile.planes == UniformTile::kMaxPlanes) return false;
    tile.plane[tile.planes++] = c.triangle;
    frontier = c.keyMax;
    (t.kind == kClosedFront ? fronts : backs) += 1;
    complete = fronts >= peelCap + 1 && backs >= peelCap;
  }
  return true;
}

template <int P>
UniformPeel replayOrder(const UniformTile& tile, const std::vector<RasterTriangle>& triangles, uint32_t iterations,
                        uint32_t cap) {
  // The planes are strictly ordered at every texel, so the replay sees the same order everywhere: run it on
  // their positions as keys (0 = the enter surface) and read back which plane the exit key is.
  KeptCrossings<P> kept;
  kept.clear();
  for (int k = 0; k < tile.planes; ++k) {
    const Kind kind = triangles[size_t(tile.plane[k])].kind;
    if (kind == kClosedFront) kept.addFront(float(k));
    else if (kind == kClosedBack) kept.addBack(float(k));
  }
  const ReplayedTexel r = replayTexel(kept, 0.0f, iterations, cap);
  UniformPeel out;
  out.state = r.state;
  out.finishedAt = r.finishedAt;
  // The exit key is max(front cursor, back cursor); the back cursor starts just before the enter key.
  out.exitPlane = int8_t(std::max(r.frontCursor, std::max(r.backCursor, 0.0f)));
  return out;
}

}  // namespace

UniformPeel replayUniformTile(const UniformTile& tile, const std::vector<RasterTriangle>& triangles,
                              uint32_t iterations, uint32_t cap) {
  if (cap <= 1) return replayOrder<1>(tile, triangles, iterations, cap);
  if (cap == 2) return replayOrder<2>(tile, triangles, iterations, cap);
  return replayOrder<3>(tile, triangles, iterations, cap);
}

namespace {

// The region's 64 x 64 blocks and the triangles that cover or cross each, in triangle order.
struct BlockBins {
  int32_t blocksX = 0, blocksY = 0;
  std::vector<uint32_t> first;                          // entries of block b: [first[b], first[b + 1])
  std::vector<std::pair<int32_t, Coverage>> entries;  // triangle index and its coverage of the block
};

void blockRect(int32_t bx, int32_t by, int32_t w, int32_t h, int32_t& ia, int32_t& ib, int32_t& ja, int32_t& jb) {
  ia = bx * kBlock;
  ib = std::min(w, ia + kBlock) - 1;
  ja = by * kBlock;
  jb = std::min(h, ja + kBlock) - 1;
}

// One coverage test per (triangle, block), in parallel over chunks of triangles whose hits are joined in chunk
// order, then grouped by block (a counting sort keeps triangle order within a block): the same bins for any
// number of threads.
BlockBins binToBlocks(const std::vector<RasterTriangle>& triangles, int32_t w, int32_t h) {
  BlockBins bins;
  bins.blocksX = (w + kBlock - 1) / kBlock;
  bins.blocksY = (h + kBlock - 1) / kBlock;
  const size_t blockCount = size_t(bins.blocksX) * size_t(bins.blocksY);
  struct Hit {
    uint32_t block;
    int32_t triangle;
    Coverage coverage;
  };
  constexpr size_t kChunk = 256;
  std::vector<std::vector<Hit>> chunks((triangles.size() + kChunk - 1) / kChunk);
  parallelFor(chunks.size(), [&](size_t chunk) {
    for (size_t k = chunk * kChunk; k < std::min(triangles.size(), (chunk + 1) * kChunk); ++k) {
      const RasterTriangle& t = triangles[k];
      if (t.i0 > t.i1 || t.j0 > t.j1) continue;
      for (int32_t by = t.j0 / kBlock; by <= t.j1 / kBlock; ++by)
        for (int32_t bx = t.i0 / kBlock; bx <= t.i1 / kBlock; ++bx) {
          int32_t ia, ib, ja, jb;
          blockRect(bx, by, w, h, ia, ib, ja, jb);
          const Coverage c = coverage(t, ia, ib, ja, jb);
          if (c != Coverage::None) chunks[chunk].push_back({uint32_t(by * bins.blocksX + bx), int32_t(k), c});
        }
    }
  }, 1);
  bins.first.assign(blockCount + 1, 0);
  size_t hits = 0;
  for (const std::vector<Hit>& chunk : chunks) {
    hits += chunk.size();
    for (const Hit& hit : chunk) ++bins.first[hit.block + 1];
  }
  for (size_t b = 0; b < blockCount; ++b) bins.first[b + 1] += bins.first[b];
  bins.entries.resize(hits);
  std::vector<uint32_t> cursor(bins.first.begin(), bins.first.end() - 1);
  for (const std::vector<Hit>& chunk : chunks)
    for (const Hit& hit : chunk) bins.entries[cursor[hit.block]++] = {hit.triangle, hit.coverage};
  return bins;
}

bool sameSet(const UniformTile& a, const UniformTile& b) {
  return a.planes == b.planes && std::equal(a.plane, a.plane + a.planes, b.plane);
}

}  // namespace

TileClasses classifyTiles(const std::vector<RasterTriangle>& triangles, uint32_t width, uint32_t height,
                          double keySign, uint32_t peelCap, const RowSpans* needed) {
  TileClasses out;
  out.tilesX = (width + kTile - 1) / kTile;
  out.tilesY = (height + kTile - 1) / kTile;
  out.setOf.assign(size_t(out.tilesX) * out.tilesY, -1);
  const int32_t w = int32_t(width), h = int32_t(height);
  // A tile can be uniform only when it lies inside the region and every texel of it is needed.
  const auto tileEligible = [&](int32_t tx, int32_t ty) {
    if ((tx + 1) * kTile > w || (ty + 1) * kTile > h) return false;
    if (!needed) return true;
    for (int32_t j = ty * kTile; j < (ty + 1) * kTile; ++j)
      if (needed->begin[size_t(j)] > uint32_t(tx * kTile) || needed->end[size_t(j)] < uint32_t((tx + 1) * kTile))
        return false;
    return true;
  };
  const BlockBins bins = binToBlocks(triangles, w, h);

  // Rows of blocks in parallel, each with sets of its own (a set is added unless it equals the row's last one:
  // neighbouring tiles often meet the same planes); joined in row order below.
  struct RowSets {
    std::vector<UniformTile> sets;
    uint64_t uniform = 0;
  };
  std::vector<RowSets> rows(size_t(bins.blocksY));
  parallelFor(rows.size(), [&](size_t row) {
    RowSets& r = rows[row];
    std::vector<Candidate> candidates;
    const auto addSet = [&](const UniformTile& tile) {
      if (r.sets.empty() || !sameSet(r.sets.back(), tile)) r.sets.push_back(tile);
      return int32_t(r.sets.size() - 1);
    };
    const auto markUniform = [&](int32_t tx, int32_t ty, int32_t set) {
      out.setOf[size_t(ty) * out.tilesX + size_t(tx)] = set;
      ++r.uniform;
    };
    const int32_t by = int32_t(row);
    for (int32_t bx = 0; bx < bins.blocksX; ++bx) {
      const size_t b = size_t(by) * size_t(bins.blocksX) + size_t(bx);
      const uint32_t e0 = bins.first[b], e1 = bins.first[b + 1];
      int32_t ia, ib, ja, jb;
      blockRect(bx, by, w, h, ia, ib, ja, jb);
      const int32_t tx0 = ia / kTile, tx1 = (ib + kTile) / kTile, ty0 = ja / kTile, ty1 = (jb + kTile) / kTile;
      // First the whole block: when every triangle covers all of it and their order holds over it, it holds
      // over each of its tiles (a tile's key ranges lie inside the block's).
      bool allFull = true;
      for (uint32_t e = e0; e < e1; ++e) allFull = allFull && bins.entries[e].second == Coverage::Full;
      if (allFull) {
        candidates.clear();
        for (uint32_t e = e0; e < e1; ++e) candidates.push_back({0, 0, bins.entries[e].first, true});
        UniformTile tile;
        if (resolve(candidates, triangles, keySign, peelCap, ia, ib, ja, jb, tile)) {
          const int32_t set = addSet(tile);
          for (int32_t ty = ty0; ty < ty1; ++ty)
            for (int32_t tx = tx0; tx < tx1; ++tx)
              if (tileEligible(tx, ty)) markUniform(tx, ty, set);
          continue;
        }
      }
      // A block that many triangles cross is detailed geometry, where tiles are rarely uniform: leave its tiles to
      // the per-texel path rather than test each of them against every triangle (only the time changes).
      uint32_t crossing = 0;
      for (uint32_t e = e0; e < e1; ++e) crossing += bins.entries[e].second == Coverage::Crossed;
      if (crossing > kMostCrossingPerBlock) continue;
      for (int32_t ty = ty0; ty < ty1; ++ty)
        for (int32_t tx = tx0; tx < tx1; ++tx) {
          if (!tileEligible(tx, ty)) continue;
          const int32_t ta = tx * kTile, tb = ta + kTile - 1, sa = ty * kTile, sb = sa + kTile - 1;
          candidates.clear();
          for (uint32_t e = e0; e < e1; ++e) {
            const auto& [k, blockCoverage] = bins.entries[e];
            const Coverage c = blockCoverage == Coverage::Full ? Coverage::Full
                                                               : coverage(triangles[size_t(k)], ta, tb, sa, sb);
            if (c != Coverage::None) candidates.push_back({0, 0, k, c == Coverage::Full});
          }
          UniformTile tile;
          if (resolve(candidates, triangles, keySign, peelCap, ta, tb, sa, sb, tile)) markUniform(tx, ty, addSet(tile));
        }
    }
  }, 1);
  // The rows' sets in row order. Within a row they are what one pass over every block in order would make; at a
  // join that pass would have merged the row's first set into the last one before it when equal: so here.
  for (size_t row = 0; row < rows.size(); ++row) {
    const RowSets& r = rows[row];
    out.uniformCount += r.uniform;
    if (r.sets.empty()) continue;
    const bool merged = !out.sets.empty() && sameSet(out.sets.back(), r.sets.front());
    const int32_t shift = int32_t(out.sets.size()) - (merged ? 1 : 0);
    out.sets.insert(out.sets.end(), r.sets.begin() + (merged ? 1 : 0), r.sets.end());
    const size_t ty0 = row * size_t(kBlock / kTile), ty1 = std::min<size_t>(out.tilesY, ty0 + kBlock / kTile);
    for (size_t tile = ty0 * out.tilesX; tile < ty1 * out.tilesX; ++tile)
      if (out.setOf[tile] >= 0) out.setOf[tile] += shift;
  }
  return out;
}

}  // namespace cpvs
