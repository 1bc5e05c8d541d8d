// Format 3.0 (formats/cpvs/format.md, "Version 3.0: one node pool per file"): golden bytes, a 3.0 file that
// answers every voxel of every view as its 2.0 twin does (through the DAG converted on open and through the walk
// over the pool in place), a streamed writer and a merge of parts that give one run's bytes, and damage behind
// valid checksums that is refused or walked inside the buffers.
//
// Regenerate the golden file after a deliberate format change (which must also bump the version):
//   CPVS_UPDATE_GOLDEN=1 ./format3_test --gtest_filter='*Golden*'
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <filesystem>
#include <random>

#include "libcpvs/base/error.h"
#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_pool.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "support/cpvs_files.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using namespace cpvsformat;
using namespace test::cpvsfiles;

const std::string& goldenPath() {
  static const std::string path = test::sourcePath("formats/cpvs/golden/tiny_v3.cpvs");
  return path;
}

std::unique_ptr<CpvsFile> openBytes(const std::string& bytes, const std::string& name) {
  return orThrow(CpvsFile::fromBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, name));
}

// Every voxel (every one up to N = 128, a sample above) and every 8x8 tile mask of every view: the 3.0 file's
// DAG (the pool's units from the view's root on) and its walk over the pool in place answer as the 2.0 file's.
// `bakerOrder`: the 2.0 file's nodes are in the order the baker writes (NodeOrder::MostReferencedFirst), as a view
// taken out of the pool is, so they are equal unit for unit (the hand-made golden content is not).
void expectSameAnswers(const CpvsFile& v2, const CpvsFile& v3, bool bakerOrder = true) {
  ASSERT_EQ(v2.lights().size(), v3.lights().size());
  std::mt19937 rng(7);
  for (size_t li = 0; li < v2.lights().size(); ++li) {
    ASSERT_EQ(v2.lights()[li].views.size(), v3.lights()[li].views.size());
    for (size_t vi = 0; vi < v2.lights()[li].views.size(); ++vi) {
      const CpvsFile::View& a = v2.lights()[li].views[vi];
      const CpvsFile::View& b = v3.lights()[li].views[vi];
      const uint32_t n = a.view.resolution;
      ASSERT_EQ(n, b.view.resolution);
      // The view's own DAG taken out of the pool: the 2.0 file's counts and leaves, and its units.
      const ShadowDag own = orThrow(v3.ownDag(b));
      EXPECT_EQ(a.nodesPerLevel, own.nodesPerLevel) << "light " << li << " view " << vi;
      EXPECT_EQ(a.dag.leaves.size(), own.leaves.size()) << "light " << li << " view " << vi;
      if (bakerOrder) {
        EXPECT_TRUE(std::equal(a.dag.nodes.begin(), a.dag.nodes.end(), own.nodes.begin(), own.nodes.end()))
            << "light " << li << " view " << vi;
        EXPECT_TRUE(std::equal(a.dag.leaves.begin(), a.dag.leaves.end(), own.leaves.begin(), own.leaves.end()));
      }
      if (b.dag.rootCode == ChildCode::Ref) {
        EXPECT_EQ(b.dag.sharedNodes.data(), v3.lights()[li].views[0].dag.sharedNodes.data());
      }
      uint64_t differ = 0, voxels = 0;
      auto check = [&](uint32_t x, uint32_t y, uint32_t z) {
        const bool expected = a.dag.shadowed(x, y, z);
        differ += b.dag.shadowed(x, y, z) != expected;
        differ += b.bytes.shadowed(x, y, z) != expected;
        if ((x & 7) == 0 && (y & 7) == 0) differ += b.bytes.tileMask(x, y, z) != a.bytes.tileMask(x, y, z);
        ++voxels;
      };
      if (n <= 128) {
        for (uint32_t z = 0; z < n; ++z)
          for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) check(x, y, z);
      } else {
        for (int i = 0; i < 200000; ++i) check(rng() % n, rng() % n, rng() % n);
      }
      EXPECT_EQ(differ, 0u) << "light " << li << " view " << vi << ": of " << voxels << " voxels";
    }
  }
}

CpvsContent contentOf(const CpvsFile& file) {
  CpvsContent content;
  content.settingsJson = file.settingsJson();
  for (const CpvsFile::LightEntry& light : file.lights()) content.lights.push_back(orThrow(bakedLightOf(file, light)));
  return content;
}

