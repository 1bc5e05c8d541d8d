// cpvs-info on .cpvs files: a real bake of the Tiny scene is shown with its header, settings,
// lights, views, DAG levels, bytes and checksums, as text and as JSON that agrees with the runtime reader; the
// kind of input is decided by the magic, not the name; and corrupt copies (flipped bytes in every part of the
// file, cuts at and around every section boundary, foreign magic, text-mode damage, a future major version)
// are rejected with exit code 2 and a message that names the file — never a crash. The bake is a format 2.0
// file (16-bit node units); a format 1.0 file (32-bit node words, formats/cpvs/golden/tiny_v1.cpvs) is shown in words.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <nlohmann/json.hpp>
#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/version.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using json = nlohmann::json;
using Bytes = std::vector<uint8_t>;
using test::runTool;
using test::sourcePath;
using test::tempDir;
using test::toolPath;

Bytes readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeFile(const std::string& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

void putLE(Bytes& b, size_t at, uint64_t v, int n) {
  for (int i = 0; i < n; ++i) b[at + i] = uint8_t(v >> (8 * i));
}

// Recomputes the header checksum after a deliberate header edit (a genuine file of another version).
void resealHeader(Bytes& b) { putLE(b, 56, XXH3_64bits(b.data(), 56), 8); }

std::string info() { return toolPath("cpvs-info"); }

// One real bake shared by the tests: the Tiny scene at N = 64 with a sun, a spot and a point light (eight
// views: the point light's six cube faces included), made once per test program.
class CpvsInfo : public ::testing::Test {
protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(tempDir());
    path_ = new std::string(*dir_ + "/tiny64.cpvs");
    const auto r = runTool(toolPath("cpvs-bake") + " " + sourcePath("data/scenes/Tiny/tiny.gltf") + " -o " + *path_ +
                           " --resolution 64 --quiet --sun 0.3,-1,0.2 --spot 0,5,0,0,-1,0,0.6,20 --point 0.5,3,1.5,0");
    bakeOutput_ = new std::string(r.output);
    bakeExit_ = r.exitCode;
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*dir_);
    delete dir_;
    delete path_;
    delete bakeOutput_;
  }
  void SetUp() override {
    ASSERT_EQ(bakeExit_, 0) << *bakeOutput_;
    bytes_ = readFile(*path_);
    ASSERT_GT(bytes_.size(), 1000u);
    file_ = orThrow(CpvsFile::open(*path_));
  }

  // Writes `bytes` as a new file in a fresh directory and runs cpvs-info on it.
  test::ToolResult runOn(const Bytes& bytes, const std::string& name, const std::string& options = "") {
    const std::string path = scratch() + "/" + name;
    writeFile(path, bytes);
    return runTool(info() + " " + options + " " + path);
  }
  // cpvs-info --json on `path`: stdout alone (stderr goes to the tool result), parsed.
  json jsonOf(const std::string& path, int expectedExit) {
    const std::string out = scratch() + "/info.json";
    const auto r = runTool("{ " + info() + " --json " + path + " > " + out + "; }");  // runTool adds 2>&1
    EXPECT_EQ(r.exitCode, expectedExit) << r.output;
    const Bytes text = readFile(out);
    return json::parse(std::string(text.begin(), text.end()));
  }
  const std::string& scratch() {
    if (scratch_.empty()) scratch_ = tempDir();
    return scratch_;
  }

  // The contract for a rejected file: exit code 2 (not a signal, not a crash), the file named, no report on
  // stdout that could pass for a valid one.
  static void expectRejected(const test::ToolResult& r, const std::string& name, const std::string& what) {
    EXPECT_EQ(r.exitCode, 2) << what << "\n" << r.output;
    EXPECT_NE(r.output.find(name + ": "), std::string::npos) << what << "\n" << r.output;
    EXPECT_NE(r.output.find("cpvs-info: error: "), std::string::npos) << what << "\n" << r.output;
    EXPECT_EQ(r.output.find("sections ok"), std::string::npos) << what << "\n" << r.output;
  }

  static std::string* dir_;
  static std::string* path_;
  static std::string* bakeOutput_;
  static int bakeExit_;
  Bytes bytes_;
  std::unique_ptr<CpvsFile> file_;
  std::string scratch_;
};
std::string* CpvsInfo::dir_ = nullptr;
std::string* CpvsInfo::path_ = nullptr;
std::string* CpvsInfo::bakeOutput_ = nullptr;
int CpvsInfo::bakeExit_ = -1;

