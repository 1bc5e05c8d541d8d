// Surface samples: on the surface, area-weighted, deterministic; and the cpvs-sample tool around them.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "libcpvs/scene/surface_samples.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

TEST(SurfaceSamples, OnTheSurfaceAreaWeightedAndDeterministic) {
  Scene scene;
  // A 1x1 quad at y = 0 facing +y and a 3x1 quad at y = 5 facing -y: three times the area, three times the
  // points.
  test::addQuad(scene, "small", {0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0});
  test::addQuad(scene, "large", {0, 5, 0}, {3, 5, 0}, {3, 5, 1}, {0, 5, 1});
  const WorldGeometry world = flatten(scene);
  const auto samples = sampleSurfaces(world, 40000, 7);
  ASSERT_EQ(samples.size(), 40000u);
  size_t onSmall = 0;
  for (const SurfaceSample& s : samples) {
    if (s.position.y < 2.5) {
      ASSERT_NEAR(s.position.y, 0.0, 1e-12);
      ++onSmall;
      EXPECT_NEAR(s.normal.y, 1.0, 1e-12);
      ASSERT_GE(s.position.x, 0.0);
      ASSERT_LE(s.position.x, 1.0);
    } else {
      ASSERT_NEAR(s.position.y, 5.0, 1e-12);
      EXPECT_NEAR(s.normal.y, -1.0, 1e-12);
      ASSERT_LE(s.position.x, 3.0);
    }
    ASSERT_GE(s.position.z, 0.0);
    ASSERT_LE(s.position.z, 1.0);
  }
  EXPECT_NEAR(double(onSmall) / 40000.0, 0.25, 0.01);
  const auto again = sampleSurfaces(world, 40000, 7);
  const auto other = sampleSurfaces(world, 40000, 8);
  EXPECT_EQ(again[123].position, samples[123].position);
  EXPECT_NE(other[123].position, samples[123].position);
  EXPECT_TRUE(sampleSurfaces(WorldGeometry{}, 10, 1).empty());
}

TEST(SampleTool, WritesTheCsvCpvsQueryReads) {
  const std::string dir = test::tempDir();
  const auto r = test::runTool(test::toolPath("cpvs-sample") + " " +
                               test::sourcePath("data/scenes/TorusKnot/torusknot.gltf") + " -o " + dir +
                               "/p.csv -n 100 --seed 3");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(dir + "/p.csv");
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header, "x,y,z,nx,ny,nz");
  size_t rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 100u);
  EXPECT_EQ(test::runTool(test::toolPath("cpvs-sample") + " " + dir + "/none.gltf -o " + dir + "/q.csv").exitCode, 2);
  EXPECT_EQ(test::runTool(test::toolPath("cpvs-sample") + " --count 5").exitCode, 1);
}

}  // namespace
}  // namespace cpvs
