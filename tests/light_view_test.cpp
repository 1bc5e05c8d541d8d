// The voxel convention (docs/architecture.md, "The voxel convention"): one mapping, fitted views, view selection.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

WorldGeometry boxesScene(glm::dvec3 offset = glm::dvec3(0), double scale = 1) {
  Scene scene;
  test::addBox(scene, "ground", offset + scale * glm::dvec3(-10, -1, -10), offset + scale * glm::dvec3(10, 0, 10));
  test::addBox(scene, "tower", offset + scale * glm::dvec3(-1, 0, -1), offset + scale * glm::dvec3(1, 6, 1));
  test::classifyMeshes(scene);
  return flatten(scene);
}

Light sun(glm::dvec3 direction) { return test::sunLight("", direction); }
Light spot(glm::dvec3 position, glm::dvec3 direction, double outer, double range) {
  return test::spotLight("", position, direction, outer, range);
}

TEST(LightView, GridRoundTripsThroughWorld) {
  const WorldGeometry world = boxesScene();
  for (const Light& light : {sun({-0.3, -1, -0.2}), spot({0, 12, 3}, {0, -1, -0.2}, 0.6, 40)}) {
    const LightView view = makeLightViews(light, world, 1024)[0];
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> unit(0.0, 1024.0);
    for (int i = 0; i < 1000; ++i) {
      const glm::dvec3 uvs(unit(rng), unit(rng), unit(rng));
      const glm::dvec3 back = toGrid(view, gridToWorld(view, uvs)).uvs;
      EXPECT_NEAR(back.x, uvs.x, 1e-6);
      EXPECT_NEAR(back.y, uvs.y, 1e-6);
      EXPECT_NEAR(back.z, uvs.z, 1e-6);
    }
  }
}

TEST(LightView, FittedViewsContainEveryVertexInsideSlicesOneToNMinusTwo) {
  const WorldGeometry world = boxesScene();
  for (const Light& light : {sun({-0.3, -1, -0.2}), sun({0, -1, 0}), sun({1, 0, 0})}) {
    const LightView view = makeLightViews(light, world, 512)[0];
    for (const glm::dvec3& p : world.positions) {
      const glm::dvec3 g = toGrid(view, p).uvs;
      EXPECT_GE(g.x, 0.0);
      EXPECT_LT(g.x, 512.0);
      EXPECT_GE(g.y, 0.0);
      EXPECT_LT(g.y, 512.0);
      EXPECT_GE(g.z, 1.0);   // two slices of margin before the nearest surface
      EXPECT_LT(g.z, 511.0); // and after the farthest
    }
  }
}

TEST(LightView, SpotViewIsFittedToGeometryInsideTheCone) {
  const WorldGeometry world = boxesScene();
  const Light light = spot({0, 12, 0}, {0, -1, 0}, 0.3, 100);
  const LightView view = makeLightViews(light, world, 256)[0];
  EXPECT_EQ(view.projection, Projection::Perspective);
  EXPECT_EQ(view.mapping, DepthMapping::Logarithmic);
  // The tower top is at depth 6, the bottom of the ground slab under the cone at depth 13.
  EXPECT_NEAR(view.near, 6.0, 0.2);
  EXPECT_NEAR(view.far, 13.0, 0.3);
  EXPECT_LE(view.xMax, std::tan(0.3) + 1e-9);
}

TEST(LightView, SameAnswersWhenTheSceneMovesOrScales) {
  const Light light = sun({-0.3, -1, -0.2});
  const WorldGeometry base = boxesScene();
  const LightView reference = makeLightViews(light, base, 1024)[0];
  const glm::dvec3 probe(0.3, 0.0, 4.2);
  const Voxel expected = worldToVoxel(reference, probe);
  for (auto [offset, scale] : {std::pair{glm::dvec3(1e5, -2e5, 1e5), 1.0}, std::pair{glm::dvec3(0), 1e-3},
                               std::pair{glm::dvec3(0), 1e4}}) {
    const WorldGeometry moved = boxesScene(offset, scale);
    const LightView view = makeLightViews(light, moved, 1024)[0];
    EXPECT_EQ(worldToVoxel(view, offset + scale * probe), expected);
  }
}

