#pragma once
// Top-down construction of a view's shadow DAG from tile chains, region by region (Kämpe et al. 2015, §3.2,
// docs/construction.md). Hash tables persist across regions, so identical subtrees merge over the whole view.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "libcpvs/dag/leaf_parent_table.h"
#include "libcpvs/dag/leaf_table.h"
#include "libcpvs/dag/node_table.h"
#include "libcpvs/dag/region_record.h"
#include "libcpvs/runtime/shadow_dag.h"
#include "libcpvs/tiles/tile_masks.h"

namespace cpvs {

struct DagBuildStats {
  uint64_t nodesBuilt = 0;       // interned (built) nodes, duplicates included
  uint64_t nodesReused = 0;      // volumes that took their Z-neighbour's node without being built (§3.2)
  uint64_t homogeneous = 0;      // volumes answered by the min-max hierarchy
  uint64_t leavesMerged = 0;     // edge merging: distinct masks answered by another leaf (leaf_table.h)
  uint64_t edgeTexelsFlipped = 0;  // and their texels that differ from their answers
};

class DagBuilder {
public:
  // regionSize: edge of the regions fed to addRegion (a power of two, at most N). maxEdgeFlips: the leaves'
  // lossy bound (leaf_table.h), 0 for a lossless DAG.
  DagBuilder(uint32_t resolution, uint32_t regionSize, bool nodeReuse, uint32_t maxEdgeFlips = 0);
  ~DagBuilder();

  // Adds the subtrees of one region. Regions may come in any order, but the same order gives the same bytes:
  // callers use splitIntoRegions' order. With `record`, also writes what the region added (region_record.h).
  void addRegion(const TileChains& chains, std::string* record = nullptr);
  // A region's record (from addRegion) checked against this builder: throws Error(InvalidInput) when it does not
  // decode for it. Adds nothing; may run on one thread while another adds or replays a region. The result views
  // `record`, which must outlive it.
  RegionEvents decodeRecord(std::string_view record);
  // Adds the region at `rect` again from its decoded record, without its chains: the builder ends as addRegion
  // would leave it when called at this point of the same sequence with the chains the record was made from.
  void replayRegion(const RegionRect& rect, const RegionEvents& events);
  // Frees what recording and replaying regions keep from region to region (finish() does too).
  void releaseRegionScratch();
  // Builds the levels above the regions and returns the relocated DAG. Every region must have been added.
  ShadowDag finish();
  // Bytes finish() may allocate beyond what it frees first (the hash indexes and region columns, which the
  // allocator can hand out again): an upper estimate, for a memory budget to refuse before running out.
  uint64_t finishExtraBytes() const;

  const DagBuildStats& stats() const { return stats_; }

private:
  struct Result {
    ChildCode code = ChildCode::Lit;
    uint32_t ref = 0;     // level-local node offset (or leaf index below level L)
    uint32_t nextT = 0;   // first tile-chain change or darkFrom strictly after the volume's first slice (lower bound)
    bool valid = false;   // false: no neighbour known
    // nextT of the four far children (c = 4..7, by c - 4) of a built node: the reuse bound of the near
    // children of the volume behind it. 0 (no reuse) where unknown.
    uint32_t farNextT[4] = {0, 0, 0, 0};
    uint32_t event = 0;  // while a region is recorded: the event of a reference (region_record.h)
  };
  Result build(uint32_t level, uint32_t tx, uint32_t ty, uint32_t z0, const Result& neighbour);
  Result buildLeafParent(uint32_t tx, uint32_t ty, uint32_t z0);
  Result intern(uint32_t level, const Result (&children)[8], uint32_t nextT);
  // The offset of the node `words` (a build-form header, then its `refs` reference words) in its level's table:
  // the leaf parents' byte-coded one at the leaf level, else the level's word table.
  uint32_t internWords(uint32_t level, const uint32_t* words, unsigned refs);
  Result buildTop(uint32_t level, uint32_t rx, uint32_t ry, uint32_t zBlock);
  size_t regionIndexOf(const RegionRect& rect) const;  // ry * regionsPerSide + rx; throws off the grid

  uint32_t resolution_;
  uint32_t regionSize_;
  bool nodeReuse_;
  uint32_t leafLevel_;    // L
  uint32_t regionLevel_;  // level whose nodes cover exactly one region's footprint
  uint32_t regionsPerSide_;
  std::vector<NodeTable> tables_;  // per level above the leaf parents
  LeafParentTable leafParents_;    // level L
  LeafTable leafTable_;
  // [ry][rx][zBlock]: each region volume's child code (low two bits) and node offset (above them), all that
  // buildTop needs. A full Result is 32 bytes; at 256k with 1k regions there are 256^3 of them (537 MB).
  std::vector<uint32_t> regionColumns_;
  static uint32_t packColumn(const Result& result);
  std::vector<bool> regionAdded_;
  DagBuildStats stats_;
  bool finished_ = false;  // finish() frees the hash indexes: nothing may be added after it
  // Per-region state while building.
  const TileChains* chains_ = nullptr;
  std::unique_ptr<TileHierarchy> hierarchy_;
  std::vector<uint8_t> decodeLevels_, replayLevels_;  // scratch of decodeRecord and replayRegion (two threads)
  std::vector<uint32_t> replayRefs_;                  // per event of the region replayed, what interning it gave
  RegionRecorder* recorder_ = nullptr;     // while a region is recorded: recorderStore_
  std::unique_ptr<RegionRecorder> recorderStore_;  // kept from region to region
};

// Builds a whole view from one region (N <= region size); convenience for tests and small bakes.
ShadowDag buildDag(const TileChains& chains, bool nodeReuse, DagBuildStats* stats = nullptr, uint32_t maxEdgeFlips = 0);

}  // namespace cpvs
