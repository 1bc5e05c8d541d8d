// How much smaller a .cpvs's DAG would be if subtrees equal up to a shift along the light or an x/y mirror were
// stored once: the estimator that decides whether smaller DAGs by transformed merging are worth a format
// (docs/smaller-dags.md). A study's tool, not a format.
//
// The file's views are read into one table of subtrees (the content DAG, pooled over views as format 3.0 pools
// them). Each subtree is then canonicalised under a group of transforms, bottom-up, and the distinct canonical
// subtrees are counted and weighed. A reference then names a canonical subtree and the transform that turns it
// into the child: (target, g, k), meaning child(x, y, z) = target(g(x, y), max(z - k, 0)).
//
//  * Shifts along the light (z, away from it). In light space a column is lit, then shadowed behind its first
//    caster, so a silhouette at another depth gives a subtree whose slices are the same after a shift. A subtree
//    whose first r slices are equal is stored shifted towards the light by k = r - 1 slices (rounded down to the
//    granularity), its last slice repeated below: the child reads slice max(z - k, 0) of it. Granularities:
//    slices (k any, log2(edge) bits a reference), leaf parents (k a multiple of 8), children (k 0 or edge / 2,
//    one bit: the shifted subtree's children are subtrees of the original DAG). Shifting by the leading run is
//    one canonical form among several (the trailing run, or a shift that gives up voxels clamped out of the node,
//    could merge more), so the counts are what this form reaches, not the most any shift could.
//  * Mirrors and the swap: the eight maps of the square (x and y mirrors, x<->y swap), 3 bits a reference; a
//    subtree is stored as the least of its eight images (the leaves: the least 64-bit mask). A z mirror is left
//    out: it turns lit-then-shadowed around.
//  * Both: the shift first (it commutes with the mirrors).
//
// Weighed as format 3.0 weighs a level (benchmarks/level_widths.h, without hot tables): a 16-bit header, then
// each reference as its child's byte offset in the child level shifted left by the level's transform bits
// (the bits its largest transform code needs) plus the transform, in the level's best pair of widths; the
// order-0 bound codes each header and each (target, transform) by its frequency in its level. Leaves 8 bytes.
// Every canonical DAG is checked against the file: random voxels reaching leaves (and every voxel of views of
// at most 256^3), looked up through both, must agree (exit 3 otherwise).
//
//   dag_transform_estimate [--levels] [--check N] [--groups LIST] FILE.cpvs...
//     a markdown row per file and group. LIST: comma-separated, first "none" (the base), then any of
//     in-leaf-parents (shifts by slices inside leaf parents only), half (by half the edge), by8 (by 8 slices),
//     slices (by slices at every edge), mirrors (every level), leaf-mirrors (the leaves only), and each shift with
//     "+mirrors" or "+leaf-mirrors". --check: voxels (200,000).
#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "benchmarks/level_widths.h"
#include "benchmarks/node_pool.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;

// A child or slice: 0 lit, 1 shadowed, else 2 + an index into its level's table (a leaf's index below leaf
// parents and in the slices of edge 8).
using Code = uint32_t;
constexpr Code kLit = 0, kShadowed = 1;
constexpr unsigned kLeafParentLog = 3;  // edge 8
constexpr unsigned kMaxLog = 24;

bool uniform(Code c) { return c < 2; }
uint32_t indexOf(Code c) { return c - 2; }

template <size_t n>
struct ArrayHash {
  size_t operator()(const std::array<uint32_t, n>& a) const {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (const uint32_t v : a) h = (h ^ v) * 0xBF58476D1CE4E5B9ull, h ^= h >> 29;
    return size_t(h);
  }
};
struct KeyHash {
  size_t operator()(const std::array<uint64_t, 3>& k) const {
    return ArrayHash<6>()({uint32_t(k[0]), uint32_t(k[0] >> 32), uint32_t(k[1]), uint32_t(k[1] >> 32),
                           uint32_t(k[2]), uint32_t(k[2] >> 32)});
  }
};

template <size_t n>
class Interned {
 public:
  // 2 + the index of `a` (new or old), or the uniform code when every entry is the same uniform code.
  Code intern(const std::array<uint32_t, n>& a, bool* fresh = nullptr) {
    if (uniform(a[0]) && std::all_of(a.begin(), a.end(), [&](uint32_t v) { return v == a[0]; })) return a[0];
    const auto [it, added] = ids_.emplace(a, uint32_t(items.size()));
    if (added) items.push_back(a);
    if (fresh) *fresh = added;
    return 2 + it->second;
  }
  std::vector<std::array<uint32_t, n>> items;