TEST(Format3, GoldenBytesPinVersion3_0) {
  const std::string bytes = writeCpvs(tinyContent(), 3);
  if (const char* update = std::getenv("CPVS_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    writeFile(goldenPath(), toBytes(bytes));
    GTEST_SKIP() << "wrote " << goldenPath() << " (" << bytes.size() << " bytes)";
  }
  const Bytes golden = readFile(goldenPath());
  ASSERT_FALSE(golden.empty()) << goldenPath() << " is missing; run with CPVS_UPDATE_GOLDEN=1 to create it";
  // A change that alters these bytes changes the format: bump the version, update formats/cpvs/format.md and
  // regenerate the golden file.
  ASSERT_EQ(toBytes(bytes), golden) << "writeCpvs no longer produces formats/cpvs/golden/tiny_v3.cpvs";
  const auto file = orThrow(CpvsFile::open(goldenPath()));
  EXPECT_EQ(file->majorVersion(), 3);
  EXPECT_EQ(file->minorVersion(), 0);
  // The layout of format.md: BAKE STRS LGHT VIEW, then the pool's LEAF NODE POOL HOTT.
  std::vector<std::string> types;
  for (const CpvsFile::SectionInfo& s : file->sections()) types.push_back(s.type);
  EXPECT_EQ(types, (std::vector<std::string>{"BAKE", "STRS", "LGHT", "VIEW", "LEAF", "NODE", "POOL", "HOTT"}));
  EXPECT_EQ(file->sections()[3].elementSize, kPooledViewRecordSize);
  // The sun's leaf parent is shared by two of its root's children and pooled once: two levels (edge 8 and 16),
  // two nodes of edge 8 (the sun's and the point light's face 0; the spot's root is the third).
  ASSERT_EQ(file->poolLevels().size(), 2u);
  EXPECT_EQ(file->poolLevels()[0].edge, 8u);
  EXPECT_EQ(file->poolLevels()[0].nodes, 3u);
  EXPECT_EQ(file->poolLevels()[1].nodes, 1u);
  EXPECT_EQ(file->poolLeaves(), 5u);
}

TEST(Format3, EveryVoxelAnswersAsIn2_0) {
  for (const bool baked : {false, true}) {
    const CpvsContent content = baked ? bakedContent() : tinyContent();
    const auto v2 = openBytes(writeCpvs(content, 2), "v2");
    const auto v3 = openBytes(writeCpvs(content, 3), "v3");
    expectSameAnswers(*v2, *v3, baked);
  }
  // The golden bakes, each re-pooled: real DAGs of a sun, a spot and alpha-tested casters.
  for (const char* path : {"tests/golden/tiny_scene_bake64_v2.cpvs", "tests/golden/alpha_test_bake128_v2.cpvs",
                           "formats/cpvs/golden/tiny_v1.cpvs"}) {
    SCOPED_TRACE(path);
    const auto v2 = orThrow(CpvsFile::open(test::sourcePath(path)));
    const std::string bytes = writeCpvs(contentOf(*v2), 3);
    const auto v3 = openBytes(bytes, "v3");
    expectSameAnswers(*v2, *v3);
    EXPECT_LT(bytes.size(), v2->fileSize());
  }
}

TEST(Format3, ViewsShareThePool) {
  // The same light twice: its subtrees are pooled once, so the second copy adds no node and no leaf.
  CpvsContent content = bakedContent();
  content.lights.resize(1);
  const auto once = openBytes(writeCpvs(content, 3), "once");
  content.lights.push_back(content.lights[0]);
  content.lights[1].light.name = "sun again";
  const auto twice = openBytes(writeCpvs(content, 3), "twice");
  ASSERT_EQ(once->poolLevels().size(), twice->poolLevels().size());
  for (size_t l = 0; l < once->poolLevels().size(); ++l) {
    EXPECT_EQ(once->poolLevels()[l].nodes, twice->poolLevels()[l].nodes);
    EXPECT_EQ(once->poolLevels()[l].bytes, twice->poolLevels()[l].bytes);
  }
  EXPECT_EQ(once->poolLeaves(), twice->poolLeaves());
  EXPECT_EQ(twice->lights()[0].views[0].bytes.root, twice->lights()[1].views[0].bytes.root);
}

TEST(Format3, TheStreamedWriterWritesWhatWriteCpvsWrites) {
  const CpvsContent content = bakedContent();
  std::vector<Light> lights;
  std::vector<size_t> views;
  for (const BakedLight& l : content.lights) {
    lights.push_back(l.light);
    views.push_back(l.views.size());
  }
  std::string streamed;
  CpvsWriter writer(content.settingsJson, lights, views, [&](uint64_t at, const char* data, size_t n) {
    if (streamed.size() < at + n) streamed.resize(size_t(at + n), '\0');
    std::memcpy(streamed.data() + at, data, n);
  }, 3);
  for (const BakedLight& l : content.lights) writer.add(l);
  const uint64_t size = writer.finish();
  EXPECT_EQ(size, streamed.size());
  EXPECT_EQ(streamed, writeCpvs(content, 3));
  EXPECT_THROW(CpvsWriter("{}", {}, {}, [](uint64_t, const char*, size_t) {}, 4), Error);
}

TEST(Format3, PartsMergeIntoTheBytesOfOneRun) {
  const std::string dir = test::tempDir();
  const std::string bake = test::toolPath("cpvs-bake") + " " + test::sourcePath("data/scenes/Tiny/tiny.gltf") +
                           " -r 64 --sun 0.3,-1,0.2 --spot 0,5,0,0,-1,0,0.6,20 --point 0.5,3,1.5,0 -q";
  ASSERT_EQ(test::runTool(bake + " --format-version 3 -o " + dir + "/whole.cpvs").exitCode, 0);
  ASSERT_EQ(test::runTool(bake + " --format-version 3 --lights 0,2 -o " + dir + "/a.cpvs").exitCode, 0);
  ASSERT_EQ(test::runTool(bake + " --format-version 3 --lights 1 -o " + dir + "/b.cpvs").exitCode, 0);
  const test::ToolResult merged =
      test::runTool(test::toolPath("cpvs-merge") + " " + dir + "/b.cpvs " + dir + "/a.cpvs -o " + dir + "/m.cpvs -q");
  ASSERT_EQ(merged.exitCode, 0) << merged.output;
  EXPECT_EQ(test::runTool("cmp " + dir + "/whole.cpvs " + dir + "/m.cpvs").exitCode, 0);
  // Parts of two format versions are not one bake.
  ASSERT_EQ(test::runTool(bake + " --lights 1 -o " + dir + "/b2.cpvs").exitCode, 0);
  const test::ToolResult mixed =
      test::runTool(test::toolPath("cpvs-merge") + " " + dir + "/a.cpvs " + dir + "/b2.cpvs -o " + dir + "/x.cpvs");
  EXPECT_EQ(mixed.exitCode, 2) << mixed.output;
  EXPECT_NE(mixed.output.find("share a format version"), std::string::npos) << mixed.output;
  // And the whole 3.0 bake answers every voxel as the 2.0 bake of the same scene.
  ASSERT_EQ(test::runTool(bake + " -o " + dir + "/whole2.cpvs").exitCode, 0);
  expectSameAnswers(*orThrow(CpvsFile::open(dir + "/whole2.cpvs")), *orThrow(CpvsFile::open(dir + "/whole.cpvs")));
  const test::ToolResult badVersion = test::runTool(bake + " --format-version 4 -o " + dir + "/y.cpvs");
  EXPECT_EQ(badVersion.exitCode, 1) << badVersion.output;
  EXPECT_NE(badVersion.output.find("--format-version must be 2 or 3"), std::string::npos) << badVersion.output;
}

TEST(Format3, EveryTruncationAndFlippedByteIsRejected) {
  const Bytes golden = readFile(goldenPath());
  ASSERT_FALSE(golden.empty());
  for (size_t size = 0; size < golden.size(); ++size)
    openError(Bytes(golden.begin(), golden.begin() + std::ptrdiff_t(size)), "cut.cpvs");
  for (size_t at = 0; at < golden.size(); at += 3) {
    Bytes damaged = golden;
    damaged[at] ^= 0x10;
    openError(damaged, "flipped.cpvs");
  }
}

// The pool's own checks, with checksums made valid again: each named damage is refused with what is wrong.
TEST(Format3, MalformedPoolsBehindValidChecksumsAreRejected) {
  const RawFile original = unpack(readFile(goldenPath()));
  auto damaged = [&](const std::function<void(RawFile&)>& damage) {
    RawFile raw = original;
    damage(raw);
    return openError(pack(raw), "pool.cpvs");
  };
  auto poolRecord = [](RawFile& f, size_t level, size_t field, uint64_t v, int n) {
    putLE(sectionOf(f, kPool).bytes, level * kPoolLevelRecordSize + field, v, n);
  };
  using P = PoolLevelLayout;
  EXPECT_NE(damaged([&](RawFile& f) { poolRecord(f, 1, P::kEdge, 32, 4); }).find("levels run 8, 16, 32"),
            std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { poolRecord(f, 0, P::kShortBytes, 0, 1); }).find("reference widths"),
            std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { poolRecord(f, 1, P::kOffset, 1, 8); }).find("of NODE"), std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { poolRecord(f, 0, P::kNodes, 4, 8); }).find("says 4 nodes"), std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { poolRecord(f, 0, P::kHotCount, 1, 4); }).find("hot table"), std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { sectionOf(f, kNode).bytes.back() = 1; }).find("tail byte"), std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { sectionOf(f, kNode).bytes.push_back(0); }).find("NODE holds"),
            std::string::npos);
  // The sun's root (view 0) pointed at the second byte of its node, and at a level it does not have.
  EXPECT_NE(damaged([&](RawFile& f) { putLE(sectionOf(f, kView).bytes, ViewRecordLayout::kPoolRoot, 1, 8); })
                .find("view 0's root: byte 1 is not a node"),
            std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) {
              putLE(sectionOf(f, kView).bytes, ViewRecordLayout::kResolution, 32, 4);
              putLE(sectionOf(f, kView).bytes, ViewRecordLayout::kLevels, 3, 1);
            }).find("no pool level of edge 32"),
            std::string::npos);
  EXPECT_NE(damaged([&](RawFile& f) { f.sections.erase(f.sections.begin() + 7); }).find("no 'HOTT' section"),
            std::string::npos);
  // A reference of the edge-16 level (the sun's root, 2 bytes of header then 1-byte references) to a leaf parent
  // that is not there.
  EXPECT_NE(damaged([&](RawFile& f) {
              const uint64_t level16 = getLE(sectionOf(f, kPool).bytes, kPoolLevelRecordSize + P::kOffset, 8);
              sectionOf(f, kNode).bytes[level16 + 2] = 0xFF;
            }).find("is not a node of the level below"),
            std::string::npos);
}

