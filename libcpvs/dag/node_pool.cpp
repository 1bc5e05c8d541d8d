#include "libcpvs/dag/node_pool.h"

#include <algorithm>
#include <bit>
#include <limits>
#include <numeric>
#include <string>
#include <unordered_map>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/popularity_order.h"

namespace cpvs {

namespace {

using UnitMemo = std::unordered_map<uint32_t, uint32_t>;  // a view's unit offset -> pooled word offset

// The bytes a reference of this value takes in a pair of widths, or 0 when it fits neither.
unsigned referenceBytes(uint64_t value, ReferenceWidths w) {
  if (value < (uint64_t(1) << (8 * w.shortBytes))) return w.shortBytes;
  if (value < (uint64_t(1) << (8 * w.longBytes))) return w.longBytes;
  return 0;
}

// The pair of widths that makes a level smallest, given each node's reference values in order.
ReferenceWidths narrowestPair(const std::vector<uint32_t>& order, std::span<const uint32_t> words,
                              const std::vector<uint64_t>& valueOf, uint32_t edge) {
  uint64_t best = std::numeric_limits<uint64_t>::max();
  ReferenceWidths chosen{0, 0};
  for (const ReferenceWidths pair : kWidthPairs) {
    uint64_t bytes = 0;
    bool fits = true;
    for (const uint32_t at : order) {
      bytes += 2;
      for (unsigned k = 1; k < nodeWordCount(words[at]); ++k) {
        const unsigned width = referenceBytes(valueOf[words[at + k]], pair);
        fits = fits && width != 0;
        bytes += width;
      }
    }
    if (fits && bytes < best) best = bytes, chosen = pair;
  }
  if (chosen.shortBytes == 0)
    throw Error(ErrorCategory::RuntimeFailure,
                "node pool: the level of edge " + std::to_string(edge) + " is too large for 32-bit references");
  return chosen;
}

}  // namespace

size_t NodePool::add(const DagView& dag) {
  if (levels_.empty()) levels_.resize(kMaxDagLevels);
  const uint32_t log2Edge = uint32_t(std::countr_zero(dag.resolution));
  Root root{dag.rootCode, log2Edge, 0};
  if (dag.rootCode == ChildCode::Ref) {
    std::vector<UnitMemo> memo(kMaxDagLevels);
    // Bottom-up by recursion: a node is interned after its children, which gives the build form's offsets.
    const auto intern = [&](const auto& self, uint32_t unit, uint32_t log2) -> uint32_t {
      if (const auto found = memo[log2].find(unit); found != memo[log2].end()) return found->second;
      const uint32_t header = dag.nodes[unit];
      uint32_t words[9] = {0};
      unsigned count = 1;
      for (unsigned c = 0; c < 8; ++c) {
        const uint32_t code = childCodeOf(header, c);
        words[0] |= code << (2 * c);
        if (code != uint32_t(ChildCode::Ref)) continue;
        const uint32_t target = dag.child(unit, header, c, 1u << log2);
        words[count++] = log2 == 3 ? leaves_.intern(dag.leaves[target]) : self(self, target, log2 - 1);
      }
      const uint32_t word = levels_[log2].intern(words, count);
      memo[log2].emplace(unit, word);
      return word;
    };
    root.word = intern(intern, 0, log2Edge);
  }
  roots_.push_back(root);
  return roots_.size() - 1;
}

uint64_t NodePool::nodes() const {
  uint64_t n = 0;
  for (const NodeTable& level : levels_) n += level.size();
  return n;
}

LaidOutPool NodePool::layOut() const {
  LaidOutPool out;
  uint32_t top = 0;  // log2 of the largest root's edge
  for (const Root& r : roots_)
    if (r.code == ChildCode::Ref) top = std::max(top, r.log2Edge);

  // Leaves, most referenced first: the leaf parents' references are their indices.
  const std::vector<uint64_t>& masks = leaves_.leaves();
  std::vector<uint32_t> leafIds(masks.size());
  std::iota(leafIds.begin(), leafIds.end(), 0u);
  const std::vector<uint32_t> leafOrder =
      mostReferencedFirst(leafIds, top >= 3 ? referenceCounts(levels_[3].records().span(), masks.size())
                                            : std::vector<uint32_t>(masks.size(), 0));
  std::vector<uint64_t> valueBelow(masks.size());  // what a reference to each child of the level below codes
  for (uint32_t i = 0; i < leafOrder.size(); ++i) {
    valueBelow[leafOrder[i]] = i;
    out.leaves.push_back(masks[leafOrder[i]]);
  }

  std::vector<LaidOutPool::Root> roots(roots_.size());
  for (size_t v = 0; v < roots_.size(); ++v) roots[v] = {roots_[v].code, 1u << roots_[v].log2Edge, 0};
  for (uint32_t log2 = 3; top >= 3 && log2 <= top; ++log2) {
    const std::span<const uint32_t> words = levels_[log2].records().span();
    std::vector<uint32_t> counts = log2 < top ? referenceCounts(levels_[log2 + 1].records().span(), words.size())
                                              : std::vector<uint32_t>(words.size(), 0);
    for (const Root& r : roots_)
      if (r.code == ChildCode::Ref && r.log2Edge == log2 && counts[r.word] != UINT32_MAX) counts[r.word] += 1;
    std::vector<uint32_t> nodeAt;  // word offsets of the level's nodes
    for (size_t i = 0; i < words.size(); i += nodeWordCount(words[i])) nodeAt.push_back(uint32_t(i));
    const std::vector<uint32_t> order = mostReferencedFirst(nodeAt, counts);

    PooledLevel level;
    level.edge = 1u << log2;
    level.nodes = order.size();
    level.widths = narrowestPair(order, words, valueBelow, level.edge);
    std::vector<uint64_t> position(words.size(), 0);
    for (const uint32_t at : order) {
      position[at] = level.bytes.size();
      const size_t headerAt = level.bytes.size();
      level.bytes.resize(headerAt + 2);
      uint32_t header = 0;
      for (unsigned c = 0, k = 1; c < 8; ++c) {
        uint32_t code = wordCodeOf(words[at], c);
        if (code == uint32_t(ChildCode::Ref)) {
          const uint64_t value = valueBelow[words[at + k++]];
          const unsigned width = referenceBytes(value, level.widths);
          code = width == level.widths.shortBytes ? 2u : 3u;
          for (unsigned b = 0; b < width; ++b) level.bytes.push_back(uint8_t(value >> (8 * b)));
        }
        header |= code << (2 * c);
      }
      level.bytes[headerAt] = uint8_t(header);
      level.bytes[headerAt + 1] = uint8_t(header >> 8);
    }
    for (size_t v = 0; v < roots_.size(); ++v)
      if (roots_[v].code == ChildCode::Ref && roots_[v].log2Edge == log2) roots[v].offset = position[roots_[v].word];
    valueBelow = std::move(position);
    out.levels.push_back(std::move(level));
  }
  out.roots = std::move(roots);
  return out;
}

}  // namespace cpvs
