#include "libcpvs/dag/dag_builder.h"

#include <algorithm>
#include <bit>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/dag_encoder.h"

namespace cpvs {

namespace {
uint32_t log2u(uint32_t v) { return uint32_t(std::countr_zero(v)); }
}  // namespace

DagBuilder::DagBuilder(uint32_t resolution, uint32_t regionSize, bool nodeReuse, uint32_t maxEdgeFlips)
    : resolution_(resolution), regionSize_(std::min(regionSize, resolution)), nodeReuse_(nodeReuse),
      leafTable_(maxEdgeFlips) {
  if (resolution < 8 || !std::has_single_bit(resolution) || !std::has_single_bit(regionSize_) || regionSize_ < 8)
    throw Error(ErrorCategory::RuntimeFailure, "DAG resolution and region size must be powers of two of at least 8");
  leafLevel_ = log2u(resolution) - 3;
  regionLevel_ = log2u(resolution / regionSize_);
  regionsPerSide_ = resolution / regionSize_;
  tables_.resize(leafLevel_);
  regionColumns_.resize(size_t(regionsPerSide_) * regionsPerSide_ * regionsPerSide_);
  regionAdded_.assign(size_t(regionsPerSide_) * regionsPerSide_, false);
}

DagBuilder::~DagBuilder() = default;

uint32_t DagBuilder::internWords(uint32_t level, const uint32_t* words, unsigned refs) {
  return level == leafLevel_ ? leafParents_.intern(words[0], words + 1, refs) : tables_[level].intern(words, refs + 1);
}

DagBuilder::Result DagBuilder::intern(uint32_t level, const Result (&children)[8], uint32_t nextT) {
  uint32_t words[9];
  uint32_t header = 0, count = 1;
  bool same = true;
  for (unsigned c = 0; c < 8; ++c) {
    header |= uint32_t(children[c].code) << (2 * c);
    if (children[c].code == ChildCode::Ref) words[count++] = children[c].ref;
    same = same && children[c].code == children[0].code;
  }
  if (same && children[0].code != ChildCode::Ref) return {children[0].code, 0, nextT, true};
  words[0] = header;
  ++stats_.nodesBuilt;
  const uint32_t ref = internWords(level, words, count - 1);
  Result result{ChildCode::Ref, ref, nextT, true};
  if (recorder_) {
    uint32_t events[8];
    for (unsigned c = 0, k = 0; c < 8; ++c)
      if (children[c].code == ChildCode::Ref) events[k++] = children[c].event;
    result.event = recorder_->node(level, header, events, count - 1);
  }
  for (unsigned c = 0; c < 4; ++c) result.farNextT[c] = children[c + 4].nextT;
  return result;
}

DagBuilder::Result DagBuilder::buildLeafParent(uint32_t tx, uint32_t ty, uint32_t z0) {
  const TileChains& ch = *chains_;
  const uint32_t tile = ch.tileIndex(tx, ty);
  const uint32_t begin = ch.first[tile], end = ch.first[tile + 1];
  uint32_t entry = uint32_t(std::upper_bound(ch.start.begin() + begin, ch.start.begin() + end, z0) - ch.start.begin()) - 1;
  Result children[8];
  for (uint32_t c = 0; c < 8; ++c) {
    const uint32_t z = z0 + c;
    while (entry + 1 < end && ch.start[entry + 1] <= z) ++entry;
    const uint64_t mask = ch.mask[entry];
    if (mask == kAllLit)
      children[c] = {ChildCode::Lit, 0, 0, true};
    else if (mask == kAllShadowed)
      children[c] = {ChildCode::Shadowed, 0, 0, true};
    else {
      children[c] = {ChildCode::Ref, leafTable_.intern(mask), 0, true};
      if (recorder_) children[c].event = recorder_->leaf(mask);
    }
  }
  // The bound counts the tile's darkFrom too (it lies after z0: this volume passed the shadow test). The chain
  // may keep a partial mask past it (Kampe places the all-shadowed entry anywhere in its window), while
  // coarser volumes behind this one that lie past every darkFrom of their footprint are shadowed.
  return intern(leafLevel_, children, std::min(ch.nextTransition(tile, z0), ch.darkFrom[tile]));
}

DagBuilder::Result DagBuilder::build(uint32_t level, uint32_t tx, uint32_t ty, uint32_t z0, const Result& neighbour) {
  const uint32_t size = resolution_ >> level;
  const uint32_t z1 = z0 + size - 1;
  const uint32_t hLevel = log2u(size / 8);
  const uint32_t hSize = hierarchy_->size[hLevel];
  const size_t h = size_t(ty >> hLevel) * hSize + (tx >> hLevel);
  // Shadow first: once a volume lies past every front surface of its footprint, so do all volumes behind it
  // (coarser footprints only raise the bound), which keeps the answer the same with and without reuse.
  if (z0 >= hierarchy_->maxDarkFrom[hLevel][h]) {
    ++stats_.homogeneous;
    return {ChildCode::Shadowed, 0, resolution_, true};
  }
  const uint32_t minLit = hierarchy_->minLitUntil[hLevel][h];
  if (z1 < minLit) {
    ++stats_.homogeneous;
    // Behind this volume the chains change at minLit at the earliest, and the shadow test above may start
    // to hold at any darkFrom of the footprint: the first of those is the next change.
    return {ChildCode::Lit, 0, hierarchy_->nextChange(*chains_, hLevel, h, z0, minLit, 0, true), true};
  }
  // §3.2: nothing changes along z in this footprint from the neighbour's first slice to our last one (no chain
  // entry, no darkFrom), so this volume equals its neighbour nearer the light: take its node without building it.
  if (nodeReuse_ && neighbour.valid && neighbour.code == ChildCode::Ref) {
    if (neighbour.nextT > z1) {
      ++stats_.nodesReused;
      return neighbour;
    }
    // The carried bound is only a lower bound: below a neighbour known by its node alone (the far child of a
    // reused or region-level volume), every descendant gets that node's bound. Ask the hierarchy exactly. A
    // leaf parent's content depends on its chain alone once it passed the shadow test, so darkFrom is left out.
    const uint32_t next =
        hierarchy_->nextChange(*chains_, hLevel, h, z0 - size, resolution_, z1, level < leafLevel_);
    if (next > z1) {
      ++stats_.nodesReused;
      Result same = neighbour;
      // The footprint's first change after the neighbour's first slice, hence after ours; a leaf parent's
      // bound counts its darkFrom as buildLeafParent's does (this volume passed the shadow test: it lies after).
      same.nextT = level < leafLevel_ ? next : std::min(next, chains_->darkFrom[chains_->tileIndex(tx, ty)]);
      for (uint32_t& t : same.farNextT) t = next;
      return same;
    }
  }
  if (level == leafLevel_) return buildLeafParent(tx, ty, z0);

  const uint32_t half = size / 2, childTiles = half / 8;
  Result children[8];
  for (unsigned c = 0; c < 8; ++c) {
    Result childNeighbour;
    if (c >= 4) {
      childNeighbour = children[c - 4];
    } else if (neighbour.valid) {
      // The child's neighbour is the far child of our neighbour, whose next change the neighbour kept
      // (farNextT: the far child's own bound, not the whole node's, which a change in the neighbour's near
      // half would lower). Below that child only its node is known: its children get its bound.
      childNeighbour = {neighbour.code, 0, neighbour.farNextT[c], true};
      for (uint32_t& t : childNeighbour.farNextT) t = childNeighbour.nextT;
      if (neighbour.code == ChildCode::Ref) {
        const MappedArray<uint32_t>& words = tables_[level].records();
        const uint32_t header = words[neighbour.ref];
        childNeighbour.code = ChildCode(wordCodeOf(header, c + 4));
        if (childNeighbour.code == ChildCode::Ref) {
          childNeighbour.ref = words[neighbour.ref + 1 + refSlot(header, c + 4)];
          if (recorder_) childNeighbour.event = recorder_->childEvent(neighbour.event, refSlot(header, c + 4));
        }
      }
    }
    children[c] = build(level + 1, tx + (c & 1) * childTiles, ty + ((c >> 1) & 1) * childTiles,
                        z0 + (c >> 2) * half, childNeighbour);
  }
  const uint32_t nextT = std::min({children[0].nextT, children[1].nextT, children[2].nextT, children[3].nextT});
  return intern(level, children, nextT);
}

size_t DagBuilder::regionIndexOf(const RegionRect& rect) const {
  if (rect.width != regionSize_ || rect.height != regionSize_ || rect.x0 % regionSize_ != 0 ||
      rect.y0 % regionSize_ != 0 || rect.x0 >= resolution_ || rect.y0 >= resolution_)
    throw Error(ErrorCategory::RuntimeFailure, "DAG builder: region does not match the builder's region grid");
  if (finished_) throw Error(ErrorCategory::RuntimeFailure, "DAG builder: a region added after finish()");
  return size_t(rect.y0 / regionSize_) * regionsPerSide_ + rect.x0 / regionSize_;
}

void DagBuilder::addRegion(const TileChains& chains, std::string* record) {
  if (chains.resolution != resolution_)
    throw Error(ErrorCategory::RuntimeFailure, "DAG builder: region does not match the builder's resolution");
  const size_t region = regionIndexOf(chains.rect);
  chains_ = &chains;
  hierarchy_ = std::make_unique<TileHierarchy>(chains);
  const DagBuildStats before = stats_;
  if (record) {
    if (!recorderStore_) recorderStore_ = std::make_unique<RegionRecorder>(regionLevel_, leafLevel_);
    recorder_ = recorderStore_.get();
    recorder_->begin();
  }
  try {
    Result neighbour;
    for (uint32_t zBlock = 0; zBlock < regionsPerSide_; ++zBlock) {
      neighbour = build(regionLevel_, 0, 0, zBlock * regionSize_, neighbour);
      regionColumns_[region * regionsPerSide_ + zBlock] = packColumn(neighbour);
      if (recorder_) recorder_->column(neighbour.code, neighbour.event);
    }
  } catch (...) {
    recorder_ = nullptr;
    throw;
  }
  regionAdded_[region] = true;
  chains_ = nullptr;
  hierarchy_.reset();
  if (record) {
    *record = recorder_->finish({stats_.nodesBuilt - before.nodesBuilt, stats_.nodesReused - before.nodesReused,
                                 stats_.homogeneous - before.homogeneous});
    recorder_ = nullptr;
  }
}

RegionEvents DagBuilder::decodeRecord(std::string_view record) {
  return decodeRegionRecord(record, regionLevel_, leafLevel_, regionsPerSide_, decodeLevels_);
}

void DagBuilder::replayRegion(const RegionRect& rect, const RegionEvents& events) {
  const size_t region = regionIndexOf(rect);
  if (events.regionLevel != regionLevel_ || events.leafLevel != leafLevel_ || events.columnCount != regionsPerSide_)
    throw Error(ErrorCategory::RuntimeFailure, "DAG builder: a region's events decoded for another builder");
  // Each call made again, its children being what the calls that made them gave here.
  struct Replay final : RegionEventVisitor {
    DagBuilder& b;
    size_t region;
    explicit Replay(DagBuilder& builder, size_t r) : b(builder), region(r) {}
    void leaf(uint32_t id, uint64_t mask) override { b.replayRefs_[id] = b.leafTable_.intern(mask); }
    void node(uint32_t id, uint32_t level, uint32_t header, const uint32_t* children, unsigned count) override {
      uint32_t words[9];
      words[0] = header;
      for (unsigned k = 0; k < count; ++k) words[1 + k] = b.replayRefs_[children[k]];
      b.replayRefs_[id] = b.internWords(level, words, count);
    }
    void column(uint32_t z, ChildCode code, uint32_t event) override {
      b.regionColumns_[region * b.regionsPerSide_ + z] =
          packColumn({code, code == ChildCode::Ref ? b.replayRefs_[event] : 0, 0, true});
    }
  } replay(*this, region);
  replayRefs_.resize(events.eventCount);
  walkRegionEvents(events, replayLevels_, replay);
  regionAdded_[region] = true;
  stats_.nodesBuilt += events.counts.nodesBuilt;
  stats_.nodesReused += events.counts.nodesReused;
  stats_.homogeneous += events.counts.homogeneous;
}

void DagBuilder::releaseRegionScratch() {
  recorderStore_.reset();
  std::vector<uint8_t>().swap(decodeLevels_);
  std::vector<uint8_t>().swap(replayLevels_);
  std::vector<uint32_t>().swap(replayRefs_);
}

uint32_t DagBuilder::packColumn(const Result& result) {
  if (result.ref >= (1u << 30))
    throw Error(ErrorCategory::RuntimeFailure, "DAG builder: a region level holds more than 2^30 words");
  return uint32_t(result.code) | (result.ref << 2);
}

DagBuilder::Result DagBuilder::buildTop(uint32_t level, uint32_t rx, uint32_t ry, uint32_t zBlock) {
  if (level == regionLevel_) {
    const uint32_t column = regionColumns_[(size_t(ry) * regionsPerSide_ + rx) * regionsPerSide_ + zBlock];
    return {ChildCode(column & 3), column >> 2, 0, true};
  }
  const uint32_t half = 1u << (regionLevel_ - level - 1);  // child span in regions
  Result children[8];
  for (unsigned c = 0; c < 8; ++c)
    children[c] = buildTop(level + 1, rx + (c & 1) * half, ry + ((c >> 1) & 1) * half, zBlock + (c >> 2) * half);
  return intern(level, children, 0);
}

ShadowDag DagBuilder::finish() {
  if (finished_) throw Error(ErrorCategory::RuntimeFailure, "DAG builder: finish() called twice");
  finished_ = true;
  for (bool added : regionAdded_)
    if (!added) throw Error(ErrorCategory::RuntimeFailure, "DAG builder: finish() before every region was added");
  const Result root = buildTop(0, 0, 0, 0);
  stats_.leavesMerged = leafTable_.merged();
  stats_.edgeTexelsFlipped = leafTable_.flipped();
  // No node is added from here on: the indexes and columns go before encoding needs its own arrays.
  releaseRegionScratch();
  for (NodeTable& table : tables_) table.releaseIndex();
  leafParents_.releaseIndex();
  leafTable_.releaseIndex();
  std::vector<uint32_t>().swap(regionColumns_);

  // The root must sit at offset 0: level 0 holds exactly the root when it is a node.
  if (root.code == ChildCode::Ref && root.ref != 0)
    throw Error(ErrorCategory::RuntimeFailure, "DAG builder: root is not the first node");
  std::vector<MappedArray<uint32_t>> levelWords;
  for (NodeTable& table : tables_) levelWords.push_back(table.take());
  return encodeBuiltDag(resolution_, root.code, std::move(levelWords), leafParents_.take(),
                        std::move(leafTable_.leaves()));
}

uint64_t DagBuilder::finishExtraBytes() const {
  // encodeBuiltDag (dag_encoder.cpp) consumes the tables level by level. It keeps at most: each leaf's new
  // index and a copy while the leaves are reordered (8 bytes a leaf), the new indices until the leaf parents
  // are encoded; then, while a level is encoded, its node starts (0.19 bytes a word or byte), a count and then
  // an offset per node (4 bytes), and its stored units (at most 2 + 4 bytes a reference: 4 bytes a word, 34 a
  // leaf parent) before the level's table is given back. The stored levels below take no more than the words
  // they replaced, and the final concatenation gives each level back as it copies it.
  const uint64_t leafBytes = 4 * uint64_t(leafTable_.leaves().size());
  const uint64_t leafParentBytes = leafParents_.records().size();
  uint64_t largestLevel = leafBytes + leafParentBytes / 5 + leafParents_.size() * (4 + 34);
  for (const NodeTable& table : tables_) {
    const uint64_t words = table.records().size();
    largestLevel = std::max(largestLevel, words * 4 + words / 5 + table.size() * 4);
  }
  uint64_t released = leafTable_.indexBytes() + leafParents_.indexBytes() + regionColumns_.capacity() * 4;
  for (const NodeTable& table : tables_) released += table.indexBytes();
  const uint64_t needed = std::max(2 * leafBytes, largestLevel);
  return needed > released ? needed - released : 0;
}

ShadowDag buildDag(const TileChains& chains, bool nodeReuse, DagBuildStats* stats, uint32_t maxEdgeFlips) {
  DagBuilder builder(chains.resolution, chains.rect.width, nodeReuse, maxEdgeFlips);
  builder.addRegion(chains);
  ShadowDag dag = builder.finish();
  if (stats) *stats = builder.stats();
  return dag;
}

}  // namespace cpvs