 private:
  std::unordered_map<std::array<uint32_t, n>, uint32_t, ArrayHash<n>> ids_;
};

// The eight maps of the square: bit 0 mirrors x, bit 1 mirrors y, bit 2 swaps x and y (applied first).
struct Square {
  static void apply(unsigned g, uint32_t edge, uint32_t& x, uint32_t& y) {
    if (g & 4) std::swap(x, y);
    if (g & 1) x = edge - 1 - x;
    if (g & 2) y = edge - 1 - y;
  }
  unsigned compose[8][8];  // compose[a][b]: apply b, then a
  unsigned inverse[8];
  unsigned quadrant[8][4];  // where quadrant q (bit 0 x, bit 1 y) goes under g
  Square() {
    const auto corners = [](unsigned g) {
      unsigned image = 0;
      for (unsigned q = 0; q < 4; ++q) {
        uint32_t x = q & 1, y = q >> 1;
        apply(g, 2, x, y);
        image |= (x | y << 1) << (2 * q);
      }
      return image;
    };
    for (unsigned a = 0; a < 8; ++a)
      for (unsigned q = 0; q < 4; ++q) quadrant[a][q] = (corners(a) >> (2 * q)) & 3;
    for (unsigned a = 0; a < 8; ++a)
      for (unsigned b = 0; b < 8; ++b) {
        unsigned image = 0;
        for (unsigned q = 0; q < 4; ++q) image |= quadrant[a][quadrant[b][q]] << (2 * q);
        for (unsigned c = 0; c < 8; ++c)
          if (corners(c) == image) compose[a][b] = c;
      }
    for (unsigned a = 0; a < 8; ++a)
      for (unsigned b = 0; b < 8; ++b)
        if (compose[a][b] == 0) inverse[a] = b;
  }
  static uint64_t leaf(unsigned g, uint64_t mask) {  // (g M)(x, y) = M(g(x, y))
    uint64_t out = 0;
    for (uint32_t y = 0; y < 8; ++y)
      for (uint32_t x = 0; x < 8; ++x) {
        uint32_t sx = x, sy = y;
        apply(g, 8, sx, sy);
        out |= ((mask >> (sy * 8 + sx)) & 1u) << (y * 8 + x);
      }
    return out;
  }
};
const Square kSquare;

// The file's subtrees and the shifted ones the canonical forms need, pooled over views. Per node: its children,
// its first and last slice (2D subtrees: quadrants at edge / 2, leaf masks at edge 8) and how many of its first
// slices are equal.
class ContentDag {
 public:
  struct Attributes {
    Code first, last;
    uint32_t leadRun;
  };

  Code leaf(uint64_t mask) {
    if (mask == 0) return kLit;
    if (mask == ~uint64_t(0)) return kShadowed;
    const auto [it, fresh] = leafIds_.emplace(mask, uint32_t(leaves.size()));
    if (fresh) leaves.push_back(mask);
    return 2 + it->second;
  }

  Code node(unsigned lg, const std::array<Code, 8>& children) {
    bool fresh = false;
    const Code code = nodes_[lg].intern(children, &fresh);
    if (!fresh) return code;
    Attributes a;
    if (lg == kLeafParentLog) {
      a.first = children[0];
      a.last = children[7];
      a.leadRun = 1;
      while (a.leadRun < 8 && children[a.leadRun] == children[0]) ++a.leadRun;
    } else {
      const uint32_t half = 1u << (lg - 1);
      std::array<Code, 4> first, last;
      a.leadRun = 2 * half;
      for (unsigned q = 0; q < 4; ++q) {
        const Attributes lo = attributes(lg - 1, children[q]), hi = attributes(lg - 1, children[q + 4]);
        first[q] = lo.first;
        last[q] = hi.last;
        const uint32_t run = lo.leadRun == half && hi.first == lo.first ? half + hi.leadRun : lo.leadRun;
        a.leadRun = std::min(a.leadRun, run);
      }
      a.first = slices_[lg - 1].intern(first);
      a.last = slices_[lg - 1].intern(last);
    }
    attributes_[lg].push_back(a);
    return code;
  }

  Attributes attributes(unsigned lg, Code c) const {
    if (uniform(c)) return {c, c, 1u << lg};
    return attributes_[lg][indexOf(c)];
  }
  std::array<Code, 8> children(unsigned lg, Code c) const {
    if (uniform(c)) return {c, c, c, c, c, c, c, c};
    return nodes_[lg].items[indexOf(c)];
  }
  size_t nodeCount(unsigned lg) const { return nodes_[lg].items.size(); }

