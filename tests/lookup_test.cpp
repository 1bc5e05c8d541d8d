// Runtime lookups (libcpvs/runtime): the one-traversal PCF equals K^2 single-voxel lookups, the bias rule
// keeps lit surfaces lit without acne, influence and view selection, and a baked scene agrees with the
// voxel convention (a surface point lands in its enter voxel).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>

#include <sys/mman.h>
#include <unistd.h>

#include "libcpvs/bake/bake.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/dag_walks.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/tiles/tile_masks.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::syntheticDepth;
using test::wideReferenceDag;
using test::identityView;
using test::sun;

// ---- synthetic DAGs -------------------------------------------------------------------------------------

ShadowDag dagFrom(const DepthRegion& depth, UndefinedMode mode = UndefinedMode::Kampe) {
  return buildDag(buildTileChains(depth, mode), true);
}

// The reference: K^2 single-voxel lookups (texels outside [0, N) are lit).
uint32_t referenceShadowed(const DagView& dag, int32_t x, int32_t y, uint32_t z, int k) {
  const int32_t n = int32_t(dag.resolution), h = k / 2;
  uint32_t count = 0;
  for (int32_t dy = -h; dy <= h; ++dy)
    for (int32_t dx = -h; dx <= h; ++dx) {
      const int32_t tx = x + dx, ty = y + dy;
      if (tx < 0 || ty < 0 || tx >= n || ty >= n) continue;
      count += dag.shadowed(uint32_t(tx), uint32_t(ty), z) ? 1 : 0;
    }
  return count;
}

TEST(Pcf, OneTraversalEqualsKSquaredLookups) {
  for (uint32_t n : {8u, 16u, 64u, 128u}) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      const ShadowDag dag = dagFrom(syntheticDepth(n, seed * 31 + n));
      const DagView view = dag.view();
      std::mt19937 rng(seed);
      std::uniform_int_distribution<int32_t> coord(-6, int32_t(n) + 5);
      std::uniform_int_distribution<uint32_t> slice(0, n - 1);
      for (int k : {1, 3, 5, 9, 11, 17}) {
        for (int i = 0; i < 3000; ++i) {
          const int32_t x = coord(rng), y = coord(rng);
          const uint32_t z = slice(rng);
          ASSERT_EQ(shadowedTexels(view, x, y, z, k), referenceShadowed(view, x, y, z, k))
              << "N=" << n << " K=" << k << " at " << x << "," << y << "," << z;
        }
      }
    }
  }
}

TEST(TopGrid, StartingFromTheGridGivesTheSameAnswers) {
  for (uint32_t n : {16u, 64u, 128u}) {
    const ShadowDag dag = dagFrom(syntheticDepth(n, n + 7));
    const DagView view = dag.view();
    for (uint32_t level = 1; level <= 5; ++level) {
      const TopGrid grid = TopGrid::build(view, level);
      ASSERT_EQ(grid.level, std::min<uint32_t>(level, uint32_t(std::countr_zero(n)) - 3));
      ASSERT_EQ(grid.cells.size(), size_t(1) << (3 * grid.level));
      for (uint32_t z = 0; z < n; z += 3)
        for (uint32_t y = 0; y < n; ++y)
          for (uint32_t x = 0; x < n; ++x)
            ASSERT_EQ(shadowedVoxel(view, grid, x, y, z), view.shadowed(x, y, z))
                << "N=" << n << " level " << level << " at " << x << "," << y << "," << z;
      std::mt19937 rng(level);
      std::uniform_int_distribution<int32_t> coord(-6, int32_t(n) + 5);
      std::uniform_int_distribution<uint32_t> slice(0, n - 1);
      for (int k : {3, 9, 17, 33}) {
        for (int i = 0; i < 500; ++i) {
          const int32_t x = coord(rng), y = coord(rng);
          const uint32_t z = slice(rng);
          ASSERT_EQ(shadowedTexels(view, grid, x, y, z, k), referenceShadowed(view, x, y, z, k))
              << "N=" << n << " level " << level << " K=" << k;
        }
      }
    }
  }
  // The automatic level keeps the grid within the DAG's own bytes, at most kMaxAutomaticTopGridLevels, and
  // takes the deepest level that does.
  for (uint32_t n : {64u, 256u}) {
    const ShadowDag dag = dagFrom(syntheticDepth(n, 3));
    const uint32_t level = TopGrid::automaticLevel(dag.view());
    EXPECT_LE(level, kMaxAutomaticTopGridLevels);
    if (level > 0) {
      EXPECT_LE(uint64_t(4) << (3 * level), dag.bytes());
    }
    if (level < kMaxAutomaticTopGridLevels) {
      EXPECT_GT(uint64_t(4) << (3 * (level + 1)), dag.bytes());
    }
  }
  // Homogeneous roots fill the grid with their code.
  ShadowDag shadowed;
  shadowed.resolution = 64;
  shadowed.rootCode = ChildCode::Shadowed;
  const TopGrid grid = TopGrid::build(shadowed.view(), 2);
  EXPECT_TRUE(shadowedVoxel(shadowed.view(), grid, 5, 6, 7));
  EXPECT_EQ(shadowedTexels(shadowed.view(), grid, 5, 5, 3, 9), 81u);
}

