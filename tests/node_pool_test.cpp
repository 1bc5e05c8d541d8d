// The node pool (libcpvs/dag/node_pool.h): views of several files pooled together read back every voxel as
// their own DAGs do, shared subtrees are stored once, each level takes the narrowest widths its references
// allow, and the same views give the same bytes. Then the runtime's validation of the pooled form
// (libcpvs/runtime/pool_validation.h): it accepts every layout, names what is wrong, and a damaged pool is
// refused or walks inside its buffers.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <tbb/task_arena.h>
#include <xxhash.h>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/node_pool.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/pool_validation.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// The walk of DagView::shadowed over the laid-out pool, written from its description in node_pool.h.
bool pooledShadowed(const LaidOutPool& pool, size_t view, uint32_t x, uint32_t y, uint32_t z,
                    LeafShape shape = LeafShape::Slices) {
  const bool octants = shape == LeafShape::Octants;
  const LaidOutPool::Root& root = pool.roots[view];
  const auto levelOf = [&](uint32_t edge) -> const PooledLevel& { return pool.levels[std::countr_zero(edge) - 3]; };
  uint32_t code = uint32_t(root.code);
  uint64_t at = root.offset;
  for (uint32_t edge = root.edge;; edge >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const PooledLevel& level = levelOf(edge);
    const unsigned c = edge == 8 && !octants
                           ? (z & 7u)
                           : ((z & (edge / 2)) ? 4u : 0u) | ((y & (edge / 2)) ? 2u : 0u) | ((x & (edge / 2)) ? 1u : 0u);
    const uint32_t header = uint32_t(level.bytes.at(at)) | uint32_t(level.bytes.at(at + 1)) << 8;
    code = childCodeOf(header, c);
    if (code != uint32_t(ChildCode::Ref)) continue;
    uint64_t ref = at + 2;
    for (unsigned before = 0; before < c; ++before) {
      const uint32_t raw = (header >> (2 * before)) & 3u;
      ref += raw == 2 ? level.widths.shortBytes : raw == 3 ? level.widths.longBytes : 0;
    }
    const unsigned width = ((header >> (2 * c)) & 3u) == 3u ? level.widths.longBytes : level.widths.shortBytes;
    uint64_t value = 0;
    for (unsigned b = 0; b < width; ++b) value |= uint64_t(level.bytes.at(ref + b)) << (8 * b);
    if (edge == 8) {
      const unsigned bit = octants ? (z & 3u) * 16u + (y & 3u) * 4u + (x & 3u) : (y & 7u) * 8u + (x & 7u);
      return (pool.leaves.at(value) >> bit) & 1u;
    }
    at = !level.hot.empty() && ((header >> (2 * c)) & 3u) == 2u ? level.hot.at(value) : value;
  }
}

// A 256^3 DAG whose 9,000 leaf parents reference 70,000 distinct leaves: the pool's leaf parents then index
// leaves past 65,535, which no golden file does. Every node references 8 children (shared modulo the level).
// With `popular`, seven of the eight children of each edge-16 node are among the first 200 leaf parents: many
// references to a few large nodes, where a hot table pays.
ShadowDag manyLeavesDag(bool popular = false) {
  const uint32_t counts[6] = {1, 8, 64, 512, 4096, 9000};
  std::vector<std::vector<uint32_t>> words(6);
  for (size_t l = 0; l < 6; ++l)
    for (uint32_t j = 0; j < counts[l]; ++j) {
      words[l].push_back(0xAAAAu);
      for (uint32_t c = 0; c < 8; ++c)
        words[l].push_back(l + 1 < 6 ? 9 * ((j * 8 + c) % (popular && l == 4 && c < 7 ? 200 : counts[l + 1]))
                                     : (j * 8 + c) % 70000);
    }
  std::vector<uint64_t> leaves(70000);
  for (size_t i = 0; i < leaves.size(); ++i) leaves[i] = (i + 1) * 0x9E3779B97F4A7C15ull;
  std::vector<std::span<const uint32_t>> levels(words.begin(), words.end());
  const std::vector<uint64_t> perLevel(counts, counts + 6);
  return orThrow(encodeDag(256, ChildCode::Ref, levels, perLevel, std::move(leaves)));
}

