#include "support/test_dags.h"

#include <algorithm>
#include <random>
#include <span>
#include <vector>

#include "libcpvs/base/error.h"

namespace cpvs::test {

DepthRegion syntheticDepth(uint32_t n, uint32_t seed, RegionRect rect) {
  if (rect.width == 0) rect = {0, 0, n, n};
  std::mt19937 rng(seed);
  struct Block {
    uint32_t x0, y0, x1, y1, e, thickness;
  };
  std::vector<Block> blocks;
  const uint32_t side = std::max(1u, n / 3);
  for (int i = 0; i < 12; ++i) {
    const uint32_t x0 = rng() % n, y0 = rng() % n;
    const uint32_t w = 1 + rng() % side, h = 1 + rng() % side;
    const uint32_t e = rng() % (n - 1);
    const uint32_t thickness = (rng() % 3 == 0) ? 1 : 1 + rng() % (n - e);
    blocks.push_back({x0, y0, std::min(n, x0 + w), std::min(n, y0 + h), e, thickness});
  }
  DepthRegion d;
  d.rect = rect;
  d.resolution = n;
  d.enter.assign(size_t(rect.width) * rect.height, n);
  d.exit.assign(size_t(rect.width) * rect.height, n);
  for (uint32_t y = 0; y < rect.height; ++y)
    for (uint32_t x = 0; x < rect.width; ++x) {
      const uint32_t gx = rect.x0 + x, gy = rect.y0 + y;
      uint32_t e = n, xs = n;
      for (const Block& b : blocks)
        if (gx >= b.x0 && gx < b.x1 && gy >= b.y0 && gy < b.y1 && b.e < e) {
          e = b.e;
          xs = std::min(n, b.e + b.thickness);
        }
      // A sloped open surface over part of the map, and single-texel open specks.
      const uint32_t slope = (gx + 2 * gy) % n;
      if (gx + gy < n / 2 && slope < e) e = slope, xs = std::min(n, slope + 1);
      const uint32_t speck = (3 * gx + gy) % n;
      if ((gx ^ gy) % 7 == 0 && gx + gy < n && speck < e) e = speck, xs = std::min(n, speck + 1);
      d.enter[size_t(y) * rect.width + x] = e;
      d.exit[size_t(y) * rect.width + x] = std::max(xs, std::min(n, e + 1));
    }
  return d;
}

ShadowDag wideReferenceDag() {
  std::vector<uint64_t> leaves(70000);
  for (size_t i = 0; i < leaves.size(); ++i) leaves[i] = (i + 1) * 0x9E3779B97F4A7C15ull;
  std::vector<uint32_t> root{0}, parents;
  for (unsigned c = 0; c < 8; ++c) {
    root[0] |= 2u << (2 * c);
    root.push_back(uint32_t(parents.size()));
    const size_t header = parents.size();
    parents.push_back(0);
    for (unsigned z = 0; z < 8; ++z) {
      const unsigned kind = (c + z) % 4;  // 0 lit, 1 shadowed, 2 a low leaf index, 3 a high one
      parents[header] |= std::min(kind, 2u) << (2 * z);
      if (kind == 2) parents.push_back(c * 8 + z);
      if (kind == 3) parents.push_back(65530 + c * 500 + z);
    }
  }
  const std::span<const uint32_t> levels[2] = {root, parents};
  const uint64_t counts[2] = {1, 8};
  return orThrow(encodeDag(16, ChildCode::Ref, levels, counts, std::move(leaves)));
}

LightView identityView(uint32_t n) {
  LightView view;
  view.projection = Projection::Orthographic;
  view.mapping = DepthMapping::Linear;
  view.resolution = n;
  view.xMin = 0;
  view.xMax = n;
  view.yMin = 0;
  view.yMax = n;
  view.near = 0;
  view.far = n;
  return view;
}

Light sun() {
  Light light;
  light.name = "sun";
  light.type = LightType::Directional;
  light.direction = {0, 0, -1};
  return light;
}

}  // namespace cpvs::test