// ---------------------------------------------------------------------------------------------------------------
// A valid file

TEST_F(CpvsInfo, TextShowsHeaderSettingsLightsViewsAndChecksums) {
  const auto r = runTool(info() + " " + *path_);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::string& out = r.output;
  auto has = [&](const std::string& s) { EXPECT_NE(out.find(s), std::string::npos) << "missing '" << s << "' in\n" << out; };
  has("file: " + *path_ + "\n");
  has("format: .cpvs 2.0 (this build reads 1.x to 3.x and writes 2.0, or 3.0 with --format-version 3)\n");
  has("tool: cpvs-bake " + std::string(kVersion) + "\n");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("input hash: ([0-9a-f]{16})\n"))) << out;
  ASSERT_NE(file_->settingsJson().find("\"input_hash\":\"" + m[1].str() + "\""), std::string::npos);
  has("resolution=64");
  has("undefined=kampe");
  has("node_reuse=true");
  has("lights (3):\n");
  has("light 0: directional 'sun0': direction (0.282216, -0.940721, 0.188144) colour (1, 1, 1) intensity 1\n");
  has("light 1: spot 'spot0': position (0, 5, 0) direction (0, -1, 0) colour (1, 1, 1) intensity 1 range 20 "
      "cone 0..0.6 rad\n");
  has("light 2: point 'point0': position (0.5, 3, 1.5) colour (1, 1, 1) intensity 1 range inf\n");
  has("view 0: N 64, orthographic, linear depth, near ");
  has("view 0: N 64, perspective, logarithmic depth, near ");
  for (const char* face : {"+X", "-X", "+Y", "-Y", "+Z", "-Z"}) has(std::string("(face ") + face + "): N 64, perspective");
  // Per view: the node counts of the four levels of N = 64, node units (u16, used in place: the reader's span
  // is the view's NODE section, sections 4, 6, 8, ...), unique leaves and bytes, as the reader sees them.
  size_t nodeSection = 4;
  for (const auto& light : file_->lights())
    for (const auto& v : light.views) {
      std::string levels;
      uint64_t nodes = 0;
      for (uint64_t c : v.nodesPerLevel) {
        levels.append(" ").append(std::to_string(c));  // (not " " + string: a false GCC 12 -Wrestrict)
        nodes += c;
      }
      ASSERT_EQ(file_->sections()[nodeSection].type, "NODE");
      const uint64_t nodeBytes = file_->sections()[nodeSection].size;
      EXPECT_EQ(nodeBytes, v.dag.nodes.size() * 2);
      nodeSection += 2;
      has("nodes per level (root first):" + levels + " = " + std::to_string(nodes) + " nodes in " +
          std::to_string(v.dag.nodes.size()) + " units (" + std::to_string(nodeBytes) + " bytes); unique leaves " +
          std::to_string(v.dag.leaves.size()) + " (" + std::to_string(v.dag.leaves.size() * 8) + " bytes); " +
          std::to_string(nodeBytes + v.dag.leaves.size() * 8) + " bytes\n");
    }
  EXPECT_EQ(out.find(" words ("), std::string::npos) << out;
  has("sections (20):\n");
  for (const auto& s : file_->sections()) {
    char checksum[20];
    std::snprintf(checksum, sizeof checksum, "%016llx", static_cast<unsigned long long>(s.checksum));
    has(s.type + " " + std::string(std::max<int>(1, 11 - int(std::to_string(s.offset).size())), ' ') +
        std::to_string(s.offset));
    has(std::string(checksum) + "  ok\n");
  }
  has("checksums (XXH3-64): header ok, section table ok, 20 of 20 sections ok\n");
  has("total: " + std::to_string(bytes_.size()) + " bytes = header 64 + section table 640 + sections ");
  has("in 8 views of 3 lights\n");
}