struct Views {
  std::vector<std::shared_ptr<const CpvsFile>> files;
  std::vector<DagView> dags;
  ShadowDag wide = test::wideReferenceDag(), manyLeaves = manyLeavesDag();
};

Views goldenViews() {
  Views v;
  for (const char* path : {"formats/cpvs/golden/tiny_v2.cpvs", "tests/golden/tiny_scene_bake64_v2.cpvs",
                           "tests/golden/alpha_test_bake128_v2.cpvs"}) {
    v.files.push_back(orThrow(CpvsFile::open(test::sourcePath(path))));
    for (const auto& light : v.files.back()->lights())
      for (const auto& view : light.views) v.dags.push_back(view.dag);
  }
  v.dags.push_back(v.wide.view());
  v.dags.push_back(v.manyLeaves.view());
  return v;
}

void expectEveryVoxelReadsBack(const LaidOutPool& pool, const std::vector<DagView>& dags, size_t firstView = 0,
                               LeafShape shape = LeafShape::Slices) {
  for (size_t v = 0; v < dags.size(); ++v) {
    const uint32_t n = dags[v].resolution;
    if (n == 0) continue;
    const uint32_t step = n > 128 ? 3 : 1;  // every voxel up to 128^3, every third one on each axis beyond
    size_t wrong = 0;
    for (uint32_t z = 0; z < n; z += step)
      for (uint32_t y = 0; y < n; y += step)
        for (uint32_t x = 0; x < n; x += step)
          wrong += pooledShadowed(pool, firstView + v, x, y, z, shape) != dags[v].shadowed(x, y, z);
    EXPECT_EQ(wrong, 0u) << "view " << v << " (N " << n << ")";
  }
}

TEST(NodePool, EveryViewReadsBackEveryVoxel) {
  const Views views = goldenViews();
  NodePool pool;
  for (const DagView& dag : views.dags) pool.add(dag);
  const LaidOutPool laid = pool.layOut();
  ASSERT_EQ(laid.roots.size(), views.dags.size());
  expectEveryVoxelReadsBack(laid, views.dags);
}

TEST(NodePool, WithHotTablesEveryViewReadsBackEveryVoxel) {
  const Views views = goldenViews();
  NodePool pool;
  for (const DagView& dag : views.dags) pool.add(dag);
  const LaidOutPool plain = pool.layOut(), hot = pool.layOut(true);
  expectEveryVoxelReadsBack(hot, views.dags);
  // A table is only taken where it makes its level smaller, its entries counted.
  for (size_t l = 0; l < hot.levels.size(); ++l)
    EXPECT_LE(hot.levels[l].bytes.size() + 4 * hot.levels[l].hot.size(), plain.levels[l].bytes.size() + 0u);
  EXPECT_TRUE(hot.levels[0].hot.empty());  // leaf parents index their leaves already

  // Many references to a few large children: the edge-16 level takes a table of 1-byte ranks (256 entries, the
  // 200 popular leaf parents among them).
  const ShadowDag popular = manyLeavesDag(true);
  NodePool popularPool;
  popularPool.add(popular.view());
  const LaidOutPool popularPlain = popularPool.layOut(), popularHot = popularPool.layOut(true);
  ASSERT_EQ(popularHot.levels[1].edge, 16u);
  EXPECT_EQ(popularHot.levels[1].hot.size(), 256u);
  EXPECT_LT(popularHot.levels[1].bytes.size() + 4 * 256, popularPlain.levels[1].bytes.size());
  expectEveryVoxelReadsBack(popularHot, {popular.view()});
}

TEST(NodePool, WithOctantLeavesEveryViewReadsBackEveryVoxel) {
  const Views views = goldenViews();
  NodePool slices, octants(LeafShape::Octants);
  for (const DagView& dag : views.dags) slices.add(dag), octants.add(dag);
  // Regrouping a block's bits keeps blocks apart: as many leaf parents (and nodes above) as with slices.
  EXPECT_EQ(octants.nodes(), slices.nodes());
  for (const bool hot : {false, true}) expectEveryVoxelReadsBack(octants.layOut(hot), views.dags, 0, LeafShape::Octants);
}

