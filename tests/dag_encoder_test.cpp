// The builder's encoder (encodeBuiltDag, which consumes the node tables to keep a forest's bake small) gives
// the bytes of the reference encoder, encodeDag with NodeOrder::MostReferencedFirst, on random DAGs: popular
// and unreferenced nodes, wide references, counts past the order's cap.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <span>
#include <vector>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/dag_encoder.h"
#include "libcpvs/dag/leaf_parent_table.h"

namespace cpvs {
namespace {

struct BuildForm {
  std::vector<std::vector<uint32_t>> levels;  // root level first, all in words: what encodeDag reads
  std::vector<uint64_t> leaves;
  // What the builder hands encodeBuiltDag: the levels above the leaf parents with references to the leaf
  // parents' byte offsets, and the leaf parents byte-coded.
  std::vector<MappedArray<uint32_t>> builtLevels;
  MappedArray<uint8_t> leafParents;
};

struct Shape {
  std::vector<size_t> nodes;  // per level below the root
  size_t leaves = 0;
  double hot = 0;  // share of references that go to one node (or leaf) of the level below, 0.9 times that to a second
};

// Nodes with random child codes; each reference picks a target with a skew (a few popular ones), or one of the
// two hot ones. Targets are node starts of the level below (leaf indices below the last level).
BuildForm randomBuildForm(std::mt19937& rng, const Shape& shape) {
  BuildForm form;
  form.leaves.resize(shape.leaves);
  for (uint64_t& leaf : form.leaves) leaf = (uint64_t(rng()) << 32) | rng();
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<size_t> counts = {1};
  counts.insert(counts.end(), shape.nodes.begin(), shape.nodes.end());
  form.levels.resize(counts.size());
  form.builtLevels.resize(counts.size() - 1);
  // Where each node (or leaf) of the level below starts: in the word form and in the builder's form.
  std::vector<uint32_t> wordStarts(shape.leaves), builtStarts(shape.leaves);
  for (uint32_t i = 0; i < shape.leaves; ++i) wordStarts[i] = builtStarts[i] = i;
  for (size_t l = counts.size(); l-- > 0;) {
    std::vector<uint32_t> permuted(wordStarts.size());
    for (uint32_t i = 0; i < permuted.size(); ++i) permuted[i] = i;
    std::shuffle(permuted.begin(), permuted.end(), rng);
    const bool leafParents = l + 1 == counts.size();
    std::vector<uint32_t>& words = form.levels[l];
    std::vector<uint32_t> levelWordStarts, levelBuiltStarts;
    for (size_t n = 0; n < counts[l]; ++n) {
      uint32_t header = 0;
      std::vector<uint32_t> wordRefs, builtRefs;
      for (unsigned c = 0; c < 8; ++c) {
        uint32_t code = rng() % 3;
        if (l == 0 && c == 0) code = 2;  // the root has a child
        if (code == 2 && permuted.empty()) code = 1;
        header |= code << (2 * c);
        if (code != 2) continue;
        const double u = unit(rng), pick = unit(rng);
        const uint32_t target = pick < shape.hot         ? permuted[0]
                                : pick < 1.9 * shape.hot ? permuted[1 % permuted.size()]
                                                         : permuted[size_t(double(permuted.size()) * u * u * u)];
        wordRefs.push_back(wordStarts[target]);
        builtRefs.push_back(builtStarts[target]);
      }
      levelWordStarts.push_back(uint32_t(words.size()));
      words.push_back(header);
      words.insert(words.end(), wordRefs.begin(), wordRefs.end());
      if (leafParents) {
        uint8_t bytes[LeafParentTable::kMaxNodeBytes];
        levelBuiltStarts.push_back(uint32_t(form.leafParents.size()));
        form.leafParents.append(bytes, LeafParentTable::encode(header, builtRefs.data(), unsigned(builtRefs.size()), bytes));
      } else {
        levelBuiltStarts.push_back(uint32_t(form.builtLevels[l].size()));
        form.builtLevels[l].append(&header, 1);
        form.builtLevels[l].append(builtRefs.data(), builtRefs.size());
      }
    }
    wordStarts = levelWordStarts;
    builtStarts = levelBuiltStarts;
  }
  return form;
}

ShadowDag expectSameBytes(BuildForm form, uint32_t resolution) {
  std::vector<std::span<const uint32_t>> spans;
  std::vector<uint64_t> nodesPerLevel;
  for (size_t l = 0; l < form.levels.size(); ++l) {
    spans.emplace_back(form.levels[l]);
    uint64_t nodes = 0;
    for (size_t i = 0; i < form.levels[l].size(); i += nodeWordCount(form.levels[l][i])) ++nodes;
    nodesPerLevel.push_back(nodes);
  }
  const ShadowDag reference =
      orThrow(encodeDag(resolution, ChildCode::Ref, spans, nodesPerLevel, form.leaves, NodeOrder::MostReferencedFirst));
  const ShadowDag built = encodeBuiltDag(resolution, ChildCode::Ref, std::move(form.builtLevels),
                                         std::move(form.leafParents), form.leaves);
  EXPECT_EQ(built.nodesPerLevel, reference.nodesPerLevel);
  EXPECT_EQ(built.levelOffsets, reference.levelOffsets);
  EXPECT_EQ(built.leaves, reference.leaves);
  EXPECT_EQ(built.nodes.size(), reference.nodes.size());
  EXPECT_TRUE(built.nodes == reference.nodes);
  return reference;
}

TEST(DagEncoder, GivesTheReferenceEncodersBytesOnRandomDags) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const Shape shape{{1 + rng() % 8, 1 + rng() % 60, 1 + rng() % 400, 1 + rng() % 3000}, rng() % 2000, 0.02};
    SCOPED_TRACE(trial);
    expectSameBytes(randomBuildForm(rng, shape), 64);
  }
}

