// The option parsing every tool shares (tools/common/cli.h).
#include <gtest/gtest.h>

#include "libcpvs/base/error.h"
#include "tools/common/cli.h"

namespace cpvs {
namespace {

TEST(Cli, ParsesResolutions) {
  EXPECT_EQ(tools::parseResolution("4k"), 4096u);
  EXPECT_EQ(tools::parseResolution("64K"), 65536u);
  EXPECT_EQ(tools::parseResolution("512"), 512u);
  for (const char* bad : {"3000", "0", "-4k", "4kk", "", "1k5", "1024k", "nan"}) EXPECT_THROW(tools::parseResolution(bad), Error);
}

TEST(Cli, ParsesByteSizes) {
  EXPECT_EQ(tools::parseByteSize("2G"), uint64_t(2) << 30);
  EXPECT_EQ(tools::parseByteSize("512m"), uint64_t(512) << 20);
  EXPECT_EQ(tools::parseByteSize("1.5G"), uint64_t(3) << 29);
  for (const char* bad : {"", "G", "0.5K", "-1G", "1e99T", "12X", "nan"}) EXPECT_THROW(tools::parseByteSize(bad), Error) << bad;
}

TEST(Cli, SuggestsTheNearestKnownOption) {
  CLI::App app{"test", "tool"};
  std::string value;
  app.add_option("--sun", value);
  app.add_option("--spot", value);
  app.add_option("--slot", value);
  app.add_option("-r,--resolution", value);
  app.add_option("--exclude-mesh", value);
  EXPECT_EQ(tools::nearestOption(app, "--sunn"), "--sun");
  EXPECT_EQ(tools::nearestOption(app, "--snu"), "--sun");               // two letters swapped
  EXPECT_EQ(tools::nearestOption(app, "-sun"), "--sun");                // one dash
  EXPECT_EQ(tools::nearestOption(app, "--SUN=1,2,3"), "--sun");         // case and a value after '='
  EXPECT_EQ(tools::nearestOption(app, "--resolutoin"), "--resolution");
  EXPECT_EQ(tools::nearestOption(app, "--res"), "--resolution");        // a prefix of one option
  EXPECT_EQ(tools::nearestOption(app, "--exclude-meshes"), "--exclude-mesh");
  EXPECT_EQ(tools::nearestOption(app, "--frobnicate"), "");
  EXPECT_EQ(tools::nearestOption(app, "--sbot"), "--spot or --slot");   // equally near
}

TEST(Cli, AValueErrorIsKeptBesideTheWordsTakenForNothing) {
  CLI::App app{"test", "tool"};
  int count = 0;
  std::string scene;
  app.add_option("--count", count);
  app.add_option("scene", scene)->type_name("SCENE");
  try {
    app.parse("--count abc level.gltf extra.gltf", false);
    FAIL() << "parsed";
  } catch (const CLI::ParseError& e) {
    const std::string message = tools::describeParseError(app, e);
    EXPECT_NE(message.find("--count"), std::string::npos) << message;
    EXPECT_NE(message.find("abc"), std::string::npos) << message;
    EXPECT_NE(message.find("'extra.gltf', the 2nd positional argument, was taken for nothing"), std::string::npos)
        << message;
  }
}

TEST(Cli, NamesThePositionalArguments) {
  CLI::App app{"test", "cpvs-view"};
  std::string scene, file;
  app.add_option("scene", scene)->type_name("SCENE");
  app.add_option("cpvs", file);
  EXPECT_EQ(tools::positionalUsage(app), "cpvs-view SCENE cpvs");
}

TEST(Cli, CommandLineLightsShowTheirFormatAndCatchDegrees) {
  const auto messageOf = [](tools::LightOptions options) {
    Scene scene;
    try {
      options.applyTo(scene);
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::InvalidArgument);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  tools::LightOptions point;
  point.points = {"0,2,0"};
  EXPECT_EQ(messageOf(point), "--point '0,2,0': expected 4 or 5 comma-separated numbers, got 3: X,Y,Z,RANGE[,CANDELA]: "
                              "RANGE 0 = unlimited");
  tools::LightOptions sun;
  sun.suns = {"0,-1,x"};
  EXPECT_EQ(messageOf(sun), "--sun '0,-1,x': 'x' is not a finite number (expected X,Y,Z[,LUX]: the direction the light "
                            "travels)");
  tools::LightOptions degrees;
  degrees.spots = {"0,3,0,0,-1,0,45,10"};
  EXPECT_EQ(messageOf(degrees), "--spot '0,3,0,0,-1,0,45,10': OUTER_ANGLE_RAD 45 looks like degrees: the angle is in "
                                "radians (0.785)");
  tools::LightOptions notRadians;  // no angle in radians is above pi
  notRadians.spots = {"0,3,0,0,-1,0,4,10"};
  EXPECT_EQ(messageOf(notRadians), "--spot '0,3,0,0,-1,0,4,10': OUTER_ANGLE_RAD 4 looks like degrees: the angle is in "
                                   "radians (0.070)");
  tools::LightOptions wide;  // a full cone angle in radians, perhaps
  wide.spots = {"0,3,0,0,-1,0,2,10"};
  EXPECT_EQ(messageOf(wide), "--spot '0,3,0,0,-1,0,2,10': OUTER_ANGLE_RAD 2 must be a half-angle in radians in (0, pi/2] "
                             "(90 degrees = 1.571)");
  tools::LightOptions fine;
  fine.spots = {"0,3,0,0,-1,0,0.785,10"};
  EXPECT_EQ(messageOf(fine), "no error");
}

}  // namespace
}  // namespace cpvs
