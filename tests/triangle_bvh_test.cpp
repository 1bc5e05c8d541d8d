// The triangle index that lets each light look only at what it reaches (libcpvs/scene/triangle_bvh.h), and the
// views and view geometry fitted with it, which must equal those fitted over every triangle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <random>

#include "libcpvs/scene/triangle_bvh.h"
#include "libcpvs/views/view_fitting.h"
#include "libcpvs/views/view_geometry.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// A city-like block: a ground sheet (so the flattened world has closing triangles), a grid of boxes of many
// heights, and scattered open quads.
WorldGeometry blocks() {
  Scene scene;
  test::addQuad(scene, "ground", {-60, 0, 60}, {60, 0, 60}, {60, 0, -60}, {-60, 0, -60});
  std::mt19937 random(7);
  std::uniform_real_distribution<double> height(0.5, 25.0);
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) {
      const double x = -55 + 9.5 * i, z = -55 + 9.5 * j;
      const std::string name = "block " + std::to_string(12 * i + j);
      test::addBox(scene, name, {x, 0, z}, {x + 6, height(random), z + 5});
      if ((i + j) % 5 == 0) test::addQuad(scene, "q", {x, 3, z + 6}, {x + 4, 3, z + 6}, {x + 4, 5, z + 8}, {x, 5, z + 8});
    }
  test::classifyMeshes(scene);
  return flatten(scene);
}

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(TriangleBvh, FindsEveryTriangleWhoseBoundsOverlapInIndexOrder) {
  const WorldGeometry world = blocks();
  ASSERT_GT(world.closingEnd, world.closingBegin) << "the ground must be a closed sheet for this test";
  const TriangleBvh index(world);
  EXPECT_EQ(index.triangleCount(), world.triangleCount());
  std::mt19937 random(3);
  std::uniform_real_distribution<double> at(-80, 80), size(0.0, 40.0);
  size_t found = 0;
  for (int q = 0; q < 300; ++q) {
    const glm::dvec3 lo(at(random), at(random) * 0.3, at(random));
    const glm::dvec3 hi = lo + glm::dvec3(size(random), size(random), size(random)) * (q % 10 == 0 ? 0.0 : 1.0);
    std::vector<uint32_t> got;
    index.overlapping(lo, hi, got);
    ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
    ASSERT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end());
    for (size_t t = 0; t < world.triangleCount(); ++t) {
      glm::dvec3 a(std::numeric_limits<double>::infinity()), b(-std::numeric_limits<double>::infinity());
      for (int k = 0; k < 3; ++k) {
        a = glm::min(a, world.positions[world.indices[3 * t + k]]);
        b = glm::max(b, world.positions[world.indices[3 * t + k]]);
      }
      const bool overlaps = a.x <= hi.x && lo.x <= b.x && a.y <= hi.y && lo.y <= b.y && a.z <= hi.z && lo.z <= b.z;
      const bool listed = std::binary_search(got.begin(), got.end(), uint32_t(t));
      if (overlaps) {
        ASSERT_TRUE(listed) << "triangle " << t << " missed by query " << q;
      }
      if (listed && !overlaps) {  // only from rounding the bounds outward to float
        const glm::dvec3 gap = glm::max(a - hi, lo - b);
        ASSERT_LT(std::max({gap.x, gap.y, gap.z}), 1e-4) << "triangle " << t << " far outside query " << q;
      }
    }
    found += got.size();
  }
  EXPECT_GT(found, 1000u);
}

// Spots and point lights with and without a range, and a sun: with the index, the fitted views and the triangles
// gathered for each view are the same, bit for bit, as without it.
TEST(TriangleBvh, ViewsAndViewGeometryEqualThoseOverEveryTriangle) {
  const WorldGeometry world = blocks();
  const TriangleBvh index(world);
  std::vector<Light> lights = {test::sunLight("sun", {0.3, -1, 0.2})};
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 p(-50 + 13.0 * i, 8 + 3 * (i % 3), 40 - 11.0 * i);
    lights.push_back(test::spotLight("spot", p, {0.1 * (i - 4), -1, 0.05 * i}, 0.3 + 0.1 * i, i == 3 ? 1e30 : 15 + 5 * i));
    lights.push_back(test::pointLight("point", p + glm::dvec3(3, -2, 1), i == 5 ? std::numeric_limits<double>::infinity() : 12 + 4 * i));
  }
  size_t views = 0, gathered = 0, culled = 0;
  for (const Light& light : lights) {
    const std::vector<LightView> all = makeLightViews(light, world, 512);
    const std::vector<LightView> near = makeLightViews(light, world, 512, &index);
    ASSERT_EQ(all.size(), near.size());
    for (size_t v = 0; v < all.size(); ++v) {
      const LightView &a = all[v], &b = near[v];
      EXPECT_EQ(a.empty, b.empty);
      for (const auto& [x, y] : {std::pair{a.xMin, b.xMin}, {a.xMax, b.xMax}, {a.yMin, b.yMin}, {a.yMax, b.yMax},
                                 {a.near, b.near}, {a.far, b.far}})
        EXPECT_TRUE(sameBits(x, y)) << light.name << " view " << v << ": " << x << " vs " << y;
      const ViewGeometry ga = gatherViewGeometry(world, a), gb = gatherViewGeometry(world, a, &index);
      EXPECT_EQ(ga.positions, gb.positions) << light.name << " view " << v;
      EXPECT_EQ(ga.gridBounds, gb.gridBounds);
      EXPECT_EQ(ga.closedIndices, gb.closedIndices);
      EXPECT_EQ(ga.openIndices, gb.openIndices);
      ++views;
      gathered += ga.triangleCount();
      culled += a.empty ? 0 : world.triangleCount() - ga.triangleCount();
    }
  }
  EXPECT_GT(views, 50u);
  EXPECT_GT(gathered, 1000u);
  EXPECT_GT(culled, gathered) << "most lights must reach only part of the scene, or the index proves little";
}

}  // namespace
}  // namespace cpvs