TEST(Pcf, HomogeneousRootsAndWholeGridKernels) {
  ShadowDag lit, shadowed;
  lit.resolution = shadowed.resolution = 32;
  lit.rootCode = ChildCode::Lit;
  shadowed.rootCode = ChildCode::Shadowed;
  EXPECT_EQ(shadowedTexels(lit.view(), 5, 5, 3, 9), 0u);
  EXPECT_EQ(shadowedTexels(shadowed.view(), 5, 5, 3, 9), 81u);
  EXPECT_EQ(shadowedTexels(shadowed.view(), 0, 0, 3, 9), 25u);    // corner: 5 x 5 inside
  EXPECT_EQ(shadowedTexels(shadowed.view(), 16, 16, 0, 255), 1024u);  // kernel larger than the grid
  EXPECT_EQ(shadowedTexels(shadowed.view(), -1, 4, 0, 1), 0u);
}

TEST(Lookup, VisibilityMatchesReferenceOnRandomPointsAndNormals) {
  const uint32_t n = 64;
  const ShadowDag dag = dagFrom(syntheticDepth(n, 5));
  const LightView view = identityView(n);
  const Light light = sun();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> pos(-4.0, n + 4.0), dir(-1.0, 1.0);
  for (int k : {1, 3, 5, 9, 11}) {
    for (int i = 0; i < 4000; ++i) {
      const glm::dvec3 p(pos(rng), pos(rng), -pos(rng));
      const glm::dvec3 normal = i % 5 == 0 ? glm::dvec3(0.0) : glm::dvec3(dir(rng), dir(rng), dir(rng));
      const float v = visibility(view, dag.view(), light, p, normal, k);
      const LookupCell cell = lookupCell(view, p, normal, {k, NormalOrientation::AsGiven});
      float expected = 1.0f;
      if (cell.kind == LookupCell::Kind::BackFacing) expected = 0.0f;
      if (cell.kind == LookupCell::Kind::Voxel)
        expected = float(1.0 - double(referenceShadowed(dag.view(), cell.x, cell.y, uint32_t(cell.z), k)) / (k * k));
      ASSERT_EQ(v, expected) << "K=" << k << " point " << p.x << "," << p.y << "," << p.z;
      ASSERT_GE(v, 0.0f);
      ASSERT_LE(v, 1.0f);
    }
  }
}

TEST(Lookup, BatchEqualsSinglePointLookups) {
  const uint32_t n = 64;
  const ShadowDag dag = dagFrom(syntheticDepth(n, 11));
  const LightView view = identityView(n);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> pos(-4.0, n + 4.0), dir(-1.0, 1.0);
  std::vector<SurfacePoint> points;
  for (int i = 0; i < 5000; ++i) {
    SurfacePoint p{{pos(rng), pos(rng), -pos(rng)}, glm::dvec3(dir(rng), dir(rng), dir(rng))};
    if (i % 7 == 0) p.normal = glm::dvec3(0.0);
    if (i % 101 == 0) p.position.x = std::nan("");
    points.push_back(p);
  }
  for (uint32_t gridLevels : {0u, 2u}) {
    const LightShadow shadow = orThrow(LightShadow::create(sun(), {view}, {dag.view()}, gridLevels));
    for (int k : {1, 3, 9, 17, 33}) {
      for (NormalOrientation o : {NormalOrientation::AsGiven, NormalOrientation::TowardLight}) {
        std::vector<float> batch(points.size());
        ASSERT_TRUE(shadow.visibility(points, {k, o}, batch).ok());
        for (size_t i = 0; i < points.size(); ++i)
          ASSERT_EQ(batch[i], shadow.visibility(points[i].position, points[i].normal, {k, o}))
              << "K=" << k << " grid " << gridLevels << " point " << i;
      }
    }
  }
}

// ---- the AVX-512 walks (dag_walks.h) against DagView::shadowed ---------------------------------------

