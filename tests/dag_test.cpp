// Tile chains and DAG construction: every required voxel is exact in every mode, node reuse changes nothing,
// and regions give the same grid as one piece.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <random>
#include <string>

#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/test_dags.h"

namespace cpvs {
namespace {

using test::syntheticDepth;

void expectExact(const DagView& dag, const DepthRegion& depth) {
  const uint32_t n = depth.resolution;
  uint64_t errors = 0;
  for (uint32_t y = 0; y < depth.rect.height; ++y) {
    for (uint32_t x = 0; x < depth.rect.width; ++x) {
      const uint32_t e = depth.enterAt(x, y), xs = depth.exitAt(x, y);
      for (uint32_t z = 0; z < n; ++z) {
        const bool shadowed = dag.shadowed(depth.rect.x0 + x, depth.rect.y0 + y, z);
        if (z <= e && shadowed) ++errors;
        if (z >= xs && !shadowed) ++errors;
      }
    }
  }
  EXPECT_EQ(errors, 0u);
}

class DagModes : public ::testing::TestWithParam<UndefinedMode> {};

TEST_P(DagModes, RequiredVoxelsAreExactAndReuseChangesNothing) {
  for (uint32_t n : {64u, 128u}) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      const DepthRegion depth = syntheticDepth(n, seed);
      const TileChains chains = buildTileChains(depth, GetParam(), 2);
      DagBuildStats withStats, withoutStats;
      const ShadowDag with = buildDag(chains, true, &withStats);
      const ShadowDag without = buildDag(chains, false, &withoutStats);
      expectExact(with.view(), depth);
      // Identical-node culling only skips building nodes that hash-consing would merge anyway.
      EXPECT_EQ(with.nodes, without.nodes);
      EXPECT_EQ(with.leaves, without.leaves);
      EXPECT_GT(withStats.nodesReused, 0u);
      EXPECT_LT(withStats.nodesBuilt, withoutStats.nodesBuilt);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllModes, DagModes,
                         ::testing::Values(UndefinedMode::Kampe, UndefinedMode::Sintorn, UndefinedMode::None),
                         [](const auto& info) { return std::string(undefinedModeName(info.param)); });

TEST(Dag, ModesAgreeOnEveryVoxelThatIsNotFree) {
  const uint32_t n = 128;
  const DepthRegion depth = syntheticDepth(n, 7);
  const ShadowDag kampe = buildDag(buildTileChains(depth, UndefinedMode::Kampe), true);
  const ShadowDag sintorn = buildDag(buildTileChains(depth, UndefinedMode::Sintorn), true);
  const ShadowDag none = buildDag(buildTileChains(depth, UndefinedMode::None), true);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      for (uint32_t z = 0; z < n; ++z) {
        const uint32_t e = depth.enterAt(x, y), xs = depth.exitAt(x, y);
        if (z > e && z < xs) continue;
        const bool expected = z >= xs;
        ASSERT_EQ(kampe.view().shadowed(x, y, z), expected);
        ASSERT_EQ(sintorn.view().shadowed(x, y, z), expected);
        ASSERT_EQ(none.view().shadowed(x, y, z), expected);
      }
  // The point of the modes: using free voxels makes the DAG smaller.
  EXPECT_LE(kampe.bytes(), sintorn.bytes());
  EXPECT_LT(sintorn.bytes(), none.bytes());
}

TEST(Dag, RegionsGiveTheSameGridAsOnePiece) {
  const uint32_t n = 128, regionSize = 32;
  const DepthRegion whole = syntheticDepth(n, 11);
  const ShadowDag single = buildDag(buildTileChains(whole, UndefinedMode::Kampe), true);
  DagBuilder builder(n, regionSize, true);
  for (uint32_t ry = 0; ry < n / regionSize; ++ry)
    for (uint32_t rx = 0; rx < n / regionSize; ++rx) {
      const DepthRegion part = syntheticDepth(n, 11, {rx * regionSize, ry * regionSize, regionSize, regionSize});
      builder.addRegion(buildTileChains(part, UndefinedMode::Kampe));
    }
  const ShadowDag regions = builder.finish();
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      for (uint32_t z = 0; z < n; ++z) ASSERT_EQ(single.view().shadowed(x, y, z), regions.view().shadowed(x, y, z));
  // Hash tables persist across regions: the same unique nodes below the region level.
  EXPECT_EQ(single.leaves.size(), regions.leaves.size());
}

TEST(Dag, VolumesPastEveryFrontSurfaceOfTheirFootprintAreShadowed) {
  // A slab: every texel enters a solid at slice 10 and leaves it at 60. The chains keep the free voxels lit
  // until the exit (nothing needs shadow before it), but a volume lying past every front surface of its
  // footprint holds only free and shadowed voxels, so it is all shadowed (Kämpe et al. 2015, §3.4, as Sintorn):
  // the root's four near children are lit (z < 32 < 60), its four far children shadowed (32 > 10), and
  // nothing else is stored.
  const uint32_t n = 64;
  DepthRegion depth;
  depth.rect = {0, 0, n, n};
  depth.resolution = n;
  depth.enter.assign(size_t(n) * n, 10);
  depth.exit.assign(size_t(n) * n, 60);
  for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn}) {
    for (bool reuse : {true, false}) {
      const ShadowDag dag = buildDag(buildTileChains(depth, mode), reuse);
      EXPECT_EQ(dag.nodes.size(), 1u) << undefinedModeName(mode);
      EXPECT_TRUE(dag.leaves.empty()) << undefinedModeName(mode);
      EXPECT_FALSE(dag.view().shadowed(5, 7, 31));
      EXPECT_TRUE(dag.view().shadowed(5, 7, 32));
      expectExact(dag.view(), depth);
    }
  }
}

