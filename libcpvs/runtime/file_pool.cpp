#include "libcpvs/runtime/file_pool.h"

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
uint64_t countNodes(std::span<const uint8_t> bytes, const CpvsFile::PoolLevel& l) {
  uint64_t nodes = 0;
  for (uint64_t at = 0; at < bytes.size(); ++nodes) {
    const uint32_t header = uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8;
    const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1);
    at += 2 + uint64_t(l.shortBytes) * popcount32(refs) + uint64_t(l.longBytes - l.shortBytes) * popcount32(wide);
  }
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
      for (uint64_t at = 0; at < bytes.size();) {  // as countNodes
        level.starts[at / 64] |= uint64_t(1) << (at % 64);
        const uint32_t header = uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8;
        const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1);
        at += 2 + uint64_t(levels[l].shortBytes) * popcount32(refs) +
              uint64_t(levels[l].longBytes - levels[l].shortBytes) * popcount32(wide);
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
class Conversion {
public:
  Conversion(uint64_t nodes, uint64_t leaves) : nodeStamp_(nodes, 0), nodeId_(nodes), leafStamp_(leaves, 0), leafId_(leaves) {}

  Result<ShadowDag> storedForm(const ByteDagView& walk, const PoolIndex& index) {
    if (walk.rootCode != ChildCode::Ref) return encodeDag(walk.resolution, walk.rootCode, {}, {}, {});
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

}  // namespace

Outcome readFilePool(const FilePoolSections& s, std::span<CpvsFile::View* const> views,
                     std::vector<CpvsFile::PoolLevel>& levels, std::vector<std::unique_ptr<ShadowDag>>& converted,
                     const std::string& name) {
  if (Outcome o = readLevels(s, levels, name); !o) return o;
  std::vector<PoolLevelView> levelViews;
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

  ByteDagView base;
  base.bytes = s.nodes;
  base.leaves = s.leaves;
  for (size_t i = 0; i < levels.size(); ++i) {
    const unsigned log2 = unsigned(std::countr_zero(levels[i].edge));
    base.coding[log2] = {i > 0 ? levels[i - 1].offset : 0, levels[i].shortBytes, levels[i].longBytes, 0,
                         levelViews[i].hot};
  }
  const PoolIndex index(levels, levelViews);
  Conversion scratch(index.nodes(), s.leaves.size());
  uint64_t convertedBytes = 0;
  for (size_t vi = 0; vi < views.size(); ++vi) {
    CpvsFile::View* v = views[vi];
    ByteDagView walk = base;
    walk.resolution = v->bytes.resolution;
    walk.rootCode = v->bytes.rootCode;
    walk.root = walk.rootCode == ChildCode::Ref ? levels[std::countr_zero(walk.resolution) - 3].offset + v->bytes.root : 0;
    Result<ShadowDag> dag = scratch.storedForm(walk, index);
    if (!dag) return invalid(name, "a view's DAG has no 2.0 form: " + dag.outcome().message());
    convertedBytes += dag.value().bytes();
    if (convertedBytes > s.maxConvertedBytes)
      return invalid(name, "its views' DAGs would take more than " + std::to_string(s.maxConvertedBytes >> 20) +
                               " MiB once converted on open (64 times the file and 256 MiB): this reader converts a "
                               "3.0 file's views into the 2.0 form its walks read; view " +
                               std::to_string(vi) + " passed it");
    converted.push_back(std::make_unique<ShadowDag>(std::move(dag).value()));
    v->bytes = walk;
    v->dag = converted.back()->view();
    if (!converted.back()->nodesPerLevel.empty()) v->nodesPerLevel = converted.back()->nodesPerLevel;
  }
  return {};
}

}  // namespace cpvs