// A copy of a DAG's units that ends exactly where an unreadable page begins: a walk that reads one byte past
// the last unit dies of SIGSEGV instead of passing unnoticed.
class GuardedUnits {
public:
  explicit GuardedUnits(std::span<const uint16_t> units) {
    const size_t page = size_t(sysconf(_SC_PAGESIZE));
    const size_t bytes = units.size() * sizeof(uint16_t);
    length_ = (bytes + page - 1) / page * page + page;
    base_ = mmap(nullptr, length_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (base_ == MAP_FAILED) throw std::runtime_error("mmap failed");
    char* guard = static_cast<char*>(base_) + length_ - page;
    if (mprotect(guard, page, PROT_NONE) != 0) throw std::runtime_error("mprotect failed: no guard page");
    data_ = reinterpret_cast<uint16_t*>(guard - bytes);
    std::memcpy(data_, units.data(), bytes);
  }
  ~GuardedUnits() { munmap(base_, length_); }
  GuardedUnits(const GuardedUnits&) = delete;
  GuardedUnits& operator=(const GuardedUnits&) = delete;
  std::span<const uint16_t> units(size_t count) const { return {data_, count}; }

private:
  void* base_ = nullptr;
  size_t length_ = 0;
  uint16_t* data_ = nullptr;
};

using DescendGroup = void (*)(const WalkDag&, const WalkSet&, size_t, uint32_t, WalkResult, void*);

// Every voxel of the DAG walked from the root (in groups, as the lookups do) with the vector walks `descendGroup`:
// its visibility, and its tile's mask at its slice.
void expectWalksEqualDagLookupsOnEveryVoxel(DescendGroup descendGroup) {
  size_t dagsWalked = 0;
  std::vector<std::pair<uint32_t, uint32_t>> cases{{16, 0}};  // (N, seed); seed 0: wideReferenceDag
  for (uint32_t n : {16u, 32u, 64u})
    for (uint32_t seed = 1; seed <= 4; ++seed) cases.emplace_back(n, seed);
  for (const auto& [n, seed] : cases) {
    const ShadowDag dag = seed == 0 ? wideReferenceDag() : dagFrom(syntheticDepth(n, seed * 13 + n));
    if (dag.rootCode != ChildCode::Ref) continue;
    const GuardedUnits guarded(dag.nodes);
    DagView view = dag.view();
    view.nodes = guarded.units(dag.nodes.size());
    const WalkDag walkDag{view.nodes.data(), view.nodes.size(), view.leaves.data(), view.childBase, n};
    const size_t count = size_t(n) * n * n;
    WalkStorage storage;
    const WalkSet walks = storage.reserve(count);
    auto start = [&] {
      for (uint32_t i = 0; i < count; ++i) walks.set(i, i % n, (i / n) % n, i / (n * n), 0, i);
    };
    std::vector<float> visibility(count, -1.0f);
    std::vector<uint64_t> masks(count, 0x5A5A5A5A5A5A5A5Aull);
    start();
    for (size_t b = 0; b < count; b += kWalksInFlight)
      descendGroup(walkDag, walks.from(b), std::min(kWalksInFlight, count - b), n, WalkResult::Visibility,
                   visibility.data());
    start();
    for (size_t b = 0; b < count; b += kWalksInFlight)
      descendGroup(walkDag, walks.from(b), std::min(kWalksInFlight, count - b), n, WalkResult::TileMask,
                   masks.data());
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t x = i % n, y = (i / n) % n, z = i / (n * n);
      ASSERT_EQ(visibility[i], view.shadowed(x, y, z) ? 0.0f : 1.0f) << "N=" << n << " at " << x << "," << y << "," << z;
      uint64_t tile = 0;
      for (uint32_t b = 0; b < 64; ++b)
        tile |= uint64_t(view.shadowed((x & ~7u) + (b & 7u), (y & ~7u) + (b >> 3), z)) << b;
      ASSERT_EQ(masks[i], tile) << "N=" << n << " at " << x << "," << y << "," << z;
    }
    ++dagsWalked;
  }
  EXPECT_GE(dagsWalked, 9u);
}

TEST(DagWalks, VectorWalksEqualDagLookupsOnEveryVoxel) {
  if (!vectorWalksAvailable()) GTEST_SKIP() << "no AVX-512F on this CPU (or CPVS_LOOKUP_ISA lowers it)";
  expectWalksEqualDagLookupsOnEveryVoxel(&descendGroupAvx512);
}

TEST(DagWalks, Avx2WalksEqualDagLookupsOnEveryVoxel) {
  if (bestCellIsa() < CellIsa::Avx2) GTEST_SKIP() << "no AVX2 on this CPU (or CPVS_LOOKUP_ISA lowers it)";
  expectWalksEqualDagLookupsOnEveryVoxel(&descendGroupAvx2);
}

// The batch lookups through LightShadow on a DAG that ends at an unreadable page: the vector walks (where the
// CPU has them) give the scalar single-point answers, K = 1 and PCF, with and without a top grid.
TEST(DagWalks, BatchOnAGuardedDagEqualsSinglePointLookups) {
  const uint32_t n = 64;
  const ShadowDag dag = dagFrom(syntheticDepth(n, 23));
  ASSERT_EQ(dag.rootCode, ChildCode::Ref);
  const GuardedUnits guarded(dag.nodes);
  DagView view = dag.view();
  view.nodes = guarded.units(dag.nodes.size());
  std::vector<SurfacePoint> points;
  for (uint32_t z = 0; z < n; z += 3)
    for (uint32_t y = 0; y < n; ++y)
      for (uint32_t x = 0; x < n; ++x) points.push_back({{x + 0.5, y + 0.5, -(z + 0.5)}, glm::dvec3(0.0)});
  for (uint32_t gridLevels : {0u, 1u, 2u}) {
    const LightShadow shadow = orThrow(LightShadow::create(sun(), {identityView(n)}, {view}, int(gridLevels)));
    for (int k : {1, 3, 9}) {
      std::vector<float> batch(points.size());
      for (size_t b = 0; b < points.size(); b += kLookupBatch) {
        const size_t e = std::min(points.size(), b + kLookupBatch);
        orThrow(shadow.visibility(std::span<const SurfacePoint>(points.data() + b, e - b), {k},
                          std::span<float>(batch.data() + b, e - b)));
      }
      for (size_t i = 0; i < points.size(); ++i)
        ASSERT_EQ(batch[i], shadow.visibility(points[i].position, points[i].normal, {k}))
            << "K=" << k << " grid " << gridLevels << " point " << i;
    }
  }
}

