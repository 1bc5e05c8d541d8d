// libFuzzer target: the query-point readers. The first byte picks the format (CSV, PLY, or an EXR G-buffer),
// the rest is the file. Any input must give points or an Error.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "libcpvs/io/gbuffer.h"
#include "libcpvs/io/points.h"
#include "libcpvs/base/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const std::string folder = [] {
    char pattern[] = "/tmp/cpvs-fuzz-points-XXXXXX";
    const char* made = ::mkdtemp(pattern);
    if (!made) std::abort();
    return std::string(made);
  }();
  static const char* const kNames[] = {"/points.csv", "/points.ply", "/gbuffer.exr"};
  const std::string path = folder + kNames[data[0] % 3];
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 1) std::fwrite(data + 1, 1, size - 1, f);
  std::fclose(f);
  try {
    if (data[0] % 3 == 2) {
      uint32_t width = 0, height = 0;
      bool normals = false;
      (void)cpvs::readGBuffer(path, "", width, height, normals);
    } else {
      auto reader = cpvs::PointReader::open(path);
      std::vector<cpvs::QueryPoint> chunk;
      while (reader->next(chunk, 4096)) {
      }
    }
  } catch (const cpvs::Error&) {
  }
  return 0;
}