TEST_F(CpvsInfo, JsonAgreesWithTheReader) {
  const json j = jsonOf(*path_, 0);
  EXPECT_EQ(j["file"], *path_);
  EXPECT_EQ(j["kind"], "cpvs");
  EXPECT_EQ(j["valid"], true);
  EXPECT_EQ(j["formatVersion"], "2.0");
  EXPECT_EQ(j["major"], 2);
  EXPECT_EQ(j["minor"], 0);
  EXPECT_EQ(j["header"]["size"], 64);
  EXPECT_EQ(j["header"]["flags"], 0);
  EXPECT_EQ(j["header"]["sectionCount"], file_->sections().size());
  EXPECT_EQ(j["header"]["fileSize"], bytes_.size());
  EXPECT_EQ(j["header"]["checksumOk"], true);
  EXPECT_EQ(j["header"]["sectionTableChecksumOk"], true);
  EXPECT_EQ(j["tool"], "cpvs-bake");
  EXPECT_EQ(j["toolVersion"], kVersion);
  // The settings are the BAKE block itself, and the input hash is the one in it.
  EXPECT_EQ(j["settings"], json::parse(file_->settingsJson()));
  EXPECT_EQ(j["settings"]["resolution"], 64);
  EXPECT_EQ(j["settings"]["undefined"], "kampe");
  EXPECT_EQ(j["inputHash"], j["settings"]["input_hash"]);
  EXPECT_TRUE(std::regex_match(j["inputHash"].get<std::string>(), std::regex("[0-9a-f]{16}")));

  ASSERT_EQ(j["lights"].size(), file_->lights().size());
  ASSERT_EQ(j["lights"].size(), 3u);
  const char* types[] = {"directional", "spot", "point"};
  const char* faces[] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  size_t views = 0;
  uint64_t dagBytes = 0;
  size_t nodeSection = 4;  // BAKE STRS LGHT VIEW, then NODE LEAF per view
  for (size_t li = 0; li < 3; ++li) {
    const json& jl = j["lights"][li];
    const auto& fl = file_->lights()[li];
    EXPECT_EQ(jl["index"], li);
    EXPECT_EQ(jl["name"], fl.light.name);
    EXPECT_EQ(jl["type"], types[li]);
    EXPECT_EQ(jl["color"], json::array({1.0, 1.0, 1.0}));
    EXPECT_EQ(jl["intensity"], 1.0);
    ASSERT_EQ(jl["views"].size(), fl.views.size());
    for (size_t vi = 0; vi < fl.views.size(); ++vi) {
      const json& jv = jl["views"][vi];
      const auto& fv = fl.views[vi];
      if (li == 2)
        EXPECT_EQ(jv["face"], faces[vi]);
      else
        EXPECT_TRUE(jv["face"].is_null());
      EXPECT_EQ(jv["resolution"], 64);
      EXPECT_EQ(jv["projection"], li == 0 ? "orthographic" : "perspective");
      EXPECT_EQ(jv["depthMapping"], li == 0 ? "linear" : "logarithmic");
      EXPECT_EQ(jv["near"].get<double>(), fv.view.near);
      EXPECT_EQ(jv["far"].get<double>(), fv.view.far);
      EXPECT_EQ(jv["xMin"].get<double>(), fv.view.xMin);
      EXPECT_EQ(jv["yMax"].get<double>(), fv.view.yMax);
      ASSERT_EQ(jv["viewFromWorld"].size(), 16u);
      for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row)
          EXPECT_EQ(jv["viewFromWorld"][4 * c + row].get<double>(), fv.view.viewFromWorld[c][row]);
      EXPECT_EQ(jv["empty"], fv.view.empty);
      EXPECT_EQ(jv["levels"], 4);
      EXPECT_EQ(jv["nodesPerLevel"].get<std::vector<uint64_t>>(), fv.nodesPerLevel);
      EXPECT_FALSE(jv.contains("nodeWords"));  // format 1's name
      EXPECT_EQ(jv["nodeUnits"], fv.dag.nodes.size());
      ASSERT_EQ(file_->sections()[nodeSection].type, "NODE");
      EXPECT_EQ(jv["nodeBytes"], file_->sections()[nodeSection].size);
      EXPECT_EQ(jv["nodeBytes"], fv.dag.nodes.size() * 2);
      nodeSection += 2;
      EXPECT_EQ(jv["uniqueLeaves"], fv.dag.leaves.size());
      EXPECT_EQ(jv["bytes"], fv.dag.nodes.size() * 2 + fv.dag.leaves.size() * 8);
      EXPECT_EQ(jv["rootCode"], fv.dag.rootCode == ChildCode::Ref ? "ref" : fv.dag.rootCode == ChildCode::Lit ? "lit" : "shadowed");
      ++views;
      dagBytes += jv["bytes"].get<uint64_t>();
    }
  }
  // The spot's record, field by field.
  const json& spot = j["lights"][1];
  EXPECT_EQ(spot["range"], 20.0);
  EXPECT_EQ(spot["outerConeAngle"], 0.6);
  EXPECT_EQ(spot["innerConeAngle"], 0.0);
  EXPECT_EQ(spot["position"], json::array({0.0, 5.0, 0.0}));
  EXPECT_EQ(spot["direction"], json::array({0.0, -1.0, 0.0}));
  EXPECT_TRUE(j["lights"][2]["range"].is_null());  // unlimited
  EXPECT_FALSE(j["lights"][0].contains("range"));   // a sun has none

  ASSERT_EQ(j["sections"].size(), file_->sections().size());
  uint64_t sectionBytes = 0;
  for (size_t i = 0; i < file_->sections().size(); ++i) {
    const auto& s = file_->sections()[i];
    const json& js = j["sections"][i];
    EXPECT_EQ(js["type"], s.type);
    EXPECT_EQ(js["offset"], s.offset);
    EXPECT_EQ(js["size"], s.size);
    EXPECT_EQ(js["elementSize"], s.elementSize);
    char checksum[20];
    std::snprintf(checksum, sizeof checksum, "%016llx", static_cast<unsigned long long>(s.checksum));
    EXPECT_EQ(js["checksum"], checksum);
    EXPECT_EQ(js["checksumOk"], true);
    sectionBytes += s.size;
  }
  EXPECT_EQ(j["totals"]["lights"], 3);
  EXPECT_EQ(j["totals"]["views"], views);
  EXPECT_EQ(views, 8u);
  EXPECT_EQ(j["totals"]["dagBytes"], dagBytes);
  EXPECT_EQ(j["totals"]["sectionBytes"], sectionBytes);
  EXPECT_EQ(j["totals"]["bytes"], bytes_.size());
  EXPECT_EQ(j["totals"]["headerBytes"].get<uint64_t>() + j["totals"]["sectionTableBytes"].get<uint64_t>() +
                sectionBytes + j["totals"]["paddingBytes"].get<uint64_t>(),
            bytes_.size());
}