TEST(Lookup, SpecialCases) {
  const uint32_t n = 32;
  ShadowDag allShadow;
  allShadow.resolution = n;
  allShadow.rootCode = ChildCode::Shadowed;
  LightView view = identityView(n);
  const Light light = sun();
  const glm::dvec3 inside(10.5, 10.5, -10.5), none(0.0);
  EXPECT_EQ(visibility(view, allShadow.view(), light, inside, none, 1), 0.0f);
  // Outside the lateral grid: no caster there.
  EXPECT_EQ(visibility(view, allShadow.view(), light, glm::dvec3(-0.5, 10, -10), none, 1), 1.0f);
  EXPECT_EQ(visibility(view, allShadow.view(), light, glm::dvec3(10, 32.0, -10), none, 9), 1.0f);
  // Non-finite input is answered 0.
  const double nan = std::nan("");
  EXPECT_EQ(visibility(view, allShadow.view(), light, glm::dvec3(nan, 1, 1), none, 1), 0.0f);
  EXPECT_EQ(visibility(view, allShadow.view(), light, inside, glm::dvec3(0, INFINITY, 0), 1), 0.0f);
  // An empty view is lit everywhere.
  view.empty = true;
  EXPECT_EQ(visibility(view, allShadow.view(), light, inside, none, 1), 1.0f);
  // Depth beyond the grid clamps to the last slice (behind everything: shadowed here).
  view.empty = false;
  EXPECT_EQ(visibility(view, allShadow.view(), light, glm::dvec3(3, 3, -1000), none, 1), 0.0f);
  EXPECT_EQ(checkPcfKernel(4).category(), ErrorCategory::InvalidArgument);
  EXPECT_FALSE(checkPcfKernel(0).ok());
  EXPECT_FALSE(checkPcfKernel(257).ok());
  EXPECT_TRUE(checkPcfKernel(9).ok());
}

// The runtime's API reports misuse as an Outcome and never throws.
TEST(Lookup, MisuseIsReportedNotThrown) {
  const ShadowDag lit = orThrow(encodeDag(16, ChildCode::Lit, {}, {}, {}));
  const Result<LightShadow> mismatched = LightShadow::create(sun(), {identityView(16), identityView(16)}, {lit.view()});
  ASSERT_FALSE(mismatched.ok());
  EXPECT_EQ(mismatched.outcome().category(), ErrorCategory::InvalidInput);
  EXPECT_NE(mismatched.outcome().message().find("2 views but 1 DAGs"), std::string::npos) << mismatched.outcome().message();

  const LightShadow shadow = orThrow(LightShadow::create(sun(), {identityView(16)}, {lit.view()}));
  const std::vector<SurfacePoint> points(3, SurfacePoint{glm::dvec3(1, 1, -1), glm::dvec3(0, 0, 1)});
  std::vector<float> out(2, -1.0f);
  const Outcome sizes = shadow.visibility(points, {1}, out);
  EXPECT_EQ(sizes.category(), ErrorCategory::InvalidArgument);
  EXPECT_EQ(out, std::vector<float>(2, -1.0f));  // nothing written
  out.assign(3, -1.0f);
  EXPECT_FALSE(shadow.visibility(points, {4}, out).ok());  // even K
  EXPECT_TRUE(shadow.visibility(points, {3}, out).ok());
  EXPECT_EQ(out, std::vector<float>(3, 1.0f));
}

// The lights the mapping tests look at test::groundAndRidge() with.
Light tiltedSpot() {
  Light spot;
  spot.type = LightType::Spot;
  spot.position = {1, 6, 2};
  spot.direction = glm::normalize(glm::dvec3(-0.2, -1, -0.1));
  spot.outerConeAngle = 1.0;
  return spot;
}

Light tiltedSun() {
  Light directional;
  directional.direction = glm::normalize(glm::dvec3(0.3, -1, 0.5));
  return directional;
}

TEST(Lookup, JacobianMatchesFiniteDifferences) {
  const WorldGeometry world = test::groundAndRidge();
  const Light spot = tiltedSpot(), directional = tiltedSun();
  for (const Light& light : {spot, directional}) {
    const LightView view = makeLightViews(light, world, 256)[0];
    for (const glm::dvec3& p : {glm::dvec3(0.3, 0.1, -0.7), glm::dvec3(-2, 0, 3), glm::dvec3(1, 1, 1)}) {
      const glm::dmat3 j = gridJacobian(view, p);
      const double h = 1e-5;
      for (int axis = 0; axis < 3; ++axis) {
        glm::dvec3 e(0.0);
        e[axis] = h;
        const glm::dvec3 fd = (toGrid(view, p + e).uvs - toGrid(view, p - e).uvs) / (2 * h);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(j[axis][c], fd[c], 1e-4 * (1 + std::abs(fd[c])));
      }
      // The grid normal is perpendicular to the grid image of every tangent.
      const glm::dvec3 normal = glm::normalize(glm::dvec3(0.2, 1, -0.3));
      const glm::dvec3 m = gridNormal(view, p, normal);
      const glm::dvec3 t1 = glm::cross(normal, glm::dvec3(1, 0, 0)), t2 = glm::cross(normal, t1);
      EXPECT_NEAR(glm::dot(m, j * t1) / (glm::length(m) * glm::length(j * t1)), 0.0, 1e-9);
      EXPECT_NEAR(glm::dot(m, j * t2) / (glm::length(m) * glm::length(j * t2)), 0.0, 1e-9);
    }
  }
}

