// The batch's point-to-voxel mapping (libcpvs/runtime/batch_cells.h): the AVX2 path (single precision with a
// double fall-back) and the AVX-512 one give the scalar path's cells bit for bit, and both give lookupCell's (the single-point
// lookup), on random points and on the hard ones: exactly on voxel boundaries and within 1e-7 voxels of them,
// behind the eye, on the cone's edge, non-finite, huge, zero normals.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/float_cells.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "support/test_support.h"
#include "libcpvs/views/view_fitting.h"

namespace cpvs {
namespace {

std::vector<Light> testLights() {
  Light spot;
  spot.type = LightType::Spot;
  spot.name = "spot";
  spot.position = {1, 6, 2};
  spot.direction = glm::normalize(glm::dvec3(-0.2, -1, -0.1));
  spot.outerConeAngle = 0.7;
  spot.range = 9.0;
  Light sun;
  sun.name = "sun";
  sun.direction = glm::normalize(glm::dvec3(0.3, -1, 0.5));
  Light point;
  point.type = LightType::Point;
  point.name = "point";
  point.position = {0.5, 3, -1};
  return {spot, sun, point};
}

// Random points and normals around the scene, and the hard cases for one view.
std::vector<SurfacePoint> hardPoints(const LightView& view, const Light& light, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coord(-9.0, 9.0), unit(-1.0, 1.0);
  auto randomNormal = [&] { return glm::dvec3(unit(rng), unit(rng), unit(rng)); };
  std::vector<SurfacePoint> points;
  for (int i = 0; i < 3000; ++i) points.push_back({{coord(rng), coord(rng), coord(rng)}, randomNormal()});
  // Exactly on voxel corners across the grid (every slice boundary too), with axis-aligned and zero normals.
  const double n = view.resolution;
  for (double u = 0; u <= n; u += n / 16)
    for (double s = 0; s <= n; s += n / 8) {
      const glm::dvec3 p = gridToWorld(view, {u, n / 2, s});
      for (const glm::dvec3& normal : {glm::dvec3(0.0), glm::dvec3(0, 1, 0), glm::dvec3(1, 0, 0), -light.direction})
        points.push_back({p, normal});
    }
  // The light's position itself (behind / at a perspective eye), and points on the spot's cone edge.
  points.push_back({light.position, {0, 1, 0}});
  points.push_back({light.position - 0.5 * light.direction, {0, 1, 0}});
  const glm::dvec3 side = glm::normalize(glm::cross(light.direction, glm::dvec3(1, 0, 0)));
  for (double t : {1.0, 4.0, 8.999999, 9.0, 9.000001}) {
    const glm::dvec3 edge = light.direction * std::cos(light.outerConeAngle) + side * std::sin(light.outerConeAngle);
    points.push_back({light.position + t * edge, {0, 1, 0}});
  }
  // Non-finite and absurd inputs, in every coordinate.
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  for (double bad : {inf, -inf, nan, 1e300, -1e300, 1e-310}) {
    for (int c = 0; c < 3; ++c) {
      SurfacePoint p{{0.1, 0.2, 0.3}, {0, 1, 0}};
      p.position[c] = bad;
      points.push_back(p);
      p = {{0.1, 0.2, 0.3}, {0, 1, 0}};
      p.normal[c] = bad;
      points.push_back(p);
    }
  }
  return points;
}

// SurfacePoint records as mapCells reads them.
PointArrays interleavedArrays(const std::vector<SurfacePoint>& points) {
  const double* base = reinterpret_cast<const double*>(points.data());
  return {base, 6, base + 3, 6};
}

struct Cells {
  std::vector<int32_t> x, y, z;
  std::vector<uint8_t> state;
  explicit Cells(size_t n) : x(n, -7), y(n, -7), z(n, -7), state(n, 99) {}
  CellBatchOutput output() { return {x.data(), y.data(), z.data(), state.data()}; }
};

TEST(BatchCells, VectorPathsEqualScalarEqualsLookupCell) {
  const CellIsa best = bestCellIsa();
  const WorldGeometry world = test::groundAndRidge();
  size_t voxels = 0, lit = 0, zero = 0;
  for (const Light& light : testLights()) {
    const std::vector<LightView> views = makeLightViews(light, world, 1024);
    const LightShadow shadow = orThrow(LightShadow::create(light, views, std::vector<DagView>(views.size())));  // for viewIndex
    for (const LightView& view : views) {
      const ViewMapping mapping(view);
      const std::vector<SurfacePoint> points = hardPoints(view, light, 5);
      for (const LookupOptions options : {LookupOptions{1, NormalOrientation::AsGiven, 0.25},
                                          LookupOptions{9, NormalOrientation::AsGiven, 0.0},
                                          LookupOptions{3, NormalOrientation::TowardLight, 0.5}}) {
        const SpotInfluence spot = spotInfluence(light);
        CellBatchInput in;
        in.mapping = &mapping;
        in.settings = cellSettings(options);
        in.spot = light.type == LightType::Spot ? &spot : nullptr;
        in.points = interleavedArrays(points);
        in.count = points.size();
        Cells scalar(points.size()), avx2(points.size()), avx512(points.size());
        mapCells(in, scalar.output(), CellIsa::Scalar);
        mapCells(in, avx2.output(), CellIsa::Avx2);  // a lesser path where the CPU lacks it
        mapCells(in, avx512.output(), CellIsa::Avx512);
        for (size_t i = 0; i < points.size(); ++i) {
          const SurfacePoint& p = points[i];
          SCOPED_TRACE(light.name + " view " + std::to_string(view.face) + " point " + std::to_string(i) + " K " +
                       std::to_string(options.pcfKernel));
          for (const Cells* vector : {&avx2, &avx512}) {
            ASSERT_EQ(vector->state[i], scalar.state[i]);
            ASSERT_EQ(vector->x[i], scalar.x[i]);
            ASSERT_EQ(vector->y[i], scalar.y[i]);
            ASSERT_EQ(vector->z[i], scalar.z[i]);
          }
          // The single-point lookup: the same kind and voxel (influence checked the way LightShadow does).
          const LookupCell cell = lookupCell(mapping, p.position, p.normal, options);
          // (Point lights: mapCells maps the points LightShadow has sorted into this face, with no test.)
          const bool inside = light.type != LightType::Spot || shadow.viewIndex(p.position) == 0;
          uint8_t expected = kCellZero;
          if (inside && cell.kind == LookupCell::Kind::Lit) expected = kCellLit;
          if (inside && cell.kind == LookupCell::Kind::Voxel) expected = kCellVoxel;
          ASSERT_EQ(scalar.state[i], expected);
          if (expected == kCellVoxel) {
            ASSERT_EQ(scalar.x[i], cell.x);
            ASSERT_EQ(scalar.y[i], cell.y);
            ASSERT_EQ(scalar.z[i], cell.z);
            // And the voxel convention: toVoxel of the biased point.
            const Voxel v = toVoxel(view, cell.uvs);
            ASSERT_EQ((Voxel{cell.x, cell.y, cell.z}), v);
          }
          voxels += expected == kCellVoxel;
          lit += expected == kCellLit;
          zero += expected == kCellZero;
        }
      }
    }
  }
  // The cases are all there (a mapping that answered one kind everywhere would fail the comparisons above
  // only by luck).
  EXPECT_GT(voxels, 10000u);
  EXPECT_GT(lit, 1000u);
  EXPECT_GT(zero, 1000u);
  if (best != CellIsa::Avx512)
    GTEST_SKIP() << "this CPU lacks AVX-512" << (best == CellIsa::Avx2 ? "" : " and AVX2")
                 << ": those paths fell back to a lesser one";
}

// Index lists and every batch length around the 4-lane groups: lane j maps points[indices[j]], and a short
// last group writes only its own lanes.
TEST(BatchCells, IndexListsAndShortGroups) {
  const WorldGeometry world = test::groundAndRidge();
  const LightView view = makeLightViews(testLights()[1], world, 256).at(0);
  const ViewMapping mapping(view);
  const std::vector<SurfacePoint> points = hardPoints(view, testLights()[1], 9);
  std::vector<uint32_t> indices;
  for (uint32_t i = 0; i < points.size(); i += 3) indices.push_back(uint32_t(points.size() - 1 - i));
  CellBatchInput in;
  in.mapping = &mapping;
  in.points = interleavedArrays(points);
  Cells all(points.size());
  in.count = points.size();
  mapCells(in, all.output(), CellIsa::Scalar);
  for (CellIsa isa : {CellIsa::Scalar, CellIsa::Avx2, CellIsa::Avx512})
    for (size_t count = 0; count <= 17; ++count) {
      in.indices = indices.data();
      in.count = count;
      Cells some(count + 8);
      mapCells(in, some.output(), isa);
      for (size_t j = 0; j < count; ++j) {
        ASSERT_EQ(some.state[j], all.state[indices[j]]) << count << " " << j;
        ASSERT_EQ(some.x[j], all.x[indices[j]]);
        ASSERT_EQ(some.z[j], all.z[indices[j]]);
      }
      for (size_t j = count; j < count + 8; ++j) ASSERT_EQ(some.state[j], 99) << "wrote past the batch";
    }
}

// Positions and normals in separate arrays (numpy's (n, 3) layout), and one normal for every point: the same
// cells on every path as SurfacePoint records, with and without index lists. Each array is exactly 3n doubles,
// so a load past a vector's third coordinate reads past the allocation (the sanitized build catches it).
TEST(BatchCells, SeparateArraysEqualSurfacePoints) {
  const WorldGeometry world = test::groundAndRidge();
  for (const Light& light : testLights()) {
    const LightView view = makeLightViews(light, world, 512).at(0);
    const ViewMapping mapping(view);
    std::vector<SurfacePoint> points = hardPoints(view, light, 13);
    const SpotInfluence spot = spotInfluence(light);
    for (bool oneNormal : {false, true}) {
      const glm::dvec3 shared(0.3, 0.8, -0.2);
      if (oneNormal)
        for (SurfacePoint& p : points) p.normal = shared;
      std::vector<double> positions, normals;
      for (const SurfacePoint& p : points)
        for (int c = 0; c < 3; ++c) {
          positions.push_back(p.position[c]);
          normals.push_back(p.normal[c]);
        }
      const std::vector<double> single = {shared.x, shared.y, shared.z};
      std::vector<uint32_t> indices;
      for (uint32_t i = 0; i < points.size(); i += 2) indices.push_back(uint32_t(points.size() - 1 - i));
      for (CellIsa isa : {CellIsa::Scalar, CellIsa::Avx2, CellIsa::Avx512})
        for (const uint32_t* selection : {static_cast<const uint32_t*>(nullptr), static_cast<const uint32_t*>(indices.data())}) {
          CellBatchInput in;
          in.mapping = &mapping;
          in.settings = cellSettings(LookupOptions{3, NormalOrientation::TowardLight, 0.25});
          in.spot = light.type == LightType::Spot ? &spot : nullptr;
          in.indices = selection;
          in.count = selection ? indices.size() : points.size();
          in.points = interleavedArrays(points);
          Cells records(in.count), separate(in.count);
          mapCells(in, records.output(), isa);
          in.points = oneNormal ? PointArrays{positions.data(), 3, single.data(), 0}
                                : PointArrays{positions.data(), 3, normals.data(), 3};
          ASSERT_FALSE(in.points.interleaved());
          mapCells(in, separate.output(), isa);
          SCOPED_TRACE(light.name + (oneNormal ? " one normal" : "") + (selection ? " indices" : "") + " isa " +
                       std::to_string(int(isa)));
          EXPECT_EQ(separate.state, records.state);
          EXPECT_EQ(separate.x, records.x);
          EXPECT_EQ(separate.y, records.y);
          EXPECT_EQ(separate.z, records.z);
        }
    }
  }
}

// The AVX2 path maps in single precision where a view allows it (float_cells.h) and maps again in double the
// points whose cell it cannot decide. Their cells must be the double path's everywhere: on random points, and
// on points whose biased grid position lies within 1e-7 to 1e-2 voxels of a voxel boundary in u, v or s (found
// by solving for the point whose lookup lands there), at grids of 1k to 32k. The share mapped again must stay
// small on random points (else the single-precision path would be pointless) and large right at the boundaries
// (else the bounds would not be doing their work).
TEST(BatchCells, SinglePrecisionCellsEqualDoubleCells) {
  const CellIsa best = bestCellIsa();
  if (best < CellIsa::Avx2) GTEST_SKIP() << "this CPU has no single-precision path (no AVX2)";
  const WorldGeometry world = test::groundAndRidge();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> coord(-9.0, 9.0), unit(-1.0, 1.0), fraction(0.0, 1.0);
  size_t checked = 0;
  for (const Light& light : testLights())
    for (const uint32_t resolution : {1024u, 8192u, 32768u}) {
      const std::vector<LightView> views = makeLightViews(light, world, resolution);
      const LightView& view = views.at(0);
      const ViewMapping mapping(view);
      const SpotInfluence spot = spotInfluence(light);
      for (const LookupOptions options : {LookupOptions{9, NormalOrientation::AsGiven, 0.25},
                                          LookupOptions{1, NormalOrientation::AsGiven, 0.0},
                                          LookupOptions{3, NormalOrientation::TowardLight, 0.5}}) {
        // The normal facing the light (the lookups that reach a voxel), tilted at random.
        const glm::dvec3 towardLight = light.type == LightType::Directional ? -light.direction : glm::dvec3(0.0);
        const auto facingNormal = [&](const glm::dvec3& p) {
          const glm::dvec3 base = light.type == LightType::Directional ? towardLight : glm::normalize(light.position - p);
          return base + 0.6 * glm::dvec3(unit(rng), unit(rng), unit(rng));
        };
        std::vector<SurfacePoint> random, boundary;
        for (int i = 0; i < 8000; ++i) {
          const glm::dvec3 p(coord(rng), coord(rng) * 0.3, coord(rng));
          random.push_back({p, facingNormal(p)});
        }
        const double n = resolution;
        for (int i = 0; i < 4000; ++i) {
          // A target q near a boundary in one coordinate (the others random), then the point whose lookup lands
          // on it: the bias offset q - g changes slowly with the point, so three steps settle it.
          const double delta = std::pow(10.0, -7.0 + 5.0 * fraction(rng)) * (fraction(rng) < 0.5 ? -1 : 1);
          glm::dvec3 target(n * (0.05 + 0.9 * fraction(rng)), n * (0.05 + 0.9 * fraction(rng)), n * (0.05 + 0.9 * fraction(rng)));
          const int axis = i % 3;
          target[axis] = std::floor(target[axis]) + delta;
          glm::dvec3 p = gridToWorld(view, target), normal = facingNormal(p);
          for (int step = 0; step < 3; ++step) {
            const LookupCell cell = lookupCell(mapping, p, normal, options);
            p = gridToWorld(view, target - (cell.uvs - toGrid(mapping, p).uvs));
          }
          boundary.push_back({p, normal});
        }
        for (const auto* set : {&random, &boundary}) {
          CellBatchInput in;
          in.mapping = &mapping;
          in.settings = cellSettings(options);
          in.spot = light.type == LightType::Spot ? &spot : nullptr;
          in.points = interleavedArrays(*set);
          in.count = set->size();
          Cells scalar(set->size());
          mapCells(in, scalar.output(), CellIsa::Scalar);
          for (const CellIsa isa : {CellIsa::Avx2, CellIsa::Avx512}) {
            if (isa > best) continue;
            Cells vector(set->size());
            size_t remapped = 0;
            CellBatchOutput out = vector.output();
            out.doubleRemapped = &remapped;
            mapCells(in, out, isa);
            SCOPED_TRACE(light.name + " at " + std::to_string(resolution) + (set == &random ? " random" : " boundary") +
                         " isa " + std::to_string(int(isa)) + " K " + std::to_string(options.pcfKernel));
            size_t voxels = 0;
            for (size_t i = 0; i < set->size(); ++i) {
              ASSERT_EQ(vector.state[i], scalar.state[i]) << "point " << i;
              ASSERT_EQ(vector.x[i], scalar.x[i]) << "point " << i;
              ASSERT_EQ(vector.y[i], scalar.y[i]) << "point " << i;
              ASSERT_EQ(vector.z[i], scalar.z[i]) << "point " << i;
              voxels += scalar.state[i] == kCellVoxel;
            }
            const double share = double(remapped) / double(set->size());
            if (isa != CellIsa::Avx2) {  // AVX-512 maps in double (as fast here: docs/lookups.md)
              EXPECT_EQ(remapped, 0u);
            } else if (set == &random) {
              EXPECT_LT(share, resolution <= 8192 ? 0.02 : 0.08);
            } else {
              EXPECT_GT(voxels, set->size() / 2);  // the boundary points do reach voxels
              EXPECT_GT(share, 0.3);
            }
            checked += set->size();
          }
        }
      }
    }
  EXPECT_GT(checked, 100000u);
}

// float_cells.h's log in single precision, which its slice bound takes to be within 8 eps (|log x| + 1) of the
// true log: measured over floats of every exponent (the worst seen is under 2; the test allows 4, half the
// bound's figure).
struct ScalarFloatBits {
  static float mantissaOne(float x) { return std::bit_cast<float>((std::bit_cast<uint32_t>(x) & 0x007fffffu) | 0x3f800000u); }
  static float exponent(float x) { return float(int((std::bit_cast<uint32_t>(x) >> 23) & 0xffu) - 127); }
};
TEST(BatchCells, SinglePrecisionLogStaysWithinItsBound) {
  std::mt19937 rng(3);
  double worst = 0;
  for (int i = 0; i < 2000000; ++i) {
    const uint32_t bits = 0x00800000u + uint32_t(rng() % (0x7f7fffffu - 0x00800000u));  // every normal float
    const float x = std::bit_cast<float>(bits);
    const double exact = std::log(double(x));
    const double got = floatLog<float, ScalarFloatBits>(x);
    worst = std::max(worst, std::fabs(got - exact) / (0x1p-24 * (std::fabs(exact) + 1)));
  }
  std::printf("float log: worst %.3f eps (|log x| + 1)\n", worst);
  EXPECT_LT(worst, 4.0);
}

}  // namespace
}  // namespace cpvs
