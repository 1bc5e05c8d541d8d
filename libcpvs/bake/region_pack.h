#pragma once
// The region records of one view, as the bake cache keeps them (docs/incremental-bakes.md): per region of the
// view, in splitIntoRegions' order, its key and its DAG events (libcpvs/dag/region_record.h). One file per view
// frame, so a re-bake after an edit finds the records of the regions the edit did not reach.
//
// Coding (little-endian): "CPVSRGN1", the frame key (u64), the key of the light entry stored with it (u64), the
// region count (u64), per region its key (u64),
// its record's length (u64) and the record; then an XXH3-64 of every byte before it. A region with no record
// (a bake stopped before it) has length 0 and key 0.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cpvs {

struct CachedRegion {
  uint64_t key = 0;
  std::string record;
};

struct RegionPack {
  // The light entry (BakeCache::pathOf) the same bake stored: the next bake of this frame that stores another
  // one supersedes it.
  uint64_t lightKey = 0;
  std::vector<CachedRegion> regions;  // by region index
};

std::string encodeRegionPack(uint64_t frameKey, const RegionPack& pack);
// The pack for `frameKey`. Throws Error(InvalidInput) naming `name` and what is wrong: a damaged file, a checksum
// that does not match, or another frame's pack.
RegionPack decodeRegionPack(std::string_view bytes, uint64_t frameKey, const std::string& name);

}  // namespace cpvs