TEST(Lookup, HoistedToGridIsToGridBitForBit) {
  const WorldGeometry world = test::groundAndRidge();
  const Light spot = tiltedSpot(), directional = tiltedSun();
  Light point;
  point.type = LightType::Point;
  point.position = {0.5, 3, -1};
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> coord(-8.0, 8.0);
  for (const Light& light : {spot, directional, point})
    for (const LightView& view : makeLightViews(light, world, 1024)) {
      const ViewMapping mapping(view);
      for (int i = 0; i < 2000; ++i) {
        const glm::dvec3 p(coord(rng), coord(rng), coord(rng));
        const GridPoint a = toGrid(mapping, p), b = toGrid(view, p);
        ASSERT_EQ(a.inFront, b.inFront);
        if (!b.inFront) continue;
        ASSERT_EQ(a.depth, b.depth);
        ASSERT_EQ(a.uvs.x, b.uvs.x);
        ASSERT_EQ(a.uvs.y, b.uvs.y);
        ASSERT_EQ(a.uvs.z, b.uvs.z);
        // The bias lookupCell applies is q = g + b m^ with m^ the unit gridNormal (step 2 of the rule).
        if (view.empty) continue;  // answered lit before any bias
        const glm::dvec3 normal = glm::normalize(glm::dvec3(coord(rng), coord(rng), coord(rng)));
        glm::dvec3 m = glm::normalize(gridNormal(view, p, normal));
        const LookupCell biased = lookupCell(view, p, normal, {3, NormalOrientation::TowardLight, 0.5});
        if (m.z > 0) m = -m;
        const glm::dvec3 q = b.uvs + biasDistance(m, 3, 0.5) * m;
        ASSERT_NEAR(biased.uvs.x, q.x, 1e-9 * (1 + std::abs(q.x)));
        ASSERT_NEAR(biased.uvs.y, q.y, 1e-9 * (1 + std::abs(q.y)));
        ASSERT_NEAR(biased.uvs.z, q.z, 1e-9 * (1 + std::abs(q.z)));
        // voxelOf's truncation is toVoxel's floor and clamp wherever the lookup uses it.
        const LookupCell cell = lookupCell(view, p, glm::dvec3(0.0), {});
        if (cell.kind == LookupCell::Kind::Voxel) {
          const Voxel expected = toVoxel(view, b.uvs);
          ASSERT_EQ(cell.x, expected.x);
          ASSERT_EQ(cell.y, expected.y);
          ASSERT_EQ(cell.z, expected.z);
        }
      }
    }
}

// A tilted open plane s = c + a u + b v in the identity view, rasterised the baker's way (enter at texel
// centres, floor), with the plane's world normal facing the light.
struct TiltedPlane {
  double c, a, b;
  double s(double u, double v) const { return c + a * u + b * v; }
  glm::dvec3 normal() const { return glm::normalize(glm::dvec3(a, b, 1.0)); }
};

DepthRegion planeDepth(uint32_t n, const TiltedPlane& plane) {
  DepthRegion d;
  d.rect = {0, 0, n, n};
  d.resolution = n;
  d.enter.resize(size_t(n) * n);
  d.exit.resize(size_t(n) * n);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      const double s = plane.s(x + 0.5, y + 0.5);
      const uint32_t e = s < 0 ? 0 : (s >= n ? n : uint32_t(std::floor(s)));
      d.enter[size_t(y) * n + x] = e;
      d.exit[size_t(y) * n + x] = std::min(n, e + 1);
    }
  return d;
}

TEST(Bias, TiltedLitPlaneHasNoAcneWithNormalBias) {
  const uint32_t n = 128;
  const LightView view = identityView(n);
  const Light light = sun();
  // Slopes up to 2.5 slices per texel (a sun ~70 degrees off the normal), including diagonal tilts.
  for (const TiltedPlane& plane : {TiltedPlane{30, 0.0, 0.0}, TiltedPlane{4, 0.5, 0.35}, TiltedPlane{2, 0.9, 0.0},
                                   TiltedPlane{110, 0.0, -0.8}, TiltedPlane{10, 2.5, 0.0}, TiltedPlane{5, 1.2, 1.2}}) {
    const ShadowDag dag = dagFrom(planeDepth(n, plane));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> lateral(12.0, n - 12.0);
    int tested = 0, acneUnbiased = 0;
    for (int i = 0; i < 4000; ++i) {
      const double u = lateral(rng), v = lateral(rng);
      const double s = plane.s(u, v);
      if (s < 12 || s > n - 12) continue;  // keep the footprint and its bias inside the grid
      const glm::dvec3 p(u, v, -s);
      ++tested;
      for (int k : {1, 3, 9}) {
        ASSERT_EQ(visibility(view, dag.view(), light, p, plane.normal(), k), 1.0f)
            << "K=" << k << " slope " << plane.a << "," << plane.b << " at " << u << "," << v;
      }
      if (visibility(view, dag.view(), light, p, glm::dvec3(0.0), 9) < 1.0f) ++acneUnbiased;
      // Flipping an already light-facing normal changes nothing.
      ASSERT_EQ(visibility(view, dag.view(), light, p, plane.normal(), 9, NormalOrientation::TowardLight), 1.0f);
      // A normal facing away from the light is flipped only on request.
      ASSERT_EQ(visibility(view, dag.view(), light, p, -plane.normal(), 1, NormalOrientation::TowardLight), 1.0f);
      if (plane.a != 0 || plane.b != 0) {
        ASSERT_EQ(visibility(view, dag.view(), light, p, -plane.normal(), 1), 0.0f);
      }
    }
    EXPECT_GT(tested, 200) << "slope " << plane.a << "," << plane.b;
    // Without the bias a tilted plane self-shadows under a 9x9 kernel: the test above means something.
    if (plane.a != 0 || plane.b != 0) {
      EXPECT_GT(acneUnbiased, tested / 4);
    }
  }
}