TEST_F(CpvsInfo, TheKindOfInputIsDecidedByTheMagicNotTheName) {
  // A .cpvs named like a scene, and a scene named like a .cpvs.
  const auto asScene = runOn(bytes_, "looks-like-a-scene.gltf");
  EXPECT_EQ(asScene.exitCode, 0) << asScene.output;
  EXPECT_NE(asScene.output.find("format: .cpvs 2.0"), std::string::npos) << asScene.output;
  const auto asCpvs = runOn(readFile(sourcePath("data/scenes/Tiny/tiny.gltf")), "looks-like-a-bake.cpvs");
  EXPECT_EQ(asCpvs.exitCode, 0) << asCpvs.output;
  EXPECT_NE(asCpvs.output.find("Box: 12 triangles, closed"), std::string::npos) << asCpvs.output;
  // Light options describe scenes; a .cpvs holds its own lights.
  const auto withSun = runTool(info() + " --sun 0,-1,0 " + *path_);
  EXPECT_EQ(withSun.exitCode, 1) << withSun.output;
  EXPECT_NE(withSun.output.find(*path_), std::string::npos) << withSun.output;
}

TEST_F(CpvsInfo, ALaterMinorVersionIsShownAsSuch) {
  Bytes later = bytes_;
  putLE(later, 10, 3, 2);
  resealHeader(later);
  const auto r = runOn(later, "later.cpvs");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("format: .cpvs 2.3 (this build reads 1.x to 3.x and writes 2.0, or 3.0 with --format-version 3)"), std::string::npos)
      << r.output;
}

