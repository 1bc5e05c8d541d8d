// Region records: a view built with some regions replayed from an earlier build's records is the same DAG,
// byte for byte, as one built from every region's chains; a record that does not decode is refused before the
// builder changes.
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>
#include <vector>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/test_dags.h"

namespace cpvs {
namespace {

constexpr uint32_t kN = 128, kRegion = 32, kPerSide = kN / kRegion;

struct Variant {
  UndefinedMode mode;
  bool nodeReuse;
  uint32_t maxEdgeFlips;
};

RegionRect rectOf(uint32_t r) { return {(r % kPerSide) * kRegion, (r / kPerSide) * kRegion, kRegion, kRegion}; }

// The chains of region r of a scene whose `edited` regions come from another depth map.
TileChains chainsOf(uint32_t r, const std::set<uint32_t>& edited, const Variant& v) {
  return buildTileChains(test::syntheticDepth(kN, edited.count(r) ? 23 : 11, rectOf(r)), v.mode, 1);
}

void expectSameDag(const ShadowDag& a, const ShadowDag& b) {
  EXPECT_EQ(a.rootCode, b.rootCode);
  EXPECT_EQ(a.nodesPerLevel, b.nodesPerLevel);
  EXPECT_EQ(a.levelOffsets, b.levelOffsets);
  EXPECT_EQ(a.nodes, b.nodes);
  EXPECT_EQ(a.leaves, b.leaves);
}

class RegionReplay : public ::testing::TestWithParam<Variant> {};

TEST_P(RegionReplay, ReplayedRegionsGiveTheBytesOfACleanBuild) {
  const Variant v = GetParam();
  // The "before" build keeps every region's record.
  std::vector<std::string> records(kPerSide * kPerSide);
  DagBuilder before(kN, kRegion, v.nodeReuse, v.maxEdgeFlips);
  for (uint32_t r = 0; r < records.size(); ++r) before.addRegion(chainsOf(r, {}, v), &records[r]);
  const ShadowDag original = before.finish();
  // An edit changes a few regions, the first among them so every replayed region follows a changed one.
  for (const std::set<uint32_t>& edited : {std::set<uint32_t>{}, std::set<uint32_t>{0, 5, 6}, std::set<uint32_t>{9}}) {
    DagBuilder clean(kN, kRegion, v.nodeReuse, v.maxEdgeFlips);
    DagBuilder incremental(kN, kRegion, v.nodeReuse, v.maxEdgeFlips);
    for (uint32_t r = 0; r < records.size(); ++r) {
      clean.addRegion(chainsOf(r, edited, v));
      if (edited.count(r))
        incremental.addRegion(chainsOf(r, edited, v));
      else
        incremental.replayRegion(rectOf(r), incremental.decodeRecord(records[r]));
    }
    const DagBuildStats cleanStats = clean.stats(), incrementalStats = incremental.stats();
    const ShadowDag expected = clean.finish(), got = incremental.finish();
    expectSameDag(expected, got);
    EXPECT_EQ(incremental.stats().nodesBuilt, clean.stats().nodesBuilt);
    EXPECT_EQ(incrementalStats.nodesReused, cleanStats.nodesReused);
    EXPECT_EQ(incremental.stats().leavesMerged, clean.stats().leavesMerged);
    if (edited.empty()) expectSameDag(original, got);
  }
}

INSTANTIATE_TEST_SUITE_P(Variants, RegionReplay,
                         ::testing::Values(Variant{UndefinedMode::Kampe, true, 0}, Variant{UndefinedMode::Kampe, false, 0},
                                           Variant{UndefinedMode::None, true, 0}, Variant{UndefinedMode::Kampe, true, 2}),
                         [](const auto& info) {
                           return std::string(undefinedModeName(info.param.mode)) +
                                  (info.param.nodeReuse ? "Reuse" : "NoReuse") + "Flips" +
                                  std::to_string(info.param.maxEdgeFlips);
                         });

TEST(RegionReplay, DamagedRecordsAreRefusedBeforeTheBuilderChanges) {
  const Variant v{UndefinedMode::Kampe, true, 0};
  std::vector<std::string> records(kPerSide * kPerSide);
  DagBuilder first(kN, kRegion, true);
  for (uint32_t r = 0; r < records.size(); ++r) first.addRegion(chainsOf(r, {}, v), &records[r]);
  const ShadowDag expected = first.finish();
  ASSERT_GT(records[5].size(), 40u);

  // Every truncation, and a record of another grid, throw InvalidInput; the builder then takes the right record
  // and ends as if nothing had been tried.
  DagBuilder builder(kN, kRegion, true);
  const auto refused = [&](uint32_t r, const std::string& bad) {
    try {
      builder.replayRegion(rectOf(r), builder.decodeRecord(bad));
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
      return true;
    }
    return false;
  };
  for (uint32_t r = 0; r < records.size(); ++r) {
    if (r == 5) {
      for (size_t cut = 0; cut < records[r].size(); ++cut) EXPECT_TRUE(refused(r, records[r].substr(0, cut))) << cut;
      EXPECT_TRUE(refused(r, records[r] + '\0'));
      DagBuilder coarser(kN, kRegion * 2, true);  // two columns, not four
      EXPECT_THROW(coarser.decodeRecord(records[r]), Error);
    }
    builder.replayRegion(rectOf(r), builder.decodeRecord(records[r]));
  }
  expectSameDag(expected, builder.finish());

  // Random damage either decodes (a checksum around the record is what catches it) or is refused; it never
  // reads outside the record or the builder's tables (the sanitized run checks).
  std::mt19937 random(5);
  size_t refusedCount = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bad = records[trial % records.size()];
    if (bad.empty()) continue;
    for (int k = 0; k < 1 + trial % 3; ++k) bad[random() % bad.size()] = char(random());
    DagBuilder scratch(kN, kRegion, true);
    try {
      scratch.replayRegion(rectOf(trial % records.size()), scratch.decodeRecord(bad));
    } catch (const Error& e) {
      ASSERT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
      ++refusedCount;
    }
  }
  EXPECT_GT(refusedCount, 500u);
}

}  // namespace
}  // namespace cpvs
