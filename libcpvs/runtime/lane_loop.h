#pragma once
// mapCells' loop over a batch in groups of the lane width, for every path (batch_cells.cpp's scalar lanes,
// lanes_x86.h's vector ones). Same rule as view_mapping.h: standard headers only, and in an unnamed namespace,
// since the vector kernels include it under their CPVS_TARGET_BEGIN_* (portability.h).
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs {
namespace {

// mapCells for one kind of view and one layout of the points with lane type L: L::kWidth points at a time
// (L::load reads them from SurfacePoint records, L::loadSplit from separate position and normal arrays; L::cells
// gives their voxels and states, one byte per lane; a short last group repeats its last point in the unused
// lanes, read, never stored).
template <class L, class Shape, bool kInterleaved>
void mapCellsShaped(const CellBatchInput& in, const CellBatchOutput& out) {
  using Real = typename L::Real;
  using Mask = typename L::Mask;
  constexpr size_t kWidth = L::kWidth;
  // Local copies: the byte stores to out.state could alias *in.mapping, which would make the compiler reload
  // every constant in every group.
  const ViewMapping mapping = *in.mapping;
  const CellSettings settings = in.settings;
  const SpotInfluence spot = in.spot ? *in.spot : SpotInfluence{};
  const SpotInfluence* spotOrNull = in.spot ? &spot : nullptr;
  const double* const points = in.points.positions;
  const uint32_t* const indices = in.indices;
  for (size_t j = 0; j < in.count; j += kWidth) {
    const size_t lanes = in.count - j < kWidth ? in.count - j : kWidth;
    const double* p[kWidth];
    Real c[6];
    if constexpr (kInterleaved) {  // the tools' layout: one pointer and a constant stride, nothing more per lane
      for (size_t l = 0; l < kWidth; ++l) {
        const size_t k = j + (l < lanes ? l : lanes - 1);
        p[l] = points + 6 * size_t(indices ? indices[k] : k);
      }
      L::load(p, c);
    } else {
      const double* n[kWidth];
      for (size_t l = 0; l < kWidth; ++l) {
        const size_t k = j + (l < lanes ? l : lanes - 1);
        const size_t i = size_t(indices ? indices[k] : k);
        p[l] = points + in.points.positionStride * i;
        n[l] = in.points.normals + in.points.normalStride * i;
      }
      L::loadSplit(p, n, c);
    }
    const CellVerdict<Real, Mask> v =
        cellVerdict<Real, Mask, Shape>(mapping, settings, spotOrNull, c[0], c[1], c[2], c[3], c[4], c[5]);
    alignas(64) int32_t xs[kWidth], ys[kWidth], zs[kWidth];
    const uint64_t state = L::cells(v, xs, ys, zs);
    if (lanes == kWidth && std::endian::native == std::endian::little) {
      std::memcpy(out.x + j, xs, sizeof xs);
      std::memcpy(out.y + j, ys, sizeof ys);
      std::memcpy(out.z + j, zs, sizeof zs);
      std::memcpy(out.state + j, &state, kWidth);  // little-endian: byte l is lane l
      continue;
    }
    for (size_t l = 0; l < lanes; ++l) {
      out.x[j + l] = xs[l];
      out.y[j + l] = ys[l];
      out.z[j + l] = zs[l];
      out.state[j + l] = uint8_t(state >> (8 * l));
    }
  }
}

// mapCells with lane type L: the kind of view and the points' layout each chosen once per batch, each loop
// compiled for its choice (SurfacePoint records then cost no stride arithmetic per lane).
template <class L>
void mapCellsLanes(const CellBatchInput& in, const CellBatchOutput& out) {
  detail::withFixedShape(*in.mapping, [&](auto shape) {
    if (in.points.interleaved())
      mapCellsShaped<L, decltype(shape), true>(in, out);
    else
      mapCellsShaped<L, decltype(shape), false>(in, out);
  });
}

}  // namespace
}  // namespace cpvs