TEST(NodePool, KeepsEachSubtreeOnceAcrossViews) {
  const Views views = goldenViews();
  NodePool once, twice;
  for (const DagView& dag : views.dags) {
    once.add(dag);
    twice.add(dag);
  }
  for (const DagView& dag : views.dags) twice.add(dag);
  EXPECT_EQ(twice.nodes(), once.nodes());
  EXPECT_EQ(twice.leaves(), once.leaves());
  // Every node is reached by twice the views: none by one view only, each bucket k of `once` moves up by one.
  const std::vector<uint64_t> sharedOnce = once.nodesByViewsReaching(), sharedTwice = twice.nodesByViewsReaching();
  ASSERT_GE(sharedOnce.size(), 2u);  // the golden files' views share some nodes
  EXPECT_EQ(sharedTwice[0], 0u);
  EXPECT_EQ(sharedTwice[1], sharedOnce[0]);
  const LaidOutPool laid = twice.layOut();
  for (size_t v = 0; v < views.dags.size(); ++v) {
    EXPECT_EQ(laid.roots[v].offset, laid.roots[v + views.dags.size()].offset);
    EXPECT_EQ(laid.roots[v].code, laid.roots[v + views.dags.size()].code);
  }
  expectEveryVoxelReadsBack(laid, views.dags, views.dags.size());
  // Pooling the golden files' views shares something: fewer nodes than the views hold together.
  uint64_t stored = 0;
  for (const auto& file : views.files)
    for (const auto& light : file->lights())
      for (const auto& view : light.views)
        for (const uint64_t n : view.nodesPerLevel) stored += n;
  for (const ShadowDag* dag : {&views.wide, &views.manyLeaves})
    for (const uint64_t n : dag->nodesPerLevel) stored += n;
  EXPECT_LT(once.nodes(), stored);
}

TEST(NodePool, EachLevelTakesTheNarrowestWidthsItsReferencesAllow) {
  const Views views = goldenViews();
  NodePool pool;
  for (const DagView& dag : views.dags) pool.add(dag);
  const LaidOutPool laid = pool.layOut();
  // manyLeavesDag's leaf parents index leaves past 65535: the leaf parents' long width is 3 bytes.
  ASSERT_GT(laid.leaves.size(), 65536u);
  EXPECT_EQ(laid.levels[0].edge, 8u);
  EXPECT_EQ(laid.levels[0].widths.longBytes, 3u);
  // So are its 9,000 leaf parents' offsets (26 bytes each) from the edge-16 level; every level above is small
  // enough for references of 1 or 2 bytes.
  EXPECT_EQ(laid.levels[1].widths.longBytes, 3u);
  for (size_t l = 2; l < laid.levels.size(); ++l) EXPECT_LE(laid.levels[l].widths.longBytes, 2u) << laid.levels[l].edge;
}

TEST(NodePool, TheStreamedLayoutIsTheLayout) {
  // layOutInto (the writer's: level by level, each build-form level freed once done, no view counts) hands over
  // exactly layOut's bytes, with and without hot tables.
  const Views views = goldenViews();
  for (const bool hot : {false, true}) {
    NodePool whole, streamed(LeafShape::Slices, /*countViews=*/false);
    for (const DagView& dag : views.dags) whole.add(dag), streamed.add(dag);
    whole.add(views.wide.view()), streamed.add(views.wide.view());
    const LaidOutPool expected = whole.layOut(hot);
    LaidOutPool got;
    streamed.layOutInto(hot, {[&](std::vector<uint64_t>&& leaves) { got.leaves = std::move(leaves); },
                              [&](PooledLevel&& level) { got.levels.push_back(std::move(level)); },
                              [&](std::vector<LaidOutPool::Root>&& roots) { got.roots = std::move(roots); }});
    EXPECT_EQ(got.leaves, expected.leaves);
    ASSERT_EQ(got.levels.size(), expected.levels.size());
    for (size_t l = 0; l < got.levels.size(); ++l) {
      EXPECT_EQ(got.levels[l].bytes, expected.levels[l].bytes) << l;
      EXPECT_EQ(got.levels[l].hot, expected.levels[l].hot) << l;
      EXPECT_EQ(got.levels[l].nodes, expected.levels[l].nodes) << l;
    }
    ASSERT_EQ(got.roots.size(), expected.roots.size());
    for (size_t v = 0; v < got.roots.size(); ++v) EXPECT_EQ(got.roots[v].offset, expected.roots[v].offset);
    // Consumed: nothing more is added or laid out.
    EXPECT_THROW(streamed.add(views.dags[0]), Error);
    EXPECT_THROW((void)streamed.layOut(), Error);
  }
}

