#pragma once
// A pool of DAG nodes laid out with two reference widths per level, in bytes: the candidate coding for a
// .cpvs 3.0 that benchmarks/level_width_estimate weighs and benchmarks/level_width_walk times (the library's
// NodePool, libcpvs/dag/node_pool.h, is its implementation). A study's tool, not a format.
//
// Every node edge (8, 16, ... N) is one level of the pool, its nodes most referenced first (ties as first
// seen, as cpvs-bake orders a view's levels). A node is a 16-bit header, 2 bits per child as in format 2.0
// (0 lit, 1 shadowed, 2 short reference, 3 long reference), then its references in child order, each in the
// level's short or long width (1 to 4 bytes, little-endian). A reference is the child's byte offset in its
// level (below a leaf parent: the leaf's index in the pool's leaves, most referenced first); each level picks
// the pair of widths that makes it smallest. Child k's reference is read directly: it starts after the
// header and the references before it, whose widths the header gives.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <vector>

#include "benchmarks/node_pool.h"
#include "libcpvs/dag/node_pool.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs::study {

using Widths = ReferenceWidths;  // the library's pairs (kWidthPairs), in the same order

// The bytes of a reference of this value in a pair of widths: the short one when it fits, else the long one,
// else "does not fit" (a huge count, so that the pair loses).
inline uint64_t referenceBytes(uint64_t value, Widths w) {
  if (w.shortBytes < 8 && value < (uint64_t(1) << (8 * w.shortBytes))) return w.shortBytes;
  if (w.longBytes >= 8 || value < (uint64_t(1) << (8 * w.longBytes))) return w.longBytes;
  return std::numeric_limits<uint32_t>::max();
}

// Reference counts capped at 2^16 (encodeDag's order), ids ordered most referenced first, ties by id.
inline std::vector<uint32_t> popularityOrder(std::vector<uint32_t> ids, const std::vector<uint64_t>& refs) {
  std::stable_sort(ids.begin(), ids.end(), [&](uint32_t a, uint32_t b) {
    return std::min<uint64_t>(refs[a], 1u << 16) > std::min<uint64_t>(refs[b], 1u << 16);
  });
  return ids;
}

struct PoolLevel {
  uint32_t edge = 0;
  std::vector<uint32_t> order;  // pooled node ids as laid out
  uint64_t references = 0, begin = 0, bytes = 0;  // begin: the level's first byte in ByteDag::bytes
  Widths widths;
};

// The study's layout of a pool: what the estimator weighs the other codings over. The library's NodePool
// (libcpvs/dag/node_pool.h) lays out the same bytes (level_width_estimate checks it); the walks read those.
struct StudyLayout {
  std::vector<uint8_t> bytes;
  std::vector<PoolLevel> levels;         // ascending edge
  std::vector<uint64_t> nodeOffset;      // by pooled id: byte offset in its level
  std::vector<uint32_t> leafIndex;       // by pooled leaf id
  uint64_t nodeBytes() const { return bytes.size(); }
};

inline StudyLayout layOut(const Pool& pool) {
  StudyLayout out;
  std::vector<uint64_t> refs(pool.nodes.size(), 0), leafRefs(pool.leaves, 0);
  for (const PooledNode& n : pool.nodes)
    for (const uint32_t c : n.children) (n.edge == 8 ? leafRefs : refs)[c] += 1;
  for (const PooledRoot& r : pool.roots)  // a view's root counts as a reference, as NodePool counts it
    if (r.code == ChildCode::Ref) refs[r.node] += 1;
  std::vector<uint32_t> leafIds(pool.leaves);
  std::iota(leafIds.begin(), leafIds.end(), 0u);
  const std::vector<uint32_t> leafOrder = popularityOrder(leafIds, leafRefs);
  out.leafIndex.assign(pool.leaves, 0);
  for (uint32_t i = 0; i < leafOrder.size(); ++i) out.leafIndex[leafOrder[i]] = i;
  std::map<uint32_t, std::vector<uint32_t>> byEdge;  // ascending edge: children are laid out before parents
  for (uint32_t id = 0; id < pool.nodes.size(); ++id) byEdge[pool.nodes[id].edge].push_back(id);
  out.nodeOffset.assign(pool.nodes.size(), 0);
  const auto valueOf = [&](const PooledNode& n, uint32_t c) {
    return n.edge == 8 ? uint64_t(out.leafIndex[c]) : out.nodeOffset[c];
  };
  for (auto& [edge, ids] : byEdge) {
    PoolLevel level;
    level.edge = edge;
    level.order = popularityOrder(ids, refs);
    uint64_t best = std::numeric_limits<uint64_t>::max();
    for (const Widths pair : kWidthPairs) {
      uint64_t bytes = 0;
      for (const uint32_t id : level.order) {
        bytes += 2;
        for (const uint32_t c : pool.nodes[id].children) bytes += referenceBytes(valueOf(pool.nodes[id], c), pair);
      }
      if (bytes < best) best = bytes, level.widths = pair;
    }
    level.begin = out.bytes.size();
    for (const uint32_t id : level.order) {
      const PooledNode& n = pool.nodes[id];
      out.nodeOffset[id] = out.bytes.size() - level.begin;
      const size_t headerAt = out.bytes.size();
      out.bytes.resize(headerAt + 2);
      uint32_t header = 0;
      for (unsigned c = 0, k = 0; c < 8; ++c) {
        uint32_t code = (n.codes >> (2 * c)) & 3u;
        if (code == uint32_t(ChildCode::Ref)) {
          const uint64_t value = valueOf(n, n.children[k++]);
          const unsigned width = unsigned(referenceBytes(value, level.widths));
          code = width == level.widths.shortBytes ? 2u : 3u;
          for (unsigned b = 0; b < width; ++b) out.bytes.push_back(uint8_t(value >> (8 * b)));
          level.references += 1;
        }
        header |= code << (2 * c);
      }
      out.bytes[headerAt] = uint8_t(header);
      out.bytes[headerAt + 1] = uint8_t(header >> 8);
    }
    level.bytes = out.bytes.size() - level.begin;
    out.levels.push_back(std::move(level));
  }
  return out;
}

