#include "libcpvs/runtime/pool_validation.h"

#include <vector>

#include "libcpvs/runtime/byte_dag.h"

namespace cpvs {

namespace {

// Which bytes of a level start a node: one bit a byte.
struct NodeStarts {
  std::vector<uint64_t> bits;
  explicit NodeStarts(size_t bytes) : bits((bytes + 63) / 64, 0) {}
  void mark(uint64_t at) { bits[at / 64] |= uint64_t(1) << (at % 64); }
  bool has(uint64_t at) const { return at / 64 < bits.size() && ((bits[at / 64] >> (at % 64)) & 1u); }
};

Outcome invalid(const std::string& where, const std::string& what) {
  return Outcome(ErrorCategory::InvalidInput, where + ": " + what);
}

// Walks a level's nodes over its bytes, marking where each starts; they must cover the bytes exactly.
Outcome markNodes(const PoolLevelView& level, NodeStarts& starts, const std::string& where) {
  const std::string name = "pool level of edge " + std::to_string(level.edge);
  if (level.shortBytes < 1 || level.shortBytes > level.longBytes || level.longBytes > 4)
    return invalid(where, name + ": reference widths " + std::to_string(level.shortBytes) + "/" +
                              std::to_string(level.longBytes) + " (each 1 to 4, short at most long)");
  for (uint64_t at = 0; at < level.bytes.size();) {
    if (level.bytes.size() - at < 2) return invalid(where, name + ": a node header cut off at byte " + std::to_string(at));
    const uint32_t header = uint32_t(level.bytes[at]) | uint32_t(level.bytes[at + 1]) << 8;
    uint64_t size = 2;
    for (unsigned c = 0; c < 8; ++c) {
      const uint32_t code = (header >> (2 * c)) & 3u;
      size += code == 2 ? level.shortBytes : code == 3 ? level.longBytes : 0;
    }
    if (level.bytes.size() - at < size)
      return invalid(where, name + ": the node at byte " + std::to_string(at) + " runs past the level's end");
    starts.mark(at);
    at += size;
  }
  return {};
}

}  // namespace

Outcome validatePool(std::span<const PoolLevelView> levels, uint64_t leafCount, std::span<const PoolRootView> roots,
                     const std::string& where) {
  if (levels.size() > kMaxDagLevels) return invalid(where, "pool of " + std::to_string(levels.size()) + " levels");
  std::vector<NodeStarts> starts;
  starts.reserve(levels.size());
  for (size_t l = 0; l < levels.size(); ++l) {
    if (levels[l].edge != (8u << l))
      return invalid(where, "pool level " + std::to_string(l) + " has edge " + std::to_string(levels[l].edge) +
                                ", not " + std::to_string(8u << l) + " (levels run 8, 16, 32, ...)");
    starts.emplace_back(levels[l].bytes.size());
    if (Outcome o = markNodes(levels[l], starts.back(), where); !o) return o;
  }
  // Every reference points at a node start of the level below (a leaf below the leaf parents): no walk leaves
  // the buffers, and none can cycle, since every step goes one level down.
  for (size_t l = 0; l < levels.size(); ++l) {
    const PoolLevelView& level = levels[l];
    const std::string name = "pool level of edge " + std::to_string(level.edge);
    if (!level.hot.empty() && l == 0) return invalid(where, name + ": a hot table below which there are only leaves");
    if (level.hot.size() > (uint64_t(1) << (8 * level.shortBytes)))
      return invalid(where, name + ": a hot table of " + std::to_string(level.hot.size()) + " entries, more than its " +
                                std::to_string(level.shortBytes) + "-byte ranks reach");
    for (size_t r = 0; r < level.hot.size(); ++r)
      if (!starts[l - 1].has(level.hot[r]))
        return invalid(where, name + ": hot entry " + std::to_string(r) + " is not a node of the level below");
    for (uint64_t at = 0; at < level.bytes.size();) {
      const uint32_t header = uint32_t(level.bytes[at]) | uint32_t(level.bytes[at + 1]) << 8;
      uint64_t ref = at + 2;
      for (unsigned c = 0; c < 8; ++c) {
        const uint32_t code = (header >> (2 * c)) & 3u;
        if (code < 2) continue;
        const unsigned width = code == 2 ? level.shortBytes : level.longBytes;
        const uint64_t value = readLittleEndian(level.bytes.data() + ref, width);
        ref += width;
        const bool ranked = code == 2 && !level.hot.empty();
        const bool ok = l == 0 ? value < leafCount : ranked ? value < level.hot.size() : starts[l - 1].has(value);
        if (!ok)
          return invalid(where, name + ": the node at byte " + std::to_string(at) + ", child " + std::to_string(c) +
                                    ": reference " + std::to_string(value) +
                                    (l == 0 ? " is not below the leaf count " + std::to_string(leafCount)
                                            : ranked ? " is past the hot table" : " is not a node of the level below"));
      }
      at = ref;
    }
  }
  for (size_t v = 0; v < roots.size(); ++v) {
    const PoolRootView& root = roots[v];
    const std::string name = "view " + std::to_string(v) + "'s root";
    if (uint32_t(root.code) > uint32_t(ChildCode::Ref)) return invalid(where, name + ": code " + std::to_string(int(root.code)));
    if (root.code != ChildCode::Ref) continue;
    size_t l = 0;
    while (l < levels.size() && levels[l].edge != root.edge) ++l;
    if (l == levels.size())
      return invalid(where, name + ": no pool level of edge " + std::to_string(root.edge));
    if (!starts[l].has(root.offset))
      return invalid(where, name + ": byte " + std::to_string(root.offset) + " is not a node of the level of edge " +
                                std::to_string(root.edge));
  }
  return {};
}

}  // namespace cpvs
