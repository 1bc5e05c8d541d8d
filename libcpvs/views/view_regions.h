#pragma once
// Regions: the rectangles of texels of a light view that are rendered, masked and built one at a time, so
// that a bake's memory is bounded by the region and not by N^2.
#include <cstdint>
#include <vector>

namespace cpvs {

// A rectangle of texels of a view: [x0, x0 + width) x [y0, y0 + height).
struct RegionRect {
  uint32_t x0 = 0, y0 = 0, width = 0, height = 0;
};

// The texels of a region a caller will read, row by row: row j (region coordinates) needs [begin[j], end[j]);
// begin == end when it needs none. A renderer may leave every other texel of the region unrendered.
struct RowSpans {
  std::vector<uint32_t> begin, end;
};

// Splits an N x N view into regions of at most regionSize x regionSize texels (row-major order).
std::vector<RegionRect> splitIntoRegions(uint32_t resolution, uint32_t regionSize);

}  // namespace cpvs
