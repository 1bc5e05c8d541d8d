#pragma once
// Hash-consing of DAG nodes as words, one table per level, over interned_records.h (the leaf parents are
// byte-coded: leaf_parent_table.h; leaf masks: leaf_table.h).
#include <cstdint>

#include "libcpvs/dag/interned_records.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// A stored node's header says its length (a node is never the start of another: their headers differ).
struct NodeWordCount {
  uint32_t operator()(const uint32_t* node) const { return nodeWordCount(node[0]); }
};
// intern(words, count) returns the word offset of an equal node, appending it when new; records() are the words.
using NodeTable = InternedRecords<uint32_t, NodeWordCount>;

}  // namespace cpvs