// The library's laid-out pool in one array, as a file would map it: levels one after the other, then 3 zero
// bytes so that a reference is read with one 4-byte load.
struct ByteDag {
  std::vector<uint8_t> bytes;
  std::vector<uint64_t> leaves;
  // Per log2(edge) of a node: where its children's level starts (0 for leaf parents: leaf indices), its level's
  // widths, and where its own level starts.
  uint32_t childBase[kMaxDagLevels] = {};
  uint8_t shortBytes[kMaxDagLevels] = {}, longBytes[kMaxDagLevels] = {};
  uint32_t levelBegin[kMaxDagLevels] = {};
  std::vector<uint32_t> hot[kMaxDagLevels];  // a level's hot table (NodePool::layOut(true)), or empty
  LeafShape shape;

  ByteDag(const LaidOutPool& pool, LeafShape leafShape) : leaves(pool.leaves), shape(leafShape) {
    for (const PooledLevel& level : pool.levels) {
      const unsigned log2 = unsigned(std::countr_zero(level.edge));
      if (log2 >= kMaxDagLevels) continue;  // never: edges are powers of two up to 2^20
      levelBegin[log2] = uint32_t(bytes.size());
      if (log2 > 3) childBase[log2] = levelBegin[log2 - 1];
      shortBytes[log2] = level.widths.shortBytes;
      longBytes[log2] = level.widths.longBytes;
      hot[log2] = level.hot;
      bytes.insert(bytes.end(), level.bytes.begin(), level.bytes.end());
    }
    bytes.insert(bytes.end(), 3, 0);
  }
  uint64_t nodeBytes() const { return bytes.size() - 3; }
  uint64_t tableBytes() const {
    uint64_t n = 0;
    for (const auto& table : hot) n += 4 * table.size();
    return n;
  }
};

// One view of a ByteDag: the walk of DagView::shadowed over the byte form.
struct ByteDagView {
  const ByteDag* dag = nullptr;
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  uint32_t root = 0;  // the root node's first byte

  static ByteDagView of(const ByteDag& dag, const LaidOutPool::Root& r) {
    const unsigned log2 = unsigned(std::countr_zero(r.edge));
    return {&dag, r.edge, r.code, r.code == ChildCode::Ref ? dag.levelBegin[log2] + uint32_t(r.offset) : 0u};
  }

