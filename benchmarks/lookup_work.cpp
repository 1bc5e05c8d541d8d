// lookup_work: the runtime's batch lookups repeated, with the runtime alone (as cpvs-lookup-example links it),
// so that the same program runs natively and cross-compiled under an emulator. Opens FILE.cpvs, reads surface
// points (X,Y,Z,NX,NY,NZ per line, a header line skipped), then answers every point for every light `repeat`
// times, each light's batch in turn (LightShadow::visibility, K x K PCF). Prints one line of JSON: lights,
// points, lookups (lights x points x repeat), the lookup ISA the batches used, the wall seconds of the lookups
// alone, and a checksum of the answers (the same on every path).
//
// benchmarks/arm64_lookup_work.py runs it under qemu-user with an instruction-counting plugin twice per case
// (repeat 1 and 3): the difference over the lookups it adds is the instructions per lookup, opening excluded.
//
//   lookup_work FILE.cpvs POINTS.csv [--pcf K] [--repeat R]        (CPVS_LOOKUP_ISA caps the path, as in the tools)
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/lookup_isa.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_shadows.h"

namespace {

const char* isaName(cpvs::CellIsa isa) {
  switch (isa) {
    case cpvs::CellIsa::Scalar: return "scalar";
    case cpvs::CellIsa::Neon: return "neon";
    case cpvs::CellIsa::Avx2: return "avx2";
    case cpvs::CellIsa::Avx512: return "avx512";
  }
  return "?";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s FILE.cpvs POINTS.csv [--pcf K] [--repeat R]\n", argv[0]);
    return 1;
  }
  cpvs::LookupOptions options;
  int repeat = 1;
  for (int i = 3; i < argc; i += 2) {
    if (i + 1 == argc) {
      std::fprintf(stderr, "%s: '%s' needs a value\n", argv[0], argv[i]);
      return 1;
    }
    if (!std::strcmp(argv[i], "--pcf")) options.pcfKernel = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "%s: unknown option '%s'\n", argv[0], argv[i]);
      return 1;
    }
  }
  if (const cpvs::Outcome kernel = cpvs::checkPcfKernel(options.pcfKernel); !kernel || repeat < 1) {
    std::fprintf(stderr, "%s: --pcf K must be odd in 1..63 and --repeat at least 1\n", argv[0]);
    return 1;
  }
  if (const cpvs::Outcome isa = cpvs::limitCellIsaFromEnvironment(); !isa) {
    std::fprintf(stderr, "%s: %s\n", argv[0], isa.message().c_str());
    return 1;
  }

  std::vector<cpvs::SurfacePoint> points;
  FILE* csv = std::fopen(argv[2], "r");
  if (!csv) {
    std::fprintf(stderr, "%s: %s: cannot open\n", argv[0], argv[2]);
    return 2;
  }
  char line[512];
  for (size_t row = 0; std::fgets(line, sizeof line, csv); ++row) {
    double v[6];
    if (std::sscanf(line, "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) == 6) {
      cpvs::SurfacePoint p;
      p.position = {v[0], v[1], v[2]};
      p.normal = {v[3], v[4], v[5]};
      points.push_back(p);
    } else if (row > 0) {
      std::fprintf(stderr, "%s: %s, line %zu: expected X,Y,Z,NX,NY,NZ\n", argv[0], argv[2], row + 1);
      std::fclose(csv);
      return 2;
    }
  }
  std::fclose(csv);

  const cpvs::Result<std::unique_ptr<cpvs::CpvsFile>> file = cpvs::CpvsFile::open(argv[1]);
  if (!file) {
    std::fprintf(stderr, "%s: %s\n", argv[0], file.outcome().message().c_str());
    return 2;
  }
  cpvs::Result<std::vector<cpvs::LightShadow>> shadows = cpvs::lightShadowsOf(*file.value());
  if (!shadows) {
    std::fprintf(stderr, "%s: %s\n", argv[0], shadows.outcome().message().c_str());
    return 2;
  }
  const std::vector<cpvs::LightShadow> lights = std::move(shadows).value();

  std::vector<float> answers(points.size());
  uint64_t checksum = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeat; ++r)
    for (const cpvs::LightShadow& light : lights) {
      if (const cpvs::Outcome done = light.visibility(points, options, answers); !done) {
        std::fprintf(stderr, "%s: %s\n", argv[0], done.message().c_str());
        return 1;
      }
      for (const float a : answers) {  // FNV-1a over the answers' bits
        uint32_t bits;
        std::memcpy(&bits, &a, 4);
        checksum = (checksum ^ bits) * 0x100000001b3ull;
      }
    }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("{\"lights\": %zu, \"points\": %zu, \"repeat\": %d, \"lookups\": %llu, \"pcf\": %d, \"isa\": \"%s\", "
              "\"seconds\": %.6f, \"checksum\": \"%016llx\"}\n",
              lights.size(), points.size(), repeat,
              static_cast<unsigned long long>(lights.size() * points.size() * size_t(repeat)), options.pcfKernel,
              isaName(cpvs::bestCellIsa()), seconds, static_cast<unsigned long long>(checksum));
  return 0;
}
