// The messages a newcomer meets in the first hour, each for a slip a new user makes, run through the tools as
// a user would (docs/cli.md, "Errors"): inputs given in the wrong order, a misspelt option, a value typed
// without its option, what cpvs-info looked for and did not find, the query's headline figure, and points
// made on another scene than the one they are scored against.
#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::sourcePath;
using test::tempDir;
using test::toolPath;

std::string tinyScene() { return sourcePath("data/scenes/Tiny/tiny.gltf"); }
std::string torusKnot() { return sourcePath("data/scenes/TorusKnot/torusknot.gltf"); }

// A small bake of the Tiny scene (its own sun) and points sampled on it, made once for the tests below.
struct Baked {
  std::string dir, cpvs, points;
};

const Baked& tinyBake() {
  static const Baked baked = [] {
    Baked b;
    b.dir = tempDir();
    b.cpvs = b.dir + "/tiny.cpvs";
    b.points = b.dir + "/points.csv";
    const auto bake = runTool(toolPath("cpvs-bake") + " " + tinyScene() + " -r 256 -q -o " + b.cpvs);
    EXPECT_EQ(bake.exitCode, 0) << bake.output;
    const auto sample = runTool(toolPath("cpvs-sample") + " " + tinyScene() + " -n 2000 -o " + b.points);
    EXPECT_EQ(sample.exitCode, 0) << sample.output;
    return b;
  }();
  return baked;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

size_t occurrences(const std::string& text, const std::string& part) {
  size_t count = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
  return count;
}

TEST(Messages, AFileGivenWhereTheOtherKindBelongsIsNamedWithTheUsage) {
  const Baked& b = tinyBake();
  const std::string out = b.dir + "/x.png";
  // cpvs-view FILE.cpvs SCENE: swapped.
  auto r = runTool(toolPath("cpvs-view") + " " + b.cpvs + " " + tinyScene() + " -o " + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "cpvs-view: error: " + b.cpvs + " is a baked .cpvs file")) << r.output;
  EXPECT_TRUE(contains(r.output, "usage: cpvs-view SCENE FILE.cpvs")) << r.output;
  EXPECT_FALSE(contains(r.output, "JSON")) << r.output;
  // A .cpvs where a scene belongs, in every tool that takes a scene.
  for (const std::string& command : {toolPath("cpvs-bake") + " " + b.cpvs + " -o " + b.dir + "/y.cpvs",
                                     toolPath("cpvs-sample") + " " + b.cpvs + " -o " + b.dir + "/p.csv",
                                     toolPath("cpvs-sweep") + " " + b.cpvs + " --resolutions 64",
                                     toolPath("cpvs-query") + " " + b.cpvs + " --points " + b.points + " -o " + b.dir +
                                         "/v.csv --reference " + b.cpvs}) {
    r = runTool(command);
    EXPECT_EQ(r.exitCode, 1) << command << "\n" << r.output;
    EXPECT_TRUE(contains(r.output, b.cpvs + " is a baked .cpvs file, where a scene (.gltf, .glb) was expected"))
        << command << "\n" << r.output;
  }
  // A scene where a .cpvs belongs.
  for (const std::string& command : {toolPath("cpvs-query") + " " + tinyScene() + " --points " + b.points + " -o " +
                                         b.dir + "/v.csv",
                                     toolPath("cpvs-merge") + " " + tinyScene() + " -o " + b.dir + "/m.cpvs"}) {
    r = runTool(command);
    EXPECT_EQ(r.exitCode, 1) << command << "\n" << r.output;
    EXPECT_TRUE(contains(r.output, tinyScene() + " is a glTF scene, where a baked .cpvs file was expected"))
        << command << "\n" << r.output;
  }
  // A scene given as points.
  r = runTool(toolPath("cpvs-query") + " " + b.cpvs + " --points " + tinyScene() + " -o " + b.dir + "/v.csv");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "--points " + tinyScene() + " is a glTF scene, where points")) << r.output;
  EXPECT_TRUE(contains(r.output, "cpvs-sample")) << r.output;
}

