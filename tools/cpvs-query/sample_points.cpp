// cpvs-sample-points: query points on a scene's surfaces, for cpvs-query benchmarks and accuracy runs
// (docs/query.md). Area-weighted triangles, uniform barycentric coordinates, the triangle's geometric normal
// (CCW front, closed solids facing out), a fixed seed: the same command writes the same bytes. Points inside a
// closed solid (Embree parity count from just off the surface) are left out: nothing can see them, and the
// baker may answer either way there (free voxels).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <CLI/CLI.hpp>

#include "formats/gltf/gltf_import.h"
#include "libcpvs/reference/embree_scene.h"
#include "tools/common/cli.h"

namespace {

using namespace cpvs;

struct Options {
  std::string scene, output;
  uint64_t count = 100000;
  uint64_t seed = 1;
  bool shuffle = true;
  std::vector<std::string> excludedMeshes;
};

int run(const Options& options) {
  if (options.count == 0) throw Error(ExitCode::Usage, "--count must be at least 1");
  Scene scene = importGltf(options.scene);
  if (!options.excludedMeshes.empty()) excludeMeshes(scene, options.excludedMeshes);
  const WorldGeometry world = flatten(scene);
  std::vector<double> cdf;
  cdf.reserve(world.triangleCount());
  double total = 0;
  for (size_t t = 0; t < world.triangleCount(); ++t) {
    const glm::dvec3 a = world.positions[world.indices[3 * t]], b = world.positions[world.indices[3 * t + 1]],
                     c = world.positions[world.indices[3 * t + 2]];
    total += 0.5 * glm::length(glm::cross(b - a, c - a));
    cdf.push_back(total);
  }
  if (!(total > 0)) throw Error(ExitCode::InputInvalid, options.scene + ": no triangle with an area to sample");
  const EmbreeScene rt(world);
  const double epsilon = 1e-6 * glm::length(world.bounds.extent());
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<std::pair<glm::dvec3, glm::dvec3>> points;
  uint64_t inside = 0;
  while (points.size() < options.count) {
    const size_t t = size_t(std::lower_bound(cdf.begin(), cdf.end(), uniform(rng) * total) - cdf.begin());
    if (t >= world.triangleCount()) continue;
    const glm::dvec3 a = world.positions[world.indices[3 * t]], b = world.positions[world.indices[3 * t + 1]],
                     c = world.positions[world.indices[3 * t + 2]];
    const double r1 = std::sqrt(uniform(rng)), r2 = uniform(rng);
    const glm::dvec3 p = (1 - r1) * a + r1 * (1 - r2) * b + r1 * r2 * c;
    const glm::dvec3 n = glm::cross(b - a, c - a);
    if (!(glm::length(n) > 0)) continue;
    const glm::dvec3 unit = glm::normalize(n);
    if (rt.isInsideClosedSolid(p + epsilon * unit)) {
      ++inside;
      if (inside > 100 * options.count) throw Error(ExitCode::InputInvalid, options.scene + ": almost every surface point lies inside a closed solid");
      continue;
    }
    points.emplace_back(p, unit);
  }
  if (!options.shuffle)  // spatially coherent order: by triangle, as a mesh walk would give them
    std::stable_sort(points.begin(), points.end(), [](const auto& x, const auto& y) {
      return x.first.x < y.first.x || (x.first.x == y.first.x && x.first.z < y.first.z);
    });
  std::string out = "x,y,z,nx,ny,nz\n";
  char line[256];
  for (const auto& [p, n] : points) {
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%.9g,%.9g,%.9g\n", p.x, p.y, p.z, n.x, n.y, n.z);
    out += line;
  }
  tools::writeFileAtomically(options.output, out);
  std::fprintf(stderr, "cpvs-sample-points: %llu points on %zu triangles (%llu inside closed solids left out) -> %s\n",
               static_cast<unsigned long long>(points.size()), world.triangleCount(),
               static_cast<unsigned long long>(inside), options.output.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{"cpvs-sample-points: points on a glTF scene's surfaces with their normals, as a cpvs-query CSV "
               "(area-weighted, fixed seed, points inside closed solids left out).\nManual: docs/query.md",
               "cpvs-sample-points"};
  app.add_option("scene", options.scene, "Scene (.gltf or .glb)")->required()->type_name("SCENE");
  app.add_option("-o,--output", options.output, "CSV to write (x,y,z,nx,ny,nz)")->required()->type_name("OUT.csv");
  app.add_option("-n,--count", options.count, "Number of points")->capture_default_str();
  app.add_option("--seed", options.seed, "Random seed")->capture_default_str();
  app.add_flag("!--sorted", options.shuffle, "Write the points sorted by x, z (coherent) instead of in random order");
  app.add_option("--exclude-mesh", options.excludedMeshes, "Drop a mesh (repeatable)")->type_name("NAME");
  tools::addVersionFlag(app, "cpvs-sample-points");
  app.footer(tools::exitCodeHelp());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : int(ExitCode::Usage);
  }
  return tools::runMain("cpvs-sample-points", [&] { return run(options); });
}
