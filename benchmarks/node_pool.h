#pragma once
// One node pool for a whole .cpvs, as the format study counted it (docs/format-3-study.md; the smaller-DAG
// estimator, dag_transform_estimate.cpp, pools transformed DAGs with it): every view's DAG pooled so that each
// distinct subtree (the same child codes over the same distinct children, at the same node size) and each
// distinct leaf mask is kept once per file. A study's tool, not a format.
#include <cstdint>
#include <map>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"

namespace cpvs::study {

// Where each node of a view's DAG starts (in units), level by level from the root.
inline std::vector<std::vector<uint32_t>> nodeOffsetsByLevel(const CpvsFile::View& v) {
  std::vector<std::vector<uint32_t>> offsets(v.nodesPerLevel.size());
  uint32_t at = 0;
  for (size_t l = 0; l < offsets.size(); ++l)
    for (uint64_t k = 0; k < v.nodesPerLevel[l]; ++k) {
      offsets[l].push_back(at);
      at += nodeUnitCount(v.dag.nodes[at]);
    }
  return offsets;
}

// A distinct subtree: the node's edge, its child codes (references as 2) and the pooled ids of its children
// (leaf ids for a leaf parent, node ids otherwise).
struct NodeKey {
  uint32_t edge;
  uint32_t codes;
  std::vector<uint32_t> children;
  bool operator<(const NodeKey& o) const {
    return std::tie(edge, codes, children) < std::tie(o.edge, o.codes, o.children);
  }
};

struct PooledNode {
  uint32_t edge;
  uint32_t ownUnits;                // header plus references as stored in the view that first had it
  uint32_t codes;                   // child codes, 2 bits each (references as 2)
  std::vector<uint32_t> children;   // pooled ids (leaves below edge 8)
};

// A view's root: its code and, when a reference, its pooled node.
struct PooledRoot {
  ChildCode code;
  uint32_t node;
  uint32_t resolution;
};

struct Pool {
  std::vector<PooledNode> nodes;
  std::vector<PooledRoot> roots;  // one per view, in the file's view order
  std::vector<uint64_t> leafMasks;  // by pooled leaf id
  uint64_t leaves = 0, referencedRoots = 0, views = 0, storedBytes = 0;
};

// Pools views one at a time: a builder per file pools the whole file, a builder per view pools nothing
// (a view's DAG is deduplicated already) but lists its nodes in the same form.
class PoolBuilder {
 public:
  void add(const CpvsFile::View& v) {
    ++pool_.views;
    const DagView& dag = v.dag;
    pool_.storedBytes += dag.nodes.size() * 2 + dag.leaves.size() * 8;
    if (dag.rootCode == ChildCode::Ref) ++pool_.referencedRoots;
    std::vector<uint32_t> leafId(dag.leaves.size());
    for (size_t i = 0; i < dag.leaves.size(); ++i) {
      const auto [it, fresh] = leafIds_.emplace(dag.leaves[i], uint32_t(leafIds_.size()));
      if (fresh) pool_.leafMasks.push_back(dag.leaves[i]);
      leafId[i] = it->second;
    }
    const size_t levels = v.nodesPerLevel.size();
    const std::vector<std::vector<uint32_t>> offsets = nodeOffsetsByLevel(v);
    std::unordered_map<uint32_t, uint32_t> below;  // unit offset (or leaf index) -> pooled id
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
        const auto [it, fresh] = nodeIds_.emplace(key, uint32_t(nodeIds_.size()));
        if (fresh) pool_.nodes.push_back({edge, nodeUnitCount(header), key.codes, key.children});
        here[offset] = it->second;
      }
      below = std::move(here);
    }
    pool_.roots.push_back({dag.rootCode, dag.rootCode == ChildCode::Ref ? below.at(0) : 0u, dag.resolution});
    pool_.leaves = leafIds_.size();
  }
  const Pool& pool() const { return pool_; }

 private:
  Pool pool_;
  std::unordered_map<uint64_t, uint32_t> leafIds_;
  std::map<NodeKey, uint32_t> nodeIds_;
};

}  // namespace cpvs::study