TEST(Dag, LevelsAndLeavesAreStoredMostReferencedFirst) {
  // cpvs-bake's order (NodeOrder::MostReferencedFirst): within every level, and in the leaf pool, a node or
  // leaf is referenced at least as often as the next one, so the popular ones take one-unit references.
  const ShadowDag dag = buildDag(buildTileChains(syntheticDepth(256, 4), UndefinedMode::Kampe), true);
  const DagView view = dag.view();
  const size_t levels = dag.nodesPerLevel.size();
  ASSERT_GE(levels, 4u);
  std::vector<std::vector<uint32_t>> counts(levels + 1);  // per level by node position; [levels]: leaves
  std::vector<std::vector<uint32_t>> starts(levels);      // unit offsets of each level's nodes
  for (size_t l = 0; l < levels; ++l) {
    uint32_t at = uint32_t(dag.levelOffsets[l]);
    for (uint64_t k = 0; k < dag.nodesPerLevel[l]; ++k) {
      starts[l].push_back(at);
      at += nodeUnitCount(dag.nodes[at]);
    }
    counts[l].assign(starts[l].size(), 0);
  }
  counts[levels].assign(dag.leaves.size(), 0);
  uint64_t popularSeen = 0;
  for (size_t l = 0; l < levels; ++l) {
    const uint32_t size = dag.resolution >> l;
    for (uint32_t at : starts[l]) {
      const uint32_t header = dag.nodes[at];
      for (unsigned c = 0; c < 8; ++c) {
        if (childCodeOf(header, c) != uint32_t(ChildCode::Ref)) continue;
        const uint32_t target = view.child(at, header, c, size);
        if (l + 1 == levels) {
          ++counts[levels][target];
        } else {
          const auto it = std::lower_bound(starts[l + 1].begin(), starts[l + 1].end(), target);
          ASSERT_TRUE(it != starts[l + 1].end() && *it == target) << "level " << l << " refers inside a node";
          ++counts[l + 1][size_t(it - starts[l + 1].begin())];
        }
      }
    }
  }
  for (size_t l = 1; l <= levels; ++l) {
    for (size_t i = 1; i < counts[l].size(); ++i)
      ASSERT_GE(counts[l][i - 1], counts[l][i]) << (l == levels ? "leaves" : "level " + std::to_string(l)) << " at " << i;
    popularSeen += !counts[l].empty() && counts[l].front() > 1;
  }
  EXPECT_GT(popularSeen, 2u);  // shared subtrees exist, so the order is not trivially flat
}

