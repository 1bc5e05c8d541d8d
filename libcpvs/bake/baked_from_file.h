#pragma once
// A light of an opened .cpvs as the writer takes it: what cpvs-merge and the bake cache read back and write
// again (the same content gives the same bytes); and whether a file was baked from a given scene.
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

// Copies the light's record and every view's mapping and DAG (nodes, leaves, nodes per level: CpvsFile::ownDag,
// which takes a 3.x view's own nodes out of the pool). Fails as ownDag does.
Result<BakedLight> bakedLightOf(const CpvsFile& file, const CpvsFile::LightEntry& entry);

}  // namespace cpvs

namespace cpvs {

// Whether a .cpvs was baked from a scene: the input hash the file records against the one the scene gives
// with the file's own settings (its BAKE block) and lights. A file without a recorded hash, or a part of a
// split bake (which holds only some of the scene's lights), cannot be checked: `checked` is false and
// `reason` says why.
struct BakedFromCheck {
  bool checked = false;
  bool matches = false;
  uint64_t recordedHash = 0, sceneHash = 0;
  std::string reason;
};
BakedFromCheck checkBakedFrom(const Scene& scene, const CpvsFile& file);

}  // namespace cpvs
