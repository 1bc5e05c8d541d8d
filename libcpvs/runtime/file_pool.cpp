#include "libcpvs/runtime/file_pool.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "libcpvs/runtime/pool_validation.h"

namespace cpvs {

using namespace cpvsformat;
using P = PoolLevelLayout;

namespace {

Outcome invalid(const std::string& name, const std::string& what) {
  return Outcome(ErrorCategory::InvalidInput, name + ": " + what);
}

template <class T>
T load(const uint8_t* at) {
  T v;
  std::memcpy(&v, at, sizeof v);  // little-endian hosts only (cpvs_reader.cpp)
  return v;
}

// The POOL records: levels of edge 8, 16, ... back to back in NODE from its first byte, each hot table a run of
// HOTT after the previous one's, NODE ending in kPoolTailBytes zero bytes and HOTT in the last table.
Outcome readLevels(const FilePoolSections& s, std::vector<CpvsFile::PoolLevel>& levels, const std::string& name) {
  const uint64_t count = s.records.size() / s.recordSize;
  if (count > kMaxDagLevels) return invalid(name, "POOL holds " + std::to_string(count) + " levels (at most 32)");
  uint64_t nodeEnd = 0, hotEnd = 0;
  levels.clear();
  for (uint64_t i = 0; i < count; ++i) {
    const uint8_t* r = s.records.data() + i * s.recordSize;
    const std::string what = "pool level " + std::to_string(i);
    CpvsFile::PoolLevel l;
    l.edge = load<uint32_t>(r + P::kEdge);
    l.shortBytes = r[P::kShortBytes];
    l.longBytes = r[P::kLongBytes];
    l.offset = load<uint64_t>(r + P::kOffset);
    l.bytes = load<uint64_t>(r + P::kSize);
    l.nodes = load<uint64_t>(r + P::kNodes);
    const uint64_t firstHot = load<uint32_t>(r + P::kFirstHot);
    l.hotEntries = load<uint32_t>(r + P::kHotCount);
    if (s.strict && load<uint16_t>(r + P::kReserved) != 0)
      return invalid(name, what + ": reserved field is not zero in a 3.0 file");
    if (l.edge != (8u << i))
      return invalid(name, what + " has edge " + std::to_string(l.edge) + ", not " + std::to_string(8u << i) +
                               " (levels run 8, 16, 32, ...)");
    if (l.offset != nodeEnd || l.bytes > s.nodes.size() - nodeEnd)
      return invalid(name, what + ": " + std::to_string(l.bytes) + " bytes at offset " + std::to_string(l.offset) +
                               " of NODE (expected at " + std::to_string(nodeEnd) + ", within its " +
                               std::to_string(s.nodes.size()) + " bytes)");
    if (firstHot != (l.hotEntries ? hotEnd : 0) || l.hotEntries > s.hot.size() - hotEnd)
      return invalid(name, what + ": a hot table of " + std::to_string(l.hotEntries) + " entries at " +
                               std::to_string(firstHot) + " (expected at " + std::to_string(hotEnd) + ", within HOTT's " +
                               std::to_string(s.hot.size()) + ")");
    nodeEnd += l.bytes;
    hotEnd += l.hotEntries;
    levels.push_back(l);
  }
  if (s.nodes.size() - nodeEnd != kPoolTailBytes)
    return invalid(name, "NODE holds " + std::to_string(s.nodes.size()) + " bytes, its levels " +
                             std::to_string(nodeEnd) + " and the tail " + std::to_string(kPoolTailBytes));
  for (uint64_t at = nodeEnd; at < s.nodes.size(); ++at)
    if (s.nodes[at] != 0) return invalid(name, "NODE's tail byte " + std::to_string(at) + " is not zero");
  if (hotEnd != s.hot.size())
    return invalid(name, "HOTT holds " + std::to_string(s.hot.size()) + " entries, the levels' tables " +
                             std::to_string(hotEnd));
  return {};
}

// The nodes of each level, counted over its bytes (validatePool has checked that they tile it).
// Bytes a node of a pool level takes: its header and its references in the level's widths.
inline uint64_t nodeBytes(uint32_t header, const CpvsFile::PoolLevel& l) {
  const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1);
  return 2 + uint64_t(l.shortBytes) * popcount32(refs) + uint64_t(l.longBytes - l.shortBytes) * popcount32(wide);
}

uint64_t countNodes(std::span<const uint8_t> bytes, const CpvsFile::PoolLevel& l) {
  uint64_t nodes = 0;
  for (uint64_t at = 0; at < bytes.size(); ++nodes)
    at += nodeBytes(uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8, l);
  return nodes;
}

// Which byte of a (validated) pool starts which node: a node's ordinal in the whole pool, levels ascending, from
// its level and byte offset in constant time (a bit per byte and a count per 64 bytes).
class PoolIndex {
public:
  PoolIndex(std::span<const CpvsFile::PoolLevel> levels, std::span<const PoolLevelView> views) {
    for (size_t l = 0; l < levels.size(); ++l) {
      Level level;
      level.offset = levels[l].offset;
      level.firstOrdinal = nodes_;
      level.starts.assign((views[l].bytes.size() + 63) / 64, 0);
      const std::span<const uint8_t> bytes = views[l].bytes;
      for (uint64_t at = 0; at < bytes.size();) {  // node by node, as countNodes
        level.starts[at / 64] |= uint64_t(1) << (at % 64);
        at += nodeBytes(uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8, levels[l]);
      }
      level.before.resize(level.starts.size());
      uint64_t count = 0;
      for (size_t w = 0; w < level.starts.size(); ++w) {
        level.before[w] = count;
        count += popcount64(level.starts[w]);
      }
      nodes_ += count;
      levels_.push_back(std::move(level));
    }
  }
  uint64_t nodes() const { return nodes_; }
  // The ordinal of the node at byte `at` of `bytes` (ByteDagView's), in the level of index `level` (0: edge 8).
  uint64_t ordinal(size_t level, uint64_t at) const {
    const Level& l = levels_[level];
    const uint64_t local = at - l.offset;
    return l.firstOrdinal + l.before[local / 64] + popcount64(l.starts[local / 64] & ((uint64_t(1) << (local % 64)) - 1));
  }

private:
  struct Level {
    uint64_t offset = 0, firstOrdinal = 0;
    std::vector<uint64_t> starts, before;
  };
  std::vector<Level> levels_;
  uint64_t nodes_ = 0;
};

// A view's DAG from the pool into the stored form of 2.0 (slice leaves): the nodes and leaves its root reaches,
// each once, in the order the baker writes (NodeOrder::MostReferencedFirst), for the walks that read DagView.
// Which pool nodes a view has met is kept per pool node with the view's stamp, so nothing is cleared between
// views and every lookup is an array read.
class ViewConversion {
public:
  ViewConversion(uint64_t nodes, uint64_t leaves) : nodeStamp_(nodes, 0), nodeId_(nodes), leafStamp_(leaves, 0), leafId_(leaves) {}

