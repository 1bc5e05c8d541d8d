#include "libcpvs/dag/leaf_table.h"

#include <bit>
#include <string>

#include <xxhash.h>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

uint64_t hashOf(uint64_t mask) { return XXH3_64bits(&mask, sizeof mask); }

}  // namespace

uint64_t edgeTexels(uint64_t mask) {
  constexpr uint64_t notFirstColumn = 0xfefefefefefefefeull, notLastColumn = 0x7f7f7f7f7f7f7f7full;
  const uint64_t leftDiffers = (mask ^ (mask << 1)) & notFirstColumn;   // texel x differs from x - 1
  const uint64_t rightDiffers = (mask ^ (mask >> 1)) & notLastColumn;   // texel x differs from x + 1
  const uint64_t upDiffers = (mask ^ (mask << 8)) & ~uint64_t(0xff);   // row y differs from y - 1
  const uint64_t downDiffers = (mask ^ (mask >> 8)) & (~uint64_t(0) >> 8);
  return leftDiffers | rightDiffers | upDiffers | downDiffers;
}

LeafTable::LeafTable(uint32_t maxEdgeFlips) : maxEdgeFlips_(maxEdgeFlips) {
  if (maxEdgeFlips > kMaxEdgeFlips)
    throw Error(ErrorCategory::InvalidArgument, "leaf table: at most " + std::to_string(kMaxEdgeFlips) +
                                                    " edge texels may differ, not " + std::to_string(maxEdgeFlips));
}

uint32_t LeafTable::stored(uint64_t mask) const {
  if (leaves_.empty()) return UINT32_MAX;
  return index_.find(hashOf(mask), [&](uint32_t at) { return leaves_[at] == mask; });
}

uint32_t LeafTable::nearest(uint64_t mask) const {
  // Candidates in a fixed order, the fewest flips first, then by texel: the answer does not depend on timing.
  // They are hashed and their slots prefetched a batch at a time: the probes are cache misses, and a batch's
  // misses overlap instead of following one another.
  constexpr int kBatch = 16;
  uint64_t candidate[kBatch], hash[kBatch];
  int count = 0;
  uint32_t found = UINT32_MAX;
  const auto flush = [&] {
    for (int k = 0; k < count; ++k) index_.prefetch(hash[k]);
    for (int k = 0; k < count && found == UINT32_MAX; ++k)
      found = index_.find(hash[k], [&](uint32_t at) { return leaves_[at] == candidate[k]; });
    count = 0;
    return found != UINT32_MAX;
  };
  const auto add = [&](uint64_t other) {
    candidate[count] = other;
    hash[count] = hashOf(other);
    return ++count == kBatch && flush();
  };
  const uint64_t edges = edgeTexels(mask);
  for (uint64_t a = edges; a; a &= a - 1)
    if (add(mask ^ (a & -a))) return found;
  if (flush()) return found;
  if (maxEdgeFlips_ >= 2)
    for (uint64_t a = edges; a; a &= a - 1)
      for (uint64_t b = a & (a - 1); b; b &= b - 1)
        if (add(mask ^ (a & -a) ^ (b & -b))) return found;
  flush();
  return found;
}

uint32_t LeafTable::insert(uint64_t mask) {
  if (index_.full(leaves_.size(), leaves_.size())) {
    index_.rebuild(leaves_.size(), leaves_.size(), [&](auto&& add) {
      for (size_t i = 0; i < leaves_.size(); ++i) add(uint32_t(i), hashOf(leaves_[i]));
    });
  }
  const uint32_t newIndex = uint32_t(leaves_.size());
  const uint32_t index = index_.findOrInsert(hashOf(mask), newIndex, [&](uint32_t at) { return leaves_[at] == mask; });
  if (index == newIndex) leaves_.push_back(mask);
  return index;
}

uint32_t LeafTable::intern(uint64_t mask) {
  if (maxEdgeFlips_ == 0) return insert(mask);
  const uint32_t same = stored(mask);
  if (same != UINT32_MAX) return same;
  if (!aliasMasks_.empty()) {
    const uint32_t alias = aliasIndex_.find(hashOf(mask), [&](uint32_t at) { return aliasMasks_[at] == mask; });
    if (alias != UINT32_MAX) return aliasLeaf_[alias];
  }
  const uint32_t near = leaves_.empty() ? UINT32_MAX : nearest(mask);
  if (near == UINT32_MAX) return insert(mask);
  if (aliasIndex_.full(aliasMasks_.size(), aliasMasks_.size())) {
    aliasIndex_.rebuild(aliasMasks_.size(), aliasMasks_.size(), [&](auto&& add) {
      for (size_t i = 0; i < aliasMasks_.size(); ++i) add(uint32_t(i), hashOf(aliasMasks_[i]));
    });
  }
  aliasIndex_.findOrInsert(hashOf(mask), uint32_t(aliasMasks_.size()), [](uint32_t) { return false; });
  aliasMasks_.push_back(mask);
  aliasLeaf_.push_back(near);
  ++merged_;
  flipped_ += uint64_t(std::popcount(mask ^ leaves_[near]));
  return near;
}

void LeafTable::releaseIndex() {
  index_.release();
  aliasIndex_.release();
  std::vector<uint64_t>().swap(aliasMasks_);
  std::vector<uint32_t>().swap(aliasLeaf_);
}

uint64_t LeafTable::indexBytes() const {
  return index_.bytes() + aliasIndex_.bytes() + aliasMasks_.capacity() * 8 + aliasLeaf_.capacity() * 4;
}

}  // namespace cpvs