TEST(NodePool, SameViewsGiveTheSameBytes) {
  const Views views = goldenViews();
  NodePool a, b;
  for (const DagView& dag : views.dags) a.add(dag);
  for (const DagView& dag : views.dags) b.add(dag);
  const LaidOutPool la = a.layOut(), lb = b.layOut();
  ASSERT_EQ(la.levels.size(), lb.levels.size());
  for (size_t l = 0; l < la.levels.size(); ++l) {
    EXPECT_EQ(la.levels[l].bytes, lb.levels[l].bytes);
    EXPECT_EQ(la.levels[l].widths.shortBytes, lb.levels[l].widths.shortBytes);
    EXPECT_EQ(la.levels[l].widths.longBytes, lb.levels[l].widths.longBytes);
  }
  EXPECT_EQ(la.leaves, lb.leaves);
}

// A 512^3 DAG with levels of up to 200,000 nodes (about 110,000 of them reachable), each child picked by a hash: levels large enough
// that the layout splits them into parts (one per thread of the arena).
ShadowDag manyNodesDag() {
  const uint32_t counts[7] = {1, 8, 64, 512, 4096, 32768, 200000};
  constexpr uint32_t kLeaves = 70000;
  std::vector<std::vector<uint32_t>> words(7);
  for (size_t l = 0; l < 7; ++l)
    for (uint32_t j = 0; j < counts[l]; ++j) {
      words[l].push_back(0xAAAAu);
      for (uint32_t c = 0; c < 8; ++c) {
        const uint64_t mixed = (uint64_t(l) << 40 | uint64_t(j) << 8 | c) * 0x9E3779B97F4A7C15ull;
        const uint32_t pick = uint32_t(mixed >> 32);
        words[l].push_back(l + 1 < 7 ? 9 * (pick % counts[l + 1]) : pick % kLeaves);
      }
    }
  std::vector<uint64_t> leaves(kLeaves);
  for (size_t i = 0; i < leaves.size(); ++i) leaves[i] = (i + 1) * 0xD1B54A32D192ED03ull;
  std::vector<std::span<const uint32_t>> levels(words.begin(), words.end());
  const std::vector<uint64_t> perLevel(counts, counts + 7);
  return orThrow(encodeDag(512, ChildCode::Ref, levels, perLevel, std::move(leaves)));
}

// The layout cuts large levels into parts encoded side by side, one per thread: the bytes must not depend on
// how many (a bake's -j). Laid out in an arena of one thread and of two, with and without hot tables.
TEST(NodePool, TheLayoutDoesNotDependOnTheThreadCount) {
  const ShadowDag dag = manyNodesDag();
  NodePool pool(LeafShape::Slices, /*countViews=*/false);
  pool.add(dag.view());
  for (const bool hot : {false, true}) {
    LaidOutPool one, parts;
    tbb::task_arena(1).execute([&] { one = pool.layOut(hot); });
    tbb::task_arena(2).execute([&] { parts = pool.layOut(hot); });
    ASSERT_EQ(one.levels.size(), parts.levels.size());
    uint64_t largest = 0;
    for (size_t l = 0; l < one.levels.size(); ++l) {
      EXPECT_EQ(one.levels[l].bytes, parts.levels[l].bytes) << "level " << l << " hot tables " << hot;
      EXPECT_EQ(one.levels[l].hot, parts.levels[l].hot);
      EXPECT_EQ(one.levels[l].widths.shortBytes, parts.levels[l].widths.shortBytes);
      EXPECT_EQ(one.levels[l].widths.longBytes, parts.levels[l].widths.longBytes);
      largest = std::max<uint64_t>(largest, one.levels[l].nodes);
    }
    EXPECT_EQ(one.leaves, parts.leaves);
    ASSERT_EQ(one.roots.size(), parts.roots.size());
    EXPECT_EQ(one.roots[0].offset, parts.roots[0].offset);
    EXPECT_GT(largest, 65536u);  // a level the layout does split
    for (const uint32_t v : {0u, 100u, 511u})
      EXPECT_EQ(pooledShadowed(parts, 0, v, (v * 7) % 512, (v * 13) % 512), dag.view().shadowed(v, (v * 7) % 512, (v * 13) % 512));
  }
}

