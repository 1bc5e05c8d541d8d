#pragma once
// The step every engine takes after opening a .cpvs: one LightShadow per light of the file.
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

// The LightShadow of one light of an open file (its views and DAGs referenced: the file must outlive it).
Result<LightShadow> lightShadowOf(const CpvsFile::LightEntry& entry, int topGridLevels = kAutomaticTopGrid);
// Every light's, in the file's order; the first light that fails fails the whole.
Result<std::vector<LightShadow>> lightShadowsOf(const CpvsFile& file, int topGridLevels = kAutomaticTopGrid);

}  // namespace cpvs
