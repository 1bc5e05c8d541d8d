// The light model (libcpvs/runtime/light.h): the facing rule on its edge cases and against the lookup's own back
// test, the influence, the parameters each type has, and the report line.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light.glsl.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::pointLight;
using test::spotLight;
using test::sunLight;

TEST(Light, FacingRuleOnItsEdgeCases) {
  const Light sun = sunLight("sun", {0, -1, 0});
  const glm::dvec3 p(1, 0, 2);
  EXPECT_TRUE(facesLight(sun, p, {0, 1, 0}));    // toward the light
  EXPECT_TRUE(facesLight(sun, p, {1, 0, 0}));    // at a right angle: faces it (n . l = 0)
  EXPECT_FALSE(facesLight(sun, p, {0, -1, 0}));  // away
  EXPECT_TRUE(facesLight(sun, p, {0, 0, 0}));    // no normal: faces every light
  EXPECT_TRUE(facesLight(sun, p, {0, -1, 0}, NormalOrientation::TowardLight));  // the lookup flips it
  EXPECT_FALSE(facesLight(sun, p, {0, -1e-300, 0}));  // any negative product is away, however small

  const Light point = pointLight("lamp", {0, 4, 0}, 10);
  EXPECT_TRUE(facesLight(point, {0, 0, 0}, {0, 1, 0}));
  EXPECT_TRUE(facesLight(point, {0, 0, 0}, {1, 0, 0}));
  EXPECT_FALSE(facesLight(point, {0, 0, 0}, {0, -1, 0}));
  EXPECT_FALSE(facesLight(point, {0, 8, 0}, {0, 1, 0}));  // above the lamp, facing up: away
  EXPECT_TRUE(facesLight(point, {0, 4, 0}, {0, -1, 0}));  // at the light itself nothing is away
}

TEST(Light, ReceivesLightIsInfluenceAndFacing) {
  const Light spot = spotLight("spot", {0, 4, 0}, {0, -1, 0}, 0.5, 10);
  EXPECT_TRUE(receivesLight(spot, {0, 0, 0}, {0, 1, 0}));
  EXPECT_FALSE(receivesLight(spot, {0, 0, 0}, {0, -1, 0}));  // in the cone, facing away
  EXPECT_FALSE(receivesLight(spot, {5, 0, 0}, {0, 1, 0}));   // outside the cone
  EXPECT_FALSE(receivesLight(spot, {0, -7, 0}, {0, 1, 0}));  // beyond the range
  EXPECT_FALSE(receivesLight(spot, {0, 4, 0}, {0, 0, 0}));   // the light itself: no direction, outside
  const Light point = pointLight("lamp", {0, 0, 0}, 2);
  EXPECT_TRUE(withinInfluence(point, {2, 0, 0}));  // the range is inclusive
  EXPECT_FALSE(withinInfluence(point, {2.000001, 0, 0}));
  EXPECT_TRUE(withinInfluence(sunLight("sun", {0, -1, 0}), {1e30, -1e30, 0}));
  EXPECT_EQ(influenceRange(sunLight("sun", {0, -1, 0})), std::numeric_limits<double>::infinity());
  EXPECT_EQ(influenceRange(point), 2.0);
}

// The facing rule is the lookup's back test: on every view of every light type, a lookup answers BackFacing
// exactly where facesLight says away (normals far enough from the plane that the grid's rounding cannot flip
// the sign), and a normal at an exact right angle to a sun is never a back face.
TEST(Light, FacingRuleIsTheLookupsBackTest) {
  const WorldGeometry world = test::groundAndRidge();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-4.0, 4.0), height(0.0, 1.5), dir(-1.0, 1.0);
  size_t back = 0, front = 0;
  for (const Light& light : {sunLight("sun", {0.3, -1, 0.2}), spotLight("spot", {0, 6, 0}, {0, -1, 0}, 0.9, 20),
                             pointLight("lamp", {0.5, 3, -0.5}, 20)}) {
    const std::vector<LightView> views = makeLightViews(light, world, 256);
    for (int i = 0; i < 4000; ++i) {
      const glm::dvec3 p(coord(rng), height(rng), coord(rng));
      const glm::dvec3 n = glm::normalize(glm::dvec3(dir(rng), dir(rng), dir(rng)));
      const auto view = selectView(light, views, p);
      if (!view || !withinInfluence(light, p)) continue;
      const glm::dvec3 l = glm::normalize(towardLight(light, p));
      if (std::abs(glm::dot(n, l)) < 1e-6) continue;
      const LookupCell cell = lookupCell(views[*view], p, n, {});
      if (cell.kind == LookupCell::Kind::Lit && views[*view].empty) continue;
      const bool lookupBack = cell.kind == LookupCell::Kind::BackFacing;
      ASSERT_EQ(lookupBack, !facesLight(light, p, n)) << describeLight(light) << " point " << p.x << "," << p.y
                                                      << "," << p.z;
      (lookupBack ? back : front) += 1;
      const LookupCell flipped = lookupCell(views[*view], p, n, {1, NormalOrientation::TowardLight});
      ASSERT_NE(flipped.kind, LookupCell::Kind::BackFacing);
    }
  }
  EXPECT_GT(back, 1000u);
  EXPECT_GT(front, 1000u);
  const Light overhead = sunLight("overhead", {0, -1, 0});
  const std::vector<LightView> views = makeLightViews(overhead, world, 256);
  for (const glm::dvec3& n : {glm::dvec3(1, 0, 0), glm::dvec3(0, 0, -1), glm::dvec3(0.6, 0, 0.8)}) {
    ASSERT_TRUE(facesLight(overhead, {0.5, 0.25, 0.5}, n));
    EXPECT_NE(lookupCell(views[0], {0.5, 0.25, 0.5}, n, {}).kind, LookupCell::Kind::BackFacing);
  }
}