  // Child c's reference value (c must be a reference) of the node at byte `at` with this header, edge 2^log2.
  uint32_t readRef(uint32_t at, uint32_t header, unsigned c, unsigned log2) const {
    const uint32_t below = (1u << (2 * c)) - 1u;
    const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1);
    const uint32_t shortBytes = dag->shortBytes[log2], longBytes = dag->longBytes[log2];
    const uint32_t skip = shortBytes * popcount32(refs & below) + (longBytes - shortBytes) * popcount32(wide & below);
    uint32_t value;
    std::memcpy(&value, dag->bytes.data() + at + 2 + skip, 4);
    const uint32_t width = (wide >> (2 * c + 1)) & 1u ? longBytes : shortBytes;
    return width == 4 ? value : value & ((1u << (8 * width)) - 1u);
  }

  uint32_t headerAt(uint32_t at) const { return uint32_t(dag->bytes[at]) | uint32_t(dag->bytes[at + 1]) << 8; }
  // The child of the node at byte `at` (edge 2^log2), a reference: its first byte, or its leaf index (log2 3).
  uint32_t childAt(uint32_t at, uint32_t header, unsigned c, unsigned log2) const {
    const uint32_t ref = readRef(at, header, c, log2);
    const bool ranked = !dag->hot[log2].empty() && ((header >> (2 * c)) & 3u) == 2u;
    return dag->childBase[log2] + (ranked ? dag->hot[log2][ref] : ref);
  }
  // Down the octree levels to the leaf parent holding voxel (x, y, z): its byte in `at` and code 2, or the code
  // of the homogeneous node above it.
  uint32_t toLeafParent(uint32_t x, uint32_t y, uint32_t z, uint32_t& at) const {
    uint32_t code = uint32_t(rootCode);
    at = root;
    for (uint32_t half = resolution >> 1; half >= 8 && code == uint32_t(ChildCode::Ref); half >>= 1) {
      const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
      const uint32_t header = headerAt(at);
      code = childCodeOf(header, c);
      if (code == uint32_t(ChildCode::Ref)) at = childAt(at, header, c, unsigned(std::countr_zero(half)) + 1);
    }
    return code;
  }
  // A leaf parent's child c as a 64-bit mask: its leaf, or all ones / all zeros.
  uint64_t leafOf(uint32_t at, uint32_t header, unsigned c) const {
    const uint32_t code = childCodeOf(header, c);
    return code == uint32_t(ChildCode::Ref) ? dag->leaves[childAt(at, header, c, 3)] : 0 - uint64_t(code);
  }

  bool shadowed(uint32_t x, uint32_t y, uint32_t z) const {
    uint32_t at;
    const uint32_t code = toLeafParent(x, y, z, at);
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const uint32_t header = headerAt(at);
    if (dag->shape == LeafShape::Slices) return (leafOf(at, header, z & 7u) >> ((y & 7u) * 8u + (x & 7u))) & 1u;
    const unsigned c = (z & 4u) | ((y & 4u) >> 1) | ((x & 4u) >> 2);
    return (leafOf(at, header, c) >> ((z & 3u) * 16u + (y & 3u) * 4u + (x & 3u))) & 1u;
  }

  // The 8x8 mask (bit (y & 7) * 8 + (x & 7)) of the tile holding (x, y) at slice z, as a PCF footprint reads it:
  // one slice, or four octants' rows at that depth.
  uint64_t tileMask(uint32_t x, uint32_t y, uint32_t z) const {
    uint32_t at;
    const uint32_t code = toLeafParent(x, y, z, at);
    if (code != uint32_t(ChildCode::Ref)) return 0 - uint64_t(code == uint32_t(ChildCode::Shadowed));
    const uint32_t header = headerAt(at);
    if (dag->shape == LeafShape::Slices) return leafOf(at, header, z & 7u);
    // Octants c0 .. c0 + 3 (x half, y half = q & 1, q >> 1) at z's half: their references follow one another,
    // so the first one's place is counted once and each next one is a width further.
    const unsigned c0 = z & 4u;
    const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1), below = (1u << (2 * c0)) - 1u;
    const uint32_t shortBytes = dag->shortBytes[3], longBytes = dag->longBytes[3];
    uint32_t ref = at + 2 + shortBytes * popcount32(refs & below) + (longBytes - shortBytes) * popcount32(wide & below);
    uint64_t mask = 0;
    for (unsigned q = 0; q < 4; ++q) {
      const unsigned c = c0 + q;
      const uint32_t code = (header >> (2 * c)) & 3u;
      uint64_t octant = 0 - uint64_t(code == 1u);
      if (code >= 2u) {
        const uint32_t width = code == 3u ? longBytes : shortBytes;
        uint32_t value;
        std::memcpy(&value, dag->bytes.data() + ref, 4);
        value = width == 4 ? value : value & ((1u << (8 * width)) - 1u);
        octant = dag->leaves[value];
        ref += width;
      }
      // Its 4 rows at the slice (4 bits each) spread to the low nibbles of 4 bytes, then placed in the tile.
      const uint64_t rows = (octant >> ((z & 3u) * 16u)) & 0xFFFFu;
      const uint64_t spread = (rows & 0xFu) | ((rows & 0xF0u) << 4) | ((rows & 0xF00u) << 8) | ((rows & 0xF000u) << 12);
      mask |= spread << ((q >> 1) * 32 + (q & 1u) * 4);
    }
    return mask;
  }
};

}  // namespace cpvs::study
