#pragma once
// Per 8x8 texel tile, the visibility along depth as a chain of 64-bit masks (Kämpe et al. 2015, §3.4, docs/architecture.md).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/raster/depth_maps.h"

namespace cpvs {

// How free voxels (inside closed solids, e < z < x) are resolved.
enum class UndefinedMode : uint8_t {
  Kampe = 0,    // Kämpe et al. 2015, §3.4: greedy masks that shadow as much as allowed, each started at the most aligned
                // slice its window allows (tile_masks.cpp, docs/construction.md §1)
  Sintorn = 1,  // Sintorn 2014: lit+free -> lit, shadow+free -> shadow, mixed -> free becomes shadow
  None = 2,     // no free voxels: every texel exits right after its first surface (as for open geometry)
};
UndefinedMode parseUndefinedMode(const std::string& name);  // throws Error(Usage)
const char* undefinedModeName(UndefinedMode mode);

// Bit (ty * 8 + tx) of a mask is texel (tx, ty) of the tile; a set bit is shadowed.
inline constexpr uint64_t kAllLit = 0;
inline constexpr uint64_t kAllShadowed = ~uint64_t(0);

// The chains of all tiles of one region. Tile t's chain is entries [first[t], first[t + 1]): entry i holds
// mask[i] for slices [start[i], start[i + 1]) (the last one up to N). Masks only gain bits along a chain;
// the first entry always starts at slice 0.
struct TileChains {
  RegionRect rect;              // in texels; width and height are multiples of 8
  uint32_t resolution = 0;      // N
  uint32_t tilesX = 0, tilesY = 0;
  std::vector<uint32_t> first;  // tilesX * tilesY + 1
  std::vector<uint32_t> start;
  std::vector<uint64_t> mask;
  // Per tile, feeding the min-max hierarchy: every slice before litUntil is all lit in the chain; darkFrom is
  // the farthest enter slice + 1 (N where a texel sees nothing). From darkFrom on no voxel of the tile needs
  // light, so a volume lying past it over its whole footprint may be all shadowed even where the chain kept
  // free voxels lit (Kämpe et al. 2015, §3.4: shadowed + free -> shadowed); the chain is all shadowed from its last entry
  // at the latest, which is never before darkFrom.
  std::vector<uint32_t> litUntil;
  std::vector<uint32_t> darkFrom;
  // Lossy chains only (docs/lossy.md): voxels left lit at or past their texel's exit slice, in front of its next
  // surface (free: no receiver there) and behind it (delayed: at most the max voxel error per texel). Counted
  // from the chains: the DAG may still shadow some of them (past every darkFrom of a volume's footprint).
  uint64_t freeVoxelsLit = 0, voxelsDelayed = 0;

  uint32_t tileIndex(uint32_t tx, uint32_t ty) const { return ty * tilesX + tx; }
  uint64_t maskAt(uint32_t tile, uint32_t slice) const;
  // The first chain start strictly after `slice` (N when the tile does not change again).
  uint32_t nextTransition(uint32_t tile, uint32_t slice) const;
};

// The slice of [earliest, latest] with the most trailing zero bits (latest when earliest >= latest): where
// Kampe chains start an entry whose window allows any slice of that range.
uint32_t mostAlignedSlice(uint32_t earliest, uint32_t latest);

// Builds the chains of a region from its depth maps. Tiles are independent; `threads` > 1 splits rows
// between threads (the result does not depend on it). With `maxVoxelError` (lossy, mode kampe only) and the
// region's next surfaces (raster/next_surface.h), each texel's shadow may start anywhere up to
// max(exit, next - kNextSurfaceGuard, enter + 1 + maxVoxelError) (docs/lossy.md); a region without next
// surfaces (all free, outside a spot light's cone) keeps its exact chains.
TileChains buildTileChains(const DepthRegion& depth, UndefinedMode mode, unsigned threads = 1,
                           std::optional<uint32_t> maxVoxelError = std::nullopt);

// Min-max hierarchy over the tiles of a region: level 0 is per tile, level k covers 2^k x 2^k tiles.
struct TileHierarchy {
  std::vector<uint32_t> size;                   // tiles per side at each level
  std::vector<std::vector<uint32_t>> minLitUntil;
  std::vector<std::vector<uint32_t>> maxLastChange;  // start of the chain's last entry (0 for a one-entry chain)
  std::vector<std::vector<uint32_t>> minDarkFrom;
  std::vector<std::vector<uint32_t>> maxDarkFrom;
  explicit TileHierarchy(const TileChains& chains);

  // The first slice in (after, cap) at which a chain of the footprint starts an entry or (withDarkFrom) a
  // darkFrom of the footprint lies; cap if none. Stops early with any such slice <= enough. Subtrees whose
  // ranges miss the interval are skipped. With cap <= the footprint's minLitUntil no chain can answer, which
  // leaves the smallest darkFrom in (after, cap).
  uint32_t nextChange(const TileChains& chains, uint32_t level, size_t index, uint32_t after, uint32_t cap,
                      uint32_t enough, bool withDarkFrom) const;
};

}  // namespace cpvs
