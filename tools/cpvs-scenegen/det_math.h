#pragma once
// Deterministic random numbers and trigonometry for cpvs-scenegen.
//
// The generated scenes must be byte-identical for the same arguments on every platform, so nothing here
// uses std::*_distribution (whose output differs between standard libraries) or libm's sin/cos/atan (which
// may differ in the last bit between C libraries). Only +, -, *, / and sqrt are used: IEEE-754 rounds
// those exactly, and C++ in ISO mode does not contract them into FMAs.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace cpvs::scenegen {

inline constexpr double kPi = 3.14159265358979323846;

// splitmix64 (Steele, Lea, Flood 2014): a tiny, well-mixed 64-bit generator.
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// A stateless hash of up to four integers (used for per-block / per-lattice-point seeds).
inline std::uint64_t hash64(std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0,
                            std::uint64_t d = 0) {
  std::uint64_t s = a;
  std::uint64_t h = splitmix64(s);
  s = h ^ b;
  h = splitmix64(s);
  s = h ^ c;
  h = splitmix64(s);
  s = h ^ d;
  return splitmix64(s);
}

// Uniform double in [0, 1) from the top 53 bits of a 64-bit value.
inline double toUnit(std::uint64_t x) { return static_cast<double>(x >> 11) * (1.0 / 9007199254740992.0); }

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() { return splitmix64(state_); }
  double unit() { return toUnit(next()); }                          // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }  // [lo, hi)
  // Integer in [lo, hi] (inclusive). The modulo bias is below 2^-40 for the ranges used here.
  int range(int lo, int hi) {
    const std::uint64_t span = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo + 1);
    return lo + static_cast<int>(next() % span);
  }
  bool chance(double p) { return unit() < p; }
  // 0 .. count-1 in an order drawn from this generator (Fisher-Yates), the same on every platform.
  std::vector<std::size_t> shuffledOrder(std::size_t count) {
    std::vector<std::size_t> order(count);
    for (std::size_t i = 0; i < count; ++i) order[i] = i;
    for (std::size_t i = count; i > 1; --i) std::swap(order[i - 1], order[static_cast<std::size_t>(next() % i)]);
    return order;
  }

 private:
  std::uint64_t state_;
};

// sin and cos of x (radians) by range reduction to [-pi/4, pi/4] and Taylor series; accurate to ~1e-16.
struct SinCos {
  double s, c;
};
inline SinCos detSinCos(double x) {
  // Reduce to r in [-pi/4, pi/4] with x = r + q * pi/2.
  const double halfPi = kPi / 2.0;
  double qd = x / halfPi;
  long long q = static_cast<long long>(qd >= 0.0 ? qd + 0.5 : qd - 0.5);
  const double r = x - static_cast<double>(q) * halfPi;
  const double r2 = r * r;
  // Taylor series (terms up to r^17 / r^16 are below 1e-17 for |r| <= pi/4).
  double s = 0.0, c = 0.0;
  {
    double term = r;
    s = term;
    for (int k = 1; k <= 8; ++k) {
      term *= -r2 / static_cast<double>((2 * k) * (2 * k + 1));
      s += term;
    }
  }
  {
    double term = 1.0;
    c = term;
    for (int k = 1; k <= 8; ++k) {
      term *= -r2 / static_cast<double>((2 * k - 1) * (2 * k));
      c += term;
    }
  }
  switch (((q % 4) + 4) % 4) {
    case 0: return {s, c};
    case 1: return {c, -s};
    case 2: return {-s, -c};
    default: return {-c, s};
  }
}
inline double detSin(double x) { return detSinCos(x).s; }
inline double detCos(double x) { return detSinCos(x).c; }
inline double detTan(double x) {
  const SinCos sc = detSinCos(x);
  return sc.s / sc.c;
}

inline double detSqrt(double x) { return std::sqrt(x); }  // IEEE-754 correctly rounded

// atan(x) by halving the angle until the argument is small (atan x = 2 atan(x / (1 + sqrt(1 + x^2))))
// and a Taylor series.
inline double detAtan(double x) {
  double scale = 1.0;
  for (int i = 0; i < 4; ++i) {
    x = x / (1.0 + detSqrt(1.0 + x * x));
    scale *= 2.0;
  }
  // |x| <= tan(pi/32) ~ 0.0985 now: 12 terms reach 1e-25.
  const double x2 = x * x;
  double term = x, sum = x;
  for (int k = 1; k <= 12; ++k) {
    term *= -x2;
    sum += term / static_cast<double>(2 * k + 1);
  }
  return scale * sum;
}

// Natural logarithm for x > 0: exact binary exponent split (frexp) and an atanh series for the mantissa.
inline double detLog(double x) {
  int e = 0;
  double m = std::frexp(x, &e);  // x = m * 2^e, m in [0.5, 1)
  if (m < 0.70710678118654752) {
    m *= 2.0;
    --e;
  }
  const double t = (m - 1.0) / (m + 1.0);  // |t| < 0.172
  const double t2 = t * t;
  double term = t, sum = t;
  for (int k = 1; k <= 14; ++k) {
    term *= t2;
    sum += term / static_cast<double>(2 * k + 1);
  }
  return 2.0 * sum + static_cast<double>(e) * 0.69314718055994530942;
}

}  // namespace cpvs::scenegen
