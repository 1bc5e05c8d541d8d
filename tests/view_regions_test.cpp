// Regions of a light view and the triangles each one gets (libcpvs/views/view_regions.h, view_geometry.h).
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "libcpvs/views/view_geometry.h"
#include "libcpvs/views/view_regions.h"

namespace cpvs {
namespace {

// Culling a region from its bin gives exactly what culling it from every triangle gives (same triangles, same
// order), for bounds inside, across and outside the view, unbounded and NaN ones, and uneven last regions.
TEST(RegionBins, CullEachRegionAsEveryTriangleWould) {
  ViewGeometry geometry;
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  for (int t = 0; t < 3000; ++t) {
    std::vector<uint32_t>& indices = t % 3 ? geometry.openIndices : geometry.closedIndices;
    for (int k = 0; k < 3; ++k) {
      indices.push_back(uint32_t(geometry.positions.size()));
      geometry.positions.push_back(glm::vec3(float(t), float(k), 0.0f));
    }
  }
  // Bounds per triangle (closed first, then open): points, strips and boxes across the view and beyond it.
  std::mt19937 again(7);
  geometry.gridBounds.resize(geometry.triangleCount());
  std::uniform_real_distribution<float> pick(-300.0f, 1400.0f);
  for (size_t t = 0; t < geometry.triangleCount(); ++t) {
    const float u = pick(again), v = pick(again);
    geometry.gridBounds[t] = {u, u + float(t % 5) * 60.0f, v, v + float(t % 3) * 200.0f};
  }
  geometry.gridBounds[5] = {-inf, inf, 10.0f, 20.0f};
  geometry.gridBounds[6] = {nan, 50.0f, nan, nan};
  geometry.gridBounds[7] = {1023.5f, 1024.5f, -1.0f, -1.0f};
  for (uint32_t resolution : {1000u, 1024u})
    for (uint32_t regionSize : {64u, 256u, 1024u}) {
      const std::vector<RegionRect> regions = splitIntoRegions(resolution, regionSize);
      const std::vector<std::vector<uint32_t>> bins = binToRegions(geometry, resolution, regionSize);
      ASSERT_EQ(bins.size(), regions.size());
      size_t kept = 0;
      for (size_t r = 0; r < regions.size(); ++r) {
        const ViewGeometry all = cullToRegion(geometry, regions[r]), binned = cullToRegion(geometry, regions[r], bins[r]);
        ASSERT_EQ(all.positions, binned.positions) << "region " << r << " of " << regionSize;
        ASSERT_EQ(all.closedIndices, binned.closedIndices);
        ASSERT_EQ(all.openIndices, binned.openIndices);
        kept += all.triangleCount();
      }
      EXPECT_GT(kept, regions.size());
    }
}

}  // namespace
}  // namespace cpvs
