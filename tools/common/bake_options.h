#pragma once
// The command-line options that shape a bake's bytes (resolution, voxel size, modes, peeling, regions, ground
// sheets), shared by cpvs-bake and by cpvs-info, which prints the input hash a bake with them would have.
#include <string>

#include <CLI/CLI.hpp>

#include "libcpvs/bake/bake.h"

namespace cpvs::tools {

struct BakeShapeOptions {
  std::string resolution = "4k";
  double voxelSize = 0;
  std::string undefinedMode = "kampe";
  bool noNodeReuse = false;
  bool perTexel = false;
  bool noConeCrop = false;
  std::string regionSize = "1k";
  uint32_t maxPeels = 2;
  std::string maxMemory;  // empty: defaultMemoryBudget(); "none": no budget
  std::string ground = "auto";
  int64_t maxVoxelError = -1;  // -1: lossless
  int64_t maxEdgeError = 0;
  uint32_t formatVersion = kCpvsDefaultMajor;

  void addTo(CLI::App& app);
  // Sets those fields of `settings`. Throws Error(InvalidArgument) naming the flag.
  void applyTo(BakeSettings& settings) const;
};

}  // namespace cpvs::tools
