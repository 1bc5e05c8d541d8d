#pragma once
// mapCells' loop over a batch in groups of the lane width, for every path (batch_cells.cpp's scalar lanes,
// lanes_x86.h's vector ones). Same rule as view_mapping.h: standard headers and the runtime's own lane headers
// only, and in an unnamed namespace, since the vector kernels include it under their CPVS_TARGET_BEGIN_*
// (portability.h).
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/float_cells.h"
#include "libcpvs/runtime/portability.h"

namespace cpvs {
namespace {

// Brings the SurfacePoint records of points [first, first + count) of a batch without an index list into the
// cache, eight groups before the loop reads them: records read once, 48 bytes each, where the hardware
// prefetcher alone left the mapping waiting on memory (docs/lookups.md, "The mapping in single precision").
// Always inlined: GCC takes a function of prefetches alone for one without effects and drops its calls.
[[gnu::always_inline]] inline void prefetchRecords(const double* points, size_t first, size_t count, size_t total) {
  if (first >= total) return;
  const char* begin = reinterpret_cast<const char*>(points + 6 * first);
  const size_t bytes = 6 * sizeof(double) * (first + count <= total ? count : total - first);
  for (size_t at = 0; at < bytes; at += 64) portable::prefetchRead(begin + at);
}

// Whether lane type L's loop prefetches the records (the x86 vector paths, where it was measured to pay; the
// scalar and NEON paths were measured only in instructions, which a prefetch adds).
template <class L>
constexpr bool kPrefetchesRecords = requires { L::kPrefetchRecords; };

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
    if (kPrefetchesRecords<L> && kInterleaved && !indices) prefetchRecords(points, j + 8 * kWidth, kWidth, in.count);
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

// mapCells in single precision (float_cells.h) with float lane type FL, FL::kWidth points at a time; the lanes
// it cannot decide are collected, up to kRedoChunk at a time, and mapped again with the double lane type DL
// (the same cells as every other path, bit for bit). FL::load gives a group's view coordinates as the double
// path computes them, its normals and its offsets from the spot, all rounded to float; FL::store writes the
// certain lanes and returns the uncertain ones' bits.
template <class FL, class DL, class Shape, bool kInterleaved>
void mapCellsFloatShaped(const CellBatchInput& in, const CellBatchOutput& out, const FloatViewMapping& fm) {
  constexpr size_t kWidth = FL::kWidth, kRedoChunk = 512;
  uint32_t redoPoint[kRedoChunk], redoAt[kRedoChunk];
  alignas(64) int32_t redoX[kRedoChunk], redoY[kRedoChunk], redoZ[kRedoChunk];
  uint8_t redoState[kRedoChunk];
  size_t redo = 0;
  const auto remap = [&] {
    CellBatchInput again = in;
    again.indices = redoPoint;
    again.count = redo;
    mapCellsShaped<DL, Shape, kInterleaved>(again, {redoX, redoY, redoZ, redoState});
    for (size_t k = 0; k < redo; ++k) {
      out.x[redoAt[k]] = redoX[k];
      out.y[redoAt[k]] = redoY[k];
      out.z[redoAt[k]] = redoZ[k];
      out.state[redoAt[k]] = redoState[k];
    }
    if (out.doubleRemapped) *out.doubleRemapped += redo;
    redo = 0;
  };
  const CellSettings settings = in.settings;
  const FloatBiasBounds bias = floatBiasBounds(fm, settings, !in.mapping->linear);
  const double* const points = in.points.positions;
  const uint32_t* const indices = in.indices;
  // One group; whole groups (kFull) have their lane count and index arithmetic fixed at compile time.
  const auto group = [&]<bool kFull>(size_t j, size_t lanes, auto indexOf) {
    const double* p[kWidth];
    const double* n[kWidth];
    uint32_t index[kWidth];
    for (size_t l = 0; l < kWidth; ++l) {
      index[l] = uint32_t(indexOf(j + (kFull || l < lanes ? l : lanes - 1)));
      if constexpr (kInterleaved) {
        p[l] = points + 6 * size_t(index[l]);
        n[l] = p[l] + 3;
      } else {
        p[l] = points + in.points.positionStride * index[l];
        n[l] = in.points.normals + in.points.normalStride * index[l];
      }
    }
    typename FL::Real c[9];
    FL::template load<kInterleaved>(p, n, *in.mapping, fm, c);
    const auto lanesOut = floatCellVerdict<typename FL::Real, typename FL::Mask, typename FL::Bits, Shape>(
        *in.mapping, fm, settings, bias, c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8]);
    uint32_t uncertain = FL::store(lanesOut, out, j, kFull ? kWidth : lanes);
    while (uncertain) {
      const unsigned l = unsigned(std::countr_zero(uncertain));
      uncertain &= uncertain - 1;
      if (redo == kRedoChunk) remap();
      redoPoint[redo] = index[l];
      redoAt[redo++] = uint32_t(j + l);
    }
  };
  const auto run = [&](auto indexOf) {
    const size_t whole = in.count - in.count % kWidth;
    for (size_t j = 0; j < whole; j += kWidth) {
      if (kPrefetchesRecords<FL> && kInterleaved && !indices) prefetchRecords(points, j + 8 * kWidth, kWidth, in.count);
      group.template operator()<true>(j, kWidth, indexOf);
    }
    if (whole < in.count) group.template operator()<false>(whole, in.count - whole, indexOf);
  };
  if (indices)
    run([indices](size_t k) { return indices[k]; });
  else
    run([](size_t k) { return k; });
  if (redo) remap();
}

// mapCells for the vector paths: single precision where the view allows it (floatViewMapping), else double.
template <class FL, class DL>
void mapCellsFloatOrDouble(const CellBatchInput& in, const CellBatchOutput& out) {
  const FloatViewMapping fm = floatViewMapping(*in.mapping, in.spot);
  if (!fm.usable || in.count < FL::kWidth) return mapCellsLanes<DL>(in, out);
  detail::withFixedShape(*in.mapping, [&](auto shape) {
    if (in.points.interleaved())
      mapCellsFloatShaped<FL, DL, decltype(shape), true>(in, out, fm);
    else
      mapCellsFloatShaped<FL, DL, decltype(shape), false>(in, out, fm);
  });
}

}  // namespace
}  // namespace cpvs