TEST(TileChains, MasksOnlyGainBitsAndSummariesMatch) {
  const DepthRegion depth = syntheticDepth(64, 3);
  for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn, UndefinedMode::None}) {
    const TileChains chains = buildTileChains(depth, mode);
    for (uint32_t t = 0; t < chains.tilesX * chains.tilesY; ++t) {
      ASSERT_EQ(chains.start[chains.first[t]], 0u);
      for (uint32_t i = chains.first[t] + 1; i < chains.first[t + 1]; ++i) {
        EXPECT_LT(chains.start[i - 1], chains.start[i]);
        EXPECT_EQ(chains.mask[i - 1] & ~chains.mask[i], 0u);
        EXPECT_NE(chains.mask[i - 1], chains.mask[i]);
      }
      for (uint32_t z = 0; z < 64; ++z) {
        if (z < chains.litUntil[t]) {
          EXPECT_EQ(chains.maskAt(t, z), kAllLit);
        }
      }
      // darkFrom: the farthest enter + 1 of the tile's texels (N when one sees nothing), and the chain turns
      // all shadowed no earlier.
      uint32_t farthestEnter = 0;
      const uint32_t tx = t % chains.tilesX, ty = t / chains.tilesX;
      for (uint32_t j = 0; j < 64; ++j)
        farthestEnter = std::max(farthestEnter, depth.enterAt(tx * 8 + (j & 7), ty * 8 + (j >> 3)));
      EXPECT_EQ(chains.darkFrom[t], std::min(farthestEnter + 1, 64u));
      const uint32_t last = chains.first[t + 1] - 1;
      if (chains.mask[last] == kAllShadowed) {
        EXPECT_GE(chains.start[last], chains.darkFrom[t]);
      }
    }
  }
}

// The chain rules of docs/construction.md §1 applied texel by texel, as directly as they read: the reference
// the sorted walk in tile_masks.cpp must reproduce.
std::vector<std::pair<uint32_t, uint64_t>> referenceChain(const uint32_t (&e)[64], const uint32_t (&x)[64],
                                                          uint32_t n, UndefinedMode mode) {
  std::vector<std::pair<uint32_t, uint64_t>> out{{0, kAllLit}};
  uint32_t minX = n, maxE = 0;
  for (int j = 0; j < 64; ++j) minX = std::min(minX, x[j]), maxE = std::max(maxE, e[j]);
  auto place = [&](uint64_t m, uint32_t latest) {
    uint32_t earliest = out.back().first + 1;
    for (int j = 0; j < 64; ++j)
      if (m >> j & 1) earliest = std::max(earliest, e[j] + 1);
    return mode == UndefinedMode::Kampe ? mostAlignedSlice(earliest, latest) : latest;
  };
  uint64_t current = kAllLit;
  for (uint32_t z = minX; z < n;) {
    if (z > maxE) {
      out.push_back({place(kAllShadowed, z), kAllShadowed});
      break;
    }
    uint64_t m = 0;
    for (int j = 0; j < 64; ++j) m |= uint64_t(e[j] < z) << j;
    if (m != current) out.push_back({place(m, z), current = m});
    uint32_t next = n;
    for (int j = 0; j < 64; ++j) {
      if (mode == UndefinedMode::Sintorn && e[j] >= z) next = std::min(next, e[j] + 1);
      if (mode != UndefinedMode::Sintorn && !(current >> j & 1)) next = std::min(next, x[j]);
    }
    if (mode == UndefinedMode::Kampe && next > maxE + 1 && maxE + 1 < n) {
      out.push_back({place(kAllShadowed, std::min(next, n - 1)), kAllShadowed});
      break;
    }
    z = std::min(next, maxE + 1);
  }
  return out;
}

