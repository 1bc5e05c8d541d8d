#pragma once
// One pool of DAG nodes and leaf masks for many views: each distinct subtree (the same node edge, child codes
// and children) and each distinct leaf mask is kept once, whichever view it came from, and laid out with two
// reference widths per level, optionally with hot tables and octant leaves (docs/format-3-study.md: the
// candidates for a format 3.0; no file holds them yet).
//
// Laid-out form: one level per node edge (8, 16, ... the largest root's), ascending, each level's nodes most
// referenced first (popularity_order.h; a view's root counts as a reference). A node is a 16-bit header, 2 bits
// per child (0 lit, 1 shadowed, 2 short reference, 3 long reference; children in the order of shadow_dag.h),
// then its references in child order, little-endian, each in its level's short or long width (1 to 4 bytes).
// A reference is the child's byte offset in the level below; below a leaf parent (edge 8) it is the leaf's
// index (leaf shapes: byte_dag.h's LeafShape). Each level takes the pair of widths that makes it smallest (the
// first such pair in kWidthPairs).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "libcpvs/dag/leaf_parent_table.h"
#include "libcpvs/dag/leaf_table.h"
#include "libcpvs/dag/mapped_array.h"
#include "libcpvs/runtime/byte_dag.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

struct ReferenceWidths {
  uint8_t shortBytes = 0, longBytes = 0;
};
// The pairs a level may take, in the order ties are broken.
inline constexpr ReferenceWidths kWidthPairs[] = {{1, 1}, {2, 2}, {3, 3}, {4, 4}, {1, 2},
                                                   {1, 3}, {1, 4}, {2, 3}, {2, 4}, {3, 4}};

struct PooledLevel {
  uint32_t edge = 0;
  ReferenceWidths widths;
  uint64_t nodes = 0;
  std::vector<uint8_t> bytes;
  // With hot tables (a candidate still being measured): when not empty, a short reference is the child's rank
  // in the level below (most referenced first) and hot[rank] its byte offset; a long one is the byte offset.
  std::vector<uint32_t> hot;
};

struct LaidOutPool {
  std::vector<PooledLevel> levels;  // ascending edge, from 8 up to the largest root's
  std::vector<uint64_t> leaves;     // masks, most referenced first
  struct Root {
    ChildCode code = ChildCode::Lit;
    uint32_t edge = 0;    // the view's resolution
    uint64_t offset = 0;  // a reference: the root node's byte offset in the level of its edge
  };
  std::vector<Root> roots;  // one per view, in the order they were added
};

// The laid-out pool in one array, as a file would hold it (levels one after the other, ascending edge), with
// the runtime's view of each root (byte_dag.h). The views point into this object's arrays, which a move keeps
// in place (it cannot be copied).
struct PooledDags {
  std::vector<uint8_t> bytes;
  std::vector<uint64_t> leaves;
  std::vector<std::vector<uint32_t>> hot;  // by log2(edge)
  std::vector<ByteDagView> views;          // one per root
  PooledDags() = default;
  PooledDags(PooledDags&&) = default;
  PooledDags(const PooledDags&) = delete;
};
PooledDags concatenate(const LaidOutPool& pool, LeafShape shape);

// A pooled level's build form: the byte code of leaf_parent_table.h serves every level (a node's header, then its
// children's ids as differences, in varints).
using PooledLevelTable = LeafParentTable;

class NodePool {
public:
  // countViews: keep, per node, how many views reach it (nodesByViewsReaching; 4 bytes a node), for the studies.
  explicit NodePool(LeafShape shape = LeafShape::Slices, bool countViews = true)
      : shape_(shape), countViews_(countViews) {}

