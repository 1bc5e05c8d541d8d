#pragma once
// The index of a hash-consing table: open addressing with linear probing over 32-bit slots, filled to at most
// three quarters. A slot holds an item's id + 1 (a record's offset or a leaf index) in its low bits and, in the bits
// the ids leave free, the top bits of the item's hash: a filter that spares most probes a comparison with the
// stored item (a cache miss each). No hash is stored beside the slot: growing rehashes the stored items, so a
// slot costs 4 bytes instead of the 8 of an (id, hash) pair, and a table of n items between 5.3n and 10.7n bytes
// (docs/construction.md, "Memory").
#include <algorithm>
#include <bit>
#include <cstdint>
#include <utility>
#include <vector>

#include "libcpvs/base/error.h"

namespace cpvs {

class HashIndex {
public:
  // Whether inserting one more item, whose id may reach `nextId`, needs rebuild() first.
  bool full(uint64_t items, uint64_t nextId) const {
    return 4 * (items + 1) > 3 * slots_.size() || nextId + 1 >= (uint64_t(1) << idBits_);
  }

  // Sizes the index for one item more than `items`, with ids up to `nextId`, and reinserts every item:
  // forEachItem(insert) calls insert(id, hash) once per stored item.
  template <class ForEachItem>
  void rebuild(uint64_t items, uint64_t nextId, ForEachItem&& forEachItem) {
    if (nextId + 1 > UINT32_MAX)
      throw Error(ErrorCategory::RuntimeFailure, "DAG builder: a node table passed 2^32 entries");
    size_t capacity = slots_.empty() ? 1024 : slots_.size();
    while (4 * (items + 1) > 3 * capacity) capacity *= 2;
    std::vector<uint32_t>().swap(slots_);  // the old slots are not needed: the items are rehashed
    slots_.assign(capacity, 0);
    idBits_ = std::max<uint32_t>(uint32_t(std::bit_width(nextId + 1)), idBits_);
    // Each insert is a cache miss in a large index: the items are inserted kAhead after their slots are
    // prefetched. The slots they land in are the same as one by one (each waits for the inserts before it).
    constexpr size_t kAhead = 16;
    std::pair<uint32_t, uint64_t> pending[kAhead];
    size_t seen = 0;
    const auto place = [&](uint32_t id, uint64_t hash) {
      for (size_t i = size_t(hash) & (slots_.size() - 1);; i = (i + 1) & (slots_.size() - 1)) {
        if (slots_[i] == 0) {
          slots_[i] = slotOf(id, hash);
          break;
        }
      }
    };
    forEachItem([&](uint32_t id, uint64_t hash) {
      if (seen >= kAhead) place(pending[seen % kAhead].first, pending[seen % kAhead].second);
      pending[seen++ % kAhead] = {id, hash};
      prefetch(hash);
    });
    for (size_t k = seen > kAhead ? seen - kAhead : 0; k < seen; ++k) place(pending[k % kAhead].first, pending[k % kAhead].second);
  }

  // The id of the item equal(id) confirms, among those with this hash; or newId, recorded, when there is none.
  template <class Equal>
  uint32_t findOrInsert(uint64_t hash, uint32_t newId, Equal&& equal) {
    const uint32_t tag = tagOf(hash);
    const uint32_t idMask = idBits_ >= 32 ? UINT32_MAX : (1u << idBits_) - 1;
    const size_t mask = slots_.size() - 1;
    for (size_t i = size_t(hash) & mask;; i = (i + 1) & mask) {
      const uint32_t slot = slots_[i];
      if (slot == 0) {
        slots_[i] = slotOf(newId, hash);
        return newId;
      }
      if ((slot & ~idMask) == tag && equal((slot & idMask) - 1)) return (slot & idMask) - 1;
    }
  }

  // The id of the item equal(id) confirms, among those with this hash; UINT32_MAX when there is none.
  template <class Equal>
  uint32_t find(uint64_t hash, Equal&& equal) const {
    const uint32_t tag = tagOf(hash);
    const uint32_t idMask = idBits_ >= 32 ? UINT32_MAX : (1u << idBits_) - 1;
    const size_t mask = slots_.size() - 1;
    for (size_t i = size_t(hash) & mask;; i = (i + 1) & mask) {
      const uint32_t slot = slots_[i];
      if (slot == 0) return UINT32_MAX;
      if ((slot & ~idMask) == tag && equal((slot & idMask) - 1)) return (slot & idMask) - 1;
    }
  }

  // The id in the slot a search for this hash starts at, when its hash bits match (the item a search would most
  // likely compare first); UINT32_MAX otherwise.
  uint32_t firstCandidate(uint64_t hash) const {
    if (slots_.empty()) return UINT32_MAX;
    const uint32_t idMask = idBits_ >= 32 ? UINT32_MAX : (1u << idBits_) - 1;
    const uint32_t slot = slots_[size_t(hash) & (slots_.size() - 1)];
    return slot != 0 && (slot & ~idMask) == tagOf(hash) ? (slot & idMask) - 1 : UINT32_MAX;
  }

  // Brings the slot a search for this hash starts at into the cache.
  void prefetch(uint64_t hash) const {
    if (!slots_.empty()) __builtin_prefetch(slots_.data() + (size_t(hash) & (slots_.size() - 1)));
  }

  void release() { std::vector<uint32_t>().swap(slots_); }
  // Empties the index, keeping its slots (for a table refilled many times).
  void clear() { std::fill(slots_.begin(), slots_.end(), 0u); }
  uint64_t bytes() const { return slots_.capacity() * 4; }

private:
  uint32_t tagOf(uint64_t hash) const { return idBits_ >= 32 ? 0 : uint32_t(hash >> (32 + idBits_)) << idBits_; }
  uint32_t slotOf(uint32_t id, uint64_t hash) const { return tagOf(hash) | (id + 1); }

  std::vector<uint32_t> slots_;  // 0: empty
  uint32_t idBits_ = 1;          // low bits of a slot that hold id + 1; the rest hold the hash's top bits
};

}  // namespace cpvs
