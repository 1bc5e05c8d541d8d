// libFuzzer target: glTF import (JSON and GLB, told apart by the magic as the importer does). The input is
// written to a scene file in a private folder (importGltf reads a path); any input must give a Scene or an
// Error, never a crash, a hang or a read outside that folder.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/base/error.h"

namespace {

const std::string& sceneFolder() {
  static const std::string folder = [] {
    char pattern[] = "/tmp/cpvs-fuzz-gltf-XXXXXX";
    const char* made = ::mkdtemp(pattern);
    if (!made) std::abort();
    return std::string(made);
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = sceneFolder() + "/scene.gltf";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size) std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    const cpvs::Scene scene = cpvs::importGltf(path);
    (void)cpvs::flatten(scene);
  } catch (const cpvs::Error&) {
  }
  // cpvs-view's import, which also decodes base-colour images (data URIs and embedded ones in the input).
  try {
    cpvs::ImportOptions options;
    options.loadBaseColorTextures = true;
    (void)cpvs::importGltf(path, options);
  } catch (const cpvs::Error&) {
  }
  return 0;
}