TEST(Messages, AMisspeltOptionIsNamedFirstWithTheNearestKnownOne) {
  const Baked& b = tinyBake();
  auto r = runTool(toolPath("cpvs-bake") + " " + tinyScene() + " --sunn 0.3,-0.8,0.4 -o " + b.dir + "/y.cpvs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(r.output.rfind("cpvs-bake: error: unknown option --sunn (did you mean --sun?)", 0), 0u) << r.output;
  EXPECT_FALSE(contains(r.output, "0.3,-0.8,0.4 was")) << r.output;  // the value of the unknown option, not a stray
  EXPECT_TRUE(contains(r.output, "cpvs-bake: usage: cpvs-bake SCENE")) << r.output;
  // A prefix of one option; a tool apart from the library (cpvs-scenegen) says it the same way.
  r = runTool(toolPath("cpvs-bake") + " " + tinyScene() + " --resol 1k -o " + b.dir + "/y.cpvs");
  EXPECT_TRUE(contains(r.output, "unknown option --resol (did you mean --resolution?)")) << r.output;
  r = runTool(toolPath("cpvs-scenegen") + " city --triangels 5000 -o " + b.dir + "/c.glb");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(r.output.rfind("cpvs-scenegen: error: unknown option --triangels (did you mean --triangles?)", 0), 0u)
      << r.output;
  // Nothing near: no suggestion.
  r = runTool(toolPath("cpvs-info") + " " + tinyScene() + " --frobnicate");
  EXPECT_TRUE(contains(r.output, "cpvs-info: error: unknown option --frobnicate\n")) << r.output;
}

TEST(Messages, APositionalTakenForNothingIsSaidToBelongAfterTheMissingOption) {
  const Baked& b = tinyBake();
  const auto r = runTool(toolPath("cpvs-query") + " " + b.cpvs + " " + b.points + " -o " + b.dir + "/v.csv");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "'" + b.points + "', the 2nd positional argument, was taken for nothing (cpvs-query "
                                  "takes 1: FILE.cpvs)"))
      << r.output;
  EXPECT_TRUE(contains(r.output, "--points is required: '" + b.points + "' goes after it (--points " + b.points + ")"))
      << r.output;
}

TEST(Messages, CommandLineLightsShowTheirFormat) {
  const Baked& b = tinyBake();
  auto r = runTool(toolPath("cpvs-bake") + " " + tinyScene() + " --point 0,2,0 -o " + b.dir + "/y.cpvs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "got 3: X,Y,Z,RANGE[,CANDELA]: RANGE 0 = unlimited")) << r.output;
  r = runTool(toolPath("cpvs-bake") + " " + tinyScene() + " --spot 0,3,0,0,-1,0,45,10 -o " + b.dir + "/y.cpvs");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "OUTER_ANGLE_RAD 45 looks like degrees: the angle is in radians (0.785)")) << r.output;
}

TEST(Messages, CpvsInfoSaysWhatItLookedForAndDidNotFind) {
  // TorusKnot: one closed mesh and no lights.
  const auto r = runTool(toolPath("cpvs-info") + " " + torusKnot());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "lights (0): none in the scene (KHR_lights_punctual); give --sun, --spot or --point to "
                                 "cpvs-bake"))
      << r.output;
  EXPECT_TRUE(contains(r.output, "ground sheets: none found (every casting mesh is closed; a ground sheet is an open "
                                 "mesh"))
      << r.output;
  // The JSON says the same.
  const auto json = runTool(toolPath("cpvs-info") + " " + torusKnot() + " --json");
  EXPECT_TRUE(contains(json.output, "\"noGroundSheet\": \"every casting mesh is closed; ")) << json.output;
  // With the check off, it says so.
  const auto off = runTool(toolPath("cpvs-info") + " " + torusKnot() + " --ground off");
  EXPECT_TRUE(contains(off.output, "ground sheets: none found (--ground off)")) << off.output;
  // A scene with lights says nothing of the kind.
  const auto tiny = runTool(toolPath("cpvs-info") + " " + tinyScene());
  EXPECT_FALSE(contains(tiny.output, "give --sun")) << tiny.output;
}

TEST(Messages, TheQuerySummaryLeadsWithOneFigure) {
  const Baked& b = tinyBake();
  const auto r = runTool(toolPath("cpvs-query") + " " + b.cpvs + " --points " + b.points + " -o " + b.dir +
                         "/v.csv --reference " + tinyScene());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  const std::regex headline(R"(cpvs-query: [0-9.]+% misclassified against Embree rays: [0-9]+ of the [0-9]+ \(point, )"
                            R"(light\) pairs where a shadow can be wrong)");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(r.output, match, headline)) << r.output;
  const size_t breakdown = r.output.find("cpvs-query:   breakdown: ");
  ASSERT_NE(breakdown, std::string::npos) << r.output;
  EXPECT_LT(size_t(match.position(0)), breakdown) << r.output;
  EXPECT_FALSE(contains(r.output, "warning")) << r.output;  // points made on this scene are on its surfaces
}

TEST(Messages, PointsMadeOnAnotherSceneAreNamedAsSuch) {
  const Baked& b = tinyBake();
  // Points on the torus knot, queried against the Tiny bake and scored against the Tiny scene.
  const std::string points = b.dir + "/knot_points.csv";
  ASSERT_EQ(runTool(toolPath("cpvs-sample") + " " + torusKnot() + " -n 1000 -o " + points).exitCode, 0);
  const auto r = runTool(toolPath("cpvs-query") + " " + b.cpvs + " --points " + points + " -o " + b.dir +
                         "/v.csv --reference " + tinyScene() + " --report " + b.dir + "/q.json");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "cpvs-query: warning: " + points + ": ")) << r.output;
  EXPECT_TRUE(contains(r.output, "voxels from every surface of the reference scene " + tinyScene() +
                                 ": were they made on another scene?"))
      << r.output;
  EXPECT_EQ(occurrences(r.output, "made on another scene"), 1u) << r.output;
}

}  // namespace
}  // namespace cpvs