  // The subtree whose every z slice is `slice` (a 2D subtree of this edge).
  Code repeated(unsigned lg, Code slice) {
    if (uniform(slice)) return slice;
    const std::array<uint64_t, 3> key{lg, slice, 0};
    if (const auto it = repeated_.find(key); it != repeated_.end()) return it->second;
    std::array<Code, 8> children;
    if (lg == kLeafParentLog) {
      children.fill(slice);
    } else {
      const std::array<Code, 4> quadrants = slices_[lg - 1].items[indexOf(slice)];
      for (unsigned c = 0; c < 8; ++c) children[c] = repeated(lg - 1, quadrants[c & 3]);
    }
    return repeated_[key] = node(lg, children);
  }

  // Slices k .. edge - 1 of `upper` followed by slices 0 .. k - 1 of `lower` (both of this edge).
  Code window(unsigned lg, Code upper, Code lower, uint32_t k) {
    if (k == 0 || (uniform(upper) && upper == lower)) return upper;
    const std::array<uint64_t, 3> key{(uint64_t(upper) << 8) | lg, lower, k};
    if (const auto it = windows_.find(key); it != windows_.end()) return it->second;
    const std::array<Code, 8> a = children(lg, upper), b = children(lg, lower);
    std::array<Code, 8> out;
    if (lg == kLeafParentLog) {
      for (unsigned z = 0; z < 8; ++z) out[z] = z + k < 8 ? a[z + k] : b[z + k - 8];
    } else {
      const uint32_t half = 1u << (lg - 1), skip = k / half, within = k % half;
      for (unsigned q = 0; q < 4; ++q) {
        const Code column[4] = {a[q], a[q + 4], b[q], b[q + 4]};
        out[q] = window(lg - 1, column[skip], column[skip + 1], within);
        out[q + 4] = window(lg - 1, column[skip + 1], column[skip + 2], within);
      }
    }
    return windows_[key] = node(lg, out);
  }

  std::vector<uint64_t> leaves;

 private:
  Interned<8> nodes_[kMaxLog + 1];
  Interned<4> slices_[kMaxLog + 1];
  std::vector<Attributes> attributes_[kMaxLog + 1];
  std::unordered_map<uint64_t, uint32_t> leafIds_;
  std::unordered_map<std::array<uint64_t, 3>, Code, KeyHash> repeated_, windows_;
};

struct ViewRoot {
  unsigned lg;
  Code content;
};

// Reads every view's DAG into the content DAG, level by level from the leaf parents up.
std::vector<ViewRoot> readViews(const CpvsFile& file, ContentDag& content) {
  std::vector<ViewRoot> roots;
  for (const CpvsFile::LightEntry& light : file.lights())
    for (const CpvsFile::View& v : light.views) {
      const DagView& dag = v.dag;
      const unsigned rootLog = unsigned(std::countr_zero(dag.resolution));
      if (dag.rootCode != ChildCode::Ref) {
        roots.push_back({rootLog, dag.rootCode == ChildCode::Shadowed ? kShadowed : kLit});
        continue;
      }
      std::vector<Code> leafCode(dag.leaves.size());
      for (size_t i = 0; i < dag.leaves.size(); ++i) leafCode[i] = content.leaf(dag.leaves[i]);
      const size_t levels = v.nodesPerLevel.size();
      const std::vector<std::vector<uint32_t>> offsets = study::nodeOffsetsByLevel(v);
      std::unordered_map<uint32_t, Code> below;
      for (size_t l = levels; l-- > 0;) {
        const uint32_t edge = dag.resolution >> l;
        const unsigned lg = unsigned(std::countr_zero(edge));
        std::unordered_map<uint32_t, Code> here;
        for (const uint32_t offset : offsets[l]) {
          const uint32_t header = dag.nodes[offset];
          std::array<Code, 8> children;
          for (unsigned c = 0; c < 8; ++c) {
            const uint32_t code = childCodeOf(header, c);
            if (code != uint32_t(ChildCode::Ref)) {
              children[c] = code == uint32_t(ChildCode::Shadowed) ? kShadowed : kLit;
              continue;
            }
            const uint32_t target = dag.child(offset, header, c, edge);
            children[c] = edge == 8 ? leafCode.at(target) : below.at(target);
          }
          here[offset] = content.node(lg, children);
        }
        below = std::move(here);
      }
      roots.push_back({rootLog, below.at(0)});
    }
  return roots;
}

enum class Mirrors { None, Leaves, All };
const char* nameOf(Mirrors m) { return m == Mirrors::None ? "no" : m == Mirrors::Leaves ? "leaves only" : "x, y, swap"; }