TEST(Format3, ConvertingViewsOneByOneIsBounded) {
  // A view's own DAG (ownDag) copies what its root reaches, and a small file can name one large subtree from
  // many views: the conversions are bounded together (convertedBytesAllowed), so that no file can make a
  // report or a merge take unbounded memory or time. Here the golden file's pool with a bound of a few bytes.
  const auto file = orThrow(CpvsFile::open(goldenPath()));
  const std::span<const uint8_t> bytes = file->bytes();
  FilePoolSections sections;
  for (const CpvsFile::SectionInfo& s : file->sections()) {
    const std::span<const uint8_t> at = bytes.subspan(s.offset, s.size);
    if (s.type == "POOL") sections.records = at, sections.recordSize = s.elementSize;
    if (s.type == "NODE") sections.nodes = at;
    if (s.type == "HOTT") sections.hot = {reinterpret_cast<const uint32_t*>(at.data()), at.size() / 4};
    if (s.type == "LEAF") sections.leaves = {reinterpret_cast<const uint64_t*>(at.data()), at.size() / 8};
  }
  auto convertAll = [&](uint64_t bound) -> Outcome {
    std::vector<CpvsFile::View> views;
    for (const CpvsFile::LightEntry& light : file->lights())
      for (const CpvsFile::View& view : light.views) views.push_back(view);
    std::vector<CpvsFile::View*> pointers;
    for (CpvsFile::View& view : views) {  // the root as the record holds it: its offset in its own level
      if (view.bytes.rootCode == ChildCode::Ref)
        view.bytes.root -= file->poolLevels()[std::countr_zero(view.view.resolution) - 3].offset;
      pointers.push_back(&view);
    }
    sections.maxConvertedBytes = bound;
    const std::unique_ptr<FilePool> pool = orThrow(FilePool::read(sections, pointers, "bounded.cpvs"));
    for (const CpvsFile::View& view : views)
      if (Result<ShadowDag> dag = pool->ownDag(view.bytes); !dag) return dag.outcome();
    return {};
  };
  EXPECT_TRUE(convertAll(UINT64_MAX));
  const Outcome bounded = convertAll(16);
  ASSERT_FALSE(bounded);
  EXPECT_EQ(bounded.category(), ErrorCategory::InvalidInput);
  EXPECT_NE(bounded.message().find("bounded.cpvs: its views' DAGs would take more than"), std::string::npos)
      << bounded.message();
  EXPECT_GE(convertedBytesAllowed(file->fileSize()), 64 * file->fileSize());
  EXPECT_EQ(convertedBytesAllowed(UINT64_MAX), UINT64_MAX);
}

