// Shadowed texels of a K x K footprint and single voxels, counted by walking a view's DAG from its top-level
// pointer grid (Kampe et al. 2015, section 5.3), and the grid itself: the point lookups of shadow_lookup.h.
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "libcpvs/runtime/dag_footprint.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {
namespace {

using namespace lookup_detail;

// Shadowed texels of the footprint inside a node of edge `size` at (ox, oy) with child code `code`
// (for a reference: the node at word `offset`), slice z.
uint32_t countCode(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy,
                   uint32_t z, const Footprint& f);

uint32_t countNode(const DagView& dag, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy, uint32_t z,
                   const Footprint& f) {
  const uint32_t header = dag.nodes[offset];
  if (size == 8) {  // leaf parent: z-only split into 8x8x1 leaves
    const unsigned c = z & 7u;
    const uint32_t code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Lit)) return 0;
    if (code == uint32_t(ChildCode::Shadowed))
      return overlap(ox, ox + 7, f.x0, f.x1) * overlap(oy, oy + 7, f.y0, f.y1);
    const uint64_t mask = dag.leaves[dag.child(offset, header, c, 8)];
    return popcount64(mask & tileMask(f, ox, oy));
  }
  const uint32_t half = size >> 1;
  const unsigned zbit = (z & half) ? 4u : 0u;
  uint32_t count = 0;
  for (unsigned yb = 0; yb < 2; ++yb) {
    const uint32_t cy = oy + yb * half;
    const uint32_t oyCount = overlap(cy, cy + half - 1, f.y0, f.y1);
    if (!oyCount) continue;
    for (unsigned xb = 0; xb < 2; ++xb) {
      const uint32_t cx = ox + xb * half;
      const uint32_t oxCount = overlap(cx, cx + half - 1, f.x0, f.x1);
      if (!oxCount) continue;
      const unsigned c = zbit | (yb << 1) | xb;
      const uint32_t code = childCodeOf(header, c);
      if (code == uint32_t(ChildCode::Lit)) continue;
      if (code == uint32_t(ChildCode::Shadowed)) {
        count += oxCount * oyCount;
      } else {
        count += countNode(dag, dag.child(offset, header, c, size), half, cx, cy, z, f);
      }
    }
  }
  return count;
}

uint32_t countCode(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy,
                   uint32_t z, const Footprint& f) {
  if (code == uint32_t(ChildCode::Lit)) return 0;
  if (code == uint32_t(ChildCode::Shadowed))
    return overlap(ox, ox + size - 1, f.x0, f.x1) * overlap(oy, oy + size - 1, f.y0, f.y1);
  return countNode(dag, offset, size, ox, oy, z, f);
}

// Walks from a node of edge `size` with child code `code` (offset: its words) down to voxel (x, y, z).
inline bool walk(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t x, uint32_t y,
                 uint32_t z) {
  const uint16_t* nodes = nodeUnits(dag);
  for (uint32_t half = size >> 1; half >= 8; half >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = dag.child(offset, header, c, half * 2);
  }
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const unsigned c = z & 7u;
  const uint32_t header = nodes[offset];
  code = childCodeOf(header, c);
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const uint64_t mask = dag.leaves[dag.child(offset, header, c, 8)];
  return (mask >> ((y & 7u) * 8u + (x & 7u))) & 1u;
}

}  // namespace

uint32_t shadowedTexels(const DagView& dag, const TopGrid& grid, int32_t x, int32_t y, uint32_t z, int pcfKernel) {
  const int32_t n = int32_t(dag.resolution);
  const int32_t h = pcfKernel / 2;
  if (pcfKernel <= 1) {
    if (x < 0 || y < 0 || x >= n || y >= n) return 0;
    return shadowedVoxel(dag, grid, uint32_t(x), uint32_t(y), z) ? 1 : 0;
  }
  const int64_t x0 = std::max<int64_t>(0, int64_t(x) - h), x1 = std::min<int64_t>(n - 1, int64_t(x) + h);
  const int64_t y0 = std::max<int64_t>(0, int64_t(y) - h), y1 = std::min<int64_t>(n - 1, int64_t(y) + h);
  if (x0 > x1 || y0 > y1) return 0;
  const Footprint f{uint32_t(x0), uint32_t(x1), uint32_t(y0), uint32_t(y1)};
  if (dag.rootCode == ChildCode::Lit) return 0;
  if (dag.rootCode == ChildCode::Shadowed) return (f.x1 - f.x0 + 1) * (f.y1 - f.y0 + 1);
  if (grid.empty()) return countNode(dag, 0, dag.resolution, 0, 0, z, f);
  // Start in the grid cells the footprint overlaps (at most 4 for a kernel no wider than a cell).
  const uint32_t size = 1u << grid.shift, level = grid.level;
  const uint32_t gz = z >> grid.shift;
  uint32_t count = 0;
  for (uint32_t gy = f.y0 >> grid.shift; gy <= (f.y1 >> grid.shift); ++gy)
    for (uint32_t gx = f.x0 >> grid.shift; gx <= (f.x1 >> grid.shift); ++gx) {
      const uint32_t cell = grid.cells[(size_t(gz) << (2 * level)) | (size_t(gy) << level) | gx];
      count += countCode(dag, cell & 3u, cell >> 2, size, gx << grid.shift, gy << grid.shift, z, f);
    }
  return count;
}