enum class ShiftStep { None, InLeafParents, Children, LeafParents, Slices };
const char* nameOf(ShiftStep s) {
  switch (s) {
    case ShiftStep::None: return "none";
    case ShiftStep::InLeafParents: return "slices, in leaf parents only";
    case ShiftStep::Children: return "half the edge";
    case ShiftStep::LeafParents: return "8 slices";
    case ShiftStep::Slices: return "slices";
  }
  return "?";
}

// The shift's unit at a subtree of this edge (0: not shifted there).
uint32_t shiftUnit(ShiftStep step, uint32_t edge) {
  switch (step) {
    case ShiftStep::None: return 0;
    case ShiftStep::InLeafParents: return edge == 8 ? 1 : 0;
    case ShiftStep::Children: return edge / 2;
    case ShiftStep::LeafParents: return edge > 8 ? 8 : 0;
    case ShiftStep::Slices: return 1;
  }
  return 0;
}

struct Ref {
  Code target;  // 0 lit, 1 shadowed, 2 + canonical id (a canonical leaf's below leaf parents)
  uint32_t g;   // map of the square
  uint32_t k;   // shift in slices
  bool operator<(const Ref& o) const {
    return std::tie(target, g, k) < std::tie(o.target, o.g, o.k);
  }
  bool operator==(const Ref& o) const = default;
};

// The DAG of canonical subtrees under one group, built on demand from the content DAG's roots.
class CanonicalDag {
 public:
  CanonicalDag(ContentDag& content, ShiftStep step, Mirrors mirrors) : content_(content), step_(step), mirrors_(mirrors) {}

  Ref of(unsigned lg, Code c) {
    if (uniform(c)) return {c, 0, 0};
    if (const auto it = memo_[lg].find(c); it != memo_[lg].end()) return it->second;
    const ContentDag::Attributes a = content_.attributes(lg, c);
    const uint32_t edge = 1u << lg;
    const uint32_t unit = shiftUnit(step_, edge);
    uint32_t k = 0;
    if (unit && a.leadRun < edge) k = (a.leadRun - 1) / unit * unit;
    const Code shifted = k ? content_.window(lg, c, content_.repeated(lg, a.last), k) : c;
    const std::array<Code, 8> children = content_.children(lg, shifted);
    std::array<Ref, 8> refs;
    for (unsigned i = 0; i < 8; ++i) refs[i] = lg == kLeafParentLog ? leafRef(children[i]) : of(lg - 1, children[i]);
    // The least image under the square's maps (the identity alone without mirrors).
    std::array<Ref, 8> best = refs;
    unsigned bestG = 0;
    for (unsigned g = 1; mirrors_ == Mirrors::All && g < 8; ++g) {
      std::array<Ref, 8> image;
      for (unsigned i = 0; i < 8; ++i) {
        // (g B) at child i reads B at child g(i) through g.
        const unsigned from = lg == kLeafParentLog ? i : (i & 4) | kSquare.quadrant[g][i & 3];
        const Ref r = refs[from];
        image[i] = uniform(r.target) ? r : Ref{r.target, kSquare.compose[r.g][g], r.k};
      }
      if (std::lexicographical_compare(image.begin(), image.end(), best.begin(), best.end())) best = image, bestG = g;
    }
    const auto [it, fresh] = ids_[lg].emplace(best, uint32_t(nodes[lg].size()));
    if (fresh) nodes[lg].push_back(best);
    const Ref out{2 + it->second, kSquare.inverse[bestG], k};
    memo_[lg].emplace(c, out);
    return out;
  }

  Ref leafRef(Code c) {
    if (uniform(c)) return {c, 0, 0};
    const uint64_t mask = content_.leaves[indexOf(c)];
    uint64_t best = mask;
    unsigned bestG = 0;
    for (unsigned g = 1; mirrors_ != Mirrors::None && g < 8; ++g) {
      const uint64_t image = Square::leaf(g, mask);
      if (image < best) best = image, bestG = g;
    }
    const auto [it, fresh] = leafIds_.emplace(best, uint32_t(leaves.size()));
    if (fresh) leaves.push_back(best);
    return {2 + it->second, kSquare.inverse[bestG], 0};
  }

  // Voxel (x, y, z) of a subtree of edge 2^lg reached through `r`: true when shadowed.
  bool shadowed(Ref r, unsigned lg, uint32_t x, uint32_t y, uint32_t z) const {
    for (;;) {
      if (uniform(r.target)) return r.target == kShadowed;
      const uint32_t edge = 1u << lg;
      Square::apply(r.g, edge, x, y);
      z = z >= r.k ? z - r.k : 0;
      const std::array<Ref, 8>& n = nodes[lg][indexOf(r.target)];
      if (lg == kLeafParentLog) {
        const Ref leaf = n[z];
        if (uniform(leaf.target)) return leaf.target == kShadowed;
        Square::apply(leaf.g, 8, x, y);
        return (leaves[indexOf(leaf.target)] >> (y * 8 + x)) & 1u;
      }
      const uint32_t half = edge / 2;
      r = n[(z & half ? 4 : 0) | (y & half ? 2 : 0) | (x & half ? 1 : 0)];
      x &= half - 1, y &= half - 1, z &= half - 1;
      --lg;
    }
  }

