#pragma once
// Hash-consing of DAG nodes and leaf masks: one table per level; every hash hit is confirmed by comparing
// the whole node (a hash alone would corrupt shadows on a collision). A node's offset is where it was appended,
// so the index (slots and hashes) decides nothing about the bytes: it is kept small (8 bytes a slot) and can be
// released once no more nodes come.
#include <cstdint>
#include <cstring>
#include <vector>

#include <xxhash.h>

#include "libcpvs/dag/mapped_array.h"

namespace cpvs {

class NodeTable {
public:
  // Returns the word offset of a node equal to words[0, count), appending it when new.
  uint32_t intern(const uint32_t* words, uint32_t count) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    const uint32_t hash = uint32_t(XXH3_64bits(words, count * sizeof(uint32_t)));
    const size_t mask = slots_.size() - 1;
    for (size_t i = size_t(hash) & mask;; i = (i + 1) & mask) {
      const uint32_t slot = slots_[i];
      if (slot == 0) {
        const uint32_t offset = uint32_t(words_.size());
        words_.append(words, count);
        slots_[i] = offset + 1;
        hashes_[i] = hash;
        ++size_;
        return offset;
      }
      const uint32_t offset = slot - 1;
      if (hashes_[i] == hash && words_[offset] == words[0] &&
          std::memcmp(&words_[offset], words, count * sizeof(uint32_t)) == 0)
        return offset;
    }
  }
  const MappedArray<uint32_t>& words() const { return words_; }
  uint64_t size() const { return size_; }
  // Frees the index: no intern() after this.
  void releaseIndex() {
    std::vector<uint32_t>().swap(slots_);
    std::vector<uint32_t>().swap(hashes_);
  }
  uint64_t indexBytes() const { return slots_.capacity() * 4 + hashes_.capacity() * 4; }

private:
  void grow() {
    const size_t capacity = slots_.empty() ? 1024 : slots_.size() * 2;
    std::vector<uint32_t> slots(capacity, 0);
    std::vector<uint32_t> hashes(capacity, 0);
    for (size_t i = 0; i < slots_.size(); ++i) {
      if (slots_[i] == 0) continue;
      for (size_t j = size_t(hashes_[i]) & (capacity - 1);; j = (j + 1) & (capacity - 1)) {
        if (slots[j] == 0) {
          slots[j] = slots_[i];
          hashes[j] = hashes_[i];
          break;
        }
      }
    }
    slots_.swap(slots);
    hashes_.swap(hashes);
  }

  MappedArray<uint32_t> words_;  // every node once, in the order they were added
  std::vector<uint32_t> slots_;  // word offset + 1; 0 = empty
  std::vector<uint32_t> hashes_;  // the low 32 bits of each node's hash: its slot (capacity <= 2^32) and a filter
  uint64_t size_ = 0;
};

class LeafTable {
public:
  uint32_t intern(uint64_t mask) {
    if (2 * (leaves_.size() + 1) > slots_.size()) grow();
    const size_t m = slots_.size() - 1;
    for (size_t i = size_t(XXH3_64bits(&mask, sizeof mask)) & m;; i = (i + 1) & m) {
      const uint32_t slot = slots_[i];
      if (slot == 0) {
        leaves_.push_back(mask);
        slots_[i] = uint32_t(leaves_.size());
        return uint32_t(leaves_.size() - 1);
      }
      if (leaves_[slot - 1] == mask) return slot - 1;
    }
  }
  const std::vector<uint64_t>& leaves() const { return leaves_; }
  std::vector<uint64_t>& leaves() { return leaves_; }
  void releaseIndex() { std::vector<uint32_t>().swap(slots_); }
  uint64_t indexBytes() const { return slots_.capacity() * 4; }

private:
  void grow() {
    const size_t capacity = slots_.empty() ? 1024 : slots_.size() * 2;
    std::vector<uint32_t> slots(capacity, 0);
    for (uint32_t index = 0; index < leaves_.size(); ++index) {
      for (size_t j = size_t(XXH3_64bits(&leaves_[index], 8)) & (capacity - 1);; j = (j + 1) & (capacity - 1)) {
        if (slots[j] == 0) {
          slots[j] = index + 1;
          break;
        }
      }
    }
    slots_.swap(slots);
  }

  std::vector<uint64_t> leaves_;
  std::vector<uint32_t> slots_;  // leaf index + 1; 0 = empty
};

}  // namespace cpvs
