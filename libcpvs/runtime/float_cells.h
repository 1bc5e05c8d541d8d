#pragma once
// Steps 1-3 of a lookup (cell_lanes.h's cellVerdict) in single precision, twice the lanes of the double path per
// instruction and a fraction of the cost of its divisions and square roots, with a bound on how far each
// computed value may lie from the double path's. A lane is *certain* when every decision the double path takes
// for it (the spot's range and cone, in front of the eye, the face's side, inside the grid, which voxel) lies
// further from its threshold than that bound: then the double path decides it the same way, and the lane's cell
// is the double path's bit for bit. The other lanes (about 1-5 % of random points, most of those within a few
// thousandths of a voxel of a voxel boundary) are mapped again in double by the caller (lane_loop.h).
//
// The bounds (docs/lookups.md, "The mapping in single precision", writes the argument out): the point's view
// coordinates are the double path's own sums, rounded once; each later step's bound is first-order error
// propagation with the rounding of every operation (unit roundoff eps = 2^-24) counted against the magnitude of
// the operands, not the result (cancellation is covered), and the unit normal's only where its error is below
// an eighth of its length (else the lane is uncertain). The final bounds carry 1.25 times slack and four ulps of
// q. batch_cells_test and the runtime's own checks compare the result with the double path on points placed
// within 10^-7 to 10^-2 voxels of voxel boundaries.
//
// Same rule as view_mapping.h: standard headers only (the vector paths include it under their
// CPVS_TARGET_BEGIN_* (portability.h)), everything in an unnamed namespace.
#include <cmath>
#include <cstdint>
#include <limits>

#include "libcpvs/runtime/cell_lanes.h"