  std::vector<std::array<Ref, 8>> nodes[kMaxLog + 1];
  std::vector<uint64_t> leaves;

 private:
  ContentDag& content_;
  ShiftStep step_;
  Mirrors mirrors_;
  std::unordered_map<Code, Ref> memo_[kMaxLog + 1];
  struct RefsHash {
    size_t operator()(const std::array<Ref, 8>& refs) const {
      std::array<uint32_t, 24> words;
      for (unsigned i = 0; i < 8; ++i) words[3 * i] = refs[i].target, words[3 * i + 1] = refs[i].g, words[3 * i + 2] = refs[i].k;
      return ArrayHash<24>()(words);
    }
  };
  std::unordered_map<std::array<Ref, 8>, uint32_t, RefsHash> ids_[kMaxLog + 1];
  std::unordered_map<uint64_t, uint32_t> leafIds_;
};

struct LevelWeight {
  uint32_t edge = 0;
  uint64_t nodes = 0, references = 0, bytes = 0, bitBytes = 0;
  unsigned transformBits = 0, shortBits = 0, longBits = 0;
  study::Widths widths{0, 0};
  double boundBits = 0;
};

struct Weight {
  uint64_t nodes = 0, references = 0, leaves = 0, bytes = 0, bitBytes = 0;
  double boundBytes = 0;
  std::vector<LevelWeight> levels;
};

// Format 3.0's pairs of widths, and 5-byte long references for levels whose transform bits push offsets past 32.
constexpr study::Widths kPairs[] = {{1, 1}, {2, 2}, {3, 3}, {4, 4}, {1, 2}, {1, 3}, {1, 4}, {2, 3}, {2, 4}, {3, 4},
                                    {2, 5}, {3, 5}, {4, 5}, {5, 5}};