TEST(Bias, BiasIsHalfAFilterWidthPlusAMargin) {
  const double m = kDefaultBiasMargin;
  EXPECT_DOUBLE_EQ(biasDistance({0, 0, -1}, 1), m);
  EXPECT_DOUBLE_EQ(biasDistance({0, 0, -1}, 9), m);
  EXPECT_DOUBLE_EQ(biasDistance({1, 0, 0}, 9), 4.5 + m);
  EXPECT_NEAR(biasDistance(glm::normalize(glm::dvec3(1, 1, 0)), 9), m + 4.5 * std::sqrt(2.0), 1e-12);
  EXPECT_DOUBLE_EQ(biasDistance({0.6, 0, -0.8}, 3, 1.0), 1.9);
}

TEST(Bias, CasterAboveAPlaneShadowsItAndItsSurroundIsLit) {
  const uint32_t n = 64;
  // Ground at slice 50; a slab at slice 20 over texels [20, 40) x [20, 40).
  DepthRegion d = planeDepth(n, {50.5, 0, 0});
  for (uint32_t y = 20; y < 40; ++y)
    for (uint32_t x = 20; x < 40; ++x) d.enter[y * n + x] = 20, d.exit[y * n + x] = 21;
  const ShadowDag dag = dagFrom(d);
  const LightView view = identityView(n);
  const glm::dvec3 up(0, 0, 1);
  EXPECT_EQ(visibility(view, dag.view(), sun(), {30, 30, -50.5}, up, 1), 0.0f);
  EXPECT_EQ(visibility(view, dag.view(), sun(), {30, 30, -50.5}, up, 9), 0.0f);
  EXPECT_EQ(visibility(view, dag.view(), sun(), {10, 10, -50.5}, up, 9), 1.0f);
  // On the shadow's edge, PCF gives the covered fraction: texels 16..24 in x, 20..24 shadowed -> 5/9.
  EXPECT_FLOAT_EQ(visibility(view, dag.view(), sun(), {20.5, 30.5, -50.5}, up, 9), 1.0f - 5.0f / 9.0f);
  // The top of the slab is lit.
  EXPECT_EQ(visibility(view, dag.view(), sun(), {30, 30, -20.2}, up, 9), 1.0f);
}

// ---- influence and view selection ---------------------------------------------------------------------

WorldGeometry boxWorld() {
  Scene scene;
  test::addBox(scene, "box", {-3, -3, -3}, {3, 3, 3});
  test::classifyMeshes(scene);
  return flatten(scene);
}

TEST(Influence, OutsideRangeOrConeIsZero) {
  const WorldGeometry world = boxWorld();
  Light spot;
  spot.type = LightType::Spot;
  spot.position = {0, 10, 0};
  spot.direction = {0, -1, 0};
  spot.outerConeAngle = 0.5;
  spot.range = 14;
  auto views = makeLightViews(spot, world, 64);
  ShadowDag lit;
  lit.resolution = 64;
  const LightShadow shadow = orThrow(LightShadow::create(spot, views, {lit.view()}));
  const glm::dvec3 up(0, 1, 0);
  EXPECT_EQ(shadow.visibility({0, 3, 0}, up, {}), 1.0f);
  EXPECT_EQ(shadow.visibility({0, -5, 0}, up, {}), 0.0f);   // beyond range (15 > 14)
  EXPECT_EQ(shadow.visibility({4, 3, 0}, up, {}), 0.0f);    // outside the cone (atan(4/7) > 0.5)
  EXPECT_EQ(shadow.visibility({0, 11, 0}, up, {}), 0.0f);   // behind the spot
  EXPECT_EQ(visibility(views[0], lit.view(), spot, {0, -5, 0}, up, 1), 0.0f);
  EXPECT_EQ(visibility(views[0], lit.view(), spot, {0, 3, 0}, up, 1), 1.0f);

  Light point;
  point.type = LightType::Point;
  point.position = {0, 0, 10};
  point.range = 20;
  views = makeLightViews(point, world, 64);
  ASSERT_EQ(views.size(), 6u);
  // Face i is all shadowed for odd i, all lit for even i: the answer tells which face was used.
  ShadowDag faces[2];
  faces[0].resolution = faces[1].resolution = 64;
  faces[1].rootCode = ChildCode::Shadowed;
  std::vector<DagView> dags;
  for (const LightView& v : views) {
    (void)v;
    dags.push_back(faces[dags.size() % 2].view());
  }
  views[5].empty = false;  // -Z face sees the box
  const LightShadow pointShadow = orThrow(LightShadow::create(point, views, dags));
  EXPECT_EQ(pointShadow.viewIndex({0, 0, 0}), 5);
  EXPECT_EQ(pointShadow.viewIndex({5, 0, 9}), 0);
  EXPECT_EQ(pointShadow.viewIndex({0, 0, -11}), -1);  // beyond range
  EXPECT_EQ(pointShadow.visibility({0, 0, 3}, glm::dvec3(0, 0, 1), {}), 0.0f);  // face 5: shadowed root
  EXPECT_EQ(pointShadow.visibility({0, 0, 31}, glm::dvec3(0.0), {}), 0.0f);    // beyond range
}