TEST(Light, ParametersOfEachType) {
  const Light sun = sunLight("sun", {0, -1, 0});
  const Light spot = spotLight("spot", {0, 4, 0}, {0, -1, 0}, 0.5, 10);
  const Light point = pointLight("lamp", {0, 4, 0}, 10);
  EXPECT_FALSE(hasPosition(sun));
  EXPECT_TRUE(hasDirection(sun));
  EXPECT_FALSE(hasRange(sun));
  EXPECT_FALSE(hasCone(sun));
  EXPECT_TRUE(hasPosition(spot) && hasDirection(spot) && hasRange(spot) && hasCone(spot));
  EXPECT_TRUE(hasPosition(point) && hasRange(point));
  EXPECT_FALSE(hasDirection(point) || hasCone(point));
  EXPECT_EQ(towardLight(sun, {7, 7, 7}), glm::dvec3(0, 1, 0));
  EXPECT_EQ(towardLight(point, {0, 1, 0}), glm::dvec3(0, 3, 0));
}

// The shape bits the shaders branch on are the predicates', and every type's views are the ones the light model
// promises (one view of face -1, or the six cube faces in order), as the reader requires of every file.
TEST(Light, ShapeBitsAndViewsOfEachType) {
  const WorldGeometry world = test::groundAndRidge();
  for (const Light& light : {sunLight("sun", {0, -1, 0}), spotLight("spot", {0, 4, 0}, {0, -1, 0}, 0.5, 10),
                             pointLight("lamp", {0, 4, 0}, 10)}) {
    const uint32_t bits = shapeBits(light);
    EXPECT_EQ((bits & CPVS_SHAPE_POSITION) != 0, hasPosition(light)) << lightTypeName(light.type);
    EXPECT_EQ((bits & CPVS_SHAPE_CONE) != 0, hasCone(light)) << lightTypeName(light.type);
    EXPECT_EQ((bits & CPVS_SHAPE_CUBE_FACES) != 0, hasCubeFaces(light)) << lightTypeName(light.type);
    const std::vector<LightView> views = makeLightViews(light, world, 64);
    ASSERT_EQ(views.size(), viewCountOf(light)) << lightTypeName(light.type);
    for (size_t v = 0; v < views.size(); ++v) EXPECT_EQ(views[v].face, hasCubeFaces(light) ? int(v) : -1);
  }
}

TEST(Light, TypeCodesAndNames) {
  EXPECT_EQ(kLightTypeCount, CPVS_LIGHT_TYPE_COUNT);
  EXPECT_STREQ(lightTypeName(LightType(CPVS_LIGHT_DIRECTIONAL)), "directional");
  EXPECT_STREQ(lightTypeName(LightType(CPVS_LIGHT_SPOT)), "spot");
  EXPECT_STREQ(lightTypeName(LightType(CPVS_LIGHT_POINT)), "point");
  EXPECT_STREQ(lightTypeName(LightType(kLightTypeCount)), "unknown");
}

TEST(Light, ReportLine) {
  EXPECT_EQ(describeLight(sunLight("sun", {0, -1, 0})), "sun, direction (0, -1, 0)");
  EXPECT_EQ(describeLight(spotLight("spot", {1, 4, 0}, {0, -1, 0}, 0.5, 10)),
            "spot at (1, 4, 0), direction (0, -1, 0), outer cone 0.5 rad, range 10");
  EXPECT_EQ(describeLight(pointLight("lamp", {0, 4.5, 0}, 12)), "point at (0, 4.5, 0), range 12");
}

TEST(Light, StrengthFallsWithTheSquaredDistanceInsideTheInfluence) {
  Light point = pointLight("lamp", {0, 0, 0}, 10);
  point.intensity = 8;
  point.color = glm::vec3(1.0f);
  EXPECT_NEAR(strengthAt(point, {2, 0, 0}), 2.0, 1e-6);
  EXPECT_EQ(strengthAt(point, {11, 0, 0}), 0.0);
  EXPECT_EQ(strengthAt(point, {0, 0, 0}), 0.0);  // at the light itself: no finite value
  Light sun = sunLight("sun", {0, -1, 0});
  sun.intensity = 3;
  sun.color = glm::vec3(1.0f);
  EXPECT_NEAR(strengthAt(sun, {1e6, 0, 0}), 3.0, 1e-6);
}

}  // namespace
}  // namespace cpvs