TEST(DagEncoder, GivesTheReferenceEncodersBytesWithWideReferencesAndCappedCounts) {
  // 200k leaves and 100k leaf parents: references past 65,535 take two units; 30 % of all references go
  // to one node or leaf and a little less to a second, so both pass the order's cap of 65,536 and tie.
  std::mt19937 rng(11);
  const ShadowDag dag = expectSameBytes(randomBuildForm(rng, {{4, 300, 100000, 100000}, 200000, 0.3}), 64);
  uint64_t wide = 0;
  for (size_t l = 0; l < dag.levelOffsets.size(); ++l)
    for (uint64_t at = dag.levelOffsets[l], k = 0; k < dag.nodesPerLevel[l]; ++k, at += nodeUnitCount(dag.nodes[at]))
      for (unsigned c = 0; c < 8; ++c) wide += isWideRef(dag.nodes[at], c);
  EXPECT_GT(wide, 1000u);
}

TEST(DagEncoder, RefusesAReferenceIntoTheMiddleOfANode) {
  std::mt19937 rng(3);
  BuildForm form = randomBuildForm(rng, {{4, 40}, 100, 0});
  // The root's first reference now points one word past a node's start.
  form.builtLevels[0] = MappedArray<uint32_t>();
  form.levels[0][1] += 1;
  form.builtLevels[0].append(form.levels[0].data(), form.levels[0].size());
  EXPECT_THROW(encodeBuiltDag(32, ChildCode::Ref, std::move(form.builtLevels), std::move(form.leafParents), form.leaves),
               Error);
}

TEST(LeafParentTable, DecodesWhatItStoredAndKeepsEachNodeOnce) {
  // Edge values: the largest reference, differences of either sign across the whole 32-bit range, repeats.
  const std::vector<std::vector<uint32_t>> nodes = {
      {0}, {UINT32_MAX}, {UINT32_MAX, 0, UINT32_MAX}, {5, 5, 5, 6, 4, 200000, 127, 128}, {1u << 31, 0, 16383, 16384},
      {}, {0}, {UINT32_MAX, 0, UINT32_MAX}};
  LeafParentTable table;
  std::vector<uint32_t> offsets;
  for (const std::vector<uint32_t>& refs : nodes) {
    uint32_t header = 0;  // references first, then shadowed children
    for (unsigned c = 0; c < 8; ++c) header |= (c < refs.size() ? 2u : 1u) << (2 * c);
    offsets.push_back(table.intern(header, refs.data(), unsigned(refs.size())));
    uint32_t decodedHeader, decoded[8];
    const unsigned length = LeafParentTable::decode(&table.records()[offsets.back()], decodedHeader, decoded);
    EXPECT_EQ(decodedHeader, header);
    EXPECT_LE(offsets.back() + length, table.records().size());
    EXPECT_EQ(std::vector<uint32_t>(decoded, decoded + refs.size()), refs);
  }
  EXPECT_EQ(table.size(), 6u);
  EXPECT_EQ(offsets[6], offsets[0]);
  EXPECT_EQ(offsets[7], offsets[2]);
}

}  // namespace
}  // namespace cpvs
