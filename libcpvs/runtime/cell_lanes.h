#pragma once
// Steps 1-3 of a lookup (shadow_lookup.h: grid point, normal bias, voxel) and a spot light's influence test,
// written once over the lane type like view_mapping.h's mapToGrid: lookupCell runs them on one double, the
// batch on four (batch_cells_avx2.cpp), with the same operations in the same order. Each outcome is computed
// for every lane and selected at the end, so the unpredictable ones (front or back face) cost no branch.
//
// Same rule as view_mapping.h: standard headers and portability.h only (included under CPVS_TARGET_BEGIN_AVX2
// (portability.h) there).
#include <cmath>
#include <cstdint>
#include <limits>

#include "libcpvs/runtime/portability.h"
#include "libcpvs/runtime/view_mapping.h"

namespace cpvs {

// What the bias needs from LookupOptions.
struct CellSettings {
  double kernelHalf = 0.5;  // K / 2
  double margin = 0.25;     // voxels
  bool backFacingIsShadow = true;  // NormalOrientation::AsGiven: a back face answers 0; TowardLight: flip n
};

template <class Real, class Mask>
struct CellLanes {
  GridLanes<Real, Mask> grid;
  Real qu, qv, qs;  // the biased grid point q
  Mask back;        // the normal faces away from the light
  Mask inside;      // q.u and q.v in [0, N) (false for NaN)
};

// The surface normal n in grid space, m = J^-T n up to a positive factor (J = d(u, v, s) / d(world) at the
// mapped point g): the view rotation applied to n, then the grid Jacobian's inverse transpose in closed form
// (shadow_lookup.cpp, gridNormal, has the derivation).
template <class Real, class Mask, class Shape = AnyShape>
[[gnu::always_inline]] inline void gridNormalLanes(const ViewMapping& c, const GridLanes<Real, Mask>& g, Real nx,
                                                   Real ny, Real nz, Real& mx, Real& my, Real& mz) {
  const Real nvx = (Real(c.row[0][0]) * nx + Real(c.row[0][1]) * ny) + Real(c.row[0][2]) * nz;
  const Real nvy = (Real(c.row[1][0]) * nx + Real(c.row[1][1]) * ny) + Real(c.row[1][2]) * nz;
  const Real nvz = (Real(c.row[2][0]) * nx + Real(c.row[2][1]) * ny) + Real(c.row[2][2]) * nz;
  const Real d = g.depth;
  const Real invDs = Shape::linear(c) ? Real(c.invDs) : Real(c.invDs) * d;  // 1 / (ds / dd)
  if (Shape::orthographic(c)) {
    mx = nvx * Real(c.uStep);
    my = nvy * Real(c.vStep);
    mz = -nvz * invDs;
  } else {
    mx = (nvx * d) * Real(c.uStep);
    my = (nvy * d) * Real(c.vStep);
    mz = ((nvx * g.viewX + nvy * g.viewY) * g.invDepth - nvz) * invDs;
  }
}

template <class Real, class Mask, class Shape = AnyShape>
[[gnu::always_inline]] inline CellLanes<Real, Mask> cellLanes(const ViewMapping& c, const CellSettings& settings,
                                                              Real px, Real py, Real pz, Real nx, Real ny, Real nz) {
  CellLanes<Real, Mask> cell;
  cell.grid = mapToGrid<Real, Mask, Shape>(c, px, py, pz);
  const GridLanes<Real, Mask>& g = cell.grid;
  Real mx, my, mz;
  gridNormalLanes<Real, Mask, Shape>(c, g, nx, ny, nz, mx, my, mz);
  cell.back = mz > Real(0.0);
  const Real flip = laneSelect(cell.back, Real(-1.0), Real(1.0));  // TowardLight: face the light
  mx = mx * flip;
  my = my * flip;
  mz = mz * flip;
  const Real length2 = (mx * mx + my * my) + mz * mz;
  const Mask biased = (length2 > Real(0.0)) & (length2 <= Real(std::numeric_limits<double>::max()));
  const Real inv = laneSelect(biased, Real(1.0) / laneSqrt(length2), Real(0.0));
  const Real ux = mx * inv, uy = my * inv, uz = mz * inv;
  const Real b = Real(settings.kernelHalf) * (laneAbs(ux) + laneAbs(uy)) + Real(settings.margin);
  cell.qu = g.u + b * ux;
  cell.qv = g.v + b * uy;
  cell.qs = g.s + b * uz;
  const Real n = Real(c.resolution);
  cell.inside = (cell.qu >= Real(0.0)) & (cell.qu < n) & (cell.qv >= Real(0.0)) & (cell.qv < n);
  return cell;
}

// The voxel's slice: toVoxel's floor and clamp for a q whose slice may lie anywhere (NaN lands in 0). The
// lateral coordinates need no clamp where `inside` holds; truncation is floor for values >= 0.
template <class Real>
[[gnu::always_inline]] inline Real clampedSlice(Real qs, double maxIndex) {
  return laneSelect(qs >= Real(0.0), laneSelect(qs < Real(maxIndex), qs, Real(maxIndex)), Real(0.0));
}

// A spot light's influence: within range and inside the outer cone (LightShadow::viewIndex's rule).
struct SpotInfluence {
  double position[3] = {0, 0, 0};
  double direction[3] = {0, 0, -1};
  double range = std::numeric_limits<double>::infinity();
  double cosOuter = -1;
};

template <class Real, class Mask>
[[gnu::always_inline]] inline Mask insideSpot(const SpotInfluence& spot, Real px, Real py, Real pz) {
  const Real tx = px - Real(spot.position[0]), ty = py - Real(spot.position[1]), tz = pz - Real(spot.position[2]);
  const Real distance = laneSqrt((tx * tx + ty * ty) + tz * tz);
  const Real along = (tx * Real(spot.direction[0]) + ty * Real(spot.direction[1])) + tz * Real(spot.direction[2]);
  return (distance <= Real(spot.range)) & (distance != Real(0.0)) & (!(along / distance < Real(spot.cosOuter)));
}

// Where a point's lookup goes, lane by lane: `voxel` (look up (x, y, z), truncated from the returned values,
// which are 0 in the other lanes) or `lit` (answer 1); neither: answer 0. The order of the rules is
// shadow_lookup.h's: invalid input, outside the influence, empty view, behind the eye, back face, outside the
// lateral grid.
template <class Real, class Mask>
struct CellVerdict {
  Mask lit, voxel;
  Real x, y, z;
};

template <class Real, class Mask>
[[gnu::always_inline]] inline Mask finiteLane(Real x) {
  return (x - x) == Real(0.0);  // inf - inf and NaN - NaN are NaN
}

// The lane masks are combined with & on purpose (no branches).
CPVS_BITWISE_LOGIC_BEGIN
template <class Real, class Mask, class Shape = AnyShape>
[[gnu::always_inline]] inline CellVerdict<Real, Mask> cellVerdict(const ViewMapping& c, const CellSettings& settings,
                                                                  const SpotInfluence* spot, Real px, Real py,
                                                                  Real pz, Real nx, Real ny, Real nz) {
  Mask valid = finiteLane<Real, Mask>(px) & finiteLane<Real, Mask>(py) & finiteLane<Real, Mask>(pz) &
               finiteLane<Real, Mask>(nx) & finiteLane<Real, Mask>(ny) & finiteLane<Real, Mask>(nz);
  if (spot) valid = valid & insideSpot<Real, Mask>(*spot, px, py, pz);
  CellVerdict<Real, Mask> verdict;
  if (c.empty) {
    verdict.lit = valid;
    verdict.voxel = Mask(false);
    verdict.x = verdict.y = verdict.z = Real(0.0);
    return verdict;
  }
  const CellLanes<Real, Mask> cell = cellLanes<Real, Mask, Shape>(c, settings, px, py, pz, nx, ny, nz);
  const Mask inFront = cell.grid.inFront;
  const Mask zero = settings.backFacingIsShadow ? cell.back : Mask(false);
  verdict.voxel = valid & inFront & (!zero) & cell.inside;
  verdict.lit = valid & ((!inFront) | ((!zero) & (!cell.inside)));
  verdict.x = laneSelect(verdict.voxel, cell.qu, Real(0.0));
  verdict.y = laneSelect(verdict.voxel, cell.qv, Real(0.0));
  verdict.z = laneSelect(verdict.voxel, clampedSlice(cell.qs, c.resolution - 1.0), Real(0.0));
  return verdict;
}
CPVS_BITWISE_LOGIC_END

}  // namespace cpvs
