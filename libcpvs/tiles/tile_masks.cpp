#include "libcpvs/tiles/tile_masks.h"

#include <algorithm>
#include <iterator>
#include <bit>
#include <string>

#include "libcpvs/base/error.h"
#include "libcpvs/base/named_values.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/raster/next_surface.h"

namespace cpvs {

namespace {
constexpr Named<UndefinedMode> kUndefinedModes[] = {
    {UndefinedMode::Kampe, "kampe"}, {UndefinedMode::Sintorn, "sintorn"}, {UndefinedMode::None, "none"}};
}  // namespace

UndefinedMode parseUndefinedMode(const std::string& name) {
  return parseNamed(kUndefinedModes, name, "undefined-voxel mode");
}
const char* undefinedModeName(UndefinedMode mode) { return nameOf(kUndefinedModes, mode); }

uint64_t TileChains::maskAt(uint32_t tile, uint32_t slice) const {
  const auto begin = start.begin() + first[tile], end = start.begin() + first[tile + 1];
  const auto it = std::upper_bound(begin, end, slice);
  return mask[size_t(it - start.begin()) - 1];
}

uint32_t TileChains::nextTransition(uint32_t tile, uint32_t slice) const {
  const auto begin = start.begin() + first[tile], end = start.begin() + first[tile + 1];
  const auto it = std::upper_bound(begin, end, slice);
  return it == end ? resolution : *it;
}

uint32_t mostAlignedSlice(uint32_t earliest, uint32_t latest) {
  if (earliest >= latest) return latest;
  // The window's values share the bits above the highest bit b where earliest and latest differ (latest has
  // it set). Their common prefix followed by zeros is the most aligned value if it is earliest itself;
  // otherwise the prefix with bit b set and zeros below is (it lies in (earliest, latest]).
  const uint32_t b = uint32_t(std::bit_width(earliest ^ latest)) - 1;
  const uint64_t below = (uint64_t(1) << (b + 1)) - 1;  // 64-bit: b may be 31
  if ((uint64_t(latest) & ~below) == earliest) return earliest;
  return latest & ~((uint32_t(1) << b) - 1);
}

namespace {

struct Entry {
  uint32_t start;
  uint64_t mask;
};

// byEnter = (e[j] << 8) | j for the 64 texels, in ascending order. A tile's enter slices usually span a few
// dozen slices (a surface seen at some slope), so a counting sort over that span, which keeps texel order
// within a slice, replaces a general sort; a wider span (a depth discontinuity) falls back to std::sort.
void sortByEnter(const uint32_t (&e)[64], uint64_t (&byEnter)[64]) {
  uint32_t lo = e[0], hi = e[0];
  for (uint32_t j = 1; j < 64; ++j) {
    lo = std::min(lo, e[j]);
    hi = std::max(hi, e[j]);
  }
  constexpr uint32_t kSpan = 256;
  if (hi - lo >= kSpan) {
    for (uint32_t j = 0; j < 64; ++j) byEnter[j] = (uint64_t(e[j]) << 8) | j;
    std::sort(byEnter, byEnter + 64);
    return;
  }
  if (hi == lo) {  // one enter slice: texel order
    for (uint32_t j = 0; j < 64; ++j) byEnter[j] = (uint64_t(lo) << 8) | j;
    return;
  }
  uint8_t count[kSpan + 1] = {};
  const uint32_t span = hi - lo + 1;
  for (uint32_t j = 0; j < 64; ++j) ++count[e[j] - lo + 1];
  for (uint32_t k = 1; k <= span; ++k) count[k] = uint8_t(count[k] + count[k - 1]);  // count[k]: texels below lo + k
  for (uint32_t j = 0; j < 64; ++j) byEnter[count[e[j] - lo]++] = (uint64_t(e[j]) << 8) | j;
}

// One tile's chain. e[j], x[j]: enter and exit slices of texel j (bit j).
//
// Every mask the rules produce shadows the texels whose enter slice lies in front of some slice z, so masks
// are prefixes of the texels sorted by enter slice. Walking that order with a cursor makes each step O(1):
// the next mask's farthest enter is the last texel taken, and the first exit among the texels still lit is
// a suffix minimum. (tests/dag_test.cpp compares it with the rules applied texel by texel.)
// Returns the tile's farthest enter slice.
uint32_t buildChain(const uint32_t (&e)[64], const uint32_t (&x)[64], uint32_t n, UndefinedMode mode,
                    std::vector<Entry>& out) {
  out.clear();
  out.push_back({0, kAllLit});
  uint64_t byEnter[64];  // (enter << 8) | texel, sorted: texel order breaks ties, so the walk is deterministic
  sortByEnter(e, byEnter);
  uint32_t enterAt[64], litExitFrom[65];  // enter of the k-th texel; min exit of texels k..63 (n past the end)
  litExitFrom[64] = n;
  for (int k = 63; k >= 0; --k) {
    enterAt[k] = uint32_t(byEnter[k] >> 8);
    litExitFrom[k] = std::min(litExitFrom[k + 1], x[byEnter[k] & 63]);
  }
  const uint32_t minX = litExitFrom[0], maxE = enterAt[63];
  // A new entry may start anywhere after the previous one and past the enter slice of every texel it shadows,
  // up to `latest` (where the previous entry stops being allowed). Kampe starts it at the most aligned slice of
  // that window: neighbouring tiles whose windows overlap then agree on it, so whole DAG volumes stay
  // homogeneous or repeat along z. Sintorn and None keep the latest slice (Sintorn's rule fixes it anyway).
  const bool align = mode == UndefinedMode::Kampe;
  auto place = [&](uint32_t farthestEnter, uint32_t latest) {
    const uint32_t earliest = std::max(out.back().start + 1, farthestEnter + 1);
    return align ? mostAlignedSlice(earliest, latest) : latest;
  };
  uint32_t taken = 0;  // texels in the current mask: byEnter[0, taken)
  uint64_t current = kAllLit;
  uint32_t z = minX;  // nothing needs shadow before the nearest exit
  while (z < n) {
    if (z > maxE) {  // nothing needs light any more
      out.push_back({place(maxE, z), kAllShadowed});
      return maxE;
    }
    // The mask at z shadows every texel whose first surface is in front of z.
    const uint32_t before = taken;
    while (taken < 64 && enterAt[taken] < z) current |= uint64_t(1) << (byEnter[taken++] & 63);
    if (taken != before) out.push_back({place(enterAt[taken - 1], z), current});
    if (taken == 64) return maxE;
    // Sintorn: the mask follows the enter depths slice by slice, changing after the next enter depth.
    // Kampe (and None, whose x = e + 1): the mask is kept until a texel outside it must be shadowed.
    const uint32_t next = mode == UndefinedMode::Sintorn ? enterAt[taken] + 1 : litExitFrom[taken];
    if (align && next > maxE + 1 && maxE + 1 < n) {  // all shadowed is allowed from maxE + 1 to next
      out.push_back({place(maxE, std::min(next, n - 1)), kAllShadowed});
      return maxE;
    }
    z = std::min(next, maxE + 1);
  }
  return maxE;
}

// The chain buildChain gives a tile whose every exit lies past its farthest enter (maxEnter < minExit), from
// those two values alone: all lit until the nearest exit, all shadowed from there (the first mask buildChain
// tries at z = minExit already shadows every texel, since z > maxEnter). Without any exit before N the chain is
// all lit. tests/uniform_tiles_test.cpp compares the chains of summarised regions with buildChain's. Appends the
// chain to `start` and `mask`; returns its length.
uint32_t summarizedChain(uint32_t maxEnter, uint32_t minExit, uint32_t n, UndefinedMode mode,
                         std::vector<uint32_t>& start, std::vector<uint64_t>& mask) {
  start.push_back(0);
  mask.push_back(kAllLit);
  if (minExit >= n) return 1;
  const uint32_t earliest = std::max(1u, maxEnter + 1);
  start.push_back(mode == UndefinedMode::Kampe ? mostAlignedSlice(earliest, minExit) : minExit);
  mask.push_back(kAllShadowed);
  return 2;
}

// The chains of one band of tile rows, appended tile after tile to flat arrays (no allocation per tile).
struct ChainBand {
  std::vector<uint32_t> start;
  std::vector<uint64_t> mask;
  std::vector<uint32_t> length;  // entries per tile of the band
  uint64_t voxelsDelayed = 0, freeVoxelsLit = 0;
};

// A texel's lossy window (docs/lossy.md): its shadow may start anywhere before `freeEnd` without changing an
// answer on a surface (no receiver lies in front of the next surface's guard), and up to `end` with the delay.
struct LossyWindow {
  uint32_t freeEnd, end;
};
LossyWindow lossyWindow(uint32_t e, uint32_t x, uint32_t next, uint32_t maxVoxelError, uint32_t n) {
  const uint32_t freeEnd = std::min(n, std::max(x, next > kNextSurfaceGuard ? next - kNextSurfaceGuard : 0));
  return {freeEnd, uint32_t(std::min<uint64_t>(n, std::max<uint64_t>(freeEnd, uint64_t(e) + 1 + maxVoxelError)))};
}

void buildRows(const DepthRegion& depth, UndefinedMode mode, const std::optional<uint32_t>& maxVoxelError,
               uint32_t rowBegin, uint32_t rowEnd, uint32_t tilesX, ChainBand& band, std::vector<uint32_t>& darkFrom) {
  uint32_t e[64], x[64], exact[64], freeEnd[64];
  const uint32_t n = depth.resolution;
  const bool lossy = maxVoxelError.has_value() && !depth.next.empty();
  const auto nextAt = [&](uint32_t px, uint32_t py) { return depth.next[size_t(py) * depth.rect.width + px]; };
  std::vector<Entry> chain;
  band.length.reserve(size_t(rowEnd - rowBegin) * tilesX);
  band.start.reserve(2 * band.length.capacity());  // most tiles hold two entries: lit, then shadowed
  band.mask.reserve(2 * band.length.capacity());
  for (uint32_t ty = rowBegin; ty < rowEnd; ++ty) {
    for (uint32_t tx = 0; tx < tilesX; ++tx) {
      if (depth.summarized(tx, ty)) {
        const TileSummary& summary = depth.tiles[size_t(ty) * tilesX + tx];
        if (mode == UndefinedMode::None && summary.maxEnter < n)  // its exits would be e + 1, not the peel's
          throw Error(ErrorCategory::RuntimeFailure, "tile chains: mode none needs every texel of a tile that sees geometry");
        uint32_t minExit = summary.minExit;
        if (lossy && summary.maxEnter < n) {  // free up to the nearest next surface of its texels (no delay)
          uint32_t nearest = n;
          for (uint32_t j = 0; j < 64; ++j) nearest = std::min(nearest, nextAt(tx * 8 + (j & 7), ty * 8 + (j >> 3)));
          minExit = lossyWindow(summary.maxEnter, summary.minExit, nearest, 0, n).freeEnd;
        }
        const uint32_t length = summarizedChain(summary.maxEnter, minExit, n, mode, band.start, band.mask);
        if (lossy && length == 2)  // each texel's exit is at least minExit: an upper bound
          band.freeVoxelsLit += 64 * uint64_t(band.start.back() - std::min(band.start.back(), summary.minExit));
        band.length.push_back(length);
        darkFrom[size_t(ty) * tilesX + tx] = std::min(summary.maxEnter + 1, n);
        continue;
      }
      for (uint32_t j = 0; j < 64; ++j) {
        const uint32_t px = tx * 8 + (j & 7), py = ty * 8 + (j >> 3);
        e[j] = depth.enterAt(px, py);
        x[j] = mode == UndefinedMode::None ? std::min(e[j] + 1, n) : depth.exitAt(px, py);
        if (e[j] >= n) x[j] = n;
        if (lossy && e[j] < n) {
          const LossyWindow w = lossyWindow(e[j], x[j], nextAt(px, py), *maxVoxelError, n);
          exact[j] = x[j];
          freeEnd[j] = w.freeEnd;
          x[j] = w.end;
        }
      }
      const uint32_t farthestEnter = buildChain(e, x, n, mode, chain);
      if (lossy) {  // where the chain shadows each texel first (N: never), against its exit and its free window
        uint64_t shadowed = 0;
        const auto count = [&](uint64_t texels, uint32_t start) {
          for (; texels; texels &= texels - 1) {
            const uint32_t j = uint32_t(std::countr_zero(texels));
            if (e[j] >= n) continue;
            band.freeVoxelsLit += std::min(start, freeEnd[j]) - std::min(start, exact[j]);
            band.voxelsDelayed += start - std::min(start, freeEnd[j]);
          }
        };
        for (const Entry& entry : chain) {
          count(entry.mask & ~shadowed, entry.start);
          shadowed |= entry.mask;
        }
        count(~shadowed, n);
      }
      for (const Entry& entry : chain) {
        band.start.push_back(entry.start);
        band.mask.push_back(entry.mask);
      }
      band.length.push_back(uint32_t(chain.size()));
      darkFrom[size_t(ty) * tilesX + tx] = std::min(farthestEnter + 1, n);
    }
  }
}

}  // namespace

TileChains buildTileChains(const DepthRegion& depth, UndefinedMode mode, unsigned threads,
                           std::optional<uint32_t> maxVoxelError) {
  const RegionRect& rect = depth.rect;
  if (rect.width % 8 != 0 || rect.height % 8 != 0)
    throw Error(ErrorCategory::RuntimeFailure, "region size must be a multiple of 8 texels");
  if (maxVoxelError && mode != UndefinedMode::Kampe)
    throw Error(ErrorCategory::InvalidArgument, "a lossy bake (max voxel error) needs the undefined-voxel mode kampe");
  if (maxVoxelError && !depth.next.empty() && depth.next.size() != depth.enter.size())
    throw Error(ErrorCategory::RuntimeFailure, "tile chains: the region's next surfaces do not match its texels");
  TileChains chains;
  chains.rect = rect;
  chains.resolution = depth.resolution;
  chains.tilesX = rect.width / 8;
  chains.tilesY = rect.height / 8;
  const size_t tileCount = size_t(chains.tilesX) * chains.tilesY;

  chains.darkFrom.resize(tileCount);
  threads = std::max(1u, std::min(threads, chains.tilesY));
  std::vector<ChainBand> bands(threads);
  parallelParts(chains.tilesY, threads, [&](unsigned part, size_t begin, size_t end) {
    buildRows(depth, mode, maxVoxelError, uint32_t(begin), uint32_t(end), chains.tilesX, bands[part], chains.darkFrom);
  });

  // Bands hold consecutive rows in order: the region's chains are their concatenation.
  size_t total = 0;
  for (const ChainBand& band : bands) total += band.start.size();
  if (total > UINT32_MAX) throw Error(ErrorCategory::RuntimeFailure, "too many tile-chain entries in one region");
  chains.start.reserve(total);
  chains.mask.reserve(total);
  chains.first.reserve(tileCount + 1);
  chains.litUntil.reserve(tileCount);
  for (ChainBand& band : bands) {
    chains.voxelsDelayed += band.voxelsDelayed;
    chains.freeVoxelsLit += band.freeVoxelsLit;
    const uint32_t offset = uint32_t(chains.start.size());
    uint32_t at = 0;
    for (uint32_t length : band.length) {
      chains.first.push_back(offset + at);
      chains.litUntil.push_back(length > 1 ? band.start[at + 1] : depth.resolution);
      at += length;
    }
    chains.start.insert(chains.start.end(), band.start.begin(), band.start.end());
    chains.mask.insert(chains.mask.end(), band.mask.begin(), band.mask.end());
    band = ChainBand();
  }
  chains.first.push_back(uint32_t(chains.start.size()));
  return chains;
}

TileHierarchy::TileHierarchy(const TileChains& chains) {
  if (chains.tilesX != chains.tilesY || (chains.tilesX & (chains.tilesX - 1)) != 0)
    throw Error(ErrorCategory::RuntimeFailure, "tile hierarchy needs a square power-of-two region");
  size.push_back(chains.tilesX);
  minLitUntil.push_back(chains.litUntil);
  std::vector<uint32_t> lastChange(chains.litUntil.size());
  for (size_t t = 0; t < lastChange.size(); ++t) lastChange[t] = chains.start[chains.first[t + 1] - 1];
  maxLastChange.push_back(std::move(lastChange));
  minDarkFrom.push_back(chains.darkFrom);
  maxDarkFrom.push_back(chains.darkFrom);
  // One coarser level of `fine` (fine x fine values), each value the min or max of its four.
  auto coarsen = [](const std::vector<uint32_t>& fine, uint32_t fineSize, auto pick) {
    const uint32_t coarseSize = fineSize / 2;
    std::vector<uint32_t> coarse(size_t(coarseSize) * coarseSize);
    for (uint32_t y = 0; y < coarseSize; ++y)
      for (uint32_t x = 0; x < coarseSize; ++x) {
        const size_t a = size_t(2 * y) * fineSize + 2 * x, b = a + fineSize;
        coarse[size_t(y) * coarseSize + x] = pick(pick(fine[a], fine[a + 1]), pick(fine[b], fine[b + 1]));
      }
    return coarse;
  };
  const auto lower = [](uint32_t a, uint32_t b) { return std::min(a, b); };
  const auto upper = [](uint32_t a, uint32_t b) { return std::max(a, b); };
  while (size.back() > 1) {
    const uint32_t fine = size.back();
    minLitUntil.push_back(coarsen(minLitUntil.back(), fine, lower));
    maxLastChange.push_back(coarsen(maxLastChange.back(), fine, upper));
    minDarkFrom.push_back(coarsen(minDarkFrom.back(), fine, lower));
    maxDarkFrom.push_back(coarsen(maxDarkFrom.back(), fine, upper));
    size.push_back(fine / 2);
  }
}

uint32_t TileHierarchy::nextChange(const TileChains& chains, uint32_t level, size_t index, uint32_t after,
                                   uint32_t cap, uint32_t enough, bool withDarkFrom) const {
  // Chain starts lie in [litUntil, lastChange] of their tile (litUntil is the second entry's start).
  const bool chainMay = minLitUntil[level][index] < cap && maxLastChange[level][index] > after;
  const bool darkMay = withDarkFrom && maxDarkFrom[level][index] > after && minDarkFrom[level][index] < cap;
  if (!chainMay && !darkMay) return cap;
  // Only darkFroms can answer and all of them lie past `after`: the smallest is the footprint's minimum.
  if (!chainMay && minDarkFrom[level][index] > after) return minDarkFrom[level][index];
  if (level == 0) {
    if (chainMay) cap = std::min(cap, chains.nextTransition(uint32_t(index), after));
    if (darkMay) cap = std::min(cap, maxDarkFrom[0][index]);
    return cap;
  }
  const uint32_t x = uint32_t(index % size[level]), y = uint32_t(index / size[level]);
  const size_t fine = size[level - 1];
  const size_t a = size_t(2 * y) * fine + 2 * x, b = a + fine;
  for (size_t child : {a, a + 1, b, b + 1}) {
    cap = nextChange(chains, level - 1, child, after, cap, enough, withDarkFrom);
    if (cap <= enough) break;
  }
  return cap;
}

}  // namespace cpvs
