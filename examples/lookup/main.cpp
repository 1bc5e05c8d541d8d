// cpvs-lookup-example: what an engine does with the runtime alone. Opens a .cpvs, builds one LightShadow per
// light and answers "how lit is this point?" for points given as x,y,z,nx,ny,nz on the command line, with an
// optional K x K PCF. Links cpvs_runtime only (GLM, xxHash and the standard library): no GL, Embree or glTF.
//
//   cpvs-lookup-example FILE.cpvs [--pcf K] [X,Y,Z,NX,NY,NZ ...]
//
// Without points on the command line, reads them from standard input, one X,Y,Z,NX,NY,NZ per line (a CSV
// header line is skipped). Prints one line per point: the point, then one visibility per light (1 lit, 0 shadowed). Exit codes: 0 ok,
// 1 usage, 2 the file cannot be read. CPVS_LOOKUP_ISA=scalar|neon|avx2|avx512 in the environment caps the
// batch lookups' instruction set, as in the tools (every path gives the same answers).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "libcpvs/runtime/lookup_isa.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_shadows.h"

namespace {

bool parsePoint(const char* text, cpvs::SurfacePoint& point) {
  double v[6];
  if (std::sscanf(text, "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) != 6) return false;
  point.position = {v[0], v[1], v[2]};
  point.normal = {v[3], v[4], v[5]};
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE.cpvs [--pcf K] [X,Y,Z,NX,NY,NZ ...]\n", argv[0]);
    return 1;
  }
  if (const cpvs::Outcome isa = cpvs::limitCellIsaFromEnvironment(); !isa) {
    std::fprintf(stderr, "%s: %s\n", argv[0], isa.message().c_str());
    return 1;
  }
  cpvs::LookupOptions options;
  std::vector<cpvs::SurfacePoint> points;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--pcf" && i + 1 < argc) {
      options.pcfKernel = std::atoi(argv[++i]);
      continue;
    }
    cpvs::SurfacePoint p;
    if (!parsePoint(argv[i], p)) {
      std::fprintf(stderr, "%s: '%s': expected X,Y,Z,NX,NY,NZ\n", argv[0], argv[i]);
      return 1;
    }
    points.push_back(p);
  }
  if (points.empty()) {
    char line[512];
    for (size_t row = 0; std::fgets(line, sizeof line, stdin); ++row) {
      cpvs::SurfacePoint p;
      if (parsePoint(line, p)) points.push_back(p);
      else if (row > 0) {
        std::fprintf(stderr, "%s: standard input, line %zu: expected X,Y,Z,NX,NY,NZ\n", argv[0], row + 1);
        return 1;
      }
    }
  }
  if (const cpvs::Outcome kernel = cpvs::checkPcfKernel(options.pcfKernel); !kernel) {
    std::fprintf(stderr, "%s: --pcf: %s\n", argv[0], kernel.message().c_str());
    return 1;
  }

  // Every runtime call reports failure as a value: no exceptions cross the API.
  const cpvs::Result<std::unique_ptr<cpvs::CpvsFile>> file = cpvs::CpvsFile::open(argv[1]);
  if (!file) {
    std::fprintf(stderr, "%s: %s\n", argv[0], file.outcome().message().c_str());
    return 2;
  }
  // The views and DAGs are referenced (spans into the file): `file` outlives `lights`.
  cpvs::Result<std::vector<cpvs::LightShadow>> shadows = cpvs::lightShadowsOf(*file.value());
  if (!shadows) {
    std::fprintf(stderr, "%s: %s\n", argv[0], shadows.outcome().message().c_str());
    return 2;
  }
  const std::vector<cpvs::LightShadow> lights = std::move(shadows).value();

  // One batch per light (the fast path); the per-point call gives the same answers.
  std::vector<std::vector<float>> visibility(lights.size(), std::vector<float>(points.size()));
  for (size_t l = 0; l < lights.size(); ++l)
    if (const cpvs::Outcome done = lights[l].visibility(points, options, visibility[l]); !done) {
      std::fprintf(stderr, "%s: %s\n", argv[0], done.message().c_str());
      return 1;
    }
  for (size_t i = 0; i < points.size(); ++i) {
    std::printf("%g,%g,%g", points[i].position.x, points[i].position.y, points[i].position.z);
    for (size_t l = 0; l < lights.size(); ++l) std::printf(" %s=%g", lights[l].light().name.c_str(), visibility[l][i]);
    std::printf("\n");
  }
  return 0;
}
