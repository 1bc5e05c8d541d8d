#pragma once
// A pool of DAG nodes laid out with two reference widths per level, in bytes: the coding format 3.0 adopted, as
// the format study weighed it (docs/format-3-study.md; the library's NodePool, libcpvs/dag/node_pool.h, is its
// implementation, and the runtime's ByteDagView, libcpvs/runtime/byte_dag.h, its walk). Kept for the smaller-DAG
// estimator (dag_transform_estimate.cpp), which weighs transformed DAGs in it. A study's tool, not a format.
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

// The pair of reference widths in bits (each at most maxBits) that codes a level's references most briefly, from
// how many need each bit count (needing[k]: references whose value has k significant bits): a short width for
// those that fit it, the long one for the rest. {0, 0} when none fits.
struct BitWidths {
  unsigned shortBits = 0, longBits = 0;
};
inline BitWidths fewestBits(const uint64_t (&needing)[65], unsigned maxBits) {
  BitWidths out;
  uint64_t fewest = std::numeric_limits<uint64_t>::max();
  for (unsigned sb = 1; sb <= maxBits; ++sb)
    for (unsigned lb = sb; lb <= maxBits; ++lb) {
      uint64_t total = 0;
      bool fits = true;
      for (unsigned k = 1; k <= 64; ++k) {
        if (!needing[k]) continue;
        fits = fits && k <= lb;
        total += needing[k] * (k <= sb ? sb : lb);
      }
      if (fits && total < fewest) fewest = total, out = {sb, lb};
    }
  return out;
}

struct PoolLevel {
  uint32_t edge = 0;
  std::vector<uint32_t> order;  // pooled node ids as laid out
  uint64_t references = 0, begin = 0, bytes = 0;  // begin: the level's first byte in ByteDag::bytes
  Widths widths;
};

// The study's layout of a pool: what the estimator weighs the other codings over. The library's NodePool
// (libcpvs/dag/node_pool.h) lays out the same bytes (the format study checked it); the walks read those.
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

}  // namespace cpvs::study