TEST(LightView, PointLightHasSixFacesAndSelectsByMajorAxis) {
  const WorldGeometry world = boxesScene();
  const Light light = test::pointLight("point", {0, 8, 0}, 50);
  const auto views = makeLightViews(light, world, 64);
  ASSERT_EQ(views.size(), 6u);
  auto face = [&](glm::dvec3 p) { return views[*selectView(light, views, p)].face; };
  EXPECT_EQ(face({5, 8.5, 1}), 0);
  EXPECT_EQ(face({-5, 8, 1}), 1);
  EXPECT_EQ(face({0, 20, 1}), 2);
  EXPECT_EQ(face({1, 0, 0}), 3);
  EXPECT_EQ(face({0, 8, 3}), 4);
  EXPECT_EQ(face({0, 8, -3}), 5);
  EXPECT_FALSE(selectView(light, views, {0, 8, 60}).has_value());  // beyond range
  EXPECT_TRUE(views[2].empty);  // nothing above the light
  // A point inside its face's frustum maps inside the face's lateral grid when geometry is there.
  const glm::dvec3 g = toGrid(views[3], {1, 0, 0.5}).uvs;
  EXPECT_GE(g.x, 0);
  EXPECT_LT(g.x, 64);
}

TEST(LightView, SpotSelectionRespectsConeAndRange) {
  const WorldGeometry world = boxesScene();
  const Light light = spot({0, 12, 0}, {0, -1, 0}, 0.3, 20);
  const auto views = makeLightViews(light, world, 64);
  EXPECT_TRUE(selectView(light, views, {0, 0, 0}).has_value());
  EXPECT_FALSE(selectView(light, views, {8, 0, 0}).has_value());    // outside the cone
  EXPECT_FALSE(selectView(light, views, {0, -10, 0}).has_value());  // beyond range
  EXPECT_FALSE(selectView(light, views, {0, 14, 0}).has_value());   // behind the light
}

TEST(LightView, VoxelsClampAndFloor) {
  LightView view;
  view.resolution = 16;
  EXPECT_EQ(toVoxel(view, {-0.5, 3.999, 16.0}), (Voxel{0, 3, 15}));
  EXPECT_EQ(toVoxel(view, {15.9999, 0.0, -1e9}), (Voxel{15, 0, 0}));
}

// The depth mapping's own log (view_mapping.h): within 2 ulp of libm's over the whole positive normal range,
// exact at 1 and at powers of two up to rounding of e ln 2, and finite for the inputs callers select away.
TEST(LightView, MappingLogIsWithinTwoUlpOfLibm) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> exponent(-1000.0, 1000.0), near1(0.5, 2.0);
  auto ulpDistance = [](double a, double b) {
    const double ulp = std::nextafter(std::abs(b), INFINITY) - std::abs(b);
    return std::abs(a - b) / ulp;
  };
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    const double x = i % 2 ? std::exp2(exponent(rng)) : near1(rng);
    worst = std::max(worst, ulpDistance(mappingLog(x), std::log(x)));
  }
  EXPECT_LE(worst, 2.0);
  EXPECT_EQ(mappingLog(1.0), 0.0);
  for (int e = -1020; e <= 1020; e += 17) EXPECT_LE(ulpDistance(mappingLog(std::ldexp(1.0, e)), e * std::log(2.0)), 2.0) << e;
  // Around sqrt(2), where the reduction switches from m to m / 2.
  for (double x = kSqrt2 - 1e-12; x < kSqrt2 + 1e-12; x += 1e-14) EXPECT_LE(ulpDistance(mappingLog(x), std::log(x)), 2.0);
  EXPECT_TRUE(std::isfinite(mappingLog(0.0)));
  EXPECT_TRUE(std::isfinite(mappingLog(INFINITY)));
  EXPECT_LT(mappingLog(4.9e-324), -700);
}

}  // namespace
}  // namespace cpvs
