#pragma once
// What the point lookups (shadowed_texels.cpp) and the batch engine (batch_lookup.cpp) share: a footprint of
// texels, its overlap with a node and a tile, and the DAG's node units. Internal to the runtime.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "libcpvs/runtime/dag_walks.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs::lookup_detail {

// The node units of a DAG, never null: a view without nodes (all lit or all shadowed) gets a few zero units,
// so that the branch-free walks can form (and prefetch) node addresses without offsetting a null pointer.
inline const uint16_t* nodeUnits(const DagView& dag) {
  static const uint16_t kNoNodes[64] = {};
  return dag.nodes.empty() ? kNoNodes : dag.nodes.data();
}

inline bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The kernel's footprint, inclusive texel bounds already clipped to [0, N).
struct Footprint {
  uint32_t x0, x1, y0, y1;
};

inline uint32_t overlap(uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1) {  // inclusive ranges
  const uint32_t lo = std::max(a0, b0), hi = std::min(a1, b1);
  return hi >= lo ? hi - lo + 1 : 0;
}

// Mask of the 8x8 tile at (ox, oy) covered by the footprint (which must overlap it).
inline uint64_t tileMask(const Footprint& f, uint32_t ox, uint32_t oy) {
  const uint32_t xa = std::max(f.x0, ox) - ox, xb = std::min(f.x1, ox + 7) - ox;
  const uint32_t ya = std::max(f.y0, oy) - oy, yb = std::min(f.y1, oy + 7) - oy;
  return kTileSpans.columns[xa * 8 + xb] & kTileSpans.rows[ya * 8 + yb];
}

}  // namespace cpvs::lookup_detail
