// ShadowReference: the ground truth of cpvs-query --reference and cpvs-sweep. Its "uniform" flag decides
// which points the 0.1 % target is measured on, so its definition is pinned here: the same answer on a circle
// of radius 2 voxels on the tangent plane and 2 voxels out along the normal.
#include <gtest/gtest.h>

#include "libcpvs/light_view.h"
#include "libcpvs/lookup/shadow_lookup.h"
#include "libcpvs/reference/shadow_reference.h"
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
  const LightShadow shadow(f.sun, f.views, {f.lit.view()});
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

}  // namespace
}  // namespace cpvs
