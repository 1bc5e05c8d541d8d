// What one node pool shared by every view of a .cpvs would weigh: each distinct subtree (the same child codes
// over the same distinct children, at the same node size) and each distinct leaf mask stored once for the
// whole file instead of once per view. A study, not a format. Two estimates bracket what a format would get:
// each shared node keeps the unit count it has in its own view (header plus its 1- or 2-unit references: the
// optimistic one), or every reference is 2 units wide (a pool too large for 16-bit references anywhere: the
// pessimistic one).
//
//   shared_pool_estimate FILE.cpvs...      prints per file: bytes as stored, pooled (both), saving
#include <cstdio>
#include <map>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/base/error.h"

namespace {

using namespace cpvs;

struct NodeKey {
  uint32_t edge;
  uint32_t codes;                   // 2-bit child codes, references as 2
  std::vector<uint32_t> children;   // canonical ids of the referenced children
  bool operator<(const NodeKey& o) const {
    return std::tie(edge, codes, children) < std::tie(o.edge, o.codes, o.children);
  }
};

int run(const char* path) {
  const auto file = orThrow(CpvsFile::open(path));
  std::unordered_map<uint64_t, uint32_t> leafIds;
  std::map<NodeKey, uint32_t> nodeIds;
  uint64_t storedBytes = 0, pooledUnits = 0, pooledWideUnits = 0, views = 0;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) {
      ++views;
      const DagView& dag = v.dag;
      storedBytes += dag.nodes.size() * 2 + dag.leaves.size() * 8;
      std::vector<uint32_t> leafId(dag.leaves.size());
      for (size_t i = 0; i < dag.leaves.size(); ++i)
        leafId[i] = leafIds.emplace(dag.leaves[i], uint32_t(leafIds.size())).first->second;
      // Unit offsets of every node, level by level (root level first).
      const size_t levels = v.nodesPerLevel.size();
      std::vector<std::vector<uint32_t>> offsets(levels);
      uint32_t at = 0;
      for (size_t l = 0; l < levels; ++l)
        for (uint64_t k = 0; k < v.nodesPerLevel[l]; ++k) {
          offsets[l].push_back(at);
          at += nodeUnitCount(dag.nodes[at]);
        }
      // Canonical ids bottom-up: a node's children are in the next level (leaves below the last).
      std::unordered_map<uint32_t, uint32_t> below;  // unit offset (or leaf index) -> canonical id
      for (size_t l = levels; l-- > 0;) {
        const uint32_t edge = dag.resolution >> l;
        std::unordered_map<uint32_t, uint32_t> here;
        for (const uint32_t offset : offsets[l]) {
          const uint32_t header = dag.nodes[offset];
          NodeKey key{edge, 0, {}};
          for (unsigned c = 0; c < 8; ++c) {
            const uint32_t code = childCodeOf(header, c);
            key.codes |= code << (2 * c);
            if (code != uint32_t(ChildCode::Ref)) continue;
            const uint32_t target = dag.child(offset, header, c, edge);
            key.children.push_back(edge == 8 ? leafId.at(target) : below.at(target));
          }
          const auto [it, fresh] = nodeIds.emplace(std::move(key), uint32_t(nodeIds.size()));
          if (fresh) {
            pooledUnits += nodeUnitCount(header);
            pooledWideUnits += 1 + 2 * it->first.children.size();
          }
          here[offset] = it->second;
        }
        below = std::move(here);
      }
    }
  const uint64_t pooledBytes = pooledUnits * 2 + leafIds.size() * 8;
  const uint64_t pooledWideBytes = pooledWideUnits * 2 + leafIds.size() * 8;
  const auto saving = [&](uint64_t b) { return 100.0 * (1.0 - double(b) / double(storedBytes ? storedBytes : 1)); };
  std::printf("| %s | %llu | %llu | %llu / %llu | %.1f %% / %.1f %% |\n", path, (unsigned long long)views,
              (unsigned long long)storedBytes, (unsigned long long)pooledBytes,
              (unsigned long long)pooledWideBytes, saving(pooledBytes), saving(pooledWideBytes));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: shared_pool_estimate FILE.cpvs...\n");
    return 1;
  }
  std::printf("| file | views | DAG bytes as stored | one shared pool: own widths / all wide | saving |\n"
              "|---|---|---|---|---|\n");
  try {
    for (int i = 1; i < argc; ++i) run(argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shared_pool_estimate: %s\n", e.what());
    return 2;
  }
  return 0;
}