TEST(Format3Walks, PooledViewsLookUpAsTheir2_0Twins) {
  // The batch lookups (K = 1, the K <= 9 corner-tile filter and the general one above it), with and without a
  // top grid, over a 3.0 view's DAG, whose units are the whole pool's from its root on: the answers of its 2.0
  // twin. tests/CMakeLists.txt runs this with the walks lowered to AVX2 and to scalar as well.
  for (const char* path : {"tests/golden/tiny_scene_bake64_v2.cpvs", "tests/golden/alpha_test_bake128_v2.cpvs"}) {
    SCOPED_TRACE(path);
    const auto v2 = orThrow(CpvsFile::open(test::sourcePath(path)));
    const auto v3 = openBytes(writeCpvs(contentOf(*v2), 3), "v3");
    for (size_t li = 0; li < v2->lights().size(); ++li)
      for (size_t vi = 0; vi < v2->lights()[li].views.size(); ++vi) {
        const DagView& a = v2->lights()[li].views[vi].dag;
        const DagView& b = v3->lights()[li].views[vi].dag;
        const uint32_t n = a.resolution;
        std::vector<SurfacePoint> points;
        std::mt19937 rng(uint32_t(11 * li + vi));
        for (int i = 0; i < 20000; ++i)  // voxel centres, and points off the grid's sides (K > 1 clips)
          points.push_back({{double(rng() % (n + 8)) - 3.5, double(rng() % (n + 8)) - 3.5, -(rng() % n + 0.5)},
                            glm::dvec3(0.0)});
        for (int gridLevels : {0, 2, kAutomaticTopGrid}) {
          const LightShadow twin = orThrow(LightShadow::create(test::sun(), {test::identityView(n)}, {a}, gridLevels));
          const LightShadow pooled = orThrow(LightShadow::create(test::sun(), {test::identityView(n)}, {b}, gridLevels));
          for (int k : {1, 3, 9, 11}) {
            std::vector<float> expected(points.size()), got(points.size());
            for (size_t at = 0; at < points.size(); at += kLookupBatch) {
              const size_t count = std::min(points.size() - at, kLookupBatch);
              orThrow(twin.visibility({points.data() + at, count}, {k}, {expected.data() + at, count}));
              orThrow(pooled.visibility({points.data() + at, count}, {k}, {got.data() + at, count}));
            }
            EXPECT_EQ(expected, got) << "light " << li << " view " << vi << " grid " << gridLevels << " K=" << k;
          }
        }
      }
  }
}

