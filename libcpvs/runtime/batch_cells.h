#pragma once
// Steps 1-3 of a lookup (shadow_lookup.h) for a whole batch of points of one view: where each lands, eight
// points at a time with AVX-512 (doubles) or AVX2 (floats, float_cells.h, the points it cannot decide mapped
// again as four doubles) where the CPU has them, four with NEON, one at a time otherwise. Every double path
// runs cell_lanes.h, so they give the same cells bit for bit, and the single-precision one gives theirs
// (batch_cells_test pins them together).
//
// Same rule as view_mapping.h: standard headers only (included under CPVS_TARGET_BEGIN_AVX2 (portability.h)).
#include <cstddef>
#include <cstdint>
#include <optional>

#include "libcpvs/runtime/cell_lanes.h"

namespace cpvs {

// What a point's lookup needs next.
enum CellState : uint8_t {
  kCellZero = 0,   // 0 without the DAG: non-finite input, outside the spot's influence, a back face (AsGiven)
  kCellLit = 1,    // 1 without the DAG: empty view, behind a perspective eye, outside the lateral grid
  kCellVoxel = 2,  // look up voxel (x, y, z)
};

// Points where the caller keeps them: point i's x, y, z at positions[i * positionStride + 0..2], its normal's at
// normals[i * normalStride + 0..2] (normalStride 0: one normal for every point). An array of SurfacePoint
// (shadow_lookup.h) is positionStride = normalStride = 6 with normals = positions + 3; a numpy array of shape
// (n, 3) is stride 3. Exactly three doubles are read at each place.
struct PointArrays {
  const double* positions = nullptr;
  size_t positionStride = 3;
  const double* normals = nullptr;
  size_t normalStride = 3;

  // SurfacePoint's layout, which the vector paths load with fewer instructions.
  bool interleaved() const { return positionStride == 6 && normalStride == 6 && normals == positions + 3; }
};

struct CellBatchInput {
  const ViewMapping* mapping = nullptr;
  CellSettings settings;
  const SpotInfluence* spot = nullptr;  // tested when set (a spot light's only view)
  PointArrays points;
  // When set, selects which points: lane j maps point indices[j] (else point j).
  const uint32_t* indices = nullptr;
  size_t count = 0;
};

// One entry per mapped point (count entries each; x, y, z are meaningful where state is kCellVoxel).
struct CellBatchOutput {
  int32_t* x = nullptr;
  int32_t* y = nullptr;
  int32_t* z = nullptr;
  uint8_t* state = nullptr;
  // When set, incremented by the points a single-precision path could not decide and mapped again in double
  // (float_cells.h), for tests and benchmarks.
  size_t* doubleRemapped = nullptr;
};

// The batch lookups' instruction sets, narrowest first: a limit lets every path up to it run. NEON exists on
// AArch64 only, AVX2 and AVX-512 on x86-64 only (portability.h), so each CPU's best is one of its own.
enum class CellIsa : uint8_t { Scalar, Neon, Avx2, Avx512 };

// The fastest path this CPU runs, lowered to the limit set by setCellIsaLimit (default: no limit).
CellIsa bestCellIsa();
// Caps the paths every later batch lookup may use, process-wide (to compare the paths, or to rule one out; the
// tools take it from the environment variable CPVS_LOOKUP_ISA). A path the CPU lacks is never used.
void setCellIsaLimit(CellIsa limit);
// "scalar", "neon", "avx2", "avx512"; nullopt for anything else (or null).
std::optional<CellIsa> parseCellIsa(const char* name);
// Maps the batch with the given path, or the best one below it that this CPU runs.
void mapCells(const CellBatchInput& in, const CellBatchOutput& out, CellIsa isa);
inline void mapCells(const CellBatchInput& in, const CellBatchOutput& out) { mapCells(in, out, bestCellIsa()); }

namespace detail {
// Calls run(FixedShape<orthographic, linear>{}) for the mapping's kind of view.
template <class Run>
[[gnu::always_inline]] inline void withFixedShape(const ViewMapping& mapping, Run&& run) {
  if (mapping.orthographic) {
    if (mapping.linear) run(FixedShape<true, true>{});
    else run(FixedShape<true, false>{});
  } else {
    if (mapping.linear) run(FixedShape<false, true>{});
    else run(FixedShape<false, false>{});
  }
}

void mapCellsAvx2(const CellBatchInput& in, const CellBatchOutput& out);    // batch_cells_avx2.cpp
void mapCellsAvx512(const CellBatchInput& in, const CellBatchOutput& out);  // batch_cells_avx512.cpp
void mapCellsNeon(const CellBatchInput& in, const CellBatchOutput& out);    // batch_cells_neon.cpp
}

}  // namespace cpvs