// A format 1.0 file is still read (its DAGs converted to 16-bit units on open) and shown as it is stored: node
// words (u32) and the NODE section's bytes in the file; the JSON gives the converted units and the file's bytes.
TEST_F(CpvsInfo, AFormat1FileIsShownInWords) {
  const std::string v1 = sourcePath("formats/cpvs/golden/tiny_v1.cpvs");
  const auto old = orThrow(CpvsFile::open(v1));
  ASSERT_EQ(old->majorVersion(), 1);
  const auto r = runTool(info() + " " + v1);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("format: .cpvs 1.0 (this build reads 1.x to 3.x and writes 2.0, or 3.0 with --format-version 3)\n"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find(" units ("), std::string::npos) << r.output;
  const json j = jsonOf(v1, 0);
  EXPECT_EQ(j["formatVersion"], "1.0");
  size_t nodeSection = 4, views = 0, nonEmpty = 0;
  uint64_t dagBytes = 0;
  for (size_t li = 0; li < old->lights().size(); ++li)
    for (size_t vi = 0; vi < old->lights()[li].views.size(); ++vi) {
      const auto& v = old->lights()[li].views[vi];
      const json& jv = j["lights"][li]["views"][vi];
      const auto& node = old->sections()[nodeSection];
      ASSERT_EQ(node.type, "NODE");
      ASSERT_EQ(node.elementSize, 4u);
      nodeSection += 2;
      uint64_t nodes = 0;
      for (uint64_t c : v.nodesPerLevel) nodes += c;
      const uint64_t bytes = node.size + v.dag.leaves.size() * 8;
      EXPECT_NE(r.output.find(" = " + std::to_string(nodes) + " nodes in " + std::to_string(node.size / 4) +
                              " words (" + std::to_string(node.size) + " bytes); unique leaves " +
                              std::to_string(v.dag.leaves.size()) + " (" + std::to_string(v.dag.leaves.size() * 8) +
                              " bytes); " + std::to_string(bytes) + " bytes\n"),
                std::string::npos)
          << r.output;
      EXPECT_EQ(jv["nodeUnits"], v.dag.nodes.size());
      EXPECT_EQ(jv["nodeBytes"], node.size);
      EXPECT_EQ(jv["bytes"], bytes);
      if (node.size > 0) {
        ++nonEmpty;
        EXPECT_LT(v.dag.nodes.size() * 2, node.size);  // converted: smaller than the file's words
      }
      ++views;
      dagBytes += bytes;
    }
  EXPECT_EQ(views, 8u);
  EXPECT_GT(nonEmpty, 0u);
  EXPECT_EQ(j["totals"]["dagBytes"], dagBytes);
}