// The pool of the golden bakes, laid out in each leaf shape and coding, hashed whole (leaves, each level's
// bytes, hot table, edge and widths, the roots): pinned, so that a change of how views are added or laid out
// that moves a byte shows here. The values are those of the recursive add before the level-by-level one
// (d9d4da5) too. When the layout changes on purpose (a new format version), print and replace them.
TEST(NodePool, TheGoldenBakesLayOutAsPinned) {
  std::vector<std::unique_ptr<CpvsFile>> files;
  for (const char* path : {"formats/cpvs/golden/tiny_v2.cpvs", "tests/golden/tiny_scene_bake64_v2.cpvs",
                           "tests/golden/alpha_test_bake128_v2.cpvs"})
    files.push_back(orThrow(CpvsFile::open(test::sourcePath(path))));
  for (const LeafShape shape : {LeafShape::Slices, LeafShape::Octants})
    for (const bool hot : {false, true}) {
      NodePool pool(shape, /*countViews=*/false);
      for (const auto& file : files)
        for (const auto& light : file->lights())
          for (const auto& view : light.views) pool.add(view.dag);
      const LaidOutPool laid = pool.layOut(hot);
      uint64_t hash = XXH3_64bits(laid.leaves.data(), laid.leaves.size() * 8);
      for (const PooledLevel& level : laid.levels) {
        hash = XXH3_64bits_withSeed(level.bytes.data(), level.bytes.size(), hash);
        hash = XXH3_64bits_withSeed(level.hot.data(), level.hot.size() * 4, hash);
        const uint32_t coding[3] = {level.edge, level.widths.shortBytes, level.widths.longBytes};
        hash = XXH3_64bits_withSeed(coding, sizeof coding, hash);
      }
      for (const LaidOutPool::Root& root : laid.roots) hash = XXH3_64bits_withSeed(&root.offset, sizeof root.offset, hash);
      const uint64_t pinned = shape == LeafShape::Octants ? 0x4a08f38f84fc26dcull : 0x65eee16dbfa4284cull;
      EXPECT_EQ(hash, pinned) << (shape == LeafShape::Octants ? "octant" : "slice") << " leaves, hot tables " << hot
                              << ": 0x" << std::hex << hash;
    }
}

}  // namespace
}  // namespace cpvs

// --- Validation of the pooled form (libcpvs/runtime/pool_validation.h) ---