// A point light's six faces, each with its own DAG: the batch groups the walks by view and must still give
// each point the single-point answer of its own face.
TEST(Influence, PointLightBatchEqualsSinglePointLookups) {
  const WorldGeometry world = boxWorld();
  const Light point = test::pointLight("point", {0.5, 0.25, 0.1}, 9);
  std::vector<LightView> views = makeLightViews(point, world, 64);
  ASSERT_EQ(views.size(), 6u);
  std::vector<ShadowDag> owned;
  for (uint32_t face = 0; face < 6; ++face) owned.push_back(dagFrom(syntheticDepth(64, 40 + face)));
  std::vector<DagView> dags;
  for (const ShadowDag& d : owned) dags.push_back(d.view());
  for (LightView& v : views) v.empty = false;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-3.0, 3.0), dir(-1.0, 1.0);
  std::vector<SurfacePoint> points;
  for (int i = 0; i < 4000; ++i) points.push_back({{pos(rng), pos(rng), pos(rng)}, {dir(rng), dir(rng), dir(rng)}});
  for (int gridLevels : {0, 2}) {
    const LightShadow shadow = orThrow(LightShadow::create(point, views, dags, gridLevels));
    for (int k : {1, 5}) {
      std::vector<float> batch(points.size());
      ASSERT_TRUE(shadow.visibility(points, {k}, batch).ok());
      size_t shadowed = 0, lit = 0;
      for (size_t i = 0; i < points.size(); ++i) {
        ASSERT_EQ(batch[i], shadow.visibility(points[i].position, points[i].normal, {k}))
            << "K=" << k << " grid " << gridLevels << " point " << i << " face " << shadow.viewIndex(points[i].position);
        shadowed += batch[i] == 0.0f;
        lit += batch[i] == 1.0f;
      }
      EXPECT_GT(shadowed, 100u);  // both answers occur: the faces' DAGs are really walked
      EXPECT_GT(lit, 100u);
    }
  }
}

// LightShadow::visibility from separate position and normal arrays (numpy's (n, 3) layout) and with one normal
// for all: the SurfacePoint overload's answers bit for bit, unfiltered and PCF, for a point light (its points
// sorted by cube face first) and a sun. Each array is exactly 3n doubles (the sanitized build catches a read
// past one).
TEST(Lookup, PointArraysEqualSurfacePoints) {
  const Light point = test::pointLight("point", {0.5, 0.25, 0.1}, 9);
  std::vector<LightView> views = makeLightViews(point, boxWorld(), 64);
  std::vector<ShadowDag> owned;
  for (uint32_t face = 0; face < 6; ++face) owned.push_back(dagFrom(syntheticDepth(64, 40 + face)));
  std::vector<DagView> dags;
  for (const ShadowDag& d : owned) dags.push_back(d.view());
  for (LightView& v : views) v.empty = false;
  const std::vector<std::pair<Light, LightShadow>> shadows = {
      {point, orThrow(LightShadow::create(point, views, dags))},
      {sun(), orThrow(LightShadow::create(sun(), {identityView(64)}, {dags[0]}))}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-3.0, 3.0), grid(0.0, 64.0), dir(-1.0, 1.0);
  for (const auto& [light, shadow] : shadows) {
    const bool isSun = light.type == LightType::Directional;
    std::vector<SurfacePoint> points;
    for (int i = 0; i < 3000; ++i) {
      const glm::dvec3 p = isSun ? glm::dvec3(grid(rng), grid(rng), -grid(rng)) : glm::dvec3(pos(rng), pos(rng), pos(rng));
      points.push_back({p, {dir(rng), dir(rng), dir(rng)}});
    }
    points.push_back({{std::nan(""), 0, 0}, {0, 1, 0}});
    const double shared[3] = {0.2, 0.9, -0.3};
    std::vector<SurfacePoint> sharing = points;
    for (SurfacePoint& p : sharing) p.normal = {shared[0], shared[1], shared[2]};
    std::vector<double> positions, normals;
    for (const SurfacePoint& p : points)
      for (int c = 0; c < 3; ++c) {
        positions.push_back(p.position[c]);
        normals.push_back(p.normal[c]);
      }
    for (int k : {1, 3, 9}) {
      const size_t n = points.size();
      std::vector<float> records(n), separate(n), recordsShared(n), oneNormal(n);
      orThrow(shadow.visibility(points, {k}, records));
      orThrow(shadow.visibility(PointArrays{positions.data(), 3, normals.data(), 3}, {k}, separate));
      orThrow(shadow.visibility(sharing, {k}, recordsShared));
      orThrow(shadow.visibility(PointArrays{positions.data(), 3, shared, 0}, {k}, oneNormal));
      EXPECT_EQ(separate, records) << light.name << " K=" << k;
      EXPECT_EQ(oneNormal, recordsShared) << light.name << " K=" << k;
      EXPECT_EQ(records.back(), 0.0f);  // the non-finite point
      size_t zeros = 0;
      for (float v : records) zeros += v == 0.0f;
      EXPECT_GT(zeros, 100u) << light.name;  // the DAGs are really walked
      EXPECT_LT(zeros, n - 100) << light.name;
    }
  }
}

// ---- a baked scene ------------------------------------------------------------------------------------

struct BakedScene {
  Scene scene;
  CpvsContent content;
  std::vector<DepthRegion> depth;  // per view of light 0 (one region each)
  bool available = false;
  std::string why;
};

