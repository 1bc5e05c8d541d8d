#pragma once
// Validation of a pooled DAG in the byte form a format 3.0 is to store (docs/format-3-study.md; the bake side
// is libcpvs/dag/node_pool.h): every node, reference, hot-table entry and root checked before any walk, in
// time linear in the bytes, so that a walk of any voxel of any view stays inside the buffers and ends. The
// reader of a 3.0 file is to call it; no file holds the form yet.
//
// The form: levels of edge 8, 16, 32, ... (ascending, none missing); a node is a 16-bit little-endian header,
// 2 bits per child (0 lit, 1 shadowed, 2 short reference, 3 long reference), then its references in child
// order, each in its level's short or long width (1 to 4 bytes, little-endian). A reference is the child's byte
// offset in the level below (a node start); below a leaf parent (edge 8) a leaf index. A level with a hot table
// codes its short references as ranks instead: hot[rank] is the child's byte offset. A view's root is lit,
// shadowed, or a node start in the level of its edge.
#include <cstdint>
#include <span>
#include <string>

#include "libcpvs/runtime/outcome.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

struct PoolLevelView {
  uint32_t edge = 0;
  uint8_t shortBytes = 0, longBytes = 0;
  std::span<const uint8_t> bytes;
  std::span<const uint32_t> hot;  // empty: short references are offsets
};

struct PoolRootView {
  ChildCode code = ChildCode::Lit;
  uint32_t edge = 0;    // the view's resolution
  uint64_t offset = 0;  // a reference: the root node's byte offset in the level of its edge
};

// Ok, or InvalidInput with "<where>: <what is wrong>" naming the level, node (byte offset), child, hot entry or
// root. `where` names the file.
Outcome validatePool(std::span<const PoolLevelView> levels, uint64_t leafCount, std::span<const PoolRootView> roots,
                     const std::string& where);

}  // namespace cpvs
