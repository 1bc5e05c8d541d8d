#pragma once
// Serialising a bake into a .cpvs (the byte-level spec: docs/format.md).
#include <string>
#include <vector>

#include "formats/cpvs/cpvs_format.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// What the baker hands to the writer.
struct BakedView {
  LightView view;
  // dag.resolution must equal view.resolution (or be 0 for an all-lit / all-shadowed DAG with no nodes);
  // dag.nodesPerLevel has one count per level (log2(N) - 2 of them), or is empty when there are no nodes.
  ShadowDag dag;
};
struct BakedLight {
  Light light;
  std::vector<BakedView> views;
};
struct CpvsContent {
  std::vector<BakedLight> lights;
  std::string settingsJson;  // bake-settings block: resolution, modes, tool version, input content hash
};

// Serialises deterministically (same content, same bytes). The result is validated as a reader would before
// it is returned: content that would not read back (a malformed DAG, a non-finite view parameter, a
// resolution that is not a power of two) throws Error(RuntimeFailure) naming the light and view.
std::string writeCpvs(const CpvsContent& content);

}  // namespace cpvs
