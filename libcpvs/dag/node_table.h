#pragma once
// Hash-consing of DAG nodes: one table per level (leaf masks: leaf_table.h); every hash hit is confirmed by
// comparing the whole node (a hash alone would corrupt shadows on a collision). A node's offset is where it was
// appended, so the index decides nothing about the bytes: it is kept small (hash_index.h, 4 bytes a slot) and is
// released once no more nodes come.
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include <xxhash.h>

#include "libcpvs/dag/hash_index.h"
#include "libcpvs/dag/mapped_array.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

class NodeTable {
public:
  // Returns the word offset of a node equal to words[0, count), appending it when new.
  uint32_t intern(const uint32_t* words, uint32_t count) {
    if (index_.full(size_, words_.size())) {
      index_.rebuild(size_, words_.size(), [&](auto&& insert) {
        for (size_t i = 0; i < words_.size(); i += nodeWordCount(words_[i]))
          insert(uint32_t(i), hashOf(&words_[i], nodeWordCount(words_[i])));
      });
    }
    const uint32_t newOffset = uint32_t(words_.size());
    const uint32_t offset = index_.findOrInsert(hashOf(words, count), newOffset, [&](uint32_t at) {
      return words_[at] == words[0] && std::memcmp(&words_[at], words, count * sizeof(uint32_t)) == 0;
    });
    if (offset == newOffset) {
      words_.append(words, count);
      ++size_;
    }
    return offset;
  }
  const MappedArray<uint32_t>& words() const { return words_; }
  uint64_t size() const { return size_; }
  // Hands the words over (to the encoder, which consumes them): no intern() after this.
  MappedArray<uint32_t> takeWords() {
    releaseIndex();
    return std::move(words_);
  }
  // Frees the index: no intern() after this.
  void releaseIndex() { index_.release(); }
  uint64_t indexBytes() const { return index_.bytes(); }

private:
  static uint64_t hashOf(const uint32_t* words, uint32_t count) { return XXH3_64bits(words, count * sizeof(uint32_t)); }

  MappedArray<uint32_t> words_;  // every node once, in the order they were added
  HashIndex index_;              // by word offset
  uint64_t size_ = 0;
};

}  // namespace cpvs
