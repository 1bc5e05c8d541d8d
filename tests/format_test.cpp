// The .cpvs container (formats/cpvs/format.md): round trip of baked DAGs, determinism, golden bytes that pin version
// 2.0, 1.0 files that still open (converted) and decode the same, and a reader that rejects every corrupt,
// truncated or foreign input with Error(InputInvalid) — never a crash — while opening later 2.x files.
//
// Regenerate the golden file after a deliberate format change (which must also bump the version):
//   CPVS_UPDATE_GOLDEN=1 ./format_test --gtest_filter='*Golden*'
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <regex>
#include <set>

#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/base/error.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/cpvs_files.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::syntheticDepth;

using namespace cpvsformat;
using namespace test::cpvsfiles;

// ---------------------------------------------------------------------------------------------------------------
// Content

// ---------------------------------------------------------------------------------------------------------------
// Comparisons

void expectSameLight(const Light& a, const Light& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.color, b.color);
  EXPECT_EQ(a.intensity, b.intensity);
  EXPECT_EQ(a.range, b.range);
  EXPECT_EQ(a.innerConeAngle, b.innerConeAngle);
  EXPECT_EQ(a.outerConeAngle, b.outerConeAngle);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.direction, b.direction);
}

void expectSameView(const LightView& a, const LightView& b) {
  EXPECT_EQ(a.projection, b.projection);
  EXPECT_EQ(a.mapping, b.mapping);
  EXPECT_EQ(a.resolution, b.resolution);
  EXPECT_EQ(a.viewFromWorld, b.viewFromWorld);
  EXPECT_EQ(a.xMin, b.xMin);
  EXPECT_EQ(a.xMax, b.xMax);
  EXPECT_EQ(a.yMin, b.yMin);
  EXPECT_EQ(a.yMax, b.yMax);
  EXPECT_EQ(a.near, b.near);
  EXPECT_EQ(a.far, b.far);
  EXPECT_EQ(a.face, b.face);
  EXPECT_EQ(a.empty, b.empty);
}

