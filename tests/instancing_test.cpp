// EXT_mesh_gpu_instancing: a level whose instances come as per-node instance attributes (cpvs-scenegen
// --gpu-instancing, the way gltfpack -mi and gltf-transform's instance ship trees and lamp posts) must bake the
// same shadows, byte for byte in every DAG section, as the same level written one node per instance.
#include <gtest/gtest.h>

#include <algorithm>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::runTool;
using test::tempDir;
using test::toolPath;

std::string generate(const std::string& dir, const std::string& kind, const std::string& extra) {
  const std::string path = dir + "/" + kind + (extra.empty() ? "" : "-instanced") + ".glb";
  const std::string lights = kind == "city-spots" ? " --lights 4" : "";
  const test::ToolResult r = runTool(toolPath("cpvs-scenegen") + " " + kind + " --triangles 20000" + lights + " -o " + path + extra);
  if (r.exitCode != 0) throw std::runtime_error("cpvs-scenegen failed: " + r.output);
  return path;
}

TEST(GpuInstancing, TheInstancedCityHasEveryInstanceAndTriangle) {
  const std::string dir = tempDir();
  const Scene plain = importGltf(generate(dir, "city-spots", ""));
  const Scene instanced = importGltf(generate(dir, "city-spots", " --gpu-instancing"));
  EXPECT_EQ(instanced.instances.size(), plain.instances.size());
  EXPECT_EQ(flatten(instanced).triangleCount(), flatten(plain).triangleCount());
  EXPECT_EQ(instanced.lights.size(), plain.lights.size());
}

void expectSameDags(const std::string& kind) {
  const std::string dir = tempDir();
  std::vector<std::unique_ptr<CpvsFile>> files;
  for (const std::string extra : {"", " --gpu-instancing"}) {
    const std::string scene = generate(dir, kind, extra);
    const std::string out = scene + ".cpvs";
    const test::ToolResult r = runTool(toolPath("cpvs-bake") + " " + scene + " -o " + out + " -r 1k --quiet");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    files.push_back(orThrow(CpvsFile::open(out)));
  }
  const CpvsFile &plain = *files[0], &instanced = *files[1];
  ASSERT_EQ(plain.lights().size(), instanced.lights().size());
  size_t views = 0;
  for (size_t l = 0; l < plain.lights().size(); ++l) {
    ASSERT_EQ(plain.lights()[l].views.size(), instanced.lights()[l].views.size());
    for (size_t v = 0; v < plain.lights()[l].views.size(); ++v) {
      const CpvsFile::View& a = plain.lights()[l].views[v];
      const CpvsFile::View& b = instanced.lights()[l].views[v];
      EXPECT_EQ(a.nodesPerLevel, b.nodesPerLevel) << "light " << l << " view " << v;
      EXPECT_TRUE(std::ranges::equal(a.dag.nodes, b.dag.nodes)) << "light " << l << " view " << v;
      EXPECT_TRUE(std::ranges::equal(a.dag.leaves, b.dag.leaves)) << "light " << l << " view " << v;
      ++views;
    }
  }
  EXPECT_GE(views, 1u);
}

TEST(GpuInstancing, TheInstancedCityBakesTheSameDagsByteForByte) { expectSameDags("city"); }

TEST(GpuInstancing, TheInstancedCitySpotsBakeTheSameDagsByteForByte) { expectSameDags("city-spots"); }

}  // namespace
}  // namespace cpvs