TEST(TileChains, EveryTileFollowsTheRulesTexelByTexel) {
  for (uint32_t seed : {1u, 6u, 9u}) {
    const uint32_t n = 256;
    const DepthRegion depth = syntheticDepth(n, seed);
    for (UndefinedMode mode : {UndefinedMode::Kampe, UndefinedMode::Sintorn, UndefinedMode::None}) {
      const TileChains chains = buildTileChains(depth, mode, 2);
      uint64_t entries = 0;
      for (uint32_t t = 0; t < chains.tilesX * chains.tilesY; ++t) {
        uint32_t e[64], x[64];
        for (uint32_t j = 0; j < 64; ++j) {
          const uint32_t px = t % chains.tilesX * 8 + (j & 7), py = t / chains.tilesX * 8 + (j >> 3);
          e[j] = depth.enterAt(px, py);
          x[j] = mode == UndefinedMode::None ? std::min(e[j] + 1, n) : depth.exitAt(px, py);
          if (e[j] >= n) x[j] = n;
        }
        const auto expected = referenceChain(e, x, n, mode);
        ASSERT_EQ(chains.first[t + 1] - chains.first[t], expected.size()) << "tile " << t;
        for (size_t i = 0; i < expected.size(); ++i) {
          ASSERT_EQ(chains.start[chains.first[t] + i], expected[i].first) << "tile " << t << " entry " << i;
          ASSERT_EQ(chains.mask[chains.first[t] + i], expected[i].second) << "tile " << t << " entry " << i;
        }
        entries += expected.size();
      }
      EXPECT_GT(entries, 2 * uint64_t(chains.tilesX) * chains.tilesY);
    }
  }
}

TEST(TileChains, MostAlignedSliceHasTheMostTrailingZerosOfItsWindow) {
  const auto zeros = [](uint32_t v) { return v == 0 ? 32 : std::countr_zero(v); };
  for (uint32_t earliest = 0; earliest < 300; ++earliest)
    for (uint32_t latest = earliest; latest < 300; ++latest) {
      const uint32_t s = mostAlignedSlice(earliest, latest);
      ASSERT_GE(s, earliest);
      ASSERT_LE(s, latest);
      for (uint32_t z = earliest; z <= latest; ++z) ASSERT_LE(zeros(z), zeros(s)) << earliest << ".." << latest;
    }
  EXPECT_EQ(mostAlignedSlice(37, 30), 30u);  // an empty window keeps the latest slice
  EXPECT_EQ(mostAlignedSlice(1u << 31, ~0u), 1u << 31);
  EXPECT_EQ(mostAlignedSlice(0x7FFFFFFFu, 0x80000000u), 0x80000000u);  // they differ in every bit
  EXPECT_EQ(mostAlignedSlice(0, ~0u), 0u);
}

TEST(TileChains, KampeStartsEachEntryAtTheMostAlignedSliceItsWindowAllows) {
  // Entry i may start after entry i - 1 and past the enter slice of every texel it shadows, and must start by
  // the first exit among the texels entry i - 1 keeps lit (or the last slice, for the final all-shadowed
  // entry). Kampe takes the most aligned slice of that window; Sintorn keeps the latest.
  const uint32_t n = 256;
  const DepthRegion depth = syntheticDepth(n, 11);
  const TileChains chains = buildTileChains(depth, UndefinedMode::Kampe);
  uint64_t entries = 0, moved = 0;
  for (uint32_t t = 0; t < chains.tilesX * chains.tilesY; ++t) {
    const uint32_t tx = t % chains.tilesX, ty = t / chains.tilesX;
    uint32_t e[64], x[64];
    for (uint32_t j = 0; j < 64; ++j) {
      e[j] = depth.enterAt(tx * 8 + (j & 7), ty * 8 + (j >> 3));
      x[j] = depth.exitAt(tx * 8 + (j & 7), ty * 8 + (j >> 3));
    }
    for (uint32_t i = chains.first[t] + 1; i < chains.first[t + 1]; ++i) {
      uint32_t earliest = chains.start[i - 1] + 1, latest = n - 1;
      for (uint32_t j = 0; j < 64; ++j) {
        if (chains.mask[i] >> j & 1) earliest = std::max(earliest, e[j] + 1);
        if (!(chains.mask[i - 1] >> j & 1)) latest = std::min(latest, x[j]);
      }
      ASSERT_LE(earliest, latest) << "tile " << t << " entry " << i;
      ASSERT_EQ(chains.start[i], mostAlignedSlice(earliest, latest)) << "tile " << t << " entry " << i;
      ++entries;
      moved += chains.start[i] != latest;
    }
  }
  EXPECT_GT(entries, 500u);
  EXPECT_GT(moved, 50u);  // the synthetic map has solids thick enough to leave a choice
}