// sameUnits: the file holds the content's node units as they are (false for a converted 1.0 file, whose
// DAGs must still decode to the same voxels).
void expectSameContent(const CpvsContent& content, const CpvsFile& file, bool sameUnits = true) {
  if (sameUnits) {
    EXPECT_EQ(file.majorVersion(), kCpvsDefaultMajor);
  }
  EXPECT_EQ(file.settingsJson(), content.settingsJson);
  ASSERT_EQ(file.lights().size(), content.lights.size());
  for (size_t li = 0; li < content.lights.size(); ++li) {
    const BakedLight& in = content.lights[li];
    const CpvsFile::LightEntry& out = file.lights()[li];
    expectSameLight(in.light, out.light);
    ASSERT_EQ(out.views.size(), in.views.size());
    for (size_t vi = 0; vi < in.views.size(); ++vi) {
      const BakedView& v = in.views[vi];
      const CpvsFile::View& w = out.views[vi];
      expectSameView(v.view, w.view);
      EXPECT_EQ(w.dag.resolution, v.view.resolution);
      EXPECT_EQ(w.dag.rootCode, v.dag.rootCode);
      if (sameUnits) {
        EXPECT_TRUE(std::ranges::equal(w.dag.nodes, v.dag.nodes));
      }
      EXPECT_TRUE(std::ranges::equal(w.dag.leaves, v.dag.leaves));
      EXPECT_EQ(w.nodesPerLevel, v.dag.nodesPerLevel);
      // Every voxel decodes the same.
      const DagView before = v.dag.view();
      const uint32_t n = v.view.resolution;
      uint64_t differences = 0, shadowed = 0;
      for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
          for (uint32_t x = 0; x < n; ++x) {
            const bool s = before.shadowed(x, y, z);
            differences += s != w.dag.shadowed(x, y, z);
            shadowed += s;
          }
      EXPECT_EQ(differences, 0u) << "light " << li << " view " << vi;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// An independent packer (written from formats/cpvs/format.md, not from the writer) to build files the writer never
// makes: other versions, unknown sections, extended records, and structurally bad DAGs with valid checksums.

const std::string& goldenPath() {
  static const std::string path = test::sourcePath("formats/cpvs/golden/tiny_v2.cpvs");
  return path;
}

Bytes goldenBytes() {
  const Bytes golden = readFile(goldenPath());
  if (golden.empty()) ADD_FAILURE() << goldenPath() << " is missing; run with CPVS_UPDATE_GOLDEN=1 to create it";
  return golden;
}

// ---------------------------------------------------------------------------------------------------------------
// Round trip, determinism, golden bytes

TEST(Format, BakedDagsRoundTripThroughAMappedFile) {
  const CpvsContent content = bakedContent();
  const std::string bytes = writeCpvs(content);
  const std::string path = test::tempDir() + "/baked.cpvs";
  writeFile(path, toBytes(bytes));
  const auto mapped = orThrow(CpvsFile::open(path));
  expectSameContent(content, *mapped);
  EXPECT_EQ(mapped->fileSize(), bytes.size());
  const auto copied = orThrow(CpvsFile::fromBytes(toBytes(bytes), "baked.cpvs"));
  expectSameContent(content, *copied);
  // Node words and leaf masks are used in place, not copied.
  const auto span = mapped->bytes();
  const auto& dag = mapped->lights()[0].views[0].dag;
  EXPECT_GE(reinterpret_cast<const uint8_t*>(dag.nodes.data()), span.data());
  EXPECT_LE(reinterpret_cast<const uint8_t*>(dag.leaves.data() + dag.leaves.size()), span.data() + span.size());
  // The baked content is not trivial.
  EXPECT_EQ(mapped->lights()[0].views[0].dag.rootCode, ChildCode::Ref);
  EXPECT_GT(mapped->lights()[0].views[0].dag.leaves.size(), 10u);
}

// Opening never throws: a failure comes back as an Outcome naming the file.
TEST(Format, OpenFailuresAreOutcomes) {
  const Result<std::unique_ptr<CpvsFile>> missing = CpvsFile::open("/nonexistent/dir/shadows.cpvs");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.outcome().category(), ErrorCategory::InvalidInput);
  EXPECT_NE(missing.outcome().message().find("/nonexistent/dir/shadows.cpvs: cannot open"), std::string::npos);
  const std::vector<uint8_t> text = {'h', 'e', 'l', 'l', 'o'};
  const auto notCpvs = CpvsFile::fromBytes(text, "hello.txt");
  ASSERT_FALSE(notCpvs.ok());
  EXPECT_EQ(notCpvs.outcome().message().rfind("hello.txt: ", 0), 0u) << notCpvs.outcome().message();
}

TEST(Format, SectionsAreAlignedAndNamed) {
  const auto file = orThrow(CpvsFile::fromBytes(toBytes(writeCpvs(bakedContent())), "baked.cpvs"));
  ASSERT_EQ(file->sections().size(), 4u + 2u * 8u);
  EXPECT_EQ(file->sections()[0].type, "BAKE");
  EXPECT_EQ(file->sections()[1].type, "STRS");
  EXPECT_EQ(file->sections()[2].type, "LGHT");
  EXPECT_EQ(file->sections()[3].type, "VIEW");
  for (size_t i = 4; i < file->sections().size(); ++i) EXPECT_EQ(file->sections()[i].type, i % 2 ? "LEAF" : "NODE");
  for (const auto& s : file->sections()) {
    EXPECT_EQ(s.offset % 64, 0u);
    EXPECT_TRUE(s.checksumOk);
  }
}

TEST(Format, WritingIsDeterministic) {
  const std::string a = writeCpvs(bakedContent());
  const std::string b = writeCpvs(bakedContent());
  EXPECT_EQ(a, b);
  // Writing what was read gives the same bytes again.
  const auto file = orThrow(CpvsFile::fromBytes(toBytes(a), "a.cpvs"));
  CpvsContent again;
  again.settingsJson = file->settingsJson();
  for (const auto& l : file->lights()) {
    BakedLight bl{l.light, {}};
    for (const auto& v : l.views) bl.views.push_back({v.view, orThrow(file->ownDag(v))});
    again.lights.push_back(bl);
  }
  EXPECT_EQ(writeCpvs(again), a);
}

TEST(Format, GoldenBytesPinVersion2_0) {
  const std::string bytes = writeCpvs(tinyContent(), 2);
  if (const char* update = std::getenv("CPVS_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::filesystem::create_directories(std::filesystem::path(goldenPath()).parent_path());
    writeFile(goldenPath(), toBytes(bytes));
    GTEST_SKIP() << "wrote " << goldenPath() << " (" << bytes.size() << " bytes)";
  }
  const Bytes golden = goldenBytes();
  // A change that alters these bytes changes the format: bump kCpvsMinorVersion (compatible additions) or
  // the major version, update formats/cpvs/format.md, and regenerate the golden file.
  ASSERT_EQ(toBytes(bytes), golden) << "writeCpvs no longer produces formats/cpvs/golden/tiny_v2.cpvs";
}

TEST(Format, GoldenFileReadsBack) {
  const auto file = orThrow(CpvsFile::open(goldenPath()));
  EXPECT_EQ(file->majorVersion(), 2);
  EXPECT_EQ(file->minorVersion(), 0);
  expectSameContent(tinyContent(), *file);
  // Hand-decoded voxels of the sun's DAG (N = 16).
  const DagView& sun = file->lights()[0].views[0].dag;
  EXPECT_TRUE(sun.shadowed(0, 0, 0));    // root child 0 -> A, slice 0 -> leaf 0 bit 0
  EXPECT_FALSE(sun.shadowed(1, 0, 0));   // leaf 0 bit 1
  EXPECT_TRUE(sun.shadowed(7, 7, 0));    // leaf 0 bit 63
  EXPECT_TRUE(sun.shadowed(0, 0, 1));    // leaf 1 bit 0
  EXPECT_FALSE(sun.shadowed(0, 1, 1));   // leaf 1 bit 8
  EXPECT_TRUE(sun.shadowed(5, 5, 2));    // A slice 2 shadowed
  EXPECT_FALSE(sun.shadowed(5, 5, 3));   // A slice 3 lit
  EXPECT_TRUE(sun.shadowed(9, 3, 6));    // root child 1 shadowed
  EXPECT_FALSE(sun.shadowed(3, 9, 6));   // root child 2 lit
  EXPECT_TRUE(sun.shadowed(0, 0, 8));    // root child 4 -> A again
  const DagView& face0 = file->lights()[2].views[0].dag;
  EXPECT_TRUE(face0.shadowed(4, 0, 0));   // slice 0 -> leaf 0 bit 4
  EXPECT_TRUE(face0.shadowed(1, 1, 2));   // slice 2 shadowed
  EXPECT_TRUE(face0.shadowed(0, 0, 7));   // slice 7 -> leaf 1 (two-unit reference) bit 0
  EXPECT_FALSE(face0.shadowed(1, 0, 7));  // leaf 1 bit 1
  EXPECT_TRUE(file->lights()[2].views[1].dag.shadowed(3, 4, 5));  // all-shadowed face
  EXPECT_FALSE(file->lights()[2].views[3].dag.shadowed(3, 4, 5)); // empty face
  EXPECT_EQ(file->lights()[2].light.name, "bulb");
  EXPECT_TRUE(std::isinf(file->lights()[2].light.range));
}

// formats/cpvs/golden/tiny_v1.cpvs holds the same content in format 1.0 (32-bit words, absolute references), as the
// writer of cpvs 0.1 produced it: it opens, converted, and every voxel decodes the same.
const std::string& format1GoldenPath() {
  static const std::string path = test::sourcePath("formats/cpvs/golden/tiny_v1.cpvs");
  return path;
}

TEST(Format, Format1FilesOpenConvertedAndDecodeTheSame) {
  const auto file = orThrow(CpvsFile::open(format1GoldenPath()));
  EXPECT_EQ(file->majorVersion(), 1);
  EXPECT_EQ(file->minorVersion(), 0);
  expectSameContent(tinyContent(), *file, /*sameUnits=*/false);
  // Converted to the writer's form: the sun's references relative to level 1, all one unit wide.
  const DagView& sun = file->lights()[0].views[0].dag;
  EXPECT_TRUE(std::ranges::equal(sun.nodes, std::vector<uint16_t>{0x206, 0, 0, 0x1A, 0, 1}));
  EXPECT_EQ(file->lights()[0].views[0].nodeBytes, 6u * 4u);  // as stored: six 32-bit words
}

TEST(Format, MalformedFormat1DagsAreRejected) {
  const Bytes v1 = readFile(format1GoldenPath());
  ASSERT_FALSE(v1.empty());
  // Section 4 is the sun's NODE, in 1.0 the words {0x206, 3, 3, 0x1A, 0, 1}.
  auto withWord = [&](size_t word, uint32_t value) {
    RawFile raw = unpack(v1);
    putLE(raw.sections[4].bytes, 4 * word, value, 4);
    return pack(raw);
  };
  EXPECT_NE(openError(withWord(3, 0x1A | 0x10000)).find("invalid header"), std::string::npos);
  EXPECT_NE(openError(withWord(0, 0x206 | 0x3000)).find("invalid header"), std::string::npos);
  EXPECT_NE(openError(withWord(2, 0)).find("not the start"), std::string::npos);   // a loop to the root
  EXPECT_NE(openError(withWord(1, 4)).find("not the start"), std::string::npos);   // into a node
  EXPECT_NE(openError(withWord(5, 2)).find("references leaf 2 of 2"), std::string::npos);
  RawFile odd = unpack(v1);
  odd.sections[4].elementSize = 2;  // a 2.0 NODE in a 1.0 file
  EXPECT_NE(openError(pack(odd)).find("element size"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------------------------
// Corruption: every byte is covered by a checksum or must be zero padding.

TEST(Format, EveryFlippedByteOfTheGoldenFileIsRejected) {
  const Bytes golden = goldenBytes();
  ASSERT_FALSE(golden.empty());
  for (size_t i = 0; i < golden.size(); ++i)
    for (uint8_t flip : {uint8_t(0x01), uint8_t(0x80), uint8_t(0xFF)}) {
      Bytes bad = golden;
      bad[i] ^= flip;
      try {
        orThrow(CpvsFile::fromBytes(bad, "golden"));
        ADD_FAILURE() << "byte " << i << " ^ " << int(flip) << " was not detected";
      } catch (const Error& e) {
        ASSERT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
        ASSERT_EQ(std::string(e.what()).rfind("golden: ", 0), 0u) << e.what();
      }
    }
}

TEST(Format, ChecksumMismatchNamesTheSection) {
  const Bytes golden = goldenBytes();
  const auto file = orThrow(CpvsFile::fromBytes(golden, "g.cpvs"));
  const auto& node = file->sections()[4];
  ASSERT_EQ(node.type, "NODE");
  Bytes bad = golden;
  bad[node.offset + 1] ^= 0x10;
  EXPECT_EQ(openError(bad, "g.cpvs"), "g.cpvs: section 4 'NODE' checksum mismatch \u2014 the file is corrupt");
}

TEST(Format, EveryTruncationIsRejected) {
  const Bytes golden = goldenBytes();
  for (size_t n = 0; n < golden.size(); ++n) {
    const std::string message = openError(Bytes(golden.begin(), golden.begin() + n));
    if (n >= 64) {
      EXPECT_NE(message.find("truncated"), std::string::npos) << message;
    }
  }
  // And a bigger file at every section boundary and just around it.
  const Bytes baked = toBytes(writeCpvs(bakedContent()));
  const auto file = orThrow(CpvsFile::fromBytes(baked, "baked"));
  std::set<uint64_t> cuts;
  for (const auto& s : file->sections())
    for (uint64_t at : {s.offset, s.offset + s.size})
      for (uint64_t d : {0, 1, 63})
        if (at >= d) cuts.insert(at - d);
  for (uint64_t n : cuts)
    if (n < baked.size()) openError(Bytes(baked.begin(), baked.begin() + n));
  // Trailing bytes are rejected too.
  Bytes longer = baked;
  longer.push_back(0);
  EXPECT_NE(openError(longer).find("trailing"), std::string::npos);
}

TEST(Format, ForeignAndTextModeDamagedFilesAreToldApart) {
  EXPECT_NE(openError({}).find("not a .cpvs file"), std::string::npos);
  const Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n', 0, 0, 0, 13};
  EXPECT_NE(openError(png).find("not a .cpvs file"), std::string::npos);
  const std::string json = R"({"asset":{"version":"2.0"}})";
  EXPECT_NE(openError(Bytes(json.begin(), json.end())).find("not a .cpvs file"), std::string::npos);

  const Bytes golden = goldenBytes();
  // CR LF -> LF, as a text-mode download on Windows or a dos2unix would do.
  Bytes unix;
  for (size_t i = 0; i < golden.size(); ++i)
    if (!(golden[i] == '\r' && i + 1 < golden.size() && golden[i + 1] == '\n')) unix.push_back(golden[i]);
  const std::string m1 = openError(unix);
  EXPECT_NE(m1.find("text-mode"), std::string::npos) << m1;
  EXPECT_NE(m1.find("CR LF became LF"), std::string::npos) << m1;
  // LF -> CR LF.
  Bytes dos;
  for (uint8_t c : golden) {
    if (c == '\n') dos.push_back('\r');
    dos.push_back(c);
  }
  EXPECT_NE(openError(dos).find("LF became CR LF"), std::string::npos);
  // 7-bit transfer.
  Bytes stripped = golden;
  for (uint8_t& c : stripped) c &= 0x7F;
  EXPECT_NE(openError(stripped).find("high bit"), std::string::npos);
  // Wrong magic in a file that is otherwise fine.
  Bytes renamed = golden;
  std::memcpy(renamed.data() + 1, "KTX2", 4);
  EXPECT_NE(openError(renamed).find("not a .cpvs file"), std::string::npos);
}

TEST(Format, AnotherMajorVersionIsRejectedWithWhatToDo) {
  RawFile raw = unpack(goldenBytes());
  raw.major = 4;
  EXPECT_EQ(openError(pack(raw), "scene.cpvs"),
            "scene.cpvs: written by format version 4.0; this build reads 1.x, 2.x and 3.x \u2014 update cpvs or re-bake");
  raw.major = 0;
  raw.minor = 9;
  EXPECT_EQ(openError(pack(raw), "old.cpvs"),
            "old.cpvs: written by format version 0.9; this build reads 1.x, 2.x and 3.x \u2014 update cpvs or re-bake");
}

TEST(Format, ALaterMinorVersionOpensAndSkipsWhatItAdds) {
  const Bytes golden = goldenBytes();
  RawFile raw = unpack(golden);
  // The packer's layout (table last) differs from the writer's: still a valid 2.0 file.
  expectSameContent(tinyContent(), *orThrow(CpvsFile::fromBytes(pack(raw), "repacked")));

  raw.minor = 1;
  // A new section type, and 16 more bytes at the end of every light and view record.
  const std::string extra = "a section from the future";
  raw.sections.push_back({fourcc('X', 'T', 'R', 'A'), 1, Bytes(extra.begin(), extra.end())});
  raw.sections.insert(raw.sections.begin() + 2, RawSection{fourcc('Z', 'Z', 'Z', 'Z'), 0, Bytes(100, 0xAB)});
  // (inserting before LGHT shifts the NODE/LEAF indices the views hold: fix them up)
  for (uint32_t type : {kLght, kView}) {
    RawSection& s = sectionOf(raw, type);
    const size_t oldSize = s.elementSize, newSize = oldSize + 16;
    Bytes grown;
    for (size_t r = 0; r < s.bytes.size() / oldSize; ++r) {
      grown.insert(grown.end(), s.bytes.begin() + r * oldSize, s.bytes.begin() + (r + 1) * oldSize);
      grown.insert(grown.end(), 16, uint8_t(0x5A));
    }
    s.bytes = grown;
    s.elementSize = uint32_t(newSize);
  }
  RawSection& views = sectionOf(raw, kView);
  for (size_t r = 0; r < views.bytes.size() / views.elementSize; ++r)
    for (size_t field : {16, 20}) {
      const size_t at = r * views.elementSize + field;
      putLE(views.bytes, at, getLE(views.bytes, at, 4) + 1, 4);
    }
  // Reserved fields may be used by a later minor version.
  putLE(views.bytes, 10, 0x7777, 2);
  const Bytes future = pack(raw);
  const auto file = orThrow(CpvsFile::fromBytes(future, "future.cpvs"));
  EXPECT_EQ(file->minorVersion(), 1);
  expectSameContent(tinyContent(), *file);
  EXPECT_EQ(file->sections().size(), unpack(golden).sections.size() + 2);
  EXPECT_EQ(file->sections().back().type, "XTRA");

  // The same additions claimed by a 2.0 file are errors: 2.0 records have exactly the 2.0 size.
  raw.minor = 0;
  EXPECT_NE(openError(pack(raw)).find("element size"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------------------------
// Structural validation behind valid checksums (what a buggy writer could produce).

struct Mutation {
  std::string name;
  std::function<void(RawFile&)> apply;
  std::string expected;  // a substring of the message
};

void setNodeUnit(RawFile& f, size_t section, size_t unit, uint32_t v) { putLE(f.sections[section].bytes, 2 * unit, v, 2); }
void setView(RawFile& f, size_t view, size_t field, uint64_t v, int n) {
  putLE(sectionOf(f, kView).bytes, view * kViewRecordSize + field, v, n);
}
void setViewF64(RawFile& f, size_t view, size_t field, double v) {
  putF64(sectionOf(f, kView).bytes, view * kViewRecordSize + field, v);
}
void setLight(RawFile& f, size_t light, size_t field, uint64_t v, int n) {
  putLE(sectionOf(f, kLght).bytes, light * kLightRecordSize + field, v, n);
}

TEST(Format, MalformedContentBehindValidChecksumsIsRejected) {
  const Bytes golden = goldenBytes();
  // Golden layout: sections 0..3 BAKE STRS LGHT VIEW, then NODE/LEAF per view; the sun's NODE is section 4:
  // units {0x206, 0, 0, 0x1A, 0, 1}, levels {1, 1} (level 1 starts at unit 3), 2 leaves. The spot's NODE is
  // section 6: {0x480, 0}, 1 leaf.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Mutation> mutations = {
      {"reference into the middle of a node", [](RawFile& f) { setNodeUnit(f, 4, 1, 1); }, "not the start"},
      {"reference past the nodes", [](RawFile& f) { setNodeUnit(f, 4, 1, 60000); }, "not the start"},
      // Child 0 made two units wide: the root takes 4 units, and A's extent no longer ends at the section's end.
      {"a wide code moves the node boundaries", [](RawFile& f) { setNodeUnit(f, 4, 0, 0x207); }, "cover 5 of"},
      {"leaf index out of range", [](RawFile& f) { setNodeUnit(f, 4, 5, 2); }, "references leaf 2 of 2"},
      {"leaf index huge", [](RawFile& f) { setNodeUnit(f, 6, 1, 0xFFFF); }, "references leaf 65535 of 1"},
      {"node runs past the units", [](RawFile& f) { setNodeUnit(f, 4, 3, 0x1A | 0x8000); }, "runs past"},
      {"wide reference runs past the units", [](RawFile& f) { setNodeUnit(f, 4, 3, 0x1A | 0x4); }, "runs past"},
      {"wide leaf reference at the end", [](RawFile& f) { setNodeUnit(f, 6, 0, 0x4C0); }, "runs past"},
      {"level counts do not tile the words", [](RawFile& f) { setView(f, 0, 216, 2, 8); }, "level"},
      {"level count absurd", [](RawFile& f) { setView(f, 0, 224, uint64_t(1) << 62, 8); }, "claims"},
      {"level count missing", [](RawFile& f) { setView(f, 0, 224, 0, 8); }, "cover"},
      {"count beyond the levels", [](RawFile& f) { setView(f, 0, 216 + 8 * 5, 1, 8); }, "beyond"},
      {"root not a node but nodes at level 0", [](RawFile& f) { setView(f, 0, 8, 1, 1); }, "root level"},
      {"root code 3", [](RawFile& f) { setView(f, 0, 8, 3, 1); }, "root code"},
      {"resolution not a power of two", [](RawFile& f) { setView(f, 0, 4, 24, 4); }, "resolution 24"},
      {"resolution too large", [](RawFile& f) { setView(f, 0, 4, 1u << 21, 4); }, "resolution"},
      {"resolution vs levels", [](RawFile& f) { setView(f, 0, 4, 32, 4); }, "DAG levels"},
      {"projection", [](RawFile& f) { setView(f, 0, 0, 2, 1); }, "projection"},
      {"mapping", [](RawFile& f) { setView(f, 0, 1, 7, 1); }, "mapping"},
      {"face", [](RawFile& f) { setView(f, 0, 2, 6, 1); }, "cube face"},
      {"unknown view flag in 2.0", [](RawFile& f) { setView(f, 0, 3, 2, 1); }, "flags"},
      {"near after far", [](RawFile& f) { setViewF64(f, 0, 200, 100.0); }, "near"},
      {"NaN bound", [nan](RawFile& f) { setViewF64(f, 0, 168, nan); }, "not finite"},
      {"empty lateral extent", [](RawFile& f) { setViewF64(f, 0, 176, -1.5); }, "lateral extent"},
      {"infinite matrix", [](RawFile& f) { setViewF64(f, 0, 40, INFINITY); }, "viewFromWorld"},
      // Finite but absurd: an infinite width once subtracted, or a matrix that overflows a mapped point.
      {"bounds of 1e308", [](RawFile& f) { setViewF64(f, 0, 168, -1e308); setViewF64(f, 0, 176, 1e308); }, "beyond"},
      {"far of 1e308", [](RawFile& f) { setViewF64(f, 0, 208, 1e308); }, "beyond"},
      {"matrix element of 1e308", [](RawFile& f) { setViewF64(f, 0, 48, 1e308); }, "viewFromWorld element"},
      {"extent too small for N", [](RawFile& f) { setViewF64(f, 0, 168, 0.0); setViewF64(f, 0, 176, 1e-320); },
       "too small"},
      {"log depth with near 0", [](RawFile& f) { setViewF64(f, 1, 200, 0.0); }, "near > 0"},
      {"node section index", [](RawFile& f) { setView(f, 0, 16, 5, 4); }, "'NODE'"},
      {"leaf section index", [](RawFile& f) { setView(f, 0, 20, 99, 4); }, "'LEAF'"},
      {"node unit count", [](RawFile& f) { setView(f, 0, 24, 7, 8); }, "node units"},
      {"leaf count", [](RawFile& f) { setView(f, 0, 32, uint64_t(1) << 40, 8); }, "leaves"},
      {"view of another light", [](RawFile& f) { setView(f, 0, 12, 1, 4); }, "belongs to light"},
      {"light type", [](RawFile& f) { setLight(f, 0, 0, 3, 4); }, "light type"},
      {"name outside the pool", [](RawFile& f) { setLight(f, 1, 4, 1000, 4); }, "string pool"},
      {"name length overflow", [](RawFile& f) { setLight(f, 1, 8, 0xFFFFFFFFu, 4); }, "string pool"},
      {"views out of order", [](RawFile& f) { setLight(f, 1, 12, 0, 4); }, "do not follow"},
      {"too many views", [](RawFile& f) { setLight(f, 2, 16, 7, 4); }, "do not follow"},
      {"orphan views", [](RawFile& f) {
         Bytes& views = sectionOf(f, kView).bytes;
         const Bytes last(views.end() - ptrdiff_t(kViewRecordSize), views.end());
         views.insert(views.end(), last.begin(), last.end());
       }, "belong to no light"},
      {"point light with five views", [](RawFile& f) { setLight(f, 2, 16, 5, 4); }, "a point light has 6"},
      {"cube faces out of order", [](RawFile& f) { setView(f, 2, 2, 3, 1); }, "cube face 3 (expected 0)"},
      {"spot view on a cube face", [](RawFile& f) { setView(f, 1, 2, 0, 1); }, "cube face 0 (expected -1)"},
      {"NaN range", [nan](RawFile& f) { putF64(sectionOf(f, kLght).bytes, 40, nan); }, "range"},
      {"zero range", [](RawFile& f) { putF64(sectionOf(f, kLght).bytes, 40, 0.0); }, "range"},
      {"NaN colour", [](RawFile& f) { setLight(f, 0, 24, 0x7FC00000u, 4); }, "not finite"},
      {"reserved light field in 2.0", [](RawFile& f) { setLight(f, 0, 36, 1, 4); }, "reserved"},
      {"record size", [](RawFile& f) { sectionOf(f, kView).bytes.push_back(0); }, "multiple"},
      {"NODE element size", [](RawFile& f) { f.sections[4].elementSize = 8; }, "element size"},
      {"odd NODE size", [](RawFile& f) { f.sections[4].bytes.push_back(0); }, "multiple"},
      {"two LGHT sections", [](RawFile& f) { f.sections.push_back(sectionOf(f, kLght)); }, "two 'LGHT'"},
      {"no VIEW section", [](RawFile& f) { sectionOf(f, kView).type = fourcc('W', 'E', 'I', 'V'); }, "no 'VIEW'"},
      {"unprintable type", [](RawFile& f) { f.sections[0].type = 0x01020304; }, "printable"},
  };
  for (const Mutation& m : mutations) {
    RawFile raw = unpack(golden);
    m.apply(raw);
    const std::string message = openError(pack(raw), "bad.cpvs");
    EXPECT_EQ(message.rfind("bad.cpvs: ", 0), 0u) << m.name << ": " << message;
    EXPECT_NE(message.find(m.expected), std::string::npos) << m.name << ": " << message;
  }
}

TEST(Format, RandomDamageBehindValidChecksumsNeverBreaksTraversal) {
  // Random bytes of the records and DAGs changed, checksums made valid again: the reader either rejects the
  // file or every voxel of every view can be looked up (run under ASan/UBSan to see out-of-bounds reads).
  const RawFile original = unpack(goldenBytes());
  std::mt19937 rng(12345);
  int opened = 0, rejected = 0;
  for (int iteration = 0; iteration < 4000; ++iteration) {
    const RawFile raw = randomlyDamaged(original, 2, rng);  // LGHT, VIEW, NODE, LEAF
    std::unique_ptr<CpvsFile> file;
    try {
      file = orThrow(CpvsFile::fromBytes(pack(raw), "fuzz"));
    } catch (const Error& e) {
      ASSERT_EQ(e.category(), ErrorCategory::InvalidInput);
      ++rejected;
      continue;
    }
    ++opened;
    uint64_t shadowed = 0;
    for (const auto& light : file->lights())
      for (const auto& view : light.views) {
        const uint32_t n = view.dag.resolution;
        if (n > 32) {  // a damaged resolution that still validates: sample it
          for (int i = 0; i < 10000; ++i) shadowed += view.dag.shadowed(rng() % n, rng() % n, rng() % n);
          continue;
        }
        for (uint32_t z = 0; z < n; ++z)
          for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) shadowed += view.dag.shadowed(x, y, z);
      }
    EXPECT_GT(shadowed, 0u);
  }
  // Both outcomes happen: float fields and leaf masks take any value, structure does not.
  EXPECT_GT(opened, 100);
  EXPECT_GT(rejected, 100);
}

TEST(Format, LayoutErrorsInTheTableAreRejected) {
  const Bytes golden = goldenBytes();
  // Rewrites one table entry and fixes the table and header checksums, so only the layout is wrong.
  auto withEntry = [&](size_t index, size_t field, uint64_t value, int n) {
    Bytes b = golden;
    const uint64_t table = getLE(b, 24, 8), count = getLE(b, 16, 4);
    putLE(b, table + 32 * index + field, value, n);
    putLE(b, 40, XXH3_64bits(b.data() + table, 32 * count), 8);
    putLE(b, 56, XXH3_64bits(b.data(), 56), 8);
    return b;
  };
  const auto file = orThrow(CpvsFile::fromBytes(golden, "g"));
  const auto& s = file->sections();
  EXPECT_NE(openError(withEntry(4, 8, s[4].offset + 8, 8)).find("aligned"), std::string::npos);
  EXPECT_NE(openError(withEntry(4, 8, 1ull << 40, 8)).find("past the end"), std::string::npos);
  EXPECT_NE(openError(withEntry(4, 16, ~0ull - 3, 8)).find("past the end"), std::string::npos);
  // Section 4 made to cover section 5 as well: overlap (its checksum is recomputed to match).
  {
    Bytes b = withEntry(4, 16, s[5].offset + s[5].size - s[4].offset, 8);
    const uint64_t table = getLE(b, 24, 8), count = getLE(b, 16, 4);
    putLE(b, table + 32 * 4 + 24, XXH3_64bits(b.data() + s[4].offset, s[5].offset + s[5].size - s[4].offset), 8);
    putLE(b, 40, XXH3_64bits(b.data() + table, 32 * count), 8);
    putLE(b, 56, XXH3_64bits(b.data(), 56), 8);
    EXPECT_NE(openError(b).find("overlap"), std::string::npos);
  }
  // Section count or table offset beyond the file.
  auto withHeader = [&](size_t field, uint64_t value, int n) {
    Bytes b = golden;
    putLE(b, field, value, n);
    putLE(b, 56, XXH3_64bits(b.data(), 56), 8);
    return b;
  };
  EXPECT_NE(openError(withHeader(16, 0xFFFFFFFFu, 4)).find("section table"), std::string::npos);
  EXPECT_NE(openError(withHeader(24, 1ull << 63, 8)).find("section table"), std::string::npos);
  EXPECT_NE(openError(withHeader(24, 0, 8)).find("section table"), std::string::npos);
  EXPECT_NE(openError(withHeader(12, 128, 4)).find("header size"), std::string::npos);
  EXPECT_NE(openError(withHeader(20, 1, 4)).find("reserved"), std::string::npos);
  // Non-zero padding between sections (not covered by a checksum, so it must be zero).
  Bytes padded = golden;
  const uint64_t gap = s[0].offset + s[0].size;
  ASSERT_LT(gap, s[1].offset);
  padded[gap] = 1;
  EXPECT_NE(openError(padded).find("padding byte at offset " + std::to_string(gap)), std::string::npos);
}

TEST(Format, TheWriterRefusesContentThatWouldNotReadBack) {
  auto expectRefused = [](const CpvsContent& c, const std::string& expected) {
    try {
      writeCpvs(c);
      ADD_FAILURE() << "written: " << expected;
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::RuntimeFailure);
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  CpvsContent c = tinyContent();
  c.lights[0].views[0].dag.nodes[1] = 4;
  expectRefused(c, "not the start");
  c = tinyContent();
  c.lights[1].views[0].view.near = 0;
  expectRefused(c, "near > 0");
  c = tinyContent();
  c.lights[1].views[0].view.resolution = 16;
  expectRefused(c, "differs from the view's");
  c = tinyContent();
  c.lights[2].views[0].view.face = 9;
  expectRefused(c, "cube face");
}

TEST(Format, OpenNamesTheFile) {
  const std::string dir = test::tempDir();
  try {
    orThrow(CpvsFile::open(dir + "/missing.cpvs"));
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidInput);
    EXPECT_EQ(std::string(e.what()).rfind(dir + "/missing.cpvs: cannot open", 0), 0u) << e.what();
  }
  EXPECT_THROW(orThrow(CpvsFile::open(dir)), Error);
  writeFile(dir + "/empty.cpvs", {});
  try {
    orThrow(CpvsFile::open(dir + "/empty.cpvs"));
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a .cpvs file"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// The runtime side (cpvs_runtime: libcpvs/runtime) needs no GL, Embree, glTF or JSON: follow its includes.

TEST(Format, RuntimeSourcesIncludeNoBakerDependencies) {
  const std::filesystem::path root = CPVS_SOURCE_DIR;
  std::vector<std::string> pending;
  for (const auto& entry : std::filesystem::directory_iterator(root / "libcpvs/runtime"))
    pending.push_back(std::filesystem::relative(entry.path(), root).string());
  std::set<std::string> seen, system;
  const std::regex include(R"re(^\s*#\s*include\s*([<"])([^>"]+)[>"])re");
  while (!pending.empty()) {
    const std::string file = pending.back();
    pending.pop_back();
    if (!seen.insert(file).second) continue;
    std::ifstream in(root / file);
    ASSERT_TRUE(in) << file;
    std::string line;
    std::smatch m;
    while (std::getline(in, line))
      if (std::regex_search(line, m, include)) {
        if (m[1] == "\"" && std::filesystem::exists(root / m[2].str()))
          pending.push_back(m[2].str());
        else
          system.insert(m[2].str());
      }
  }
  EXPECT_TRUE(seen.count("libcpvs/runtime/shadow_dag.h"));
  EXPECT_TRUE(system.count("xxhash.h"));
  for (const std::string& header : system)
    for (const char* banned : {"embree", "GL/", "EGL", "GLES", "osmesa", "nlohmann", "tiny_gltf", "OpenEXR", "Imf",
                               "tbb", "CLI/", "depth_renderer", "gltf"})
      EXPECT_EQ(header.find(banned), std::string::npos) << header << " reached from libcpvs/runtime";
  for (const std::string& file : seen)
    for (const char* banned : {"raster/", "reference/", "libcpvs/import", "tools/"})
      EXPECT_EQ(file.find(banned), std::string::npos) << file << " reached from libcpvs/runtime";
}

}  // namespace
}  // namespace cpvs