uint32_t shadowedTexels(const DagView& dag, int32_t x, int32_t y, uint32_t z, int pcfKernel) {
  static const TopGrid none;
  return shadowedTexels(dag, none, x, y, z, pcfKernel);
}

CPVS_POPCNT_CLONES bool shadowedVoxel(const DagView& dag, const TopGrid& grid, uint32_t x, uint32_t y, uint32_t z) {
  if (grid.empty()) return walk(dag, uint32_t(dag.rootCode), 0, dag.resolution, x, y, z);
  const uint32_t s = grid.shift, level = grid.level;
  const uint32_t cell =
      grid.cells[(size_t(z >> s) << (2 * level)) | (size_t(y >> s) << level) | size_t(x >> s)];
  return walk(dag, cell & 3u, cell >> 2, 1u << s, x, y, z);
}

TopGrid TopGrid::build(const DagView& dag, uint32_t level) {
  TopGrid grid;
  // Entries pack a unit offset above a 2-bit code: no grid for a DAG of 2^30 units (2 GiB) or more.
  if (dag.resolution < 16 || dag.nodes.size() >= (size_t(1) << 30)) return grid;
  const uint32_t log2n = uint32_t(std::countr_zero(dag.resolution));
  level = std::min(level, log2n - 3);  // cells of at least 8 voxels: a leaf-parent node
  if (level == 0) return grid;
  grid.level = level;
  grid.shift = log2n - level;
  const uint32_t side = 1u << level;
  grid.cells.assign(size_t(side) * side * side, uint32_t(dag.rootCode));
  if (dag.rootCode != ChildCode::Ref) return grid;
  // Fill level by level: the entries of level l + 1 from the nodes of level l.
  std::vector<uint32_t> current{uint32_t(ChildCode::Ref)}, next;
  for (uint32_t l = 0; l < level; ++l) {
    const uint32_t width = 1u << l, nextWidth = width << 1;
    next.assign(size_t(nextWidth) * nextWidth * nextWidth, 0);
    for (uint32_t cz = 0; cz < width; ++cz)
      for (uint32_t cy = 0; cy < width; ++cy)
        for (uint32_t cx = 0; cx < width; ++cx) {
          const uint32_t entry = current[(size_t(cz) * width + cy) * width + cx];
          const uint32_t code = entry & 3u, offset = entry >> 2;
          const uint32_t header = code == uint32_t(ChildCode::Ref) ? dag.nodes[offset] : 0;
          for (unsigned c = 0; c < 8; ++c) {
            const uint32_t x = 2 * cx + (c & 1u), y = 2 * cy + ((c >> 1) & 1u), z = 2 * cz + ((c >> 2) & 1u);
            uint32_t child = code;  // homogeneous: every child has the parent's code
            if (code == uint32_t(ChildCode::Ref)) {
              child = childCodeOf(header, c);
              if (child == uint32_t(ChildCode::Ref)) child |= dag.child(offset, header, c, dag.resolution >> l) << 2;
            }
            next[(size_t(z) * nextWidth + y) * nextWidth + x] = child;
          }
        }
    current.swap(next);
  }
  // Root offset 0 is encoded as (0 << 2) | Ref; offsets fit in 30 bits (checked above).
  grid.cells = std::move(current);
  return grid;
}

uint32_t TopGrid::automaticLevel(const DagView& dag) {
  const uint64_t dagBytes = dag.bytes();
  uint32_t level = kMaxAutomaticTopGridLevels;
  while (level > 0 && (uint64_t(4) << (3 * level)) > dagBytes) --level;
  return level;
}

}  // namespace cpvs
