#pragma once
// Joining the parts of a split bake (cpvs-bake --lights / --shard) into the file one run would have written,
// byte for byte (docs/many-lights.md, "Splitting a bake").
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"

namespace cpvs {

struct NamedPart {
  std::string name;  // for messages (the file's path)
  const CpvsFile* file = nullptr;
};

// The content of the whole bake. Every part must come from the same scene, settings and tool version (the same
// settings block apart from its "part" key), the parts' lights must not overlap, and together they must hold
// every light of the scene. Throws Error(InvalidInput) naming the file and what differs or is missing.
CpvsContent mergeParts(const std::vector<NamedPart>& parts);

}  // namespace cpvs
