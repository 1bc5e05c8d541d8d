#pragma once
// The shadow DAG of one light view, pointer-free (docs/construction.md, §6; byte-level spec in formats/cpvs/format.md).
//
// Node levels l = 0..L with L = log2(N) - 3. A node at level l covers a cube of s = N >> l voxels.
//  * Octree nodes (s > 8) have 8 children of s/2 in Z-order: child c = (zbit << 2) | (ybit << 1) | xbit,
//    so the four children nearer the light come first.
//  * Leaf-parent nodes (s == 8, level L) split z only: child c is the 8x8x1 slice z0 + c.
// Leaves are 64-bit masks whose bit (y & 7) * 8 + (x & 7) is set when shadowed.
//
// Stored form (format 2): a node is a run of u16 units. Unit 0, the header, holds 2 bits per child
// (bits 2c..2c+1): 0 lit, 1 shadowed, 2 reference in one unit, 3 reference in two units (low half first).
// The references follow in child order. A reference from level l < L counts units from the start of level
// l + 1; one from level L indexes `leaves`. Most references are small, so most take one unit: the DAG is
// 1.5-1.9x smaller than with 32-bit words (benchmarks/ref_width_estimate.py). Nodes are stored level by level
// from the root, which sits at unit 0 when rootCode is Ref.
//
// Build form ("words", used while building and for format-1 files): a u32 header with codes 0..2 and one u32
// per referenced child; references are word offsets.
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "libcpvs/runtime/outcome.h"
#include "libcpvs/runtime/portability.h"

namespace cpvs {

enum class ChildCode : uint8_t { Lit = 0, Shadowed = 1, Ref = 2 };

inline constexpr uint32_t kMaxDagLevels = 32;

struct DagView {
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  std::span<const uint16_t> nodes;
  std::span<const uint64_t> leaves;
  // childBase[log2(s)]: what a reference from a node of edge s is counted from — the unit where the next
  // level starts, or 0 for leaf parents (s = 8), whose references are leaf indices.
  uint32_t childBase[kMaxDagLevels] = {};
  // A view of a 3.x file's node pool: the units of the whole pool, in which `nodes` is the tail from the view's
  // root on (so every walk reads it as a DAG of its own), shared with the file's other views, and the view's
  // share of the pool's bytes (what sizes its top grid). Empty and 0 for a DAG that has its spans to itself.
  std::span<const uint16_t> sharedNodes = {};
  uint64_t sharedBytes = 0;

  uint32_t levels() const;  // L + 1
  // Visibility of voxel (x, y, z), all in [0, N): true when shadowed. Assumes a validated DAG.
  bool shadowed(uint32_t x, uint32_t y, uint32_t z) const;
  // Where child c (a reference) of the node of edge `size` at unit `offset` is: its first unit, or its leaf
  // index below a leaf parent.
  uint32_t child(uint32_t offset, uint32_t header, unsigned c, uint32_t size) const;
  // Fills childBase from the unit where each level starts (root level first, levels() entries).
  void setLevelStarts(std::span<const uint64_t> levelStarts);
  // The bytes this DAG stands for: its nodes and leaves, or its share of the pool it reads.
  uint64_t bytes() const { return sharedNodes.empty() ? nodes.size_bytes() + leaves.size_bytes() : sharedBytes; }
};

struct ShadowDag {
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  std::vector<uint16_t> nodes;
  std::vector<uint64_t> leaves;
  std::vector<uint64_t> nodesPerLevel;  // unique nodes at each level
  std::vector<uint64_t> levelOffsets;   // unit where each level starts in `nodes`

