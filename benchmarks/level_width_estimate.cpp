// What a .cpvs would weigh if every DAG level chose its own two reference widths: a study for a format 3.0,
// not a format. Format 2.0 codes a reference in one or two 16-bit units (header codes 2 and 3) and counts it
// in units. Here a reference is a byte offset into its child level (or a leaf index below a leaf parent), and
// each level picks the pair of widths (short, long) of 1 to 4 bytes for its codes 2 and 3 that makes it
// smallest; child k of a node is still read directly (its byte position follows from the header and the
// level's two widths). Every level is laid out most referenced first, as cpvs-bake does it.
//
// The layout is benchmarks/level_widths.h's. Each file is weighed twice: view by view (as today: one DAG per view), and as one pool for the whole file
// (benchmarks/node_pool.h: each distinct subtree and leaf mask once; a pooled level holds the nodes of one edge
// from every view). In both, the 2.0 coding (units, widths 2 and 4 bytes) is weighed beside the chosen widths;
// per view it must equal the file's own DAG bytes, which checks the layout; pooled, the widths per level must
// weigh what the library's NodePool lays out, within 0.01 % (ties are broken in another order), and so must the
// hot tables.
//
// "Three widths" gives each child 3 bits (a 3-byte header): lit, shadowed, or a reference of 1, 2, 3 or 4
// bytes, the narrowest its value fits; still read directly. The order-0 bound codes each header and each
// reference by its frequency in its level, alone: the least any code that reads a header or a reference
// without its neighbours could weigh (leaves as they are).
//
// --cube-leaves weighs every coding over the DAG with 4x4x4 leaves instead (node_pool.h's withCubeLeaves; the
// 2.0 column then weighs that DAG in 2.0's coding, not the file), checked against NodePool's octant leaves.
//
//   level_width_estimate [--levels] [--cube-leaves] FILE.cpvs...   a markdown row per file; --levels adds the
//                                                                   pooled levels
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <vector>

#include "benchmarks/level_widths.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/cpvs_file.h"