// Lays the canonical DAG out as format 3.0 lays out a level (most referenced first, the best pair of widths) with
// each reference's transform in its low bits; again with the pair of widths in bits (1-40, a node's references
// packed and the node rounded up to whole bytes, the study's "bit widths": still read directly, where transform
// bits do not round a reference up to the next byte); and takes the order-0 bound.
Weight weigh(const CanonicalDag& dag, const std::vector<std::pair<unsigned, Ref>>& roots, ShiftStep step, Mirrors m) {
  Weight w;
  w.leaves = dag.leaves.size();
  w.bytes = w.bitBytes = w.leaves * 8;
  w.boundBytes = double(w.bytes);
  std::vector<uint64_t> leafRefs(dag.leaves.size(), 0);
  std::vector<uint64_t> offsetBelow;  // the level below's byte offsets (leaves: their index)
  // Leaves are laid out most referenced first: their index is their rank.
  for (const auto& n : dag.nodes[kLeafParentLog])
    for (const Ref& r : n)
      if (!uniform(r.target)) leafRefs[indexOf(r.target)] += 1;
  {
    std::vector<uint32_t> ids(dag.leaves.size());
    for (uint32_t i = 0; i < ids.size(); ++i) ids[i] = i;
    ids = study::popularityOrder(ids, leafRefs);
    offsetBelow.assign(ids.size(), 0);
    for (uint32_t i = 0; i < ids.size(); ++i) offsetBelow[ids[i]] = i;
  }
  std::vector<uint64_t> bitOffsetBelow = offsetBelow;  // the same in the bit-width layout
  // A level's references carry the square's map when mirrors apply to their children (below leaf parents for
  // mirrored leaves), then the shift in its unit.
  const auto transformCode = [&](const Ref& r, unsigned lg, uint32_t childEdge) -> uint64_t {
    const bool mirrored = m == Mirrors::All || (m == Mirrors::Leaves && lg == kLeafParentLog);
    return (mirrored ? r.g : 0) | (uint64_t(r.k / std::max(shiftUnit(step, childEdge), 1u)) << (mirrored ? 3 : 0));
  };
  for (unsigned lg = kLeafParentLog; lg <= kMaxLog; ++lg) {
    const auto& level = dag.nodes[lg];
    if (level.empty()) continue;
    const uint32_t edge = 1u << lg, childEdge = edge / 2;
    // Popularity: references from the level above, and a view's root counts as one (as NodePool counts it).
    std::vector<uint64_t> refs(level.size(), 0);
    if (lg < kMaxLog)
      for (const auto& n : dag.nodes[lg + 1])
        for (const Ref& r : n)
          if (!uniform(r.target)) refs[indexOf(r.target)] += 1;
    for (const auto& [rootLog, r] : roots)
      if (rootLog == lg && !uniform(r.target)) refs[indexOf(r.target)] += 1;
    LevelWeight lw;
    lw.edge = edge;
    lw.nodes = level.size();
    uint64_t maxCode = 0;
    std::map<uint32_t, uint64_t> headers;
    std::map<Ref, uint64_t> symbols;
    for (const auto& n : level) {
      uint32_t header = 0;
      for (unsigned c = 0; c < 8; ++c) {
        header |= (uniform(n[c].target) ? n[c].target : 2u) << (2 * c);
        if (uniform(n[c].target)) continue;
        ++lw.references;
        maxCode = std::max(maxCode, transformCode(n[c], lg, childEdge));
        symbols[n[c]] += 1;
      }
      headers[header] += 1;
    }
    lw.transformBits = unsigned(std::bit_width(maxCode));
    std::vector<uint32_t> ids(level.size());
    for (uint32_t i = 0; i < ids.size(); ++i) ids[i] = i;
    const std::vector<uint32_t> order = study::popularityOrder(ids, refs);
    const auto valueOf = [&](const Ref& r) {
      return (offsetBelow[indexOf(r.target)] << lw.transformBits) | transformCode(r, lg, childEdge);
    };
    uint64_t best = std::numeric_limits<uint64_t>::max();
    for (const study::Widths pair : kPairs) {
      uint64_t bytes = 0;
      for (const uint32_t id : order) {
        bytes += 2;
        for (const Ref& r : level[id])
          if (!uniform(r.target)) bytes += study::referenceBytes(valueOf(r), pair);
      }
      if (bytes < best) best = bytes, lw.widths = pair;
    }
    lw.bytes = best;
    std::vector<uint64_t> offsets(level.size(), 0);
    uint64_t at = 0;
    for (const uint32_t id : order) {
      offsets[id] = at;
      at += 2;
      for (const Ref& r : level[id])
        if (!uniform(r.target)) at += study::referenceBytes(valueOf(r), lw.widths);
    }
    // Bit widths: the pair chosen from the references' bit counts, then laid out exactly.
    const auto bitValueOf = [&](const Ref& r) {
      return (bitOffsetBelow[indexOf(r.target)] << lw.transformBits) | transformCode(r, lg, childEdge);
    };
    uint64_t needing[65] = {};
    for (const auto& n : level)
      for (const Ref& r : n)
        if (!uniform(r.target)) needing[std::max(1, int(std::bit_width(bitValueOf(r))))] += 1;
    const study::BitWidths pair = study::fewestBits(needing, 40);
    lw.shortBits = pair.shortBits;
    lw.longBits = pair.longBits;
    std::vector<uint64_t> bitOffsets(level.size(), 0);
    uint64_t bitAt = 0;
    for (const uint32_t id : order) {
      bitOffsets[id] = bitAt;
      uint64_t bits = 0;
      for (const Ref& r : level[id])
        if (!uniform(r.target)) bits += std::bit_width(bitValueOf(r)) <= lw.shortBits ? lw.shortBits : lw.longBits;
      bitAt += 2 + (bits + 7) / 8;
    }
    lw.bitBytes = bitAt;
    bitOffsetBelow = std::move(bitOffsets);
    for (const auto& [h, n] : headers) lw.boundBits += double(n) * std::log2(double(lw.nodes) / double(n));
    for (const auto& [s, n] : symbols) lw.boundBits += double(n) * std::log2(double(lw.references) / double(n));
    offsetBelow = std::move(offsets);
    w.nodes += lw.nodes;
    w.references += lw.references;
    w.bytes += lw.bytes;
    w.bitBytes += lw.bitBytes;
    w.boundBytes += lw.boundBits / 8;
    w.levels.push_back(lw);
  }
  return w;
}

