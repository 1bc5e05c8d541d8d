#include "libcpvs/dag/node_pool.h"

#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <numeric>
#include <string>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/runtime/popularity_order.h"

namespace cpvs {

namespace {

// Calls visit(offset, header, children, count) for each node of a level in build form, in id order (those whose
// records lie in [begin, end) bytes: by default the whole level).
template <class Visit>
void forEachNode(const PooledLevelTable& nodes, Visit&& visit, size_t begin = 0, size_t end = SIZE_MAX) {
  const MappedArray<uint8_t>& bytes = nodes.records();
  uint32_t header, children[8];
  for (size_t at = begin; at < std::min(end, bytes.size());) {
    const unsigned length = PooledLevelTable::decode(&bytes[at], header, children);
    visit(uint32_t(at), header, children, nodeWordCount(header) - 1);
    at += length;
  }
}

// References per child of a level's nodes (popularity_order.h's referenceCounts, over the byte-coded build form),
// and, from the same pass, where each of those nodes starts (`parentStarts`, by id), which that level's own
// layout needs next: a level is decoded once less.
std::vector<uint32_t> referenceCounts(const PooledLevelTable& parents, size_t childCount,
                                      std::vector<uint32_t>& parentStarts) {
  std::vector<uint32_t> counts(childCount, 0);
  parentStarts.clear();
  forEachNode(parents, [&](uint32_t at, uint32_t, const uint32_t* children, unsigned count) {
    parentStarts.push_back(at);
    for (unsigned k = 0; k < count; ++k) counts[children[k]] += counts[children[k]] != UINT32_MAX;
  });
  return counts;
}

// How many parts the layout splits a level of `nodes` into: one per thread of the calling arena (the bake's
// -j), one for a small level. The bytes do not depend on it: parts are concatenated, or their counts summed, in
// order.
unsigned layoutParts(size_t nodes) {
  if (nodes < (size_t(1) << 16)) return 1;
  return unsigned(std::clamp(tbb::this_task_arena::max_concurrency(), 1, 8));
}

unsigned bytesNeeded(uint32_t value) { return value < (1u << 8) ? 1 : value < (1u << 16) ? 2 : value < (1u << 24) ? 3 : 4; }

// How a level codes its references: the pair of widths, and how many of the level below's most referenced
// nodes a short reference reaches by rank (0: none, short references are offsets too).
struct LevelChoice {
  ReferenceWidths widths{0, 0};
  uint32_t hotEntries = 0;
  uint64_t referenceBytes = 0;  // what the level's references take, the table not counted
};

// The one rule for a reference, given the bytes its child's rank and offset need: short when what it would
// hold (the rank with a table, else the offset) fits the short width, else long when the offset fits that.
// Returns its width, 0 when it fits neither; `isShort` says which.
unsigned referenceWidth(unsigned rankNeeds, unsigned offsetNeeds, ReferenceWidths pair, bool table, bool& isShort) {
  isShort = (table ? rankNeeds : offsetNeeds) <= pair.shortBytes;
  return isShort ? pair.shortBytes : offsetNeeds <= pair.longBytes ? pair.longBytes : 0;
}

// The coding that makes a level smallest, given each reference's child as its byte offset and its rank in the
// level below. A reference's bytes depend only on how many bytes its offset and its rank need, so one pass
// counts those and every coding is priced from the counts. Ties go to the first pair of kWidthPairs, without a
// table before with one.
// `starts`: where each node's record starts, by id (the level's parts are counted on as many threads).
LevelChoice narrowestCoding(const PooledLevelTable& nodes, const std::vector<uint32_t>& starts,
                            const std::vector<uint32_t>& offsetBelow, const std::vector<uint32_t>& rankBelow,
                            uint64_t nodesBelow, bool allowTable, uint32_t edge) {
  using Needs = std::array<std::array<uint64_t, 5>, 5>;  // [bytes the rank needs][bytes the offset needs]
  const unsigned parts = layoutParts(starts.size());
  std::vector<Needs> partNeeds(parts, Needs{});
  parallelParts(starts.size(), parts, [&](unsigned part, size_t first, size_t last) {
    if (first == last) return;
    Needs& needs = partNeeds[part];
    forEachNode(
        nodes,
        [&](uint32_t, uint32_t, const uint32_t* children, unsigned count) {
          for (unsigned k = 0; k < count; ++k)
            needs[bytesNeeded(rankBelow[children[k]])][bytesNeeded(offsetBelow[children[k]])] += 1;
        },
        starts[first], last < starts.size() ? starts[last] : SIZE_MAX);
  });
  Needs needing{};
  for (const Needs& needs : partNeeds)
    for (size_t r = 0; r < 5; ++r)
      for (size_t o = 0; o < 5; ++o) needing[r][o] += needs[r][o];
  uint64_t best = std::numeric_limits<uint64_t>::max();
  LevelChoice chosen;
  for (const bool table : {false, true}) {
    if (table && !allowTable) continue;
    for (const ReferenceWidths pair : kWidthPairs) {
      if (table && (pair.shortBytes > 2 || pair.shortBytes >= pair.longBytes)) continue;
      const uint64_t entries = table ? std::min<uint64_t>(nodesBelow, uint64_t(1) << (8 * pair.shortBytes)) : 0;
      uint64_t bytes = 4 * entries;
      bool fits = true;
      for (unsigned rank = 1; rank <= 4; ++rank)
        for (unsigned offset = 1; offset <= 4; ++offset) {
          bool isShort;
          const unsigned width = referenceWidth(rank, offset, pair, table, isShort);
          fits = fits && (width != 0 || needing[rank][offset] == 0);
          bytes += needing[rank][offset] * width;
        }
      if (fits && bytes < best) best = bytes, chosen = {pair, uint32_t(entries), bytes - 4 * entries};
    }
  }
  if (chosen.widths.shortBytes == 0)
    throw Error(ErrorCategory::RuntimeFailure,
                "node pool: the level of edge " + std::to_string(edge) + " is too large for 32-bit references");
  return chosen;
}

}  // namespace

size_t NodePool::add(const DagView& dag) {
  if (indexesReleased_ || consumed_)
    throw Error(ErrorCategory::RuntimeFailure, "node pool: a view added after releaseIndexes() or layOutInto()");
  if (levels_.empty()) {
    levels_.resize(kMaxDagLevels);
    nodesIn_.resize(kMaxDagLevels, 0);
    starts_.resize(kMaxDagLevels);
    viewsReaching_.resize(kMaxDagLevels);
  }
  const uint32_t log2Edge = uint32_t(std::countr_zero(dag.resolution));
  Root root{dag.rootCode, log2Edge, 0};
  if (dag.rootCode == ChildCode::Ref) {
    // The nodes in the order a depth-first walk from the root completes them (children first, in child order),
    // level by level. Interning each level's nodes in that order gives every new node the id a recursive
    // intern would (a level's ids count only that level's interns), so the bytes do not depend on this
    // schedule; and a level's nodes, interned in a loop, can have their index slots prefetched a few nodes
    // ahead, where the recursion met a cache miss per node.
    std::vector<std::vector<uint32_t>> order(log2Edge + 1);
    // A view's unit offset -> its node's pooled id (every unit offset is one node's: levels do not share units);
    // UINT32_MAX - 1 marks a node the walk has met but not interned yet.
    std::vector<uint32_t> memo(dag.nodes.size(), UINT32_MAX);
    const auto visit = [&](const auto& self, uint32_t unit, uint32_t log2) -> void {
      if (memo[unit] != UINT32_MAX) return;
      memo[unit] = UINT32_MAX - 1;
      const uint32_t header = dag.nodes[unit];
      for (unsigned c = 0; log2 > 3 && c < 8; ++c)
        if (childCodeOf(header, c) == uint32_t(ChildCode::Ref)) self(self, dag.child(unit, header, c, 1u << log2), log2 - 1);
      order[log2].push_back(unit);
    };
    visit(visit, 0, log2Edge);
    for (uint32_t log2 = 3; log2 <= log2Edge; ++log2) internLevel(dag, log2, order[log2], memo);
    root.id = memo[0];
  }
  roots_.push_back(root);
  return roots_.size() - 1;
}

// One level of a view's nodes, in `units` order: each node's words (its children's pooled ids, known from the
// level below, or its leaves' indices, interned here in child order), then its id in memo. A node is hashed and
// its index slot prefetched kAhead nodes before its intern, and the record that slot names kAhead / 2 before.
void NodePool::internLevel(const DagView& dag, uint32_t log2, const std::vector<uint32_t>& units,
                           std::vector<uint32_t>& memo) {
  constexpr size_t kAhead = 16;
  struct Pending {
    uint8_t bytes[PooledLevelTable::kMaxNodeBytes];
    unsigned length;
    uint64_t hash;
  } ring[kAhead];
  PooledLevelTable& table = levels_[log2];
  const size_t n = units.size();
  for (size_t i = 0; i < n + kAhead; ++i) {
    if (i >= kAhead) {
      const Pending& p = ring[i % kAhead];
      const uint32_t id = internNode(log2, p.bytes, p.length, p.hash);
      if (countViews_) {  // a view's DAG holds each of its nodes once: one more view reaching it
        uint32_t& views = viewsReaching_[log2][id];
        views += views != UINT32_MAX;
      }
      memo[units[i - kAhead]] = id;
    }
    if (i >= kAhead / 2 && i - kAhead / 2 < n) table.prefetchCandidate(ring[(i - kAhead / 2) % kAhead].hash);
    if (i < n) {
      Pending& p = ring[i % kAhead];
      uint32_t words[9];
      const unsigned count = log2 == 3 && shape_ == LeafShape::Octants ? leafParentWords(dag, units[i], words)
                                                                      : nodeWords(dag, units[i], log2, memo, words);
      p.length = PooledLevelTable::encode(words[0], words + 1, count - 1, p.bytes);
      p.hash = PooledLevelTable::hashOf(p.bytes, p.length);
      table.prefetch(p.hash);
    }
  }
}

// A node's build-form words: its header's codes (2 bits a child), then each reference's child id (its leaf index
// below a leaf parent). Returns how many.
unsigned NodePool::nodeWords(const DagView& dag, uint32_t unit, uint32_t log2, const std::vector<uint32_t>& memo,
                             uint32_t (&words)[9]) {
  const uint32_t header = dag.nodes[unit];
  words[0] = 0;
  unsigned count = 1;
  for (unsigned c = 0; c < 8; ++c) {
    const uint32_t code = childCodeOf(header, c);
    words[0] |= code << (2 * c);
    if (code != uint32_t(ChildCode::Ref)) continue;
    const uint32_t target = dag.child(unit, header, c, 1u << log2);
    words[count++] = log2 == 3 ? leaves_.intern(dag.leaves[target]) : memo[target];
  }
  return count;
}

// A leaf parent regrouped into its 4^3 octants: the slices' bits gathered per octant, each octant a leaf.
unsigned NodePool::leafParentWords(const DagView& dag, uint32_t unit, uint32_t (&words)[9]) {
  const uint32_t header = dag.nodes[unit];
  uint64_t slices[8];
  for (unsigned z = 0; z < 8; ++z) {
    const uint32_t code = childCodeOf(header, z);
    slices[z] = code == uint32_t(ChildCode::Ref) ? dag.leaves[dag.child(unit, header, z, 8)]
                                                 : code == uint32_t(ChildCode::Shadowed) ? ~uint64_t(0) : 0;
  }
  words[0] = 0;
  unsigned count = 1;
  for (unsigned c = 0; c < 8; ++c) {
    const unsigned x0 = (c & 1u) * 4, y0 = ((c >> 1) & 1u) * 4, z0 = (c >> 2) * 4;
    uint64_t octant = 0;
    for (unsigned z = 0; z < 4; ++z)
      for (unsigned y = 0; y < 4; ++y)  // row y0 + y of slice z0 + z, columns x0 .. x0 + 3
        octant |= ((slices[z0 + z] >> ((y0 + y) * 8 + x0)) & 0xFu) << (z * 16 + y * 4);
    if (octant == 0) continue;  // lit: code 0
    if (octant == ~uint64_t(0)) {
      words[0] |= uint32_t(ChildCode::Shadowed) << (2 * c);
      continue;
    }
    words[0] |= uint32_t(ChildCode::Ref) << (2 * c);
    words[count++] = leaves_.intern(octant);
  }
  return count;
}

uint32_t NodePool::internNode(uint32_t log2, const uint8_t* bytes, unsigned length, uint64_t hash) {
  const uint64_t before = levels_[log2].records().size();
  const uint32_t offset = levels_[log2].intern(bytes, length, hash);
  if (offset != before) return starts_[log2].idAt(offset);
  // New: appended at the end, so offsets grow with ids.
  const uint32_t id = nodesIn_[log2]++;
  if (countViews_) viewsReaching_[log2].push_back(0);
  starts_[log2].append(offset, id);
  return id;
}

void NodePool::NodeStarts::append(uint32_t offset, uint32_t id) {
  while (idsBefore.size() <= offset / 512) idsBefore.append(&id, 1);  // blocks this node is the first id at or past
  if (bits.size() <= offset / 64) bits.resize(offset / 64 + 1);      // new words are zero
  bits[offset / 64] |= uint64_t(1) << (offset % 64);
}

uint32_t NodePool::NodeStarts::idAt(uint32_t offset) const {
  uint32_t id = idsBefore[offset / 512];
  for (size_t w = (offset / 512) * 8; w < offset / 64; ++w) id += uint32_t(std::popcount(bits[w]));
  return id + uint32_t(std::popcount(bits[offset / 64] & ((uint64_t(1) << (offset % 64)) - 1)));
}

std::vector<uint64_t> NodePool::nodesByViewsReaching() const {
  std::vector<uint64_t> histogram;
  for (const std::vector<uint32_t>& level : viewsReaching_)
    for (const uint32_t views : level) {
      const size_t k = views <= 1 ? 0 : size_t(std::bit_width(views - 1));
      if (histogram.size() <= k) histogram.resize(k + 1, 0);
      histogram[k] += 1;
    }
  return histogram;
}

void NodePool::releaseIndexes() {
  for (PooledLevelTable& level : levels_) level.releaseIndex();
  std::vector<NodeStarts>().swap(starts_);
  leaves_.releaseIndex();
  indexesReleased_ = true;
}

NodePool::BuildFormBytes NodePool::buildFormBytes() const {
  BuildFormBytes b;
  for (size_t log2 = 0; log2 < levels_.size(); ++log2) {
    (log2 == 3 ? b.leafParents : b.nodes) += levels_[log2].records().size();
    b.indexes += levels_[log2].indexBytes();
  }
  for (const NodeStarts& s : starts_) b.starts += s.bits.size() * 8 + s.idsBefore.size() * 4;
  b.leaves = leaves_.leaves().capacity() * 8;
  b.leafIndex = leaves_.indexBytes();
  return b;
}

uint64_t NodePool::nodes() const {
  uint64_t n = 0;
  for (const uint32_t count : nodesIn_) n += count;
  return n;
}

LaidOutPool NodePool::layOut(bool hotTables) const {
  LaidOutPool out;
  layOutImpl(hotTables,
             {[&](std::vector<uint64_t>&& leaves) { out.leaves = std::move(leaves); },
              [&](PooledLevel&& level) { out.levels.push_back(std::move(level)); },
              [&](std::vector<LaidOutPool::Root>&& roots) { out.roots = std::move(roots); }},
             false);
  return out;
}

void NodePool::layOutInto(bool hotTables, const LayoutSink& sink) {
  releaseIndexes();
  layOutImpl(hotTables, sink, true);
  consumed_ = true;
}

void NodePool::layOutImpl(bool hotTables, const LayoutSink& sink, bool release) const {
  if (consumed_) throw Error(ErrorCategory::RuntimeFailure, "node pool: laid out after layOutInto()");
  // With `release` (layOutInto, a non-const call), the build form of each level is freed as it is done.
  NodePool& self = const_cast<NodePool&>(*this);
  uint32_t top = 0;  // log2 of the largest root's edge
  for (const Root& r : roots_)
    if (r.code == ChildCode::Ref) top = std::max(top, r.log2Edge);

  // Leaves, most referenced first: the leaf parents' references are their indices.
  std::vector<uint32_t> startsAbove;  // where each node of the level above starts, by id (referenceCounts)
  const std::vector<uint64_t>& masks = leaves_.leaves();
  std::vector<uint32_t> leafIds(masks.size());
  std::iota(leafIds.begin(), leafIds.end(), 0u);
  const std::vector<uint32_t> leafOrder =
      mostReferencedFirst(leafIds, top >= 3 ? referenceCounts(levels_[3], masks.size(), startsAbove)
                                            : std::vector<uint32_t>(masks.size(), 0));
  // Each child of the level below: its byte offset (leaves: index) and its rank, by its id (leaf index).
  std::vector<uint32_t> offsetBelow(masks.size()), rankBelow(masks.size());
  std::vector<uint32_t> orderBelow = leafOrder;
  {
    std::vector<uint64_t> leaves;
    leaves.reserve(leafOrder.size());
    for (uint32_t i = 0; i < leafOrder.size(); ++i) {
      offsetBelow[leafOrder[i]] = rankBelow[leafOrder[i]] = i;
      leaves.push_back(masks[leafOrder[i]]);
    }
    sink.leaves(std::move(leaves));
  }

  std::vector<LaidOutPool::Root> roots(roots_.size());
  for (size_t v = 0; v < roots_.size(); ++v) roots[v] = {roots_[v].code, 1u << roots_[v].log2Edge, 0};
  for (uint32_t log2 = 3; top >= 3 && log2 <= top; ++log2) {
    const PooledLevelTable& table = levels_[log2];
    // Where each id's bytes start (ids are in the order of the bytes): found when the level was counted as the
    // parents of the one below.
    const std::vector<uint32_t> offsetOf = std::move(startsAbove);
    const size_t nodes = offsetOf.size();
    std::vector<uint32_t> order;  // the level's node ids as laid out
    {
      std::vector<uint32_t> counts = log2 < top ? referenceCounts(levels_[log2 + 1], nodes, startsAbove)
                                                : std::vector<uint32_t>(nodes, 0);
      for (const Root& r : roots_)
        if (r.code == ChildCode::Ref && r.log2Edge == log2 && counts[r.id] != UINT32_MAX) counts[r.id] += 1;
      std::vector<uint32_t> ids(nodes);
      std::iota(ids.begin(), ids.end(), 0u);
      order = mostReferencedFirst(ids, counts);
    }

    PooledLevel level;
    level.edge = 1u << log2;
    level.nodes = order.size();
    const LevelChoice coding =
        narrowestCoding(table, offsetOf, offsetBelow, rankBelow, orderBelow.size(), hotTables && log2 > 3, level.edge);
    level.widths = coding.widths;
    for (uint32_t r = 0; r < coding.hotEntries; ++r) level.hot.push_back(offsetBelow[orderBelow[r]]);
    std::vector<uint32_t> position(nodes, 0), rank(nodes, 0);
    for (uint32_t i = 0; i < order.size(); ++i) rank[order[i]] = i;
    // The nodes in `order`, cut into parts encoded side by side (each into its own bytes, positions relative to
    // them), then joined in order: the same bytes as one pass.
    const auto tooLarge = [&] {
      return Error(ErrorCategory::RuntimeFailure, "node pool: the level of edge " + std::to_string(level.edge) +
                                                      " passed 4 GiB");
    };
    const unsigned parts = layoutParts(order.size());
    std::vector<std::vector<uint8_t>> partBytes(parts);
    parallelParts(order.size(), parts, [&](unsigned part, size_t first, size_t last) {
      std::vector<uint8_t>& bytes = partBytes[part];
      bytes.reserve(2 * (last - first) + coding.referenceBytes / std::max<size_t>(1, order.size()) * (last - first));
      for (size_t i = first; i < last; ++i) {
        const uint32_t id = order[i];
        uint32_t codes, children[8];
        (void)PooledLevelTable::decode(&table.records()[offsetOf[id]], codes, children);
        if (bytes.size() > UINT32_MAX) throw tooLarge();
        position[id] = uint32_t(bytes.size());
        const size_t headerAt = bytes.size();
        bytes.resize(headerAt + 2);
        uint32_t header = 0;
        for (unsigned c = 0, k = 0; c < 8; ++c) {
          uint32_t code = wordCodeOf(codes, c);
          if (code == uint32_t(ChildCode::Ref)) {
            const uint32_t child = children[k++];
            const bool hot = coding.hotEntries > 0;
            bool isShort;
            const unsigned width = referenceWidth(bytesNeeded(rankBelow[child]), bytesNeeded(offsetBelow[child]),
                                                  level.widths, hot, isShort);
            const uint32_t value = isShort && hot ? rankBelow[child] : offsetBelow[child];
            code = isShort ? 2u : 3u;
            for (unsigned b = 0; b < width; ++b) bytes.push_back(uint8_t(value >> (8 * b)));
          }
          header |= code << (2 * c);
        }
        bytes[headerAt] = uint8_t(header);
        bytes[headerAt + 1] = uint8_t(header >> 8);
      }
    });
    level.bytes = std::move(partBytes[0]);
    for (unsigned part = 1; part < parts; ++part) {
      const uint64_t base = level.bytes.size();
      const size_t first = order.size() * part / parts, last = order.size() * (part + 1) / parts;
      for (size_t i = first; i < last; ++i) {
        if (base + position[order[i]] > UINT32_MAX) throw tooLarge();
        position[order[i]] += uint32_t(base);
      }
      level.bytes.insert(level.bytes.end(), partBytes[part].begin(), partBytes[part].end());
      std::vector<uint8_t>().swap(partBytes[part]);
    }
    for (size_t v = 0; v < roots_.size(); ++v)
      if (roots_[v].code == ChildCode::Ref && roots_[v].log2Edge == log2) roots[v].offset = position[roots_[v].id];
    offsetBelow = std::move(position);
    rankBelow = std::move(rank);
    orderBelow = std::move(order);
    if (release) {  // this level's build form and ids are done with; the level above is read next
      (void)self.levels_[log2].take();
    }
    sink.level(std::move(level));
  }
  sink.roots(std::move(roots));
}

PooledDags concatenate(const LaidOutPool& pool, LeafShape shape) {
  PooledDags out;
  out.leaves = pool.leaves;
  out.hot.resize(kMaxDagLevels);
  uint64_t levelBegin[kMaxDagLevels] = {};
  for (const PooledLevel& level : pool.levels) {
    const unsigned log2 = unsigned(std::countr_zero(level.edge));
    levelBegin[log2] = out.bytes.size();
    out.hot[log2] = level.hot;
    out.bytes.insert(out.bytes.end(), level.bytes.begin(), level.bytes.end());
  }
  ByteDagView base;
  base.bytes = out.bytes;
  base.leaves = out.leaves;
  base.leafShape = shape;
  for (const PooledLevel& level : pool.levels) {
    const unsigned log2 = unsigned(std::countr_zero(level.edge));
    base.coding[log2] = {log2 > 3 ? levelBegin[log2 - 1] : 0, level.widths.shortBytes, level.widths.longBytes, 0,
                         out.hot[log2]};
  }
  for (const LaidOutPool::Root& r : pool.roots) {
    ByteDagView v = base;
    v.resolution = r.edge;
    v.rootCode = r.code;
    v.root = r.code == ChildCode::Ref ? levelBegin[std::countr_zero(r.edge)] + r.offset : 0;
    out.views.push_back(v);
  }
  return out;
}

}  // namespace cpvs