TEST(Format3, RandomDamageBehindValidChecksumsNeverBreaksAWalk) {
  // Random bytes of the records and the pool changed, checksums made valid again: the reader either rejects the
  // file or every voxel of every view can be looked up through both walks (run under ASan/UBSan to see
  // out-of-bounds reads).
  const RawFile original = unpack(toBytes(writeCpvs(bakedContent(), 3)));
  std::mt19937 rng(2026);
  int opened = 0, rejected = 0;
  for (int iteration = 0; iteration < 1500; ++iteration) {
    const RawFile raw = randomlyDamaged(original, 3, rng);  // VIEW, POOL, HOTT, NODE, LEAF
    std::unique_ptr<CpvsFile> file;
    try {
      file = orThrow(CpvsFile::fromBytes(pack(raw), "fuzz"));
    } catch (const Error& e) {
      ASSERT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
      ++rejected;
      continue;
    }
    ++opened;
    uint64_t answers = 0;
    for (const auto& light : file->lights())
      for (const auto& view : light.views) {
        const uint32_t n = view.view.resolution;
        for (int i = 0; i < 3000; ++i) {
          const uint32_t x = rng() % n, y = rng() % n, z = rng() % n;
          answers += view.dag.shadowed(x, y, z) == view.bytes.shadowed(x, y, z);
          answers += view.bytes.tileMask(x, y, z) != 0;
        }
      }
    EXPECT_GT(answers, 0u);
  }
  EXPECT_GT(opened, 50);
  EXPECT_GT(rejected, 50);
}

}  // namespace
}  // namespace cpvs
