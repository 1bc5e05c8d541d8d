#include "libcpvs/runtime/shadow_dag.h"

#include <algorithm>
#include <bit>
#include <string>

#include "libcpvs/runtime/popularity_order.h"

namespace cpvs {

uint32_t DagView::levels() const { return resolution >= 8 ? uint32_t(std::countr_zero(resolution)) - 2 : 0; }

void DagView::setLevelStarts(std::span<const uint64_t> levelStarts) {
  for (uint32_t& base : childBase) base = 0;
  const uint32_t count = levels();
  // Level l holds nodes of edge N >> l; its references count from the start of level l + 1.
  for (uint32_t l = 0; l + 1 < count && l + 1 < levelStarts.size(); ++l)
    childBase[std::countr_zero(resolution >> l)] = uint32_t(levelStarts[l + 1]);
}

DagView ShadowDag::view() const {
  DagView v{resolution, rootCode, nodes, leaves};
  v.setLevelStarts(levelOffsets);
  return v;
}

bool DagView::shadowed(uint32_t x, uint32_t y, uint32_t z) const {
  uint32_t code = uint32_t(rootCode);
  uint32_t offset = 0;
  for (uint32_t half = resolution >> 1; half >= 8; half >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = child(offset, header, c, half * 2);
  }
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const unsigned c = z & 7u;
  const uint32_t header = nodes[offset];
  code = childCodeOf(header, c);
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const uint64_t mask = leaves[child(offset, header, c, 8)];
  return (mask >> ((y & 7u) * 8u + (x & 7u))) & 1u;
}

Result<ShadowDag> encodeDag(uint32_t resolution, ChildCode rootCode, std::span<const std::span<const uint32_t>> levelWords,
                    std::span<const uint64_t> nodesPerLevel, std::vector<uint64_t> leaves, NodeOrder order) {
  ShadowDag dag;
  dag.resolution = resolution;
  dag.rootCode = rootCode;
  dag.nodesPerLevel.assign(nodesPerLevel.begin(), nodesPerLevel.end());
  const size_t levels = levelWords.size();
  const bool reorder = order == NodeOrder::MostReferencedFirst;

  // Leaves first: leaf parents' references are leaf indices.
  std::vector<uint32_t> leafIndex;  // new index by old, when reordered
  if (reorder && levels > 0) {
    std::vector<uint32_t> items(leaves.size());
    for (uint32_t i = 0; i < items.size(); ++i) items[i] = i;
    const std::vector<uint32_t> ordered = mostReferencedFirst(items, referenceCounts(levelWords[levels - 1], leaves.size()));
    leafIndex.resize(leaves.size());
    dag.leaves.resize(leaves.size());
    for (uint32_t i = 0; i < ordered.size(); ++i) {
      leafIndex[ordered[i]] = i;
      dag.leaves[i] = leaves[ordered[i]];
    }
  } else {
    dag.leaves = std::move(leaves);
  }

  // Bottom-up: a level's unit positions depend on its references' widths, hence on the positions below.
  std::vector<std::vector<uint16_t>> units(levels);
  std::vector<uint32_t> childPosition, position;  // by word offset in the child level / in this level
  for (size_t l = levels; l-- > 0;) {
    const std::span<const uint32_t> words = levelWords[l];
    const bool leafParent = l + 1 == levels;
    std::vector<uint32_t> nodeOrder;  // word offsets, in the order the nodes are stored
    for (size_t i = 0; i < words.size(); i += nodeWordCount(words[i])) nodeOrder.push_back(uint32_t(i));
    if (reorder && l > 0) nodeOrder = mostReferencedFirst(nodeOrder, referenceCounts(levelWords[l - 1], words.size()));
    std::vector<uint16_t>& out = units[l];
    position.assign(words.size(), 0);
    for (const uint32_t i : nodeOrder) {
      const uint32_t header = words[i];
      if (out.size() > UINT32_MAX)
        return Outcome(ErrorCategory::RuntimeFailure, "DAG level " + std::to_string(l) + " too large for 32-bit references");
      position[i] = uint32_t(out.size());
      const size_t headerAt = out.size();
      out.push_back(0);
      const auto targetOf = [&](unsigned k) {
        const uint32_t ref = words[i + 1 + k];
        return leafParent ? (reorder ? leafIndex[ref] : ref) : childPosition[ref];
      };
      out[headerAt] = uint16_t(storeNode(header, targetOf, [&](uint16_t unit) { out.push_back(unit); }));
    }
    childPosition.swap(position);
  }
  uint64_t total = 0;
  for (const auto& level : units) {
    dag.levelOffsets.push_back(total);
    total += level.size();
  }
  // Level starts and the file's unit count are 32-bit.
  if (total > UINT32_MAX)
    return Outcome(ErrorCategory::RuntimeFailure, "DAG of " + std::to_string(total) + " node units: too large for a .cpvs view");
  dag.nodes.reserve(total);
  for (const auto& level : units) dag.nodes.insert(dag.nodes.end(), level.begin(), level.end());
  return dag;
}

}  // namespace cpvs