namespace cpvs {
namespace {

struct PoolViews {
  std::vector<PoolLevelView> levels;
  std::vector<PoolRootView> roots;
};
PoolViews viewsOf(const LaidOutPool& pool) {
  PoolViews v;
  for (const PooledLevel& l : pool.levels)
    v.levels.push_back({l.edge, l.widths.shortBytes, l.widths.longBytes, l.bytes, l.hot});
  for (const LaidOutPool::Root& r : pool.roots) v.roots.push_back({r.code, r.edge, r.offset});
  return v;
}
Outcome validate(const LaidOutPool& pool) {
  const PoolViews v = viewsOf(pool);
  return validatePool(v.levels, pool.leaves.size(), v.roots, "test.cpvs");
}

TEST(PoolValidation, AcceptsEveryLayoutOfThePool) {
  const Views views = goldenViews();
  for (const LeafShape shape : {LeafShape::Slices, LeafShape::Octants}) {
    NodePool pool(shape);
    for (const DagView& dag : views.dags) pool.add(dag);
    for (const bool hot : {false, true}) {
      const Outcome o = validate(pool.layOut(hot));
      EXPECT_TRUE(o.ok()) << o.message();
    }
  }
}

TEST(PoolValidation, NamesWhatIsWrong) {
  const Views views = goldenViews();
  NodePool pool;
  for (const DagView& dag : views.dags) pool.add(dag);
  const LaidOutPool good = pool.layOut();
  {
    LaidOutPool bad = good;  // the top level's last byte cut off
    bad.levels.back().bytes.pop_back();
    const Outcome o = validate(bad);
    EXPECT_FALSE(o.ok());
    EXPECT_NE(o.message().find("test.cpvs: pool level of edge"), std::string::npos) << o.message();
  }
  {
    LaidOutPool bad = good;  // a root into the middle of its node
    for (LaidOutPool::Root& r : bad.roots)
      if (r.code == ChildCode::Ref) r.offset += 1;
    const Outcome o = validate(bad);
    EXPECT_FALSE(o.ok());
    EXPECT_NE(o.message().find("root: byte"), std::string::npos) << o.message();
  }
  {
    LaidOutPool bad = good;  // fewer leaves than the leaf parents index
    bad.leaves.resize(bad.leaves.size() / 2);
    const Outcome o = validate(bad);
    EXPECT_FALSE(o.ok());
    EXPECT_NE(o.message().find("is not below the leaf count"), std::string::npos) << o.message();
  }
  {
    LaidOutPool bad = good;  // a level missing
    bad.levels.erase(bad.levels.begin() + 1);
    EXPECT_FALSE(validate(bad).ok());
  }
}

// Damaged pools are refused, or, where the damage leaves a valid pool (a reference to another node, a flipped
// child code that still fits), walked without leaving the buffers: every read of the walk here is
// bounds-checked (.at()), so a read outside them would throw; the runtime's walk must answer alike.
TEST(PoolValidation, DamagedPoolsAreRefusedOrWalkInsideTheirBuffers) {
  const Views views = goldenViews();
  std::vector<DagView> small;  // the golden files' views: every voxel walked
  for (const DagView& dag : views.dags)
    if (dag.resolution <= 128) small.push_back(dag);
  for (const LeafShape shape : {LeafShape::Slices, LeafShape::Octants})
    for (const bool hot : {false, true}) {
      NodePool pool(shape);
      for (const DagView& dag : small) pool.add(dag);
      const LaidOutPool good = pool.layOut(hot);
      std::mt19937 rng(7);
      size_t refused = 0, accepted = 0;
      for (int m = 0; m < 300; ++m) {
        LaidOutPool bad = good;
        for (int flips = 1 + int(rng() % 3); flips > 0; --flips) {
          PooledLevel& level = bad.levels[rng() % bad.levels.size()];
          if (!level.hot.empty() && rng() % 4 == 0) level.hot[rng() % level.hot.size()] ^= 1u << (rng() % 32);
          else if (!level.bytes.empty()) level.bytes[rng() % level.bytes.size()] ^= uint8_t(1u << (rng() % 8));
        }
        if (!validate(bad).ok()) {
          ++refused;
          continue;
        }
        ++accepted;
        // The runtime's walk (byte_dag.h) of the same damaged pool answers as the bounds-checked one here (under
        // the sanitizers, scripts/test-sanitized.sh, a read outside its buffers would be reported).
        const PooledDags runtime = concatenate(bad, shape);
        for (size_t v = 0; v < small.size(); ++v)
          for (uint32_t z = 0; z < small[v].resolution; z += 3)
            for (uint32_t y = 0; y < small[v].resolution; y += 3)
              for (uint32_t x = 0; x < small[v].resolution; x += 3) {
                bool answer = false;
                ASSERT_NO_THROW(answer = pooledShadowed(bad, v, x, y, z, shape)) << "mutation " << m;
                ASSERT_EQ(runtime.views[v].shadowed(x, y, z), answer) << "mutation " << m;
              }
      }
      EXPECT_GT(refused, 0u);
      EXPECT_GT(accepted, 0u);  // some damage leaves a valid pool: the walks above ran
    }
}

}  // namespace
}  // namespace cpvs