// Voxels whose walk reaches a leaf in the file's own DAG (a random path through referenced children).
std::vector<std::array<uint32_t, 4>> deepVoxels(const CpvsFile& file, size_t count, uint64_t seed) {
  std::vector<std::array<uint32_t, 4>> out;  // view index, x, y, z
  std::vector<const DagView*> views;
  for (const CpvsFile::LightEntry& light : file.lights())
    for (const CpvsFile::View& v : light.views) views.push_back(&v.dag);
  std::mt19937_64 rng(seed);
  for (size_t i = 0; i < count && !views.empty(); ++i) {
    const uint32_t vi = uint32_t(rng() % views.size());
    const DagView& dag = *views[vi];
    uint32_t x = 0, y = 0, z = 0;
    if (dag.rootCode == ChildCode::Ref) {
      uint32_t offset = 0;
      for (uint32_t edge = dag.resolution; edge >= 8; edge /= 2) {
        const uint32_t header = dag.nodes[offset];
        unsigned refs[8], n = 0;
        for (unsigned c = 0; c < 8; ++c)
          if (childCodeOf(header, c) == uint32_t(ChildCode::Ref)) refs[n++] = c;
        const unsigned c = n ? refs[rng() % n] : unsigned(rng() % 8);
        if (edge == 8) {
          z += c;
          x += uint32_t(rng() % 8), y += uint32_t(rng() % 8);
          break;
        }
        const uint32_t half = edge / 2;
        x += (c & 1) ? half : 0, y += (c & 2) ? half : 0, z += (c & 4) ? half : 0;
        if (!n) {
          x += uint32_t(rng() % half), y += uint32_t(rng() % half), z += uint32_t(rng() % half);
          break;
        }
        offset = dag.child(offset, header, c, edge);
      }
    } else {
      x = uint32_t(rng() % dag.resolution), y = uint32_t(rng() % dag.resolution), z = uint32_t(rng() % dag.resolution);
    }
    out.push_back({vi, x, y, z});
  }
  return out;
}

double mb(double b) { return b / 1e6; }

struct Group {
  ShiftStep step;
  Mirrors mirrors;
};

// "none", "half", "by8", "slices", "in-leaf-parents", each optionally with "+mirrors"; "mirrors" is none+mirrors.
std::vector<Group> parseGroups(const std::string& list) {
  std::vector<Group> out;
  size_t at = 0;
  while (at <= list.size()) {
    const size_t end = std::min(list.find(',', at), list.size());
    std::string token = list.substr(at, end - at);
    at = end + 1;
    Group g{ShiftStep::None, Mirrors::None};
    if (const size_t plus = token.find("+leaf-mirrors"); plus != std::string::npos)
      g.mirrors = Mirrors::Leaves, token.erase(plus);
    else if (const size_t plus = token.find("+mirrors"); plus != std::string::npos)
      g.mirrors = Mirrors::All, token.erase(plus);
    if (token == "mirrors") g.mirrors = Mirrors::All;
    else if (token == "leaf-mirrors") g.mirrors = Mirrors::Leaves;
    else if (token == "half") g.step = ShiftStep::Children;
    else if (token == "by8") g.step = ShiftStep::LeafParents;
    else if (token == "slices") g.step = ShiftStep::Slices;
    else if (token == "in-leaf-parents") g.step = ShiftStep::InLeafParents;
    else if (token != "none") throw std::runtime_error("unknown group '" + token + "'");
    out.push_back(g);
  }
  return out;
}

