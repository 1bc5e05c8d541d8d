// cpvs-merge: joins the parts of a split bake (cpvs-bake --lights / --shard) into the file one cpvs-bake run
// would have written, byte for byte (docs/many-lights.md).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/merge_parts.h"
#include "libcpvs/base/error.h"
#include "tools/common/atomic_file.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"

namespace {

using namespace cpvs;

int run(int argc, char** argv) {
  std::vector<std::string> inputs;
  std::string output;
  bool quiet = false;
  CLI::App app{"cpvs-merge: join the parts of a split bake (cpvs-bake --lights or --shard) into the .cpvs one run\n"
               "would write, byte for byte. Parts may be given in any order; together they must hold every light\n"
               "once, and all must come from the same scene, settings and cpvs-bake version."};
  tools::addStandardFlags(app, "cpvs-merge");
  app.add_option("parts", inputs, "Part files (.cpvs) written by cpvs-bake --lights / --shard")->required()->type_name("PART.cpvs");
  app.add_option("-o,--output", output, "The merged .cpvs (written atomically)")->required();
  app.add_flag("-q,--quiet", quiet, "No summary line");
  if (const auto done = tools::parseCommandLine(app, argc, argv)) return *done;

  tools::AtomicFile out(output);  // a path that cannot be written fails before the parts are read
  std::vector<std::unique_ptr<CpvsFile>> files;
  std::vector<NamedPart> parts;
  for (const std::string& path : inputs) {
    tools::expectCpvs(path, tools::positionalUsage(app) + " -o OUT.cpvs");
    files.push_back(orThrow(CpvsFile::open(path)));
    parts.push_back({path, files.back().get()});
  }
  // In the parts' format version (mergeParts checks they share it); 1.x parts, which no build writes, as 2.0.
  const uint16_t major = files.front()->majorVersion() >= 3 ? files.front()->majorVersion() : 2;
  const std::string bytes = writeCpvs(mergeParts(parts), major);
  out.write(bytes);
  out.commit();
  if (!quiet)
    std::fprintf(stderr, "cpvs-merge: %zu part(s) -> %s (%zu bytes)\n", inputs.size(), output.c_str(), bytes.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return cpvs::tools::runMain("cpvs-merge", [&] { return run(argc, argv); });
}