namespace {

using namespace cpvs;
using namespace cpvs::study;

struct LevelWeight {
  uint32_t edge = 0;
  uint64_t nodes = 0, references = 0, bytes2 = 0, bytesChosen = 0;
  Widths chosen{0, 0};
  double entropyBits = 0;  // headers and references each coded by their frequency in the level (order 0)
  uint64_t bytesThree = 0;  // 3-bit child codes (a 3-byte header): lit, shadowed and references of 1, 2, 3 or 4 bytes
  uint64_t bytesHot = 0;    // short references by rank among the child level's most referenced nodes (a table)
  uint64_t bytesBits = 0;   // two widths per level in bits (1-32), a node's references packed, the node whole bytes
  unsigned shortBits = 0, longBits = 0;
};

struct Weight {
  uint64_t leafBytes = 0, format2 = 0, chosen = 0, three = 0, hot = 0, bits = 0;
  double entropyBytes = 0;
  std::vector<LevelWeight> levels;
};

// Lays out a pool bottom-up, most referenced first in each level (level_widths.h); weighs the 2.0 coding, the
// per-level widths and three widths over that order, and the order-0 bound.
Weight weigh(const Pool& pool) {
  Weight w;
  w.leafBytes = pool.leaves * 8;
  const StudyLayout laid = layOut(pool);
  std::vector<uint64_t> offset2(pool.nodes.size()), offsetThree(pool.nodes.size()), offsetHot(pool.nodes.size());
  std::vector<uint32_t> rank(pool.nodes.size(), 0);  // place in its level's order
  std::vector<uint64_t> offsetBits(pool.nodes.size());
  for (const PoolLevel& l : laid.levels) {
    LevelWeight level;
    level.edge = l.edge;
    level.nodes = l.order.size();
    level.references = l.references;
    level.chosen = l.widths;
    level.bytesChosen = l.bytes;
    // The same order in the 2.0 coding (units: references of one or two, counted in units) and with 3-bit codes.
    const auto valueOf = [&](const PooledNode& n, uint32_t c, const std::vector<uint64_t>& offsets, uint64_t unit) {
      return n.edge == 8 ? uint64_t(laid.leafIndex[c]) : offsets[c] / unit;
    };
    uint64_t at2 = 0, atThree = 0;
    for (const uint32_t id : l.order) {
      const PooledNode& n = pool.nodes[id];
      offset2[id] = at2;
      offsetThree[id] = atThree;
      at2 += 2;
      atThree += 3;
      for (const uint32_t c : n.children) {
        at2 += referenceBytes(valueOf(n, c, offset2, 2), {2, 4});
        const uint64_t v = valueOf(n, c, offsetThree, 1);
        atThree += v < 256 ? 1 : v < 65536 ? 2 : v < (1u << 24) ? 3 : 4;
      }
    }
    level.bytes2 = at2;
    level.bytesThree = atThree;
    // Hot table: a short reference is the child's rank when below 2^(8 short) (a 4-byte rank -> offset table
    // per level, as long as the child level or the short codes reach), else the child's byte offset in the long
    // width; below leaf parents ranks and indices are the same thing, so the table gains nothing there.
    const uint64_t childNodes = l.edge == 8 ? 0 : laid.levels[size_t(&l - laid.levels.data()) - 1].order.size();
    const auto hotNodeBytes = [&](const PooledNode& n, Widths pair, uint64_t tableEntries) {
      uint64_t bytes = 2;
      for (const uint32_t c : n.children) {
        if (n.edge == 8) bytes += referenceBytes(laid.leafIndex[c], pair);
        else if (rank[c] < tableEntries) bytes += pair.shortBytes;
        else bytes += referenceBytes(offsetHot[c], {pair.longBytes, pair.longBytes});
      }
      return bytes;
    };
    uint64_t bestHot = std::numeric_limits<uint64_t>::max(), bestEntries = 0;
    Widths bestPair{4, 4};
    for (const Widths pair : kWidthPairs)
      for (const bool table : {false, true}) {
        if (table && (l.edge == 8 || pair.shortBytes > 2 || pair.shortBytes >= pair.longBytes)) continue;
        // Without a table the short width is a narrower offset: the plain pairs, as laid out above.
        const uint64_t entries = table ? std::min<uint64_t>(childNodes, uint64_t(1) << (8 * pair.shortBytes)) : 0;
        uint64_t bytes = entries * 4;
        for (const uint32_t id : l.order) {
          if (table || l.edge == 8) {
            bytes += hotNodeBytes(pool.nodes[id], pair, entries);
          } else {
            bytes += 2;
            for (const uint32_t c : pool.nodes[id].children) bytes += referenceBytes(offsetHot[c], pair);
          }
        }
        if (bytes < bestHot) bestHot = bytes, bestEntries = entries, bestPair = pair;
      }
    level.bytesHot = bestHot;
    uint64_t atHot = 0;
    for (size_t i = 0; i < l.order.size(); ++i) {
      const uint32_t id = l.order[i];
      offsetHot[id] = atHot;
      rank[id] = uint32_t(i);
      if (bestEntries > 0 || l.edge == 8) {
        atHot += hotNodeBytes(pool.nodes[id], bestPair, bestEntries);
      } else {
        atHot += 2;
        for (const uint32_t c : pool.nodes[id].children) atHot += referenceBytes(offsetHot[c], bestPair);
      }
    }
    // The order-0 bound: no code that sees a header or a reference alone (not its neighbours) does better.
    std::map<uint32_t, uint64_t> headerCount, childCount;
    for (const uint32_t id : l.order) {
      headerCount[pool.nodes[id].codes] += 1;
      for (const uint32_t c : pool.nodes[id].children) childCount[c] += 1;
    }
    for (const auto& [h, n] : headerCount) level.entropyBits += double(n) * std::log2(double(level.nodes) / double(n));
    for (const auto& [c, n] : childCount) level.entropyBits += double(n) * std::log2(double(level.references) / double(n));
    w.entropyBytes += level.entropyBits / 8;
    w.format2 += level.bytes2;
    w.chosen += level.bytesChosen;
    w.three += level.bytesThree;
    w.hot += level.bytesHot;
    // Bit widths: the pair chosen from the references' bit counts (their sum, without each node's rounding up
    // to whole bytes), then laid out exactly.
    {
      const auto valueOf = [&](const PooledNode& n, uint32_t c) {
        return n.edge == 8 ? uint64_t(laid.leafIndex[c]) : offsetBits[c];
      };
      uint64_t needing[65] = {};
      for (const uint32_t id : l.order)
        for (const uint32_t c : pool.nodes[id].children) needing[std::bit_width(valueOf(pool.nodes[id], c)) | 1] += 1;
      const BitWidths pair = fewestBits(needing, 32);
      level.shortBits = pair.shortBits;
      level.longBits = pair.longBits;
      uint64_t at = 0;
      for (const uint32_t id : l.order) {
        offsetBits[id] = at;
        uint64_t refBits = 0;
        for (const uint32_t c : pool.nodes[id].children)
          refBits += std::bit_width(valueOf(pool.nodes[id], c)) <= level.shortBits ? level.shortBits : level.longBits;
        at += 2 + (refBits + 7) / 8;
      }
      level.bytesBits = at;
      w.bits += at;
    }
    w.levels.push_back(level);
  }
  w.format2 += w.leafBytes;
  w.chosen += w.leafBytes;
  w.three += w.leafBytes;
  w.hot += w.leafBytes;
  w.bits += w.leafBytes;
  w.entropyBytes += double(w.leafBytes);
  return w;
}

double mb(uint64_t b) { return double(b) / 1e6; }
double saving(uint64_t b, uint64_t of) { return 100.0 * (1.0 - double(b) / double(of ? of : 1)); }

int run(const char* path, bool showLevels, bool cubeLeaves) {
  const auto file = orThrow(CpvsFile::open(path));
  uint64_t stored = 0, perView2 = 0, perViewChosen = 0, perViewThree = 0, perViewHot = 0, perViewBits = 0, views = 0;
  double perViewEntropy = 0;
  PoolBuilder whole;
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) {
      PoolBuilder one;
      one.add(v);
      whole.add(v);
      const Weight w = weigh(cubeLeaves ? withCubeLeaves(one.pool()) : one.pool());
      stored += one.pool().storedBytes;
      perView2 += w.format2;
      perViewChosen += w.chosen;
      perViewEntropy += w.entropyBytes;
      perViewThree += w.three;
      perViewHot += w.hot;
      perViewBits += w.bits;
      ++views;
    }
  const Weight pooled = weigh(cubeLeaves ? withCubeLeaves(whole.pool()) : whole.pool());
  // The library's pool (libcpvs/dag/node_pool.h) must lay out exactly what this study weighs.
  NodePool library(cubeLeaves ? LeafShape::Octants : LeafShape::Slices);
  for (const CpvsFile::LightEntry& light : file->lights())
    for (const CpvsFile::View& v : light.views) library.add(v.dag);
  const LaidOutPool laidOut = library.layOut(), laidOutHot = library.layOut(true);
  uint64_t libraryBytes = laidOut.leaves.size() * 8, libraryHotBytes = laidOutHot.leaves.size() * 8;
  for (const PooledLevel& level : laidOut.levels) libraryBytes += level.bytes.size();
  for (const PooledLevel& level : laidOutHot.levels) libraryHotBytes += level.bytes.size() + 4 * level.hot.size();
  const auto entropy = [&](double bytes) { return uint64_t(std::ceil(bytes)); };
  std::printf("| %s | %llu | %.2f | %.2f | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | "
              "%.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | %.2f (%.1f %%) | "
              "%.2f (%.1f %%) |\n",
              path, (unsigned long long)views, mb(stored), mb(perView2), mb(perViewChosen), saving(perViewChosen, stored),
              mb(perViewThree), saving(perViewThree, stored), mb(perViewHot), saving(perViewHot, stored),
              mb(perViewBits), saving(perViewBits, stored),
              mb(entropy(perViewEntropy)), saving(entropy(perViewEntropy), stored), mb(pooled.format2),
              saving(pooled.format2, stored), mb(pooled.chosen), saving(pooled.chosen, stored), mb(pooled.three),
              saving(pooled.three, stored), mb(pooled.hot), saving(pooled.hot, stored), mb(pooled.bits),
              saving(pooled.bits, stored),
              mb(entropy(pooled.entropyBytes)), saving(entropy(pooled.entropyBytes), stored));
  if (perView2 != stored && !cubeLeaves)
    std::fprintf(stderr, "level_width_estimate: %s: the 2.0 layout weighs %llu bytes, the file %llu: the study's layout "
                 "differs from the writer's\n", path, (unsigned long long)perView2, (unsigned long long)stored);
  if (showLevels) {
    std::printf("\n| pooled level (edge) | nodes | references | 2.0 bytes | widths | bytes | hot table | bit widths | "
                "bytes | order-0 bound |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (const LevelWeight& l : pooled.levels)
      std::printf("| %u | %llu | %llu | %llu | %u/%u | %llu | %llu | %u/%u | %llu | %llu |\n", l.edge,
                  (unsigned long long)l.nodes, (unsigned long long)l.references, (unsigned long long)l.bytes2,
                  l.chosen.shortBytes, l.chosen.longBytes, (unsigned long long)l.bytesChosen,
                  (unsigned long long)l.bytesHot, l.shortBits, l.longBits, (unsigned long long)l.bytesBits,
                  (unsigned long long)entropy(l.entropyBits / 8));
    std::printf("| leaves | %llu | | %llu | | %llu | %llu | | %llu | %llu |\n\n",
                (unsigned long long)(pooled.leafBytes / 8), (unsigned long long)pooled.leafBytes,
                (unsigned long long)pooled.leafBytes, (unsigned long long)pooled.leafBytes,
                (unsigned long long)pooled.leafBytes, (unsigned long long)pooled.leafBytes);
  }
  // Ties in popularity are broken in first-seen order, which differs (the study meets a view's nodes level by
  // level, NodePool depth first): the two may differ by a few bytes, no more.
  const auto agrees = [](uint64_t a, uint64_t b) { return std::llabs((long long)a - (long long)b) * 10000 <= (long long)b; };
  const bool libraryAgrees = agrees(libraryBytes, pooled.chosen) && agrees(libraryHotBytes, pooled.hot);
  if (!libraryAgrees)
    std::fprintf(stderr, "level_width_estimate: %s: NodePool lays out %llu bytes (with hot tables %llu), the study "
                 "%llu (%llu)\n", path, (unsigned long long)libraryBytes, (unsigned long long)libraryHotBytes,
                 (unsigned long long)pooled.chosen, (unsigned long long)pooled.hot);
  return (perView2 == stored || cubeLeaves) && libraryAgrees ? 0 : 3;  // octant leaves: another DAG than the file's
}

}  // namespace

int main(int argc, char** argv) {
  bool showLevels = false, cubeLeaves = false;
  int first = 1;
  for (; first < argc && argv[first][0] == '-'; ++first) {
    if (std::strcmp(argv[first], "--levels") == 0) showLevels = true;
    else if (std::strcmp(argv[first], "--cube-leaves") == 0) cubeLeaves = true;
    else return std::fprintf(stderr, "level_width_estimate: unknown option %s\n", argv[first]), 1;
  }
  if (argc <= first) {
    std::fprintf(stderr, "usage: level_width_estimate [--levels] [--cube-leaves] FILE.cpvs...\n");
    return 1;
  }
  std::printf("| file | views | DAGs as stored, MB | per view, 2.0 coding | per view, widths per level | "
              "per view, three widths | per view, hot table | per view, bit widths | per view, order-0 bound | "
              "pool, 2.0 coding | pool, widths per level | pool, three widths | pool, hot table | pool, bit widths | "
              "pool, order-0 bound |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int rc = 0;
  try {
    for (int i = first; i < argc; ++i) rc = std::max(rc, run(argv[i], showLevels, cubeLeaves));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "level_width_estimate: %s\n", e.what());
    return 2;
  }
  return rc;
}
