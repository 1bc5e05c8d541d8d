// cpvs-sample: area-weighted surface points with normals from a glTF scene, as a CSV that cpvs-query reads.
#include <cstdio>
#include <string>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/scene/surface_samples.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"

namespace {

using namespace cpvs;

int run(int argc, char** argv) {
  std::string scenePath, output;
  size_t count = 100000;
  uint64_t seed = 1;
  tools::LightOptions options;  // only --exclude-mesh is meaningful here
  ImportOptions import;
  CLI::App app{"cpvs-sample: writes random points on the surfaces of a glTF scene (area-weighted, with the\n"
               "triangle's outward normal) as CSV x,y,z,nx,ny,nz, the input of cpvs-query --points.\n"
               "The same scene, count and seed give the same file on every machine."};
  tools::addStandardFlags(app, "cpvs-sample");
  app.add_option("scene", scenePath, "Input scene (.gltf or .glb)")->required()->type_name("SCENE");
  app.add_option("-o,--output", output, "Output .csv (written atomically)")->required();
  app.add_option("-n,--count", count, "Number of points")->capture_default_str()->check(CLI::Range(1, 100000000));
  app.add_option("--seed", seed, "Random seed")->capture_default_str();
  app.add_option("--exclude-mesh", options.excludedMeshes, "Drop a mesh by name (repeatable), e.g. a skybox");
  tools::addImportOptions(app, import);
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;
  tools::expectScene(scenePath, tools::positionalUsage(app) + " -o POINTS.csv");
  Scene scene = importGltf(scenePath, import);
  options.applyTo(scene);
  const WorldGeometry world = flatten(scene);
  const std::vector<SurfaceSample> samples = sampleSurfaces(world, count, seed);
  if (samples.empty()) throw Error(ErrorCategory::InvalidInput, scenePath + ": the scene has no surface area to sample");
  std::string text = "x,y,z,nx,ny,nz\n";
  text.reserve(samples.size() * 96);
  char line[256];
  for (const SurfaceSample& s : samples) {
    // 17 significant digits: the points read back bit for bit.
    const int n = std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%.9g,%.9g,%.9g\n", s.position.x, s.position.y,
                                s.position.z, s.normal.x, s.normal.y, s.normal.z);
    text.append(line, size_t(n));
  }
  tools::writeFileAtomically(output, text);
  std::fprintf(stderr, "cpvs-sample: %zu points on %zu triangles -> %s\n", samples.size(), world.sceneTriangleCount(),
               output.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runMain("cpvs-sample", [&] { return run(argc, argv); });
}
