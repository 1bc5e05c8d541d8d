// The runtime's own checks, built from the runtime's files and GoogleTest alone (no libcpvs, no test support),
// so that the same program runs natively in CTest and cross-compiled under Wine and qemu
// (tests/runtime_cross_test.sh): on every file given, every lookup path answers as one point at a time and maps
// points near voxel boundaries to the scalar path's cells, damaged
// copies of a file fail with a message and never crash, and the GPU records walk (the GLSL twin compiled as
// C++) as the file's DAGs do.
//
//   runtime_checks [GTEST OPTIONS] FILE.cpvs POINTS.csv [FILE.cpvs POINTS.csv ...]
//
// POINTS.csv: X,Y,Z,NX,NY,NZ per line (cpvs-sample's output; a header line is skipped).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/dag_walk.glsl.h"
#include "libcpvs/runtime/file_shadows.h"
#include "libcpvs/runtime/gpu_records.h"

namespace cpvs {
namespace {

struct Case {
  std::string file, points;
};
std::vector<Case> gCases;

std::vector<SurfacePoint> readPoints(const std::string& path) {
  std::vector<SurfacePoint> points;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    double v[6];
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) != 6) continue;
    SurfacePoint p;
    p.position = {v[0], v[1], v[2]};
    p.normal = {v[3], v[4], v[5]};
    points.push_back(p);
  }
  return points;
}

