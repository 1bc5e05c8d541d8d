// ShadowReference: the ground truth of cpvs-query --reference and cpvs-sweep. Its "uniform" flag decides
// which points the 0.1 % target is measured on, so its definition is pinned here: the same answer on a circle
// of radius 2 voxels on the tangent plane and 2 voxels out along the normal.
#include <cmath>

#include <gtest/gtest.h>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

Light overheadSun() {
  Light sun;
  sun.type = LightType::Directional;
  sun.name = "sun";
  sun.direction = {0, -1, 0};
  return sun;
}

// Ground 40 x 40 at y = 0; a tower 20 high (it sets the depth range: a depth voxel at N = 64 is ~0.31);
// a thin slab just above the ground (y 0.05..0.1, well within two depth voxels) and a slab high above it.
struct Fixture {
  Scene scene;
  WorldGeometry world;
  Light sun = overheadSun();
  std::vector<LightView> views;
  ShadowDag lit;  // the DAG is not consulted: only the view (voxel size) is
  Fixture() {
    test::addQuad(scene, "ground", {-20, 0, -20}, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20});
    test::addBox(scene, "tower", {10, 0, 10}, {14, 20, 14});
    test::addBox(scene, "low slab", {-12, 0.05, -12}, {-4, 0.1, -4});
    test::addBox(scene, "high slab", {4, 6, -12}, {12, 6.05, -4});
    test::classifyMeshes(scene);
    world = flatten(scene);
    views = makeLightViews(sun, world, 64);
    lit.resolution = 64;
  }
};

TEST(ShadowReference, UniformMeansTheSameWithinTwoVoxelsAlongTheSurfaceAndTheNormal) {
  const Fixture f;
  ASSERT_EQ(f.views.size(), 1u);
  const ShadowReference reference(f.world);
  const LightShadow shadow = orThrow(LightShadow::create(f.sun, f.views, {f.lit.view()}));
  const glm::dvec3 up(0, 1, 0);
  auto check = [&](const glm::dvec3& p, uint8_t expected, bool expectUniform, const char* what) {
    bool uniform = !expectUniform;
    EXPECT_EQ(reference.visibility(shadow, {p, up}, uniform), expected) << what;
    EXPECT_EQ(uniform, expectUniform) << what;
    EXPECT_EQ(reference.visibility(f.sun, {p, up}), expected) << what;
  };
  check({-15, 0, 15}, 1, true, "open ground far from everything");
  check({8, 0, -8}, 0, true, "ground in the middle of the high slab's shadow");
  // The low slab is within two voxels above the ground: the probe along the normal passes over it.
  check({-8, 0, -8}, 0, false, "ground under the low slab (occluder within two voxels along the normal)");
  // 0.3 units (about one texel) outside the high slab's shadow edge at x = 4.
  check({3.7, 0, -8}, 1, false, "ground next to a shadow edge");
}

TEST(ShadowReference, BackFacingPointsAreShadowedWithoutARay) {
  const Fixture f;
  const ShadowReference reference(f.world);
  EXPECT_EQ(reference.visibility(f.sun, {{-15, 0, 15}, {0, -1, 0}}), 0);
  EXPECT_EQ(reference.visibility(f.sun, {{-15, 0, 15}, {0, 1, 0}}), 1);
  EXPECT_EQ(reference.visibility(f.sun, {{-15, 0, 15}, {0, 0, 0}}), 1);  // no normal: no facing test
}

TEST(ShadowReference, PointsInsideClosedSolids) {
  const Fixture f;
  const ShadowReference reference(f.world);
  // The tower's base face lies on the ground; a ground point under the tower is inside the tower.
  EXPECT_TRUE(reference.insideClosedSolid({{12, 0, 12}, {0, 1, 0}}));
  EXPECT_FALSE(reference.insideClosedSolid({{-15, 0, 15}, {0, 1, 0}}));
  // The tower's own wall, seen from outside.
  EXPECT_FALSE(reference.insideClosedSolid({{14, 5, 12}, {1, 0, 0}}));
}

// Two single-sided walls back to back, `gap` apart (a party wall between two buildings of the generated open
// city): a point on the first wall facing the gap is in the second wall's shadow for a sun shining down into
// the gap. The ray's origin, moved `epsilon()` along the normal, must not land beyond the second wall.
TEST(ShadowReference, OffsetStaysInsideANarrowGapBetweenWalls) {
  Scene scene;
  test::addQuad(scene, "ground", {-20, 0, -20}, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20});
  const double diagonal = std::sqrt(40.0 * 40.0 + 10.0 * 10.0 + 40.0 * 40.0);
  const double gap = 4e-6 * diagonal;  // between the default offset (1e-6) and the old one (1e-5)
  test::addQuad(scene, "wall a", {0, 0, -5}, {0, 10, -5}, {0, 10, 5}, {0, 0, 5});
  test::addQuad(scene, "wall b", {-gap, 0, -5}, {-gap, 0, 5}, {-gap, 10, 5}, {-gap, 10, -5});
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene);
  Light sun = overheadSun();
  sun.direction = glm::normalize(glm::dvec3(1, -1, 0));  // from the -x side, down into the gap
  const SurfacePoint onWallA{{0, 5, 0}, {-1, 0, 0}};
  const ShadowReference reference(world);
  EXPECT_NEAR(reference.epsilon(), ShadowReference::kDefaultRelativeEpsilon * diagonal, 1e-12);
  EXPECT_EQ(reference.visibility(sun, onWallA), 0) << "wall b shadows wall a";
  // The offset of earlier releases (1e-5 of the diagonal) jumps the origin past wall b: a false "lit".
  const ShadowReference coarse(world, NormalOrientation::AsGiven, 1e-5);
  EXPECT_EQ(coarse.visibility(sun, onWallA), 1);
  // The ground on the sun's side of the walls is lit, the ground 5 units behind them is in their shadow.
  EXPECT_EQ(reference.visibility(sun, {{-10, 0, 0}, {0, 1, 0}}), 1);
  EXPECT_EQ(reference.visibility(sun, {{5, 0, 0}, {0, 1, 0}}), 0);
}

}  // namespace
}  // namespace cpvs