const BakedScene& groundAndBox() {
  static BakedScene baked = [] {
    BakedScene b;
    test::addQuad(b.scene, "ground", {-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    test::addBox(b.scene, "box", {-2, 0, -2}, {2, 3, 2});
    test::classifyMeshes(b.scene);
    Light light = sun();
    light.direction = glm::normalize(glm::dvec3(0.8, -1.0, 0.3));
    b.scene.lights.push_back(light);
    BakeSettings settings;
    settings.resolution = 256;
    settings.threads = 1;
    BakeCallbacks callbacks;
    callbacks.depthRegion = [&](size_t li, size_t, const LightView&, const DepthRegion& region) {
      if (li == 0) b.depth.push_back(region);
    };
    try {
      b.content = bakeScene(b.scene, settings, nullptr, callbacks);
      b.available = true;
    } catch (const Error& e) {
      b.why = e.what();
    }
    return b;
  }();
  return baked;
}

TEST(Baked, SurfacePointLandsInItsEnterVoxelAndIsLit) {
  const BakedScene& baked = groundAndBox();
  if (!baked.available) GTEST_SKIP() << "no depth renderer here: " << baked.why;
  ASSERT_EQ(baked.depth.size(), 1u);
  const BakedView& bv = baked.content.lights[0].views[0];
  const DepthRegion& depth = baked.depth[0];
  const EmbreeScene rt(flatten(baked.scene));
  const uint32_t n = bv.view.resolution;
  int hits = 0, exact = 0, litOwnVoxel = 0;
  for (uint32_t y = 0; y < n; y += 3)
    for (uint32_t x = 0; x < n; x += 3) {
      const Ray ray = texelRay(bv.view, x + 0.5, y + 0.5);
      const auto hit = rt.firstHit(ray);
      if (!hit) {
        EXPECT_EQ(depth.enterAt(x, y), n);
        continue;
      }
      ++hits;
      const glm::dvec3 p = ray.origin + hit->t * ray.direction;
      const Voxel voxel = worldToVoxel(bv.view, p);
      EXPECT_EQ(voxel.x, int32_t(x));
      EXPECT_EQ(voxel.y, int32_t(y));
      if (uint32_t(voxel.z) == depth.enterAt(x, y)) ++exact;
      if (!bv.dag.view().shadowed(voxel.x, voxel.y, voxel.z)) ++litOwnVoxel;
    }
  ASSERT_GT(hits, 1000);
  // Depth rasterised in float may round a surface sitting on a slice boundary into the neighbour slice.
  EXPECT_GE(exact, hits * 995 / 1000) << exact << " of " << hits;
  EXPECT_GE(litOwnVoxel, hits * 995 / 1000) << litOwnVoxel << " of " << hits;
}

TEST(Baked, GroundUnderSlantedSunIsLitWithBiasAndShadowedBehindTheBox) {
  const BakedScene& baked = groundAndBox();
  if (!baked.available) GTEST_SKIP() << "no depth renderer here: " << baked.why;
  const BakedLight& bl = baked.content.lights[0];
  const LightShadow shadow = orThrow(LightShadow::create(bl.light, {bl.views[0].view}, {bl.views[0].dag.view()}));
  const EmbreeScene rt(flatten(baked.scene));
  const glm::dvec3 up(0, 1, 0), toLight = -bl.light.direction;
  const double texel = (bl.views[0].view.xMax - bl.views[0].view.xMin) / bl.views[0].view.resolution;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> coord(-9.5, 9.5);
  int lit = 0, shadowed = 0;
  for (int i = 0; i < 3000; ++i) {
    const glm::dvec3 p(coord(rng), 0.0, coord(rng));
    if (std::abs(p.x) < 2 && std::abs(p.z) < 2) continue;  // under the box
    // Ground truth with a margin: rays from a ring of 14 texels (for "lit", wide enough for a 9x9 kernel
    // and its bias) or 3 texels (for "shadowed") all agree with the centre.
    auto blockedOnRing = [&](double radius) {
      int blocked = 0;
      for (int s = 0; s < 9; ++s) {
        const double a = s * 0.6981317;
        const glm::dvec3 q = p + (s ? radius * texel : 0.0) * glm::dvec3(std::cos(a), 0, std::sin(a));
        blocked += rt.occluded(q + 1e-4 * up, toLight) ? 1 : 0;
      }
      return blocked;
    };
    if (blockedOnRing(14.0) == 0) {
      ++lit;
      ASSERT_EQ(shadow.visibility(p, up, {1}), 1.0f) << p.x << "," << p.z;
      ASSERT_EQ(shadow.visibility(p, up, {9}), 1.0f) << p.x << "," << p.z;
    } else if (blockedOnRing(3.0) == 9) {
      ++shadowed;
      ASSERT_EQ(shadow.visibility(p, up, {1}), 0.0f) << p.x << "," << p.z;
    }
  }
  EXPECT_GT(lit, 1000);
  EXPECT_GT(shadowed, 50);
  // The lit top of the box (a closed solid) and its lit side facing the sun.
  EXPECT_EQ(shadow.visibility({0.3, 3.0, 0.4}, up, {9}), 1.0f);
  EXPECT_EQ(shadow.visibility({-2.0, 1.5, 0.0}, glm::dvec3(-1, 0, 0), {9}), 1.0f);
  // The side facing away is in the box's own shadow.
  EXPECT_EQ(shadow.visibility({2.0, 1.5, 0.0}, glm::dvec3(1, 0, 0), {1}), 0.0f);
}

}  // namespace
}  // namespace cpvs
