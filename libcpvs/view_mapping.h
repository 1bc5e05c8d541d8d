#pragma once
// The light-view mapping of light_view.h (DESIGN.md §3) in the form every hot path evaluates it: constants
// derived once per view (ViewMapping) and mapToGrid, a template over the lane type. toGrid runs it on one
// double, the batch lookups on four at once (lookup/batch_cells_avx2.cpp): the same IEEE operations in the
// same order, so a point gets the same bits whichever path maps it (CMake sets -ffp-contract=off so that no
// path fuses a multiply and an add the others do not).
//
// Divisions are taken once per view: u = (a - xMin) uScale with uScale = N / (xMax - xMin), a perspective
// lateral a = x_view * (1 / d), a logarithmic slice log(d * (1 / near)) * (N / log(far / near)).
//
// This header must include nothing but the C/C++ standard headers below: the AVX2 translation unit includes
// it under `#pragma GCC target("avx2")`, and the scalar helpers are `static` so that no copy compiled for
// AVX2 can stand in for a scalar one at link time.
#include <cmath>
#include <cstdint>
#include <limits>

namespace cpvs {

struct LightView;

struct ViewMapping {
  // View space: coordinate i = (row[i][0] x + row[i][1] y) + (row[i][2] z + row[i][3]) (glm's order for
  // viewFromWorld * (x, y, z, 1)); depth d = -z_view.
  double row[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  double xMin = -1, yMin = -1;
  double uScale = 1, vScale = 1;  // N / (xMax - xMin), N / (yMax - yMin)
  double uStep = 1, vStep = 1;    // their inverses (xMax - xMin) / N, (yMax - yMin) / N
  double near = 1, invNear = 1;
  double sScale = 1;  // linear: N / (far - near); logarithmic: N / log(far / near)
  double invDs = 1;   // linear: (far - near) / N; logarithmic: log(far / near) / N (times d: 1 / (ds / dd))
  double resolution = 1;
  bool orthographic = true, linear = true;
  bool empty = false;  // the view's `empty` flag: no caster, every point lit

  ViewMapping() = default;
  explicit ViewMapping(const LightView& view);
};

// Scalar lanes: a double and a bool. Vector lane types provide the same functions (found by argument-dependent
// lookup) and operators.
static inline double laneSelect(bool mask, double a, double b) { return mask ? a : b; }
static inline double laneSqrt(double x) { return std::sqrt(x); }
static inline double laneAbs(double x) { return std::fabs(x); }
static inline double laneLog(double x) { return std::log(x); }

// A point in grid space, lane by lane.
template <class Real, class Mask>
struct GridLanes {
  Real viewX, viewY;  // view space
  Real depth;         // d
  Real invDepth;      // 1 / d (perspective views only)
  Real u, v, s;
  Mask inFront;       // orthographic, or d > 0
};

// The slice s of a view-space depth d.
template <class Real, class Mask>
[[gnu::always_inline]] inline Real sliceOfDepth(const ViewMapping& c, Real d) {
  if (c.linear) return (d - Real(c.near)) * Real(c.sScale);
  // log of d <= 0 is NaN or -inf: selected away (such a point is behind a perspective eye).
  return laneSelect(d > Real(0.0), laneLog(d * Real(c.invNear)) * Real(c.sScale),
                    Real(-std::numeric_limits<double>::infinity()));
}

template <class Real, class Mask>
[[gnu::always_inline]] inline GridLanes<Real, Mask> mapToGrid(const ViewMapping& c, Real x, Real y, Real z) {
  GridLanes<Real, Mask> g;
  g.viewX = (Real(c.row[0][0]) * x + Real(c.row[0][1]) * y) + (Real(c.row[0][2]) * z + Real(c.row[0][3]));
  g.viewY = (Real(c.row[1][0]) * x + Real(c.row[1][1]) * y) + (Real(c.row[1][2]) * z + Real(c.row[1][3]));
  const Real viewZ = (Real(c.row[2][0]) * x + Real(c.row[2][1]) * y) + (Real(c.row[2][2]) * z + Real(c.row[2][3]));
  const Real d = -viewZ;
  g.depth = d;
  Real a = g.viewX, b = g.viewY;
  if (c.orthographic) {
    g.invDepth = Real(1.0);
    g.inFront = Mask(true);
  } else {
    g.invDepth = Real(1.0) / d;
    a = a * g.invDepth;
    b = b * g.invDepth;
    g.inFront = d > Real(0.0);
  }
  g.u = (a - Real(c.xMin)) * Real(c.uScale);
  g.v = (b - Real(c.yMin)) * Real(c.vScale);
  g.s = sliceOfDepth<Real, Mask>(c, d);
  return g;
}

}  // namespace cpvs
