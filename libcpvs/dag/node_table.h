#pragma once
// Hash-consing of DAG nodes as words, one table per level, over interned_records.h (the leaf parents are
// byte-coded: leaf_parent_table.h; leaf masks: leaf_table.h).
#include <cstdint>

#include "libcpvs/dag/interned_records.h"
#include "libcpvs/dag/mapped_array.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

class NodeTable {
public:
  // Returns the word offset of a node equal to words[0, count), appending it when new.
  uint32_t intern(const uint32_t* words, uint32_t count) { return nodes_.intern(words, count); }
  const MappedArray<uint32_t>& words() const { return nodes_.records(); }
  uint64_t size() const { return nodes_.size(); }
  // Hands the words over (to the encoder, which consumes them): no intern() after this.
  MappedArray<uint32_t> takeWords() { return nodes_.take(); }
  // Frees the index: no intern() after this.
  void releaseIndex() { nodes_.releaseIndex(); }
  uint64_t indexBytes() const { return nodes_.indexBytes(); }

private:
  // A stored node's header says its length (a node is never the start of another: the header differs).
  struct NodeLength {
    uint32_t operator()(const uint32_t* node) const { return nodeWordCount(node[0]); }
  };
  InternedRecords<uint32_t, NodeLength> nodes_;  // every node once, in the order they were added
};

}  // namespace cpvs
