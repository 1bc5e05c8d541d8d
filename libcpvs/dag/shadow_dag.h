#pragma once
// The shadow DAG of one light view, pointer-free (DESIGN.md §4.4, §6).
//
// Node levels l = 0..L with L = log2(N) - 3. A node at level l covers a cube of s = N >> l voxels.
//  * Octree nodes (s > 8) have 8 children of s/2 in Z-order: child c = (zbit << 2) | (ybit << 1) | xbit,
//    so the four children nearer the light come first.
//  * Leaf-parent nodes (s == 8, level L) split z only: child c is the 8x8x1 slice z0 + c.
// A node is stored as words: word 0 holds 2 bits per child (bits 2c..2c+1): 0 lit, 1 shadowed, 2 reference;
// then one word per referenced child, in child order. References from levels < L are word offsets into
// `nodes`; references from level L index `leaves`, 64-bit masks whose bit (y & 7) * 8 + (x & 7) is set when
// shadowed. Nodes are stored level by level from the root, which sits at offset 0 when rootCode is Ref.
#include <cstdint>
#include <span>
#include <vector>

namespace cpvs {

enum class ChildCode : uint8_t { Lit = 0, Shadowed = 1, Ref = 2 };

struct DagView {
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  std::span<const uint32_t> nodes;
  std::span<const uint64_t> leaves;

  uint32_t levels() const;  // L + 1
  // Visibility of voxel (x, y, z), all in [0, N): true when shadowed. Assumes a validated DAG.
  bool shadowed(uint32_t x, uint32_t y, uint32_t z) const;
};

struct ShadowDag {
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  std::vector<uint32_t> nodes;
  std::vector<uint64_t> leaves;
  std::vector<uint64_t> nodesPerLevel;  // unique nodes at each level
  std::vector<uint64_t> levelOffsets;   // word offset where each level starts in `nodes`

  DagView view() const { return {resolution, rootCode, nodes, leaves}; }
  uint64_t bytes() const { return nodes.size() * 4 + leaves.size() * 8; }
};

inline uint32_t childCodeOf(uint32_t header, unsigned child) { return (header >> (2 * child)) & 3u; }

// Population counts without the POPCNT instruction: the build targets baseline x86-64, where
// __builtin_popcount is a libgcc call. Every walk and every validation of a loaded file counts bits per node.
inline uint32_t popcount32(uint32_t v) {
  v = v - ((v >> 1) & 0x55555555u);
  v = (v & 0x33333333u) + ((v >> 2) & 0x33333333u);
  return (((v + (v >> 4)) & 0x0F0F0F0Fu) * 0x01010101u) >> 24;
}
inline uint32_t popcount64(uint64_t v) {
  v = v - ((v >> 1) & 0x5555555555555555ull);
  v = (v & 0x3333333333333333ull) + ((v >> 2) & 0x3333333333333333ull);
  return uint32_t((((v + (v >> 4)) & 0x0F0F0F0F0F0F0F0Full) * 0x0101010101010101ull) >> 56);
}

// Index among the node's reference words of child `child` (which must be a reference).
inline unsigned refSlot(uint32_t header, unsigned child) {
  const uint32_t refBits = header & 0xAAAAu;  // the high bit of each 2-bit code marks a reference
  return popcount32(refBits & ((1u << (2 * child)) - 1u));
}
inline unsigned nodeWordCount(uint32_t header) { return 1u + popcount32(header & 0xAAAAu); }

}  // namespace cpvs
