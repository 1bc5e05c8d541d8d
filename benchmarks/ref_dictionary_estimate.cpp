// What one node pool for a whole .cpvs would weigh with references coded by popularity: a study for a format
// 3.0, not a format. Every view's DAG is pooled as shared_pool_estimate does it (each distinct subtree and leaf
// mask once per file); then each level's pooled nodes (and the leaves) are laid out most referenced first, and
// a reference is coded by where its child lies in that order. Four codings are weighed:
//
//   own widths   the pool with the 1- or 2-unit references each node has in its own view (shared_pool_estimate)
//   rank varint  a reference is the child's rank in its level as a LEB128 varint (1 byte below 128, 2 below
//                16,384, ...), plus a 4-byte rank -> byte offset index per node (nodes differ in length)
//   offset varint a reference is the child's byte offset in its level (popular nodes first, so small) as a
//                varint: no index, but offsets grow faster than ranks
//   node width   a reference is the child's byte offset (leaves: its index) in 1, 2, 3 or 4 bytes, the width
//                of the node's largest, told by 2 bits beside the 16-bit header (a 3-byte header): child k is
//                read directly, as the walks read a node today
//
// Roots are counted as one reference each (4 bytes) in every coding. Leaves weigh 8 bytes each in all of them.
//
//   ref_dictionary_estimate FILE.cpvs...      prints a markdown table row per file
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "benchmarks/node_pool.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using namespace cpvs::study;

unsigned varintBytes(uint64_t v) {
  unsigned n = 1;
  for (; v >= 0x80; v >>= 7) ++n;
  return n;
}

unsigned fixedBytes(uint64_t v) { return v < (1u << 8) ? 1 : v < (1u << 16) ? 2 : v < (1u << 24) ? 3 : 4; }

// Ranks by popularity within each level: rank[id] for nodes (per edge) and leafRank[id].
struct Ranks {
  std::vector<uint32_t> node, leaf;
  std::map<uint32_t, std::vector<uint32_t>> orderByEdge;  // edge -> node ids, most referenced first
};

Ranks rank(const Pool& pool) {
  std::vector<uint64_t> nodeRefs(pool.nodes.size(), 0), leafRefs(pool.leaves, 0);
  for (const PooledNode& n : pool.nodes)
    for (const uint32_t c : n.children) (n.edge == 8 ? leafRefs : nodeRefs)[c] += 1;
  Ranks r;
  r.node.assign(pool.nodes.size(), 0);
  r.leaf.assign(pool.leaves, 0);
  std::vector<uint32_t> leafOrder(pool.leaves);
  std::iota(leafOrder.begin(), leafOrder.end(), 0u);
  std::stable_sort(leafOrder.begin(), leafOrder.end(), [&](uint32_t a, uint32_t b) { return leafRefs[a] > leafRefs[b]; });
  for (uint32_t i = 0; i < leafOrder.size(); ++i) r.leaf[leafOrder[i]] = i;
  for (uint32_t id = 0; id < pool.nodes.size(); ++id) r.orderByEdge[pool.nodes[id].edge].push_back(id);
  for (auto& [edge, ids] : r.orderByEdge) {
    std::stable_sort(ids.begin(), ids.end(), [&](uint32_t a, uint32_t b) { return nodeRefs[a] > nodeRefs[b]; });
    for (uint32_t i = 0; i < ids.size(); ++i) r.node[ids[i]] = i;
  }
  return r;
}

struct Weights {
  uint64_t ownWidths = 0, rankVarint = 0, offsetVarint = 0, nodeWidth = 0;
};

Weights weigh(const Pool& pool, const Ranks& r) {
  Weights w;
  const uint64_t leafBytes = pool.leaves * 8, rootBytes = pool.referencedRoots * 4;
  w.ownWidths = leafBytes + rootBytes;
  w.rankVarint = leafBytes + rootBytes;
  for (const PooledNode& n : pool.nodes) {
    w.ownWidths += n.ownUnits * 2;
    w.rankVarint += 2 + 4;  // header, index entry
    for (const uint32_t c : n.children) w.rankVarint += varintBytes(n.edge == 8 ? r.leaf[c] : r.node[c]);
  }
  // Offsets depend on the sizes of the level below: lay out bottom-up (smallest edge first).
  for (const bool fixedWidth : {false, true}) {
    std::vector<uint64_t> offset(pool.nodes.size(), 0);
    uint64_t total = leafBytes + rootBytes;
    for (const auto& [edge, ids] : r.orderByEdge) {  // ascending edge: children are laid out before parents
      uint64_t at = 0;
      for (const uint32_t id : ids) {
        const PooledNode& n = pool.nodes[id];
        uint64_t bytes = 2;
        if (fixedWidth) {
          unsigned width = 1;
          for (const uint32_t c : n.children)
            width = std::max(width, fixedBytes(n.edge == 8 ? r.leaf[c] : offset[c]));
          bytes = 3 + uint64_t(width) * n.children.size();
        } else {
          for (const uint32_t c : n.children) bytes += varintBytes(n.edge == 8 ? r.leaf[c] : offset[c]);
        }
        offset[id] = at;
        at += bytes;
      }
      total += at;
    }
    (fixedWidth ? w.nodeWidth : w.offsetVarint) = total;
  }
  return w;
}

int run(const char* path) {
  const auto file = orThrow(CpvsFile::open(path));
  const Pool pool = poolOf(*file);
  const Weights w = weigh(pool, rank(pool));
  const auto mb = [](uint64_t b) { return double(b) / 1e6; };
  const auto saving = [&](uint64_t b) { return 100.0 * (1.0 - double(b) / double(pool.storedBytes ? pool.storedBytes : 1)); };
  std::printf("| %s | %llu | %.2f | %.2f | %llu | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) |\n",
              path, (unsigned long long)pool.views, mb(pool.storedBytes), mb(pool.leaves * 8),
              (unsigned long long)pool.nodes.size(), mb(w.ownWidths), saving(w.ownWidths),
              mb(w.rankVarint), saving(w.rankVarint), mb(w.offsetVarint), saving(w.offsetVarint), mb(w.nodeWidth),
              saving(w.nodeWidth));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: ref_dictionary_estimate FILE.cpvs...\n");
    return 1;
  }
  std::printf("| file | views | DAGs as stored, MB | pooled leaves, MB | pooled nodes | pool, own widths | "
              "rank varint + index | offset varint | node width (1-4 B) |\n|---|---|---|---|---|---|---|---|---|\n");
  try {
    for (int i = 1; i < argc; ++i) run(argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ref_dictionary_estimate: %s\n", e.what());
    return 2;
  }
  return 0;
}