TEST(TileHierarchy, NextChangeIsTheFirstChainStartOrDarkFromOfTheFootprint) {
  // Checked against every tile of the footprint, at every level, for slices across the whole depth.
  const uint32_t n = 128;
  const TileChains chains = buildTileChains(syntheticDepth(n, 5), UndefinedMode::Kampe);
  const TileHierarchy hierarchy(chains);
  uint64_t checked = 0, found = 0;
  for (uint32_t level = 0; level < hierarchy.size.size(); ++level) {
    const uint32_t side = hierarchy.size[level], span = 1u << level;
    for (uint32_t hy = 0; hy < side; ++hy)
      for (uint32_t hx = 0; hx < side; ++hx)
        for (uint32_t after = 0; after < n; after += 3)
          for (bool withDarkFrom : {false, true}) {
            uint32_t expected = n;
            for (uint32_t ty = hy * span; ty < (hy + 1) * span; ++ty)
              for (uint32_t tx = hx * span; tx < (hx + 1) * span; ++tx) {
                const uint32_t tile = chains.tileIndex(tx, ty);
                expected = std::min(expected, chains.nextTransition(tile, after));
                if (withDarkFrom && chains.darkFrom[tile] > after)
                  expected = std::min(expected, chains.darkFrom[tile]);
              }
            const size_t index = size_t(hy) * side + hx;
            ASSERT_EQ(hierarchy.nextChange(chains, level, index, after, n, 0, withDarkFrom), expected)
                << "level " << level << " node " << index << " after " << after;
            // With a cap, and stopping early: any answer <= enough is allowed once one exists.
            const uint32_t cap = std::min(after + 9, n), enough = after + 4;
            const uint32_t capped = hierarchy.nextChange(chains, level, index, after, cap, enough, withDarkFrom);
            if (expected <= enough && expected < cap) {
              EXPECT_LE(capped, enough);
              EXPECT_GT(capped, after);
            } else {
              EXPECT_EQ(capped, std::min(expected, cap));
            }
            // Capped at the footprint's minLitUntil no chain starts in range: the smallest darkFrom remains
            // (how the builder bounds a lit volume).
            const uint32_t litCap = hierarchy.minLitUntil[level][index];
            uint32_t firstDark = litCap;
            for (uint32_t ty = hy * span; ty < (hy + 1) * span; ++ty)
              for (uint32_t tx = hx * span; tx < (hx + 1) * span; ++tx) {
                const uint32_t dark = chains.darkFrom[chains.tileIndex(tx, ty)];
                if (dark > after) firstDark = std::min(firstDark, dark);
              }
            if (after < litCap) {
              EXPECT_EQ(hierarchy.nextChange(chains, level, index, after, litCap, 0, true), firstDark);
            }
            ++checked;
            found += expected < n;
          }
  }
  EXPECT_GT(found, checked / 4);  // the synthetic map has changes to find
}

TEST(TileChains, KampeUsesFewerDistinctMasksThanSintorn) {
  // One tile: texel j enters at slice j; texel 0 is an open surface, every other texel is inside a solid
  // to the end. Kampe keeps one mask ({texel 0}) for the whole depth; Sintorn follows every enter depth.
  DepthRegion depth;
  depth.rect = {0, 0, 8, 8};
  depth.resolution = 64;
  for (uint32_t j = 0; j < 64; ++j) {
    depth.enter.push_back(j);
    depth.exit.push_back(j == 0 ? 1 : 64);
  }
  const TileChains kampe = buildTileChains(depth, UndefinedMode::Kampe);
  const TileChains sintorn = buildTileChains(depth, UndefinedMode::Sintorn);
  EXPECT_EQ(kampe.first[1] - kampe.first[0], 2u);
  EXPECT_EQ(kampe.mask[1], 1u);
  EXPECT_GT(sintorn.first[1] - sintorn.first[0], 60u);
}

}  // namespace
}  // namespace cpvs
