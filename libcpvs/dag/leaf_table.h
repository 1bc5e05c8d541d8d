#pragma once
// Hash-consing of leaf masks (8x8 texel slices; bit y * 8 + x set when shadowed), optionally lossy: with a
// bound K > 0, a mask not stored yet is answered by a stored leaf that differs from it in at most K texels,
// each on a shadow edge of the mask (a texel whose neighbour in its row or column of the leaf differs), the
// nearest first (docs/lossy.md, "Edge merging"). The same mask always gets the same leaf: a mask answered by
// another leaf is remembered as an alias.
#include <cstdint>
#include <vector>

#include "libcpvs/dag/hash_index.h"

namespace cpvs {

class LeafTable {
public:
  static constexpr uint32_t kMaxEdgeFlips = 2;  // the search tries every pair of edge texels: 2 is its limit

  explicit LeafTable(uint32_t maxEdgeFlips = 0);

  // The index of the leaf that answers `mask`: equal to it, or (lossy) within the bound.
  uint32_t intern(uint64_t mask);

  const std::vector<uint64_t>& leaves() const { return leaves_; }
  std::vector<uint64_t>& leaves() { return leaves_; }
  uint64_t merged() const { return merged_; }    // distinct masks answered by another leaf
  uint64_t flipped() const { return flipped_; }  // their texels that differ from their answers, summed
  void releaseIndex();
  uint64_t indexBytes() const;

private:
  uint32_t stored(uint64_t mask) const;   // its leaf index, or UINT32_MAX
  uint32_t nearest(uint64_t mask) const;  // the first stored leaf within the bound, or UINT32_MAX
  uint32_t insert(uint64_t mask);

  uint32_t maxEdgeFlips_;
  std::vector<uint64_t> leaves_;
  HashIndex index_;  // by leaf index
  std::vector<uint64_t> aliasMasks_;
  std::vector<uint32_t> aliasLeaf_;
  HashIndex aliasIndex_;  // by alias index
  uint64_t merged_ = 0, flipped_ = 0;
};

// The texels of `mask` on one of its shadow edges: those whose right, left, lower or upper neighbour within the
// 8x8 leaf differs.
uint64_t edgeTexels(uint64_t mask);

}  // namespace cpvs