namespace cpvs {
namespace {

// A view's mapping constants rounded to float, with what the bounds need. `usable` is false where single
// precision cannot pay: an empty view (no mapping at all), a grid finer than 2^15 voxels a side (a voxel's
// fraction would carry too few bits), an orthographic view with logarithmic slices (no baker makes one), or
// constants a float cannot hold.
struct FloatViewMapping {
  bool usable = false;
  float row[3][3] = {};  // for the normal (the point's view coordinates come from the double path's own sums)
  float rowAbs = 0;      // the largest sum of |row[i][j]| over j, rounded up
  float xMin = 0, yMin = 0, uScale = 0, vScale = 0, uStep = 0, vStep = 0;
  float near = 0, invNear = 0, sScale = 0, invDs = 0, resolution = 0;
  double uOffsetAbs = 0, vOffsetAbs = 0, sOffsetAbs = 0;  // |xMin| uScale, |yMin| vScale, near sScale
  bool spot = false;
  double spotPosition[3] = {0, 0, 0};
  float spotDirection[3] = {0, 0, 0};
  float range = 0, cosOuter = 0;
};

inline bool normalFloat(double x) {
  const double a = std::fabs(x);
  return a <= double(std::numeric_limits<float>::max()) && (a == 0 || a >= 1e-30);
}

inline FloatViewMapping floatViewMapping(const ViewMapping& c, const SpotInfluence* spot) {
  FloatViewMapping f;
  if (c.empty || !(c.resolution <= 32768.0) || (c.orthographic && !c.linear)) return f;
  double rowAbs = 0;
  for (int i = 0; i < 3; ++i) {
    double sum = 0;
    for (int j = 0; j < 3; ++j) {
      if (!normalFloat(c.row[i][j])) return f;
      f.row[i][j] = float(c.row[i][j]);
      sum += std::fabs(c.row[i][j]);
    }
    rowAbs = sum > rowAbs ? sum : rowAbs;
  }
  f.rowAbs = float(rowAbs * (1 + 1e-6));
  for (const double x : {c.xMin, c.yMin, c.uScale, c.vScale, c.uStep, c.vStep, c.near, c.invNear, c.sScale, c.invDs})
    if (!normalFloat(x)) return f;  // also NaN and infinities
  f.xMin = float(c.xMin);
  f.yMin = float(c.yMin);
  f.uScale = float(c.uScale);
  f.vScale = float(c.vScale);
  f.uStep = float(c.uStep);
  f.vStep = float(c.vStep);
  f.near = float(c.near);
  f.invNear = float(c.invNear);
  f.sScale = float(c.sScale);
  f.invDs = float(c.invDs);
  f.resolution = float(c.resolution);
  f.uOffsetAbs = std::fabs(c.xMin) * c.uScale;
  f.vOffsetAbs = std::fabs(c.yMin) * c.vScale;
  f.sOffsetAbs = std::fabs(c.near) * c.sScale;
  if (spot) {
    if (!(spot->cosOuter >= -1.0 && spot->cosOuter <= 1.0) || !(spot->range > 0)) return f;
    for (int i = 0; i < 3; ++i) {
      if (!std::isfinite(spot->position[i]) || !normalFloat(spot->direction[i])) return f;
      f.spotPosition[i] = spot->position[i];
      f.spotDirection[i] = float(spot->direction[i]);
    }
    const double dirLength = std::sqrt(spot->direction[0] * spot->direction[0] + spot->direction[1] * spot->direction[1] +
                                       spot->direction[2] * spot->direction[2]);
    if (!(std::fabs(dirLength - 1) < 1e-6)) return f;  // the bounds take the direction as a unit vector
    f.spot = true;
    f.range = spot->range > double(std::numeric_limits<float>::max()) ? std::numeric_limits<float>::infinity()
                                                                       : float(spot->range);
    f.cosOuter = float(spot->cosOuter);
  }
  f.usable = true;
  return f;
}

// The certain lanes' verdicts and cells (as whole numbers in floats; 0 where not a voxel).
template <class F, class M>
struct FloatCellLanes {
  M certain, voxel, lit;
  F x, y, z;
};

// log(x) for normal positive floats: view_mapping.h's decomposition on the float's bits, then its polynomial in
// float. Within 4 eps (|log x| + 1) of the true log (the bound below counts 8).
template <class F, class Bits>
[[gnu::always_inline]] inline F floatLog(F x) {
  F m = Bits::mantissaOne(x);  // [1, 2)
  F e = Bits::exponent(x);     // unbiased, as a float
  const auto high = m > F(kSqrt2);
  m = laneSelect(high, m * F(0.5), m);
  e = laneSelect(high, e + F(1.0), e);
  return logOfParts(m, e);
}

// The range [-1, limit] a coordinate's floor is taken in (every value outside gives the same answer as its end).
template <class F>
[[gnu::always_inline]] inline F floorWithin(F q, F limit) {
  return laneFloor(laneMin(laneMax(q, F(-1.0)), limit));
}

// The per-batch constants of the bounds that depend on the lookup's settings: the bias b = K/2 (|ux| + |uy|) +
// margin is at most bMax, and the unit normal's error reaches each coordinate of q at most biasGain times.
struct FloatBiasBounds {
  float biasGain;
  float uConst, vConst, sConst;  // the parts of each coordinate's bound that do not depend on the point
};
inline FloatBiasBounds floatBiasBounds(const FloatViewMapping& c, const CellSettings& st, bool logSlices) {
  constexpr double eps = 0x1p-24, up = 1 + 1e-6;
  const double bMax = 2 * st.kernelHalf + std::fabs(st.margin);
  FloatBiasBounds b;
  b.biasGain = float(1.25 * (bMax + 2 * st.kernelHalf) * up);
  b.uConst = float((11 * eps * c.uOffsetAbs + 11 * eps * bMax) * up);
  b.vConst = float((11 * eps * c.vOffsetAbs + 11 * eps * bMax) * up);
  b.sConst = float(((logSlices ? 14 * eps * double(c.sScale) : 11 * eps * c.sOffsetAbs) + 11 * eps * bMax) * up);
  return b;
}

// kind: the view's double mapping, for Shape's questions only. vx, vy, vz: the point's view coordinates as the
// double path computes them (mapToGrid's sums), rounded; n: the normal, s: the point relative to the spot's
// position (computed in double), both rounded. Every bound is on the distance to the double path's value, not
// to the exact one (docs/lookups.md, "The mapping in single precision", derives each; the double path's own
// rounding, 2^29 times smaller, is inside their slack).
CPVS_BITWISE_LOGIC_BEGIN
template <class F, class M, class Bits, class Shape>
[[gnu::always_inline]] inline FloatCellLanes<F, M> floatCellVerdict(const ViewMapping& kind, const FloatViewMapping& c,
                                                                    const CellSettings& st, const FloatBiasBounds& bb,
                                                                    F vx, F vy, F vz, F nx, F ny, F nz, F sx, F sy,
                                                                    F sz) {
  constexpr float eps = 0x1p-24f;
  const F one(1.0f);
  M certain = finiteLane<F, M>(vx) & finiteLane<F, M>(vy) & finiteLane<F, M>(vz) & finiteLane<F, M>(nx) &
              finiteLane<F, M>(ny) & finiteLane<F, M>(nz);

  // The spot's influence: distance <= range, distance != 0, !(along / distance < cosOuter). The distance is
  // within 4 eps of the double path's, along - cosOuter distance within 13 eps distance of its sign's test.
  M spotOut(false);
  if (c.spot) {
    certain = certain & finiteLane<F, M>(sx) & finiteLane<F, M>(sy) & finiteLane<F, M>(sz);
    const F distance = laneSqrt((sx * sx + sy * sy) + sz * sz);
    const F along = (sx * F(c.spotDirection[0]) + sy * F(c.spotDirection[1])) + sz * F(c.spotDirection[2]);
    const F coneGap = along - F(c.cosOuter) * distance, coneError = F(40 * eps) * distance;
    const M inRange = distance < F(c.range * (1 - 10 * eps)), outOfRange = distance > F(c.range * (1 + 10 * eps));
    const M inCone = coneGap > coneError, outOfCone = coneGap < -coneError;
    spotOut = outOfRange | outOfCone;
    certain = certain & (distance > F(1e-18f)) & ((inRange & inCone) | spotOut);
  }

  const F d = -vz;
  const F nMax = laneMax(laneMax(laneAbs(nx), laneAbs(ny)), laneAbs(nz));
  const F nvx = (F(c.row[0][0]) * nx + F(c.row[0][1]) * ny) + F(c.row[0][2]) * nz;
  const F nvy = (F(c.row[1][0]) * nx + F(c.row[1][1]) * ny) + F(c.row[1][2]) * nz;
  const F nvz = (F(c.row[2][0]) * nx + F(c.row[2][1]) * ny) + F(c.row[2][2]) * nz;

  // Lateral a, b (within 5 eps |a| of the double path's), then u, v, s and their bounds (with the bias's
  // rounding, the 1.25 slack and the widening by 4 ulps of q folded in: uConst and friends).
  F a = vx, b = vy, u, v, s, uError, vError, sError, mx, my, mz, mError;
  M front(true), behind(false);
  if (Shape::orthographic(kind)) {  // linear slices (floatViewMapping refuses the others)
    mx = nvx * F(c.uStep);
    my = nvy * F(c.vStep);
    mz = -nvz * F(c.invDs);
    mError = F(8 * eps * c.rowAbs * (c.uStep + c.vStep + c.invDs) * (1 + 1e-6f)) * nMax;
  } else {
    // The sign of d is the double path's (rounding keeps signs); a normal d keeps the relative bounds.
    front = d >= F(std::numeric_limits<float>::min());
    behind = d < F(0.0f);
    const F invD = one / d;
    a = vx * invD;
    b = vy * invD;
    const F invDs = Shape::linear(kind) ? F(c.invDs) : F(c.invDs) * d;
    mx = (nvx * d) * F(c.uStep);
    my = (nvy * d) * F(c.vStep);
    mz = ((nvx * vx + nvy * vy) * invD - nvz) * invDs;
    mError = (F(eps * c.rowAbs) * nMax) *
                 (d * F(10.0f * (c.uStep + c.vStep)) + F(18.0f) * laneAbs(invDs) * ((laneAbs(a) + laneAbs(b)) + one)) +
             F(5 * eps) * laneAbs(mz);
  }
  u = (a - F(c.xMin)) * F(c.uScale);
  v = (b - F(c.yMin)) * F(c.vScale);
  uError = F(16 * eps * c.uScale) * laneAbs(a) + F(bb.uConst);
  vError = F(16 * eps * c.vScale) * laneAbs(b) + F(bb.vConst);
  if (Shape::linear(kind)) {
    s = (d - F(c.near)) * F(c.sScale);
    sError = F(11 * eps * c.sScale) * laneAbs(d) + F(bb.sConst);
  } else {
    const F x = d * F(c.invNear);
    front = front & (x >= F(std::numeric_limits<float>::min())) & (x <= F(std::numeric_limits<float>::max()));
    const F log = floatLog<F, Bits>(laneSelect(front, x, one));
    s = log * F(c.sScale);
    sError = F(18 * eps * c.sScale) * laneAbs(log) + F(bb.sConst);
  }

  // The bias along the unit normal in grid space, and the side of the face where certain.
  const M back = mz > mError, facing = mz < -mError;
  const F flip = laneSelect(back, F(-1.0f), one);
  mx = mx * flip;
  my = my * flip;
  mz = mz * flip;
  const F length = laneSqrt((mx * mx + my * my) + mz * mz);
  const M directionKnown = (F(8.0f) * mError < length) & (length > F(1e-15f)) &
                           (length < F(std::numeric_limits<float>::max()));
  const F invLength = one / length;
  const F ux = mx * invLength, uy = my * invLength, uz = mz * invLength;
  const F biasError = F(bb.biasGain) * (F(2.5f) * mError * invLength + F(6 * eps));  // unit normal within 2.5 mError / |m| + 6 eps
  const F bias = F(float(st.kernelHalf)) * (laneAbs(ux) + laneAbs(uy)) + F(float(st.margin));
  const F qu = u + bias * ux, qv = v + bias * uy, qs = s + bias * uz;
  const F quError = uError + biasError, qvError = vError + biasError, qsError = sError + biasError;

  // Which voxel, where the interval q +- error holds one floor (clampedSlice's clamp for the slice; outside
  // [0, N) laterally is "outside the grid" whichever floor).
  const F n(c.resolution);
  const F xLow = floorWithin(qu - quError, n), xHigh = floorWithin(qu + quError, n);
  const F yLow = floorWithin(qv - qvError, n), yHigh = floorWithin(qv + qvError, n);
  const F top = n - one;
  const F zLow = laneMin(laneMax(floorWithin(qs - qsError, n), F(0.0f)), top);
  const F zHigh = laneMin(laneMax(floorWithin(qs + qsError, n), F(0.0f)), top);
  const M known = finiteLane<F, M>(((quError + qvError) + (qsError + qs)) + (qu + qv));
  const M xKnown = xLow == xHigh, yKnown = yLow == yHigh;
  const M xInside = (xLow >= F(0.0f)) & (xLow < n), yInside = (yLow >= F(0.0f)) & (yLow < n);
  const M outside = known & ((xKnown & !xInside) | (yKnown & !yInside));
  const M inside = known & xKnown & yKnown & xInside & yInside & (zLow == zHigh);

  // cellVerdict's rules, each taken only where its inputs are certain.
  const M sideKnown = st.backFacingIsShadow ? (back | (facing & directionKnown)) : ((back | facing) & directionKnown);
  const M zero = st.backFacingIsShadow ? back : M(false);
  const M ahead = front & !spotOut;
  const M zeroLane = spotOut | (ahead & zero);
  const M litLane = (!spotOut) & (behind | (ahead & !zero & sideKnown & outside));
  const M voxelLane = ahead & !zero & sideKnown & inside;
  FloatCellLanes<F, M> out;
  out.certain = certain & (zeroLane | litLane | voxelLane);
  out.voxel = voxelLane;
  out.lit = litLane;
  out.x = laneSelect(voxelLane, xLow, F(0.0f));
  out.y = laneSelect(voxelLane, yLow, F(0.0f));
  out.z = laneSelect(voxelLane, zLow, F(0.0f));
  return out;
}
CPVS_BITWISE_LOGIC_END

}  // namespace
}  // namespace cpvs