  Result<ShadowDag> storedForm(const ByteDagView& walk, const PoolIndex& index) {
    if (walk.rootCode != ChildCode::Ref) {  // no nodes: a count of 0 on each level, as a 2.0 file holds
      Result<ShadowDag> dag = encodeDag(walk.resolution, walk.rootCode, {}, {}, {});
      if (dag) dag.value().nodesPerLevel.assign(DagView{walk.resolution, walk.rootCode, {}, {}}.levels(), 0);
      return dag;
    }
    ++stamp_;
    const uint32_t levels = DagView{walk.resolution, walk.rootCode, {}, {}}.levels();
    const unsigned top = unsigned(std::countr_zero(walk.resolution));
    // Build form, level by level from the root: a node's words are its header (codes 0..2) and, per reference,
    // the child's word offset in the next level's array (a leaf index below the leaf parents), children met
    // first placed first.
    std::vector<std::vector<uint32_t>> words(levels);
    std::vector<uint64_t> nodesPerLevel(levels, 0), leafMasks;
    std::vector<uint64_t> nodesAt{walk.root}, next;  // this level's nodes (byte offsets), in order
    for (uint32_t l = 0; l < levels; ++l) {
      const unsigned log2Edge = top - l;
      const bool leafParent = l + 1 == levels;
      next.clear();
      uint32_t nextWords = 0;
      for (uint64_t at : nodesAt) {
        const uint32_t header = walk.headerAt(at);
        uint32_t stored = 0;
        for (unsigned c = 0; c < 8; ++c) stored |= childCodeOf(header, c) << (2 * c);
        words[l].push_back(stored);
        for (unsigned c = 0; c < 8; ++c) {
          if (childCodeOf(header, c) != uint32_t(ChildCode::Ref)) continue;
          const uint64_t child = walk.childAt(at, header, c, log2Edge);
          if (leafParent) {
            if (leafStamp_[child] != stamp_) {
              leafStamp_[child] = stamp_;
              leafId_[child] = uint32_t(leafMasks.size());
              leafMasks.push_back(walk.leaves[child]);
            }
            words[l].push_back(leafId_[child]);
            continue;
          }
          const uint64_t ordinal = index.ordinal(log2Edge - 4, child);  // the child's level: edge 2^(log2Edge - 1)
          if (nodeStamp_[ordinal] != stamp_) {
            nodeStamp_[ordinal] = stamp_;
            nodeId_[ordinal] = nextWords;
            next.push_back(child);
            nextWords += 1 + popcount32(walk.headerAt(child) & 0xAAAAu);  // its header and a word per reference
          }
          words[l].push_back(nodeId_[ordinal]);
        }
      }
      nodesPerLevel[l] = nodesAt.size();
      nodesAt.swap(next);
    }
    const std::vector<std::span<const uint32_t>> spans(words.begin(), words.end());
    return encodeDag(walk.resolution, walk.rootCode, spans, nodesPerLevel, std::move(leafMasks),
                     NodeOrder::MostReferencedFirst);
  }

private:
  uint32_t stamp_ = 0;
  std::vector<uint32_t> nodeStamp_, nodeId_, leafStamp_, leafId_;
};

// The whole pool in the stored form of 2.0, once: levels converted from edge 8 up (a node's units depend on
// its references' values, the units of its children), each level's nodes in pool order, then the levels' order
// turned around in place (the whole array reversed, then each level) so that they run from the largest edge down
// as in a 2.0 DAG, without a second copy. levelStart[log2 edge]: where that level starts in the units;
// unitOf[ordinal]: the node's first unit in its level.
Outcome poolUnits(const ByteDagView& pool, std::span<const CpvsFile::PoolLevel> levels, const PoolIndex& index,
                  std::vector<uint16_t>& units, uint64_t (&levelStart)[kMaxDagLevels], std::vector<uint32_t>& unitOf,
                  const std::string& name) {
  unitOf.assign(index.nodes(), 0);
  units.clear();
  uint64_t poolBytes = 0;
  for (const CpvsFile::PoolLevel& l : levels) poolBytes += l.bytes;
  // The benchmark bakes take 0.6 units per pool byte (the 165 spots: 33.6 M units for 55.3 MB, cpvs-info): room
  // for a little more, so that the array rarely grows (a copy) and its unused tail is never touched.
  units.reserve(poolBytes / 2 + poolBytes / 4);
  std::vector<uint64_t> ascendingStart(levels.size() + 1, 0);
  uint64_t ordinal = 0;
  for (size_t i = 0; i < levels.size(); ++i) {
    const CpvsFile::PoolLevel& l = levels[i];
    const unsigned log2Edge = unsigned(std::countr_zero(l.edge));
    const uint64_t first = units.size();
    for (uint64_t at = l.offset; at < l.offset + l.bytes; at += nodeBytes(pool.headerAt(at), l)) {
      if (units.size() - first > UINT32_MAX)
        return invalid(name, "pool level " + std::to_string(i) + " takes more than 2^32 units as 2.0 nodes");
      const uint32_t header = pool.headerAt(at);
      unitOf[ordinal++] = uint32_t(units.size() - first);
      const size_t headerAt = units.size();
      units.push_back(0);
      uint32_t stored = 0;
      for (unsigned c = 0; c < 8; ++c) {
        const uint32_t code = childCodeOf(header, c);
        if (code != uint32_t(ChildCode::Ref)) {
          stored |= code << (2 * c);
          continue;
        }
        const uint64_t child = pool.childAt(at, header, c, log2Edge);  // a leaf index below the leaf parents
        const uint32_t target = i == 0 ? uint32_t(child) : unitOf[index.ordinal(i - 1, child)];
        stored |= storeReference(target, [&](uint16_t unit) { units.push_back(unit); }) << (2 * c);
      }
      units[headerAt] = uint16_t(stored);
    }
    ascendingStart[i + 1] = units.size();
  }
  // DagView's level starts are 32-bit.
  if (units.size() > UINT32_MAX)
    return invalid(name, "its pool takes " + std::to_string(units.size()) + " units as 2.0 nodes, more than 2^32");
  std::reverse(units.begin(), units.end());
  const uint64_t total = units.size();
  for (size_t i = 0; i < levels.size(); ++i) {
    const uint64_t begin = total - ascendingStart[i + 1], end = total - ascendingStart[i];
    std::reverse(units.begin() + int64_t(begin), units.begin() + int64_t(end));
    levelStart[std::countr_zero(levels[i].edge)] = begin;
  }
  return {};
}

}  // namespace