  // Adds one view's DAG in the stored form of format 2.0 (a validated file's, or encodeDag's) and returns its
  // index among the views. Only nodes reachable from the root are pooled.
  size_t add(const DagView& dag);
  // Lays the pool out. The same views added in the same order give the same bytes. With hotTables, a level
  // above the leaf parents may also code its short references as ranks (PooledLevel::hot) where that makes it
  // smaller, the table's 4 bytes an entry counted.
  LaidOutPool layOut(bool hotTables = false) const;
  // The same layout handed over as it is made, for a writer that streams it: the leaves first, then each level,
  // ascending edge, as soon as it is laid out; the roots last. Each level's build form is freed once the levels
  // above no longer need it, so the peak is the build form and one level rather than both forms whole. The same
  // bytes as layOut(hotTables). Consumes the pool: nothing is added or laid out after it.
  struct LayoutSink {
    std::function<void(std::vector<uint64_t>&& leaves)> leaves;
    std::function<void(PooledLevel&& level)> level;
    std::function<void(std::vector<LaidOutPool::Root>&& roots)> roots;
  };
  void layOutInto(bool hotTables, const LayoutSink& sink);
  // Frees the hash indexes (a fifth of the pool's memory, more while they grow) once no view is to come: add()
  // refuses views after it. layOut() needs only the nodes.
  void releaseIndexes();

  // What the build form holds now, in bytes: the nodes (the leaf parents' level apart), the hash indexes, the
  // node starts (a bit a byte and the ids before each block), the leaf masks and their index.
  struct BuildFormBytes {
    uint64_t nodes = 0, leafParents = 0, indexes = 0, starts = 0, leaves = 0, leafIndex = 0;
    uint64_t total() const { return nodes + leafParents + indexes + starts + leaves + leafIndex; }
  };
  BuildFormBytes buildFormBytes() const;

  uint64_t nodes() const;
  uint64_t leaves() const { return leaves_.leaves().size(); }
  size_t views() const { return roots_.size(); }
  // How widely the nodes are shared: entry k counts the nodes that 2^(k-1) + 1 to 2^k views reach (entry 0:
  // one view only, entry 1: two, entry 2: three or four, ...).
  std::vector<uint64_t> nodesByViewsReaching() const;

private:
  struct Root {
    ChildCode code;
    uint32_t log2Edge;
    uint32_t id;  // a reference: the root's id in its level
  };
  // levels_[log2(edge)]: the nodes of that edge in build form, byte-coded as leaf_parent_table.h codes leaf
  // parents (the header of codes 0..2, then each referenced child's id in the level below, or its leaf index
  // below a leaf parent, as varints of the difference to the one before: a node's new children were met one
  // after the other, so most differences take a byte). A node's id is its place in the order the level first
  // met it, which is the order of its bytes (the layout finds where each id's bytes start by one pass over the
  // level), so the layout keeps its arrays per node rather than per byte.
  std::vector<PooledLevelTable> levels_;
  std::vector<uint32_t> nodesIn_;  // per level
  std::vector<std::vector<uint32_t>> viewsReaching_;  // per level, by id
  // Which bytes start a node, per level, with the ids before each block of 512 bytes: a record met again gives
  // its id in constant time (its offset's rank), at 1 bit a byte.
  struct NodeStarts {
    // Mapped arrays: resident as far as written, where a vector grown a word at a time holds up to twice that.
    MappedArray<uint64_t> bits;
    MappedArray<uint32_t> idsBefore;  // per 512-byte block
    void append(uint32_t offset, uint32_t id);
    uint32_t idAt(uint32_t offset) const;
  };
  std::vector<NodeStarts> starts_;
  LeafTable leaves_;
  std::vector<Root> roots_;
  LeafShape shape_;
  bool countViews_ = true;
  bool consumed_ = false;
  // layOut's work; with `release`, each level's build form is freed once laid out and the next level counted.
  void layOutImpl(bool hotTables, const LayoutSink& sink, bool release) const;
  void internLevel(const DagView& dag, uint32_t log2, const std::vector<uint32_t>& units, std::vector<uint32_t>& memo);
  unsigned nodeWords(const DagView& dag, uint32_t unit, uint32_t log2, const std::vector<uint32_t>& memo,
                     uint32_t (&words)[9]);
  unsigned leafParentWords(const DagView& dag, uint32_t unit, uint32_t (&words)[9]);
  // The node's id in its level, given its build-form bytes; `hash` is PooledLevelTable::hashOf(bytes, length).
  uint32_t internNode(uint32_t log2, const uint8_t* bytes, unsigned length, uint64_t hash);
  bool indexesReleased_ = false;
};

}  // namespace cpvs
