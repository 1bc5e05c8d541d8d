// cpvs-bake: scene (glTF) -> one .cpvs with a shadow DAG per light view (docs/architecture.md, §4).
#include <cstdio>

#include "libcpvs/bake/bake.h"
#include "tools/common/cli.h"
#include "tools/common/file_watch.h"
#include "tools/cpvs-bake/bake_command.h"

namespace {

using namespace cpvs;

// --watch: bakes, then again whenever the scene or a file it read changes (tools/common/file_watch.h), until
// Ctrl-C. A bake that fails says why and leaves the previous output as it was (every output is atomic).
[[noreturn]] void watchAndBake(const tools::BakeCommand& o, const BakeSettings& settings, const std::string& usage) {
  std::vector<std::string> files{o.scene};
  for (;;) {
    const tools::FileStamps before = tools::stampsOf(files);
    try {
      files = tools::bakeOnce(o, settings, usage).files;
    } catch (const Error& e) {
      std::fprintf(stderr, "cpvs-bake: error: %s\n", e.what());
      if (!o.output.empty())
        std::fprintf(stderr, "cpvs-bake: %s stays as it was\n", o.output.c_str());
    }
    // A save during the bake counts: the files are compared with what they were when it started (unless the
    // scene now reads other files).
    const tools::FileStamps since = files.size() == before.size() ? before : tools::stampsOf(files);
    if (!o.quiet && tools::stampsOf(files) == since)
      std::fprintf(stderr, "cpvs-bake: watching %s%s for changes (Ctrl-C stops)\n", o.scene.c_str(),
                   files.size() > 1 ? (" and the " + std::to_string(files.size() - 1) + " file(s) it reads").c_str() : "");
    tools::waitForChange(files, since);
    if (!o.quiet) std::fprintf(stderr, "cpvs-bake: %s changed: baking again\n", o.scene.c_str());
  }
}

int run(int argc, char** argv) {
  tools::BakeCommand o;
  CLI::App app{"cpvs-bake: bake Compact Precomputed Voxelized Shadows for every light of a glTF scene.\n"
               "Lights come from the scene (KHR_lights_punctual) unless given with --sun/--spot/--point."};
  tools::addStandardFlags(app, "cpvs-bake");
  o.addTo(app);
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;
  const BakeSettings settings = o.settings();
  const std::string usage = tools::positionalUsage(app) + " -o OUT.cpvs";
  if (!o.watch) {
    tools::bakeOnce(o, settings, usage);
    return 0;
  }
  watchAndBake(o, settings, usage);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runMain("cpvs-bake", [&] { return run(argc, argv); });
}