std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Opened {
  std::unique_ptr<CpvsFile> file;
  std::vector<LightShadow> lights;
};
// The file and one LightShadow per light; a failure names itself in `error`.
Opened openAll(Result<std::unique_ptr<CpvsFile>> opened, std::string& error) {
  Opened o;
  if (!opened) {
    error = opened.outcome().message();
    return o;
  }
  o.file = std::move(opened).value();
  Result<std::vector<LightShadow>> shadows = lightShadowsOf(*o.file);
  if (!shadows) {
    error = shadows.outcome().message();
    return {};
  }
  o.lights = std::move(shadows).value();
  return o;
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Restores the default lookup path when a test ends, whatever it set.
struct IsaLimit {
  ~IsaLimit() { setCellIsaLimit(CellIsa::Avx512); }
};

TEST(RuntimeAlone, EveryLookupPathAnswersAsOnePointAtATime) {
  ASSERT_FALSE(gCases.empty()) << "no FILE.cpvs POINTS.csv given";
  IsaLimit restore;
  uint64_t lit = 0, shadowed = 0, compared = 0;
  for (const Case& c : gCases) {
    std::string error;
    const Opened o = openAll(CpvsFile::open(c.file), error);
    ASSERT_TRUE(o.file) << c.file << ": " << error;
    const std::vector<SurfacePoint> points = readPoints(c.points);
    ASSERT_FALSE(points.empty()) << c.points << ": no points";
    for (const int k : {1, 3, 9}) {
      LookupOptions options;
      options.pcfKernel = k;
      for (size_t l = 0; l < o.lights.size(); ++l) {
        std::vector<float> single(points.size());
        for (size_t i = 0; i < points.size(); ++i)
          single[i] = o.lights[l].visibility(points[i].position, points[i].normal, options);
        if (k == 1)
          for (const float v : single) lit += v == 1.0f, shadowed += v == 0.0f;
        for (const CellIsa isa : {CellIsa::Scalar, CellIsa::Neon, CellIsa::Avx2, CellIsa::Avx512}) {
          setCellIsaLimit(isa);  // a path this CPU lacks runs the best one below it
          std::vector<float> batch(points.size());
          ASSERT_TRUE(o.lights[l].visibility(points, options, batch).ok());
          ASSERT_TRUE(sameBits(batch, single)) << c.file << ", light " << l << ", K = " << k << ", path "
                                               << int(isa) << " (best here: " << int(bestCellIsa()) << ")";
          compared += points.size();
        }
      }
    }
  }
  EXPECT_GT(lit, 0u);  // the comparison means something: both answers occur
  EXPECT_GT(shadowed, 0u);
  std::printf("%llu batch answers equal to the single-point answers\n", static_cast<unsigned long long>(compared));
}

// The vector paths map in single precision (AVX2, NEON) and map again in double what they cannot decide: on points
// whose biased grid position lies within 1e-7 to 1e-2 voxels of a voxel boundary (each found by solving for the
// point whose lookup lands there), in every view of every file given, every path's cells are the scalar path's.
TEST(RuntimeAlone, CellsNearVoxelBoundariesAreAlikeOnEveryPath) {
  ASSERT_FALSE(gCases.empty()) << "no FILE.cpvs POINTS.csv given";
  uint64_t compared = 0, remapped = 0, voxels = 0, made = 0;
  uint32_t state = 12345;
  const auto fraction = [&] {  // a small LCG: the same points on every platform
    state = state * 1664525u + 1013904223u;
    return double(state >> 8) / double(1u << 24);
  };
  for (const Case& c : gCases) {
    std::string error;
    const Opened o = openAll(CpvsFile::open(c.file), error);
    ASSERT_TRUE(o.file) << c.file << ": " << error;
    for (const CpvsFile::LightEntry& entry : o.file->lights()) {
      const Light& light = entry.light;
      const SpotInfluence spot = spotInfluence(light);
      for (const auto& stored : entry.views) {
        const LightView& view = stored.view;
        if (view.empty) continue;
        const ViewMapping mapping(view);
        for (const LookupOptions options : {LookupOptions{9, NormalOrientation::AsGiven, 0.25},
                                            LookupOptions{1, NormalOrientation::TowardLight, 0.5}}) {
          std::vector<SurfacePoint> points;
          const double n = view.resolution;
          for (int i = 0; i < 3000; ++i) {
            const double delta = std::pow(10.0, -7.0 + 5.0 * fraction()) * (fraction() < 0.5 ? -1 : 1);
            glm::dvec3 target(n * (0.05 + 0.9 * fraction()), n * (0.05 + 0.9 * fraction()), n * (0.05 + 0.9 * fraction()));
            target[i % 3] = std::floor(target[i % 3]) + delta;
            glm::dvec3 p = gridToWorld(view, target);
            const glm::dvec3 toward =
                light.type == LightType::Directional ? -light.direction : glm::normalize(light.position - p);
            const glm::dvec3 normal = toward + 0.6 * glm::dvec3(fraction() - 0.5, fraction() - 0.5, fraction() - 0.5);
            for (int step = 0; step < 3; ++step) {
              const LookupCell cell = lookupCell(mapping, p, normal, options);
              p = gridToWorld(view, target - (cell.uvs - toGrid(mapping, p).uvs));
            }
            points.push_back({p, normal});
          }
          CellBatchInput in;
          in.mapping = &mapping;
          in.settings = cellSettings(options);
          in.spot = light.type == LightType::Spot ? &spot : nullptr;
          in.points = {&points[0].position.x, 6, &points[0].normal.x, 6};
          in.count = points.size();
          const size_t count = points.size();
          std::vector<int32_t> x(count), y(count), z(count), x2(count), y2(count), z2(count);
          std::vector<uint8_t> cell(count), cell2(count);
          mapCells(in, {x.data(), y.data(), z.data(), cell.data()}, CellIsa::Scalar);
          for (const CellIsa isa : {CellIsa::Neon, CellIsa::Avx2, CellIsa::Avx512}) {
            CellBatchOutput out{x2.data(), y2.data(), z2.data(), cell2.data()};
            out.doubleRemapped = &remapped;
            mapCells(in, out, isa);  // a path this CPU lacks runs the best one below it
            for (size_t i = 0; i < count; ++i)
              ASSERT_TRUE(cell2[i] == cell[i] && x2[i] == x[i] && y2[i] == y[i] && z2[i] == z[i])
                  << c.file << ", light " << light.name << ", point " << i << ", path " << int(isa);
            compared += count;
          }
          for (const uint8_t s : cell) voxels += s == kCellVoxel;
          made += count;
        }
      }
    }
  }
  EXPECT_GT(voxels, made / 8);  // the points do reach voxels
  std::printf("%llu cells near voxel boundaries alike on every path (%llu mapped again in double)\n",
              static_cast<unsigned long long>(compared), static_cast<unsigned long long>(remapped));
}

// Truncated copies and copies with one bit flipped: each opens and answers, or fails as invalid input with a
// message naming the file; none crashes (a crash fails the whole program, so CTest sees it).
TEST(RuntimeAlone, DamagedCopiesFailWithAMessage) {
  ASSERT_FALSE(gCases.empty());
  uint64_t refused = 0, opened = 0;
  for (const Case& c : gCases) {
    const std::vector<uint8_t> bytes = readBytes(c.file);
    ASSERT_FALSE(bytes.empty()) << c.file;
    if (bytes.size() > (4u << 20)) continue;  // the small files are enough, and keep this fast under emulation
    std::vector<SurfacePoint> points = readPoints(c.points);
    points.resize(std::min<size_t>(points.size(), 64));
    uint64_t state = 0x9E3779B97F4A7C15ull ^ bytes.size();
    const auto next = [&] { return (state = state * 6364136223846793005ull + 1442695040888963407ull) >> 17; };
    for (int m = 0; m < 160; ++m) {
      std::vector<uint8_t> damaged = bytes;
      if (m < 40) damaged.resize(bytes.size() * size_t(m) / 40);  // truncated, from empty on
      else damaged[next() % bytes.size()] ^= uint8_t(1u << (next() % 8));
      std::string error;
      const Opened o = openAll(CpvsFile::fromBytes(damaged, "damaged.cpvs"), error);
      if (!o.file) {
        ++refused;
        EXPECT_NE(error.find("damaged.cpvs"), std::string::npos) << "mutation " << m << ": " << error;
        continue;
      }
      ++opened;  // a flip the format cannot see (padding, a name): the answers stay in [0, 1]
      for (const LightShadow& light : o.lights) {
        std::vector<float> out(points.size());
        if (!light.visibility(points, LookupOptions(), out).ok()) continue;
        for (const float v : out) EXPECT_TRUE(v >= 0.0f && v <= 1.0f);
      }
    }
  }
  EXPECT_GT(refused, 0u);
  std::printf("%llu damaged copies refused, %llu opened\n", static_cast<unsigned long long>(refused),
              static_cast<unsigned long long>(opened));
}

// packGpuScene's records, read back as the GPU reads them (each view's node base, leaf base, root code,
// resolution and child bases) and walked by dag_walk.glsl.h compiled as C++: the file's answers on every voxel
// of views up to 64^3, on 20,000 voxels of larger ones.
TEST(RuntimeAlone, GpuRecordsWalkAsTheFile) {
  using namespace gpu_layout;
  ASSERT_FALSE(gCases.empty());
  uint64_t voxels = 0;
  for (const Case& c : gCases) {
    std::string error;
    const Opened o = openAll(CpvsFile::open(c.file), error);
    ASSERT_TRUE(o.file) << c.file << ": " << error;
    const Result<GpuSceneRecords> packed = packGpuScene(o.lights);
    ASSERT_TRUE(packed.ok()) << packed.outcome().message();
    const GpuSceneRecords& r = packed.value();
    ASSERT_EQ(r.lightCount(), o.lights.size());
    const auto* units = reinterpret_cast<const uint16_t*>(r.nodes.data());
    const size_t unitCount = r.nodes.size() * 2;
    for (size_t l = 0; l < o.lights.size(); ++l) {
      const uint32_t* light = r.lightWords.data() + l * kLightWords;
      ASSERT_EQ(light[kLightViewCount], o.lights[l].views().size());
      for (size_t v = 0; v < o.lights[l].dags().size(); ++v) {
        const DagView& dag = o.lights[l].dags()[v];
        const uint32_t* view = r.viewWords.data() + (light[kLightFirstView] + v) * kViewWords;
        if (dag.resolution < 8 || dag.rootCode != ChildCode::Ref) {
          EXPECT_EQ(view[kViewRootCode], uint32_t(dag.rootCode));
          continue;
        }
        ASSERT_LE(view[kViewNodeBase], unitCount);
        ASSERT_LE(view[kViewLeafBase], r.leaves.size());
        DagView read;
        read.resolution = view[kViewResolution];
        read.rootCode = ChildCode(view[kViewRootCode]);
        read.nodes = std::span<const uint16_t>(units + view[kViewNodeBase], unitCount - view[kViewNodeBase]);
        read.leaves = std::span<const uint64_t>(r.leaves).subspan(view[kViewLeafBase]);
        for (uint32_t level = 0; level < kMaxDagLevels; ++level) read.childBase[level] = view[kViewChildBase + level];
        const gpu::DagWalk walk{read};
        const uint32_t n = dag.resolution;
        const uint64_t all = uint64_t(n) * n * n;
        const uint64_t count = all <= (uint64_t(1) << 18) ? all : 20000;
        uint64_t state = 12345 + v;
        for (uint64_t i = 0; i < count; ++i) {
          uint32_t x, y, z;
          if (count == all) {
            x = uint32_t(i % n), y = uint32_t((i / n) % n), z = uint32_t(i / (uint64_t(n) * n));
          } else {
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            x = uint32_t(state >> 20) % n, y = uint32_t(state >> 36) % n, z = uint32_t((state >> 50) * 977) % n;
          }
          ASSERT_EQ(walk.cpvsShadowed(x, y, z), dag.shadowed(x, y, z))
              << c.file << ", light " << l << ", view " << v << ", voxel " << x << "," << y << "," << z;
        }
        voxels += count;
      }
    }
  }
  std::printf("%llu voxels walked from the GPU records as in the file\n", static_cast<unsigned long long>(voxels));
}

}  // namespace
}  // namespace cpvs

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  for (int i = 1; i + 1 < argc; i += 2) cpvs::gCases.push_back({argv[i], argv[i + 1]});
  if (argc % 2 != 1) {
    std::fprintf(stderr, "usage: %s [GTEST OPTIONS] FILE.cpvs POINTS.csv [FILE.cpvs POINTS.csv ...]\n", argv[0]);
    return 1;
  }
  return RUN_ALL_TESTS();
}