int run(const char* path, bool showLevels, size_t checks, const std::vector<Group>& groups) {
  const auto file = orThrow(CpvsFile::open(path));
  const auto t0 = std::chrono::steady_clock::now();
  ContentDag content;
  const std::vector<ViewRoot> roots = readViews(*file, content);
  uint64_t stored = 0;
  std::vector<const DagView*> views;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) stored += v.dag.bytes(), views.push_back(&v.dag);
  const auto voxels = deepVoxels(*file, checks, 12345);
  std::printf("\n%s: %zu views, DAGs as stored %.2f MB\n\n", path, roots.size(), mb(double(stored)));
  std::printf("| shift | mirrors | nodes | references | leaves | bytes (3.0 widths) | saving | bit widths | saving | "
              "order-0 bound | saving | seconds |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int rc = 0;
  double noneBytes = 0, noneBits = 0, noneBound = 0;
  for (const auto& [step, mirrors] : groups) {
      const auto t = std::chrono::steady_clock::now();
      CanonicalDag dag(content, step, mirrors);
      std::vector<Ref> rootRefs;
      std::vector<std::pair<unsigned, Ref>> rootsByLevel;
      for (const ViewRoot& r : roots) {
        rootRefs.push_back(dag.of(r.lg, r.content));
        rootsByLevel.emplace_back(r.lg, rootRefs.back());
      }
      const Weight w = weigh(dag, rootsByLevel, step, mirrors);
      size_t wrong = 0, checked = voxels.size();
      for (const auto& v : voxels) {
        const unsigned lg = roots[v[0]].lg;
        if (dag.shadowed(rootRefs[v[0]], lg, v[1], v[2], v[3]) != views[v[0]]->shadowed(v[1], v[2], v[3])) ++wrong;
      }
      // Small views (the golden files a test runs this on) are checked on every voxel as well.
      for (size_t vi = 0; vi < views.size(); ++vi) {
        const uint32_t n = views[vi]->resolution;
        if (n > 256) continue;
        for (uint32_t z = 0; z < n; ++z)
          for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x)
              wrong += dag.shadowed(rootRefs[vi], roots[vi].lg, x, y, z) != views[vi]->shadowed(x, y, z);
        checked += size_t(n) * n * n;
      }
      if (wrong) {
        std::fprintf(stderr, "dag_transform_estimate: %s: shift %s, mirrors %s: %zu of %zu voxels answer otherwise "
                     "than the file\n", path, nameOf(step), nameOf(mirrors), wrong, checked);
        rc = 3;
      }
      if (noneBytes == 0)  // the first group is the base
        noneBytes = double(w.bytes), noneBits = double(w.bitBytes), noneBound = w.boundBytes;
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      std::printf("| %s | %s | %llu | %llu | %llu | %.2f MB | %.1f %% | %.2f MB | %.1f %% | %.2f MB | %.1f %% | %.1f |\n",
                  nameOf(step),
                  nameOf(mirrors), (unsigned long long)w.nodes, (unsigned long long)w.references,
                  (unsigned long long)w.leaves, mb(double(w.bytes)), 100.0 * (1.0 - double(w.bytes) / noneBytes),
                  mb(double(w.bitBytes)), 100.0 * (1.0 - double(w.bitBytes) / noneBits),
                  mb(w.boundBytes), 100.0 * (1.0 - w.boundBytes / noneBound), seconds);
      if (showLevels) {
        std::printf("\n| edge | nodes | references | transform bits | widths (bytes) | bytes | widths (bits) | bytes | "
                    "order-0 bound |\n|---|---|---|---|---|---|---|---|---|\n");
        for (const LevelWeight& l : w.levels)
          std::printf("| %u | %llu | %llu | %u | %u/%u | %llu | %u/%u | %llu | %.0f |\n", l.edge,
                      (unsigned long long)l.nodes, (unsigned long long)l.references, l.transformBits,
                      l.widths.shortBytes, l.widths.longBytes, (unsigned long long)l.bytes, l.shortBits, l.longBits,
                      (unsigned long long)l.bitBytes, l.boundBits / 8);
        std::printf("| leaves | %llu | | | | %llu | | %llu | |\n\n", (unsigned long long)w.leaves,
                    (unsigned long long)w.leaves * 8, (unsigned long long)w.leaves * 8);
      }
      std::fflush(stdout);
    }
  size_t contentNodes = 0;
  for (unsigned lg = kLeafParentLog; lg <= kMaxLog; ++lg) contentNodes += content.nodeCount(lg);
  std::printf("\n%.1f s in all; %zu voxels reaching leaves checked per group; the content DAG grew to %zu subtrees "
              "(with the shifted ones)\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), voxels.size(), contentNodes);
  return rc;
}

}  // namespace

int main(int argc, char** argv) {
  bool showLevels = false;
  size_t checks = 200000;
  std::string groups = "none,in-leaf-parents,half,by8,slices,leaf-mirrors,mirrors,in-leaf-parents+leaf-mirrors,"
                       "in-leaf-parents+mirrors,half+mirrors,by8+mirrors,slices+mirrors";
  int first = 1;
  for (; first < argc && argv[first][0] == '-'; ++first) {
    if (std::strcmp(argv[first], "--levels") == 0) showLevels = true;
    else if (std::strcmp(argv[first], "--check") == 0 && first + 1 < argc) checks = std::strtoull(argv[++first], nullptr, 10);
    else if (std::strcmp(argv[first], "--groups") == 0 && first + 1 < argc) groups = argv[++first];
    else return std::fprintf(stderr, "dag_transform_estimate: unknown option %s\n", argv[first]), 1;
  }
  if (argc <= first) {
    std::fprintf(stderr, "usage: dag_transform_estimate [--levels] [--check N] [--groups LIST] FILE.cpvs...\n");
    return 1;
  }
  int rc = 0;
  try {
    const std::vector<Group> parsed = parseGroups(groups);
    if (parsed.empty() || parsed[0].step != ShiftStep::None || parsed[0].mirrors != Mirrors::None)
      throw std::runtime_error("--groups must start with none (the base the savings are against)");
    for (int i = first; i < argc; ++i) rc = std::max(rc, run(argv[i], showLevels, checks, parsed));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dag_transform_estimate: %s\n", e.what());
    return 2;
  }
  return rc;
}
