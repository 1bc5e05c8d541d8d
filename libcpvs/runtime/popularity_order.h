#pragma once
// The order in which the encoders lay out a level of a DAG: most referenced first. One rule for a view's levels
// (encodeDag, shadow_dag.cpp) and a pool's (libcpvs/dag/node_pool.cpp), so both put the popular nodes where
// the short references reach.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// References per node of one level, counted over the references of the level above given in build form
// (words), indexed by what those references hold: a word offset, a node id (NodePool) or a leaf index.
inline std::vector<uint32_t> referenceCounts(std::span<const uint32_t> parentWords, size_t targetCount) {
  std::vector<uint32_t> counts(targetCount, 0);
  for (size_t i = 0; i < parentWords.size();) {
    const unsigned count = nodeWordCount(parentWords[i]);
    for (unsigned k = 1; k < count; ++k) {
      uint32_t& n = counts[parentWords[i + k]];
      n += n != UINT32_MAX;
    }
    i += count;
  }
  return counts;
}

// `items` (word offsets, node ids or leaf indices) ordered by reference count, most first, ties in the given order:
// a stable counting sort on the count capped at kCap (only the head of a level needs an exact order — what
// fits the short references — and every node referenced kCap times or more belongs there).
inline std::vector<uint32_t> mostReferencedFirst(const std::vector<uint32_t>& items, const std::vector<uint32_t>& counts) {
  constexpr uint32_t kCap = 1u << 16;
  std::vector<uint32_t> bucketStart(kCap + 2, 0);
  for (uint32_t item : items) ++bucketStart[kCap - std::min(counts[item], kCap) + 1];
  for (size_t b = 1; b < bucketStart.size(); ++b) bucketStart[b] += bucketStart[b - 1];
  std::vector<uint32_t> ordered(items.size());
  for (uint32_t item : items) ordered[bucketStart[kCap - std::min(counts[item], kCap)]++] = item;
  return ordered;
}

}  // namespace cpvs