struct FilePool::Conversion {
  PoolIndex index;
  ViewConversion views;
};

FilePool::~FilePool() = default;

Result<std::unique_ptr<FilePool>> FilePool::read(const FilePoolSections& s, std::span<CpvsFile::View* const> views,
                                                 const std::string& name) {
  std::unique_ptr<FilePool> pool(new FilePool);
  std::vector<CpvsFile::PoolLevel>& levels = pool->levels_;
  if (Outcome o = readLevels(s, levels, name); !o) return o;
  std::vector<PoolLevelView>& levelViews = pool->levelViews_;
  for (const CpvsFile::PoolLevel& l : levels)
    levelViews.push_back({l.edge, l.shortBytes, l.longBytes, s.nodes.subspan(l.offset, l.bytes), {}});
  uint64_t hotAt = 0;
  for (size_t i = 0; i < levels.size(); ++i) {
    levelViews[i].hot = s.hot.subspan(hotAt, levels[i].hotEntries);
    hotAt += levels[i].hotEntries;
  }
  std::vector<PoolRootView> roots;
  for (const CpvsFile::View* v : views) roots.push_back({v->bytes.rootCode, v->bytes.resolution, v->bytes.root});
  if (Outcome o = validatePool(levelViews, s.leaves.size(), roots, name); !o) return o;
  for (size_t i = 0; i < levels.size(); ++i)
    if (const uint64_t counted = countNodes(levelViews[i].bytes, levels[i]); counted != levels[i].nodes)
      return invalid(name, "pool level " + std::to_string(i) + " says " + std::to_string(levels[i].nodes) +
                               " nodes, its bytes hold " + std::to_string(counted));

  ByteDagView base;  // the pool in place, without a root: each view's walk starts from a copy
  base.bytes = s.nodes;
  base.leaves = s.leaves;
  for (size_t i = 0; i < levels.size(); ++i) {
    const unsigned log2 = unsigned(std::countr_zero(levels[i].edge));
    base.coding[log2] = {i > 0 ? levels[i - 1].offset : 0, levels[i].shortBytes, levels[i].longBytes, 0,
                         levelViews[i].hot};
  }
  pool->leaves_ = s.leaves;
  pool->name_ = name;
  pool->maxConvertedBytes_ = s.maxConvertedBytes;

  uint64_t levelStart[kMaxDagLevels] = {};
  const PoolIndex index(levels, levelViews);
  std::vector<uint32_t> unitOf;
  if (Outcome o = poolUnits(base, levels, index, pool->units_, levelStart, unitOf, name); !o) return o;
  // What sizes each view's top grid (TopGrid::automaticLevel): its share of the pool.
  uint64_t referenced = 0;
  for (const CpvsFile::View* v : views) referenced += v->bytes.rootCode == ChildCode::Ref;
  const uint64_t poolBytes = s.nodes.size() + s.hot.size_bytes() + s.leaves.size_bytes();
  const uint64_t share = poolBytes / std::max<uint64_t>(1, referenced);
  const std::span<const uint16_t> units = pool->units_;
  for (CpvsFile::View* v : views) {
    ByteDagView walk = base;
    walk.resolution = v->bytes.resolution;
    walk.rootCode = v->bytes.rootCode;
    DagView dag{walk.resolution, walk.rootCode, {}, {}};
    if (walk.rootCode == ChildCode::Ref) {
      // The view's DagView is the units from its root on: every level below the root's starts after it, so its
      // references, counted from those levels' starts, count from the same places less the root's unit.
      const unsigned log2 = unsigned(std::countr_zero(walk.resolution));
      walk.root = levels[log2 - 3].offset + v->bytes.root;
      const uint64_t rootUnit = levelStart[log2] + unitOf[index.ordinal(log2 - 3, walk.root)];
      dag.nodes = units.subspan(rootUnit);
      dag.leaves = s.leaves;
      for (unsigned k = 4; k <= log2; ++k) dag.childBase[k] = uint32_t(levelStart[k - 1] - rootUnit);
      dag.sharedNodes = units;
      dag.sharedBytes = share;
    }
    v->bytes = walk;
    v->dag = dag;
  }
  return pool;
}

Result<ShadowDag> FilePool::ownDag(const ByteDagView& view) const {
  const std::lock_guard lock(mutex_);
  if (!conversion_) {
    PoolIndex index(levels_, levelViews_);
    const uint64_t nodes = index.nodes();
    conversion_.reset(new Conversion{std::move(index), ViewConversion(nodes, leaves_.size())});
  }
  Result<ShadowDag> dag = conversion_->views.storedForm(view, conversion_->index);
  if (!dag) return invalid(name_, "a view's DAG has no 2.0 form: " + dag.outcome().message());
  convertedBytes_ += dag.value().bytes();
  if (convertedBytes_ > maxConvertedBytes_)
    return invalid(name_, "its views' DAGs would take more than " + std::to_string(maxConvertedBytes_ >> 20) +
                              " MiB converted one by one (64 times the file and 256 MiB)");
  return dag;
}

}  // namespace cpvs