  DagView view() const;
  uint64_t bytes() const { return nodes.size() * 2 + leaves.size() * 8; }
};

// Population counts without the POPCNT instruction: the build targets baseline x86-64, where
// __builtin_popcount is a libgcc call. Every walk and every validation of a loaded file counts bits per node;
// GCC turns these into one POPCNT where the target has it, and the hot walks are compiled twice for that
// (CPVS_POPCNT_CLONES, portability.h).
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

// --- Stored form (u16 units) ---

// Child c's code as a ChildCode value: 0 lit, 1 shadowed, 2 reference of either width.
inline uint32_t childCodeOf(uint32_t header, unsigned child) {
  const uint32_t raw = (header >> (2 * child)) & 3u;
  return raw - (raw & (raw >> 1));
}
inline bool isWideRef(uint32_t header, unsigned child) { return ((header >> (2 * child)) & 3u) == 3u; }
// One bit per unit the references take: the high bit of a reference's code, and the low bit too when wide.
inline uint32_t refUnitBits(uint32_t header) { return (header & 0xAAAAu) | (header & (header >> 1) & 0x5555u); }
inline unsigned nodeUnitCount(uint32_t header) { return 1u + popcount32(refUnitBits(header)); }
// Child c's reference as stored: relative to the child level, or a leaf index. For a child that is not a
// reference the result is meaningless but the reads stay inside the node, so walks can call it unconditionally.
inline uint32_t readRef(const uint16_t* nodes, uint32_t offset, uint32_t header, unsigned child) {
  const bool ref = (header >> (2 * child + 1)) & 1u;
  const uint32_t at = offset + (ref ? 1 + popcount32(refUnitBits(header) & ((1u << (2 * child)) - 1u)) : 0u);
  const uint32_t wide = isWideRef(header, child) ? 1u : 0u;
  // When narrow the "high half" re-reads `at`: no branch.
  return uint32_t(nodes[at]) | ((uint32_t(nodes[at + wide]) << 16) & (0u - wide));
}

// Writing a reference: one unit below 2^16 (code 2), else two, low half first (code 3). Calls put(unit) per
// unit and returns the child's 2-bit code for the node's header. The one place the encoders take the rule from.
inline unsigned referenceUnits(uint32_t target) { return target > 0xFFFFu ? 2u : 1u; }
template <class Put>
uint32_t storeReference(uint32_t target, Put&& put) {
  put(uint16_t(target));
  if (target > 0xFFFFu) put(uint16_t(target >> 16));
  return 1u + referenceUnits(target);
}

inline uint32_t DagView::child(uint32_t offset, uint32_t header, unsigned c, uint32_t size) const {
  return childBase[std::countr_zero(size)] + readRef(nodes.data(), offset, header, c);
}

// --- Build form (u32 words) ---

inline uint32_t wordCodeOf(uint32_t header, unsigned child) { return (header >> (2 * child)) & 3u; }
// A node in the stored form from its build-form header: the k-th reference becomes targetOf(k), written with
// storeReference through put(unit); returns the stored header. The encoders of both forms' sources use it.
template <class TargetOf, class Put>
uint32_t storeNode(uint32_t header, TargetOf&& targetOf, Put&& put) {
  uint32_t stored = 0;
  for (unsigned c = 0, k = 0; c < 8; ++c) {
    const uint32_t code = wordCodeOf(header, c);
    stored |= (code == uint32_t(ChildCode::Ref) ? storeReference(targetOf(k++), put) : code) << (2 * c);
  }
  return stored;
}
// Index among the node's reference words of child `child` (which must be a reference).
inline unsigned refSlot(uint32_t header, unsigned child) {
  const uint32_t refBits = header & 0xAAAAu;  // the high bit of each 2-bit code marks a reference
  return popcount32(refBits & ((1u << (2 * child)) - 1u));
}
inline unsigned nodeWordCount(uint32_t header) { return 1u + popcount32(header & 0xAAAAu); }

// How encodeDag orders the nodes of each level (and the leaves). Any order is a valid file; the order decides
// how many references fit one unit.
enum class NodeOrder : uint8_t {
  AsGiven,              // as in the build form (format-1 files converted on open keep their order)
  MostReferencedFirst,  // by how many references point at them, most first, ties as given (what cpvs-bake
                        // writes: the popular nodes land in the first 65,536 units of their level)
};

// Encodes a DAG given in build form, one word array per level (root level first) whose references are word
// offsets into the next level's array (leaf indices at the last level), into the stored form. Fails
// (RuntimeFailure) if a level would not fit 32-bit references.
Result<ShadowDag> encodeDag(uint32_t resolution, ChildCode rootCode, std::span<const std::span<const uint32_t>> levelWords,
                    std::span<const uint64_t> nodesPerLevel, std::vector<uint64_t> leaves,
                    NodeOrder order = NodeOrder::AsGiven);

}  // namespace cpvs