TEST_F(CpvsInfo, AFormat3FileShowsItsPool) {
  const std::string v3 = scratch() + "/tiny64_v3.cpvs";
  const auto bake = runTool(toolPath("cpvs-bake") + " " + sourcePath("data/scenes/Tiny/tiny.gltf") + " -o " + v3 +
                            " --resolution 64 --quiet --sun 0.3,-1,0.2 --spot 0,5,0,0,-1,0,0.6,20 --point 0.5,3,1.5,0"
                            " --format-version 3");
  ASSERT_EQ(bake.exitCode, 0) << bake.output;
  const auto pooled = orThrow(CpvsFile::open(v3));
  ASSERT_EQ(pooled->majorVersion(), 3);
  const auto r = runTool(info() + " " + v3);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("format: .cpvs 3.0 ("), std::string::npos) << r.output;
  // Every view as the 2.0 bake of the same lights shows it (the same nodes and leaves), in the pool.
  uint64_t viewsAs2 = 0, poolNodes = 0;
  for (size_t li = 0; li < file_->lights().size(); ++li)
    for (size_t vi = 0; vi < file_->lights()[li].views.size(); ++vi) {
      const auto& v = file_->lights()[li].views[vi];
      uint64_t nodes = 0;
      for (uint64_t c : v.nodesPerLevel) nodes += c;
      const uint64_t bytes = v.nodeBytes + v.dag.leaves.size() * 8;
      EXPECT_EQ(orThrow(pooled->ownDag(pooled->lights()[li].views[vi])).nodesPerLevel, v.nodesPerLevel);
      if (v.dag.rootCode == ChildCode::Ref) {
        EXPECT_NE(r.output.find(" = " + std::to_string(nodes) + " nodes, unique leaves " +
                                std::to_string(v.dag.leaves.size()) + ", in the pool (as a 2.0 DAG: " +
                                std::to_string(bytes) + " bytes)\n"),
                  std::string::npos)
            << r.output;
      }
      viewsAs2 += bytes;
    }
  uint64_t poolBytes = 3 + pooled->poolLeaves() * 8;
  // The reader's in-memory form: one array of 2.0 units that every view's DagView is a tail of.
  const uint64_t sharedUnits = pooled->lights()[0].views[0].dag.sharedNodes.size_bytes();
  EXPECT_GT(sharedUnits, 0u);
  for (const auto& level : pooled->poolLevels()) {
    poolNodes += level.nodes;
    poolBytes += level.bytes + 4 * level.hotEntries;
  }
  EXPECT_NE(r.output.find("pool: " + std::to_string(pooled->poolLevels().size()) + " levels, " +
                          std::to_string(poolNodes) + " nodes, " + std::to_string(pooled->poolLeaves()) + " leaves, " +
                          std::to_string(poolBytes) + " bytes (its views as 2.0 DAGs: " + std::to_string(viewsAs2) +
                          " bytes; read as one array of 2.0 node units: " + std::to_string(sharedUnits) + " bytes)\n"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("  edge 8: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; DAGs " + std::to_string(poolBytes) + " bytes in 8 views"), std::string::npos) << r.output;
  EXPECT_LT(poolBytes, viewsAs2);
  const json j = jsonOf(v3, 0);
  EXPECT_EQ(j["formatVersion"], "3.0");
  ASSERT_TRUE(j["pool"].is_object());
  EXPECT_EQ(j["pool"]["bytes"], poolBytes);
  EXPECT_EQ(j["pool"]["viewsAs2Bytes"], viewsAs2);
  EXPECT_EQ(j["pool"]["sharedUnitBytes"], sharedUnits);
  EXPECT_EQ(j["pool"]["levels"].size(), pooled->poolLevels().size());
  EXPECT_EQ(j["pool"]["levels"][0]["edge"], 8);
  EXPECT_EQ(j["lights"][0]["views"][0]["inPool"], true);
  EXPECT_EQ(j["totals"]["dagBytes"], poolBytes);
  // A 2.0 file has no pool.
  EXPECT_TRUE(jsonOf(*path_, 0)["pool"].is_null());
}

TEST_F(CpvsInfo, HelpDocumentsCpvsInputAndExitCodes) {
  const auto help = runTool(info() + " --help");
  EXPECT_EQ(help.exitCode, 0);
  for (const char* s : {".cpvs", "checksum", "Exit codes:", "0  success", "1  usage error",
                        "2  input unreadable or invalid"})
    EXPECT_NE(help.output.find(s), std::string::npos) << s << "\n" << help.output;
}

// ---------------------------------------------------------------------------------------------------------------
// Corrupt files

TEST_F(CpvsInfo, FlippedBytesInEveryPartOfTheFileAreRejected) {
  // Positions: every header byte, every 5th byte of the section table (and its last), and in every section its
  // first, last and middle bytes and a few between; plus a padding byte of every gap. Flipping any byte must be
  // caught: every byte is covered by a checksum or must be zero.
  const uint64_t tableEnd = 64 + file_->sections().size() * 32;
  std::set<uint64_t> positions;
  for (uint64_t p = 0; p < 64; ++p) positions.insert(p);
  for (uint64_t p = 64; p < tableEnd; p += 5) positions.insert(p);
  positions.insert(tableEnd - 1);
  uint64_t end = tableEnd;
  for (const auto& s : file_->sections()) {
    if (s.offset > end) positions.insert(end + (s.offset - end) / 2);  // padding before the section
    if (s.size > 0)
      for (uint64_t k = 0; k <= 4; ++k) positions.insert(s.offset + (s.size - 1) * k / 4);
    end = s.offset + s.size;
  }
  ASSERT_EQ(end, bytes_.size());
  size_t tested = 0;
  std::set<size_t> sectionsHit;
  for (uint64_t p : positions) {
    ASSERT_LT(p, bytes_.size());
    for (size_t i = 0; i < file_->sections().size(); ++i)
      if (p >= file_->sections()[i].offset && p < file_->sections()[i].offset + file_->sections()[i].size)
        sectionsHit.insert(i);
    Bytes damaged = bytes_;
    damaged[p] ^= (p % 2) ? 0xFF : 0x01;
    const std::string name = "flip-" + std::to_string(p) + ".cpvs";
    expectRejected(runOn(damaged, name), name, "byte " + std::to_string(p) + " flipped");
    ++tested;
  }
  // Every section that has bytes (an empty view's NODE and LEAF sections have none).
  EXPECT_EQ(sectionsHit.size(), size_t(std::count_if(file_->sections().begin(), file_->sections().end(),
                                                     [](const auto& s) { return s.size > 0; })));
  EXPECT_LT(sectionsHit.size(), file_->sections().size());  // the point light's +Y face is empty
  EXPECT_GT(tested, 150u);
}

