#pragma once
// cpvs-bake's options and one bake with them: what the command line runs, and what the Python module's
// cpvs.bake runs from the same options (python/), so that both give the same bytes and the same report.
#include <algorithm>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "libcpvs/bake/bake.h"
#include "libcpvs/import/gltf_import.h"
#include "tools/common/bake_options.h"
#include "tools/common/cli.h"

namespace cpvs::tools {

struct BakeCommand {
  std::string scene;
  std::string output;
  BakeShapeOptions shape;
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::string backend = "cpu";
  std::string report;
  std::string dumpDepth;
  bool quiet = false;
  std::string lightList;
  std::string shard;
  std::string cache, cacheMaxSize;
  bool watch = false;
  LightOptions lights;
  ImportOptions import;

  // Defines cpvs-bake's options on `app`, into this.
  void addTo(CLI::App& app);
  // The settings the options give. Throws Error(InvalidArgument) naming the flag.
  BakeSettings settings() const;
};

// What one bake did: the files its import read (what --watch watches) and its report (what --report writes).
struct BakeOutcome {
  std::vector<std::string> files;
  nlohmann::json report;
};

// One bake of the scene with the options: outputs opened first (a path that cannot be written fails before the
// work), written atomically once everything is done. `progress`, when given, is called with the fraction done
// from the bake's threads; an exception it throws stops the bake, and leaves no output and no cache entry.
BakeOutcome bakeOnce(const BakeCommand& o, BakeSettings settings, const std::string& usage,
                     const std::function<void(double)>& progress = {});

}  // namespace cpvs::tools
