// The closed fractal landscape (Kämpe et al. 2015, §5, "FractalLandscape").
//
// An n x n grid of quads over [-500, 500]^2 whose heights are fractional Brownian motion of value noise
// (lattice values from a hash of seed, lattice point and octave; quintic interpolation), shaped so that
// valleys are flat and mountains steep (5..265 units). The surface is closed into a solid: side walls
// down to y = -20 and a bottom fanned from its centre. One mesh, one node, one directional sun.
#include <algorithm>
#include <vector>

#include "det_math.h"
#include "generators.h"
#include "mesh_builder.h"

namespace cpvs::scenegen {
namespace {

constexpr double kHalf = 500.0;
constexpr double kBottom = -20.0;

double lattice(std::uint64_t seed, long long ix, long long iz, int octave) {
  return 2.0 * toUnit(hash64(seed, static_cast<std::uint64_t>(ix), static_cast<std::uint64_t>(iz),
                             static_cast<std::uint64_t>(octave))) -
         1.0;
}

double quintic(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

double valueNoise(std::uint64_t seed, double x, double z, int octave) {
  const double fx = x >= 0.0 ? static_cast<double>(static_cast<long long>(x)) : -static_cast<double>(static_cast<long long>(-x) + 1);
  const double fz = z >= 0.0 ? static_cast<double>(static_cast<long long>(z)) : -static_cast<double>(static_cast<long long>(-z) + 1);
  const long long ix = static_cast<long long>(fx), iz = static_cast<long long>(fz);
  const double tx = quintic(x - fx), tz = quintic(z - fz);
  const double a = lattice(seed, ix, iz, octave), b = lattice(seed, ix + 1, iz, octave);
  const double c = lattice(seed, ix, iz + 1, octave), d = lattice(seed, ix + 1, iz + 1, octave);
  const double ab = a + (b - a) * tx, cd = c + (d - c) * tx;
  return ab + (cd - ab) * tz;
}

// fBm in roughly [-1, 1]; octaves stop once their wavelength is below two grid cells.
double fbm(std::uint64_t seed, double x, double z, double cell) {
  double sum = 0.0, amplitude = 0.5, frequency = 2.5 / (2.0 * kHalf);
  for (int octave = 0; octave < 16; ++octave) {
    if (octave > 0 && 1.0 / frequency < 2.0 * cell) break;
    sum += amplitude * valueNoise(seed, x * frequency + 0.37 * octave, z * frequency - 0.71 * octave, octave);
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum;
}

}  // namespace

GenScene generateLandscape(const LandscapeOptions& o) {
  // 2 n^2 surface triangles + 8 n wall triangles + 4 n bottom triangles.
  const double t = static_cast<double>(o.targetTriangles);
  const int n = std::max(2, static_cast<int>((-12.0 + detSqrt(144.0 + 8.0 * t)) / 4.0 + 0.5));
  const double cell = 2.0 * kHalf / n;
  const std::uint64_t seed = hash64(o.seed, 0x4C414E44ULL);

  MeshBuilder m(false, false);
  const auto idx = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double x = -kHalf + i * cell, z = -kHalf + j * cell;
      const double e = std::clamp((fbm(seed, x, z, cell) + 0.5) / 1.1, 0.0, 1.0);
      m.vertex({x, 5.0 + 260.0 * e * e, z});
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      // Corners in up order: (i+1, j), (i, j), (i, j+1), (i+1, j+1). Alternate the diagonal.
      const std::uint32_t a = idx(i + 1, j), b = idx(i, j), c = idx(i, j + 1), d = idx(i + 1, j + 1);
      if ((i + j) % 2 == 0) {
        m.triangle(a, b, c);
        m.triangle(a, c, d);
      } else {
        m.triangle(b, c, d);
        m.triangle(b, d, a);
      }
    }
  }
  // The boundary in up order: along z0 from x1 to x0, along x0 to z1, along z1 to x1, along x1 back.
  std::vector<std::uint32_t> top;
  for (int i = n; i > 0; --i) top.push_back(idx(i, 0));
  for (int j = 0; j < n; ++j) top.push_back(idx(0, j));
  for (int i = 0; i < n; ++i) top.push_back(idx(i, n));
  for (int j = n; j > 0; --j) top.push_back(idx(n, j));
  const std::size_t ring = top.size();
  std::vector<std::uint32_t> bottom(ring);
  for (std::size_t k = 0; k < ring; ++k) {
    const int i = static_cast<int>(top[k] % static_cast<std::uint32_t>(n + 1));
    const int j = static_cast<int>(top[k] / static_cast<std::uint32_t>(n + 1));
    bottom[k] = m.vertex({-kHalf + i * cell, kBottom, -kHalf + j * cell});
  }
  for (std::size_t k = 0; k < ring; ++k) {
    const std::size_t k1 = (k + 1) % ring;
    m.triangle(bottom[k], bottom[k1], top[k1]);
    m.triangle(bottom[k], top[k1], top[k]);
  }
  const std::uint32_t centre = m.vertex({0.0, kBottom, 0.0});
  for (std::size_t k = 0; k < ring; ++k) m.triangle(centre, bottom[(k + 1) % ring], bottom[k]);

  GenScene scene;
  scene.meshes.push_back(m.take("landscape"));
  scene.nodes.push_back(GenNode{"landscape", 0, -1, glm::dvec3(0.0), Quat{}, {}});
  GenLight sun;
  sun.name = "sun";
  sun.intensity = 5.0;
  sun.color = {1.0, 0.96, 0.9};
  scene.lights.push_back(sun);
  scene.nodes.push_back(GenNode{"sun", -1, 0, glm::dvec3(0.0, 400.0, 0.0), rotationFromMinusZ(sunDirection()), {}});
  return scene;
}

}  // namespace cpvs::scenegen
