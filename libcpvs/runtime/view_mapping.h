#pragma once
// The light-view mapping of light_view.h (docs/architecture.md, "The voxel convention") in the form every hot path evaluates it: constants
// derived once per view (ViewMapping) and mapToGrid, a template over the lane type. toGrid runs it on one
// double, the batch lookups on four at once (runtime/batch_cells_avx2.cpp): the same IEEE operations in the
// same order, so a point gets the same bits whichever path maps it (CMake sets -ffp-contract=off so that no
// path fuses a multiply and an add the others do not).
//
// Divisions are taken once per view: u = (a - xMin) uScale with uScale = N / (xMax - xMin), a perspective
// lateral a = x_view * (1 / d), a logarithmic slice log(d * (1 / near)) * (N / log(far / near)). The log is
// mappingLog below, not libm's: the same few operations on every lane type (libm's log is one call per lane,
// and a vector libm's rounds differently).
//
// This header must include nothing but the C/C++ standard headers below: the AVX2 translation unit includes
// it under CPVS_TARGET_BEGIN_AVX2 (portability.h), and the scalar helpers are `static` so that no copy compiled for
// AVX2 can stand in for a scalar one at link time.
#include <bit>
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

// log(x) from x = m 2^e (m in [sqrt(1/2), sqrt(2)], e an integer, both exact): e log 2 + log(1 + f), f = m - 1,
// with the classic fdlibm reduction s = f / (2 + f) and its minimax polynomial in s^2, split over ln 2's high
// and low parts. Within about one ulp of the true log for every m in the range.
template <class Real>
[[gnu::always_inline]] inline Real logOfParts(Real m, Real e) {
  const Real f = m - Real(1.0);
  const Real s = f / (Real(2.0) + f);
  const Real z = s * s, w = z * z;
  const Real t1 = w * (Real(3.999999999940941908e-01) + w * (Real(2.222219843214978396e-01) + w * Real(1.531383769920937332e-01)));
  const Real t2 = z * (Real(6.666666666666735130e-01) +
                       w * (Real(2.857142874366239149e-01) + w * (Real(1.818357216161805012e-01) + w * Real(1.479819860511658591e-01))));
  const Real r = t2 + t1;
  const Real halfF2 = (Real(0.5) * f) * f;
  return e * Real(6.93147180369123816490e-01) - ((halfF2 - (s * (halfF2 + r) + e * Real(1.90821492927058770002e-10))) - f);
}
inline constexpr double kSqrt2 = 1.4142135623730951;

// The depth mapping's log, one lane: exact for the decomposition, logOfParts for the rest. For a positive
// normal x within about an ulp of log(x); zero, subnormal or infinite x give finite values of the right sign
// and size (about -709 and +710), NaN or negative x garbage: callers select those lanes away.
static inline double mappingLog(double x) {
  const uint64_t bits = std::bit_cast<uint64_t>(x);
  double m = std::bit_cast<double>((bits & 0x000fffffffffffffull) | 0x3ff0000000000000ull);  // [1, 2)
  double e = double(int32_t((bits >> 52) & 0x7ffu)) - 1023.0;
  const bool high = m > kSqrt2;
  m = high ? m * 0.5 : m;
  e = high ? e + 1.0 : e;
  return logOfParts(m, e);
}
static inline double laneLog(double x) { return mappingLog(x); }

// Which formulas a view uses: read from the ViewMapping (AnyShape), or fixed at compile time (FixedShape), so
// that the batch has one kernel per kind of view without the other kinds' branches and constants. (In an
// unnamed namespace, like the static helpers above: no copy is shared between translation units.)
namespace {
struct AnyShape {
  static bool orthographic(const ViewMapping& c) { return c.orthographic; }
  static bool linear(const ViewMapping& c) { return c.linear; }
};
template <bool Orthographic, bool Linear>
struct FixedShape {
  static constexpr bool orthographic(const ViewMapping&) { return Orthographic; }
  static constexpr bool linear(const ViewMapping&) { return Linear; }
};
}  // namespace

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
template <class Real, class Mask, class Shape = AnyShape>
[[gnu::always_inline]] inline Real sliceOfDepth(const ViewMapping& c, Real d) {
  if (Shape::linear(c)) return (d - Real(c.near)) * Real(c.sScale);
  // log of d <= 0 is NaN or -inf: selected away (such a point is behind a perspective eye).
  return laneSelect(d > Real(0.0), laneLog(d * Real(c.invNear)) * Real(c.sScale),
                    Real(-std::numeric_limits<double>::infinity()));
}

template <class Real, class Mask, class Shape = AnyShape>
[[gnu::always_inline]] inline GridLanes<Real, Mask> mapToGrid(const ViewMapping& c, Real x, Real y, Real z) {
  GridLanes<Real, Mask> g;
  g.viewX = (Real(c.row[0][0]) * x + Real(c.row[0][1]) * y) + (Real(c.row[0][2]) * z + Real(c.row[0][3]));
  g.viewY = (Real(c.row[1][0]) * x + Real(c.row[1][1]) * y) + (Real(c.row[1][2]) * z + Real(c.row[1][3]));
  const Real viewZ = (Real(c.row[2][0]) * x + Real(c.row[2][1]) * y) + (Real(c.row[2][2]) * z + Real(c.row[2][3]));
  const Real d = -viewZ;
  g.depth = d;
  Real a = g.viewX, b = g.viewY;
  if (Shape::orthographic(c)) {
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
  g.s = sliceOfDepth<Real, Mask, Shape>(c, d);
  return g;
}

}  // namespace cpvs
