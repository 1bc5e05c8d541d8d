#pragma once
// What one region added to a view's DAG builder, kept so that a later build of the same view can add the region
// again without rendering it (docs/incremental-bakes.md). The builder hash-conses nodes over the whole view, so
// a region's nodes are not a self-contained subtree: their offsets depend on every region before. What does not
// depend on them is the sequence of intern calls the region makes, with each child named by the call that
// produced it. Replaying that sequence, in region order, leaves the tables exactly as building the region would,
// so the DAG, and the file, are the same bytes.
//
// Only the first call for each node (or leaf mask) is kept: a repeated call finds what the first stored and
// changes nothing. Leaves are kept per mask, not per leaf index: with edge merging two masks may share a leaf,
// and the second one's alias is state that later calls read.
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "libcpvs/dag/hash_index.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// The builder's counters a region adds (DagBuildStats), kept so a replayed region counts as a built one.
struct RegionCounts {
  uint64_t nodesBuilt = 0, nodesReused = 0, homogeneous = 0;
};

// Writes a region's record while the builder builds it. Calls are kept by their content (a leaf by its mask, a
// node by its level, header and children's events), never by the offset the builder gave them: with edge merging
// two masks may share a leaf in one build and not in the next, and so may the nodes above them. One recorder
// serves every region of a view (begin() empties it and keeps its arrays and indexes), so recording allocates
// nothing per region but the record itself.
class RegionRecorder {
public:
  // regionLevel: the level whose nodes cover one region; leafLevel: the level of leaf parents (their children
  // are leaves).
  RegionRecorder(uint32_t regionLevel, uint32_t leafLevel) : regionLevel_(regionLevel), leafLevel_(leafLevel) {}

  void begin();
  // A leaf mask the builder interned; returns its event.
  uint32_t leaf(uint64_t mask);
  // A node of `level` the builder interned (its build-form header, the events of its reference children in
  // order); returns its event.
  uint32_t node(uint32_t level, uint32_t header, const uint32_t* childEvents, unsigned childCount);
  // The event of the k-th reference child of node event `parent`.
  uint32_t childEvent(uint32_t parent, unsigned k) const { return childEvents_[firstChild_[parent] + k]; }
  // The region's volume at the next z block, as the builder keeps it for the levels above the regions.
  void column(ChildCode code, uint32_t event);
  // The record's bytes.
  std::string finish(const RegionCounts& counts);

private:
  uint32_t regionLevel_, leafLevel_;
  std::string bytes_;                         // the events
  std::vector<uint32_t> levelOf_, headerOf_;  // per event
  std::vector<uint64_t> valueOf_;             // per event: a leaf's mask, a node's content hash
  std::vector<uint32_t> firstChild_;          // per event, into childEvents_
  std::vector<uint32_t> childEvents_;
  std::vector<std::pair<ChildCode, uint32_t>> columns_;  // code and event, per z block
  HashIndex leafIndex_, nodeIndex_;                      // of leaf events by mask, of node events by content
  uint32_t leaves_ = 0, nodes_ = 0;
};

// A record checked against the builder it is for (decodeRegionRecord): every child names an earlier event of
// the level below, every header is one the builder could have interned, the columns are of the region level,
// nothing is left over. It views the record's bytes, which must outlive it.
struct RegionEvents {
  std::string_view record;
  uint32_t regionLevel = 0, leafLevel = 0, columnCount = 0;
  uint32_t eventCount = 0;
  RegionCounts counts;
};

// What walkRegionEvents hands over, event by event, in the order the builder made them (ids count from 0).
class RegionEventVisitor {
public:
  virtual ~RegionEventVisitor() = default;
  virtual void leaf(uint32_t id, uint64_t mask) = 0;
  // A node of `level` (leafLevel: a leaf parent, whose children are leaves) and its reference children's ids.
  virtual void node(uint32_t id, uint32_t level, uint32_t header, const uint32_t* children, unsigned count) = 0;
  // The region's volume at z block `z`: its code, and its event when a reference.
  virtual void column(uint32_t z, ChildCode code, uint32_t event) = 0;
};

// Checks `record` for a builder with these levels and `columnCount` z blocks. Throws Error(InvalidInput) naming
// what is wrong: a damaged or foreign record must be refused before the builder is touched. `levels` is scratch
// space (one byte per event), reused from call to call.
RegionEvents decodeRegionRecord(std::string_view record, uint32_t regionLevel, uint32_t leafLevel,
                                uint32_t columnCount, std::vector<uint8_t>& levels);
// Hands a checked record's events and columns to `visitor`, in order.
void walkRegionEvents(const RegionEvents& events, std::vector<uint8_t>& levels, RegionEventVisitor& visitor);

}  // namespace cpvs
