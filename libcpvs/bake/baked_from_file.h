#pragma once
// A light of an opened .cpvs as the writer takes it: what cpvs-merge and the bake cache read back and write
// again (the same content gives the same bytes).
#include "formats/cpvs/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"

namespace cpvs {

// Copies the light's record and every view's mapping and DAG (nodes, leaves, nodes per level).
BakedLight bakedLightOf(const CpvsFile::LightEntry& entry);

}  // namespace cpvs