TEST_F(CpvsInfo, ChecksumStatusNamesTheDamagedSection) {
  // Damage the spot's LEAF section (the eighth section: BAKE STRS LGHT VIEW, sun NODE LEAF, spot NODE LEAF).
  const auto& leaf = file_->sections()[7];
  ASSERT_EQ(leaf.type, "LEAF");
  Bytes damaged = bytes_;
  damaged[leaf.offset + leaf.size / 2] ^= 0x10;
  const auto text = runOn(damaged, "leaf.cpvs");
  expectRejected(text, "leaf.cpvs", "a LEAF byte flipped");
  EXPECT_NE(text.output.find("leaf.cpvs: section 7 'LEAF' checksum mismatch"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("header ok, section table ok"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("section 7 'LEAF' (" + std::to_string(leaf.size) + " bytes at offset " +
                             std::to_string(leaf.offset) + "): mismatch"),
            std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("section 6 'NODE'"), std::string::npos) << text.output;

  const json j = jsonOf(scratch() + "/leaf.cpvs", 2);
  EXPECT_EQ(j["valid"], false);
  EXPECT_EQ(j["exitCode"], 2);
  EXPECT_NE(j["error"].get<std::string>().find("leaf.cpvs: section 7 'LEAF' checksum mismatch"), std::string::npos);
  EXPECT_EQ(j["checksums"]["headerChecksumOk"], true);
  EXPECT_EQ(j["checksums"]["sectionTableChecksumOk"], true);
  ASSERT_EQ(j["checksums"]["sections"].size(), file_->sections().size());
  for (size_t i = 0; i < file_->sections().size(); ++i) {
    EXPECT_EQ(j["checksums"]["sections"][i]["type"], file_->sections()[i].type);
    EXPECT_EQ(j["checksums"]["sections"][i]["status"], i == 7 ? "mismatch" : "ok") << i;
  }
}

TEST_F(CpvsInfo, CutsAtAndAroundEverySectionBoundaryAreRejected) {
  const uint64_t tableEnd = 64 + file_->sections().size() * 32;
  std::set<uint64_t> cuts = {0, 1, 7, 8, 9, 63, 64, 65, tableEnd - 1, tableEnd, tableEnd + 1, bytes_.size() - 1};
  for (const auto& s : file_->sections())
    for (uint64_t b : {s.offset, s.offset + s.size})
      for (int64_t d : {-1, 0, 1}) cuts.insert(uint64_t(int64_t(b) + d));
  size_t tested = 0;
  for (uint64_t cut : cuts) {
    if (cut >= bytes_.size()) continue;
    const std::string name = "cut-" + std::to_string(cut) + ".cpvs";
    const auto r = runOn(Bytes(bytes_.begin(), bytes_.begin() + cut), name);
    expectRejected(r, name, "cut at " + std::to_string(cut));
    EXPECT_NE(r.output.find(cut == 0 ? "empty file" : "truncated"), std::string::npos) << r.output;
    ++tested;
  }
  EXPECT_GT(tested, 50u);
  // Trailing bytes after the end the header gives are not silently ignored either.
  Bytes longer = bytes_;
  longer.push_back(0);
  expectRejected(runOn(longer, "longer.cpvs"), "longer.cpvs", "one byte appended");
}

TEST_F(CpvsInfo, WrongMagicTextModeDamageAndAFutureMajorAreRejectedWithWhatToDo) {
  // Another format's magic in front of otherwise valid bytes.
  Bytes png = bytes_;
  std::memcpy(png.data(), "\x89PNG\r\n\x1A\n", 8);
  const auto wrong = runOn(png, "wrong-magic.cpvs");
  expectRejected(wrong, "wrong-magic.cpvs", "PNG magic");
  EXPECT_NE(wrong.output.find("not a .cpvs file"), std::string::npos) << wrong.output;
  // Not a file of any kind cpvs-info knows.
  const auto text = runOn(Bytes{'h', 'e', 'l', 'l', 'o', '\n'}, "hello.cpvs");
  expectRejected(text, "hello.cpvs", "text");
  EXPECT_NE(text.output.find("not a .cpvs file"), std::string::npos) << text.output;
  expectRejected(runOn(Bytes{}, "empty.cpvs"), "empty.cpvs", "empty file");

  // An FTP-style text-mode transfer: CR LF became LF.
  Bytes lf;
  for (size_t i = 0; i < bytes_.size(); ++i)
    if (!(bytes_[i] == '\r' && i + 1 < bytes_.size() && bytes_[i + 1] == '\n')) lf.push_back(bytes_[i]);
  const auto ftp = runOn(lf, "ftp.cpvs");
  expectRejected(ftp, "ftp.cpvs", "CR LF became LF");
  EXPECT_NE(ftp.output.find("text-mode transfer"), std::string::npos) << ftp.output;

  // A genuine file of a future major version (its header checksum is right): told what to do.
  Bytes future = bytes_;
  putLE(future, 8, 4, 2);
  putLE(future, 10, 1, 2);
  resealHeader(future);
  const auto major = runOn(future, "future.cpvs");
  expectRejected(major, "future.cpvs", "major 4");
  EXPECT_NE(major.output.find("future.cpvs: written by format version 4.1; this build reads 1.x, 2.x and 3.x — update "
                              "cpvs or re-bake"),
            std::string::npos)
      << major.output;
  writeFile(scratch() + "/future.cpvs", future);
  const json majorJson = jsonOf(scratch() + "/future.cpvs", 2);
  EXPECT_EQ(majorJson["valid"], false);
  EXPECT_NE(majorJson["error"].get<std::string>().find("format version 4.1"), std::string::npos);
  EXPECT_EQ(majorJson["checksums"]["headerChecksumOk"], true);
  // Nor is a major below the oldest one this build reads.
  Bytes ancient = bytes_;
  putLE(ancient, 8, 0, 2);
  resealHeader(ancient);
  const auto zero = runOn(ancient, "ancient.cpvs");
  expectRejected(zero, "ancient.cpvs", "major 0");
  EXPECT_NE(zero.output.find("ancient.cpvs: written by format version 0.0; this build reads 1.x, 2.x and 3.x"),
            std::string::npos)
      << zero.output;

  // A directory and a missing file.
  const auto directory = runTool(info() + " " + scratch());
  EXPECT_EQ(directory.exitCode, 2) << directory.output;
  EXPECT_NE(directory.output.find(scratch() + ": "), std::string::npos) << directory.output;
  const auto missing = runTool(info() + " " + scratch() + "/missing.cpvs");
  EXPECT_EQ(missing.exitCode, 2) << missing.output;
  EXPECT_NE(missing.output.find("missing.cpvs: cannot open"), std::string::npos) << missing.output;
}

TEST_F(CpvsInfo, JsonForARejectedFileSaysWhatIsWrong) {
  Bytes cut(bytes_.begin(), bytes_.begin() + bytes_.size() / 2);
  const std::string path = scratch() + "/half.cpvs";
  writeFile(path, cut);
  const json j = jsonOf(path, 2);
  EXPECT_EQ(j["file"], path);
  EXPECT_EQ(j["valid"], false);
  EXPECT_NE(j["error"].get<std::string>().find("half.cpvs: truncated"), std::string::npos) << j.dump(2);
  // The sections before the cut still check out; those after it lie outside the file.
  const json& sections = j["checksums"]["sections"];
  ASSERT_EQ(sections.size(), file_->sections().size());
  for (size_t i = 0; i < sections.size(); ++i) {
    const auto& s = file_->sections()[i];
    EXPECT_EQ(sections[i]["status"], s.offset + s.size <= cut.size() ? "ok" : "outside the file") << i;
  }
}

}  // namespace
}  // namespace cpvs
