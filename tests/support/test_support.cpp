#include "support/test_support.h"

#include <array>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <vector>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "libcpvs/runtime/lookup_isa.h"
#include "libcpvs/scene/mesh_topology.h"

namespace cpvs::test {

std::string sourcePath(const std::string& relative) { return std::string(CPVS_SOURCE_DIR) + "/" + relative; }

std::string toolPath(const std::string& tool) { return std::string(CPVS_BINARY_DIR) + "/bin/" + tool; }

namespace {
// CPVS_LOOKUP_ISA caps the batch lookups in the tests as it does in the tools (CTest runs the lookup tests a
// second time with avx2, so the scalar walks are tested on AVX-512 machines too).
const bool gLookupIsaFromEnvironment = [] {
  orThrow(limitCellIsaFromEnvironment());
  return true;
}();

// The folders tempDir made in this process. They are removed when the process ends if every test in it passed,
// and kept (and named on stderr) when one failed, or when CPVS_KEEP_TEST_DIRS=1, to look into.
class TempDirs {
public:
  void add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mutex_);
    dirs_.push_back(dir);
  }
  ~TempDirs() {
    const char* keep = std::getenv("CPVS_KEEP_TEST_DIRS");
    const bool failed = ::testing::UnitTest::GetInstance()->Failed();
    if (failed || (keep && std::string(keep) == "1")) {
      for (const auto& dir : dirs_) std::fprintf(stderr, "kept test folder %s\n", dir.c_str());
      return;
    }
    std::error_code ec;
    for (const auto& dir : dirs_) std::filesystem::remove_all(dir, ec);
  }

private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};
}  // namespace

std::string tempDir() {
  // Constructed after gtest's UnitTest singleton (first use is inside a test), so destroyed before it.
  static TempDirs made;
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "cpvs";
  for (char& c : name)
    if (c == '/') c = '_';
  const auto dir = std::filesystem::temp_directory_path() /
                   ("cpvs-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  made.add(dir);
  return dir.string();
}

void addBox(Scene& scene, const std::string& name, const glm::dvec3& lo, const glm::dvec3& hi) {
  Mesh mesh;
  mesh.name = name;
  for (int i = 0; i < 8; ++i)
    mesh.positions.push_back(glm::vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
  // Each face as two CCW triangles seen from outside.
  const uint32_t faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& f : faces) mesh.indices.insert(mesh.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  scene.meshes.push_back(mesh);
  scene.instances.push_back({uint32_t(scene.meshes.size() - 1), glm::dmat4(1.0), name});
}

void addQuad(Scene& scene, const std::string& name, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
             const glm::dvec3& d) {
  Mesh mesh;
  mesh.name = name;
  mesh.positions = {glm::vec3(a), glm::vec3(b), glm::vec3(c), glm::vec3(d)};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  scene.meshes.push_back(mesh);
  scene.instances.push_back({uint32_t(scene.meshes.size() - 1), glm::dmat4(1.0), name});
}

Light sunLight(const std::string& name, const glm::dvec3& direction) {
  Light sun;
  sun.name = name;
  sun.type = LightType::Directional;
  sun.direction = glm::normalize(direction);
  return sun;
}

Light spotLight(const std::string& name, const glm::dvec3& position, const glm::dvec3& direction, double outerCone,
                double range) {
  Light spot;
  spot.name = name;
  spot.type = LightType::Spot;
  spot.position = position;
  spot.direction = glm::normalize(direction);
  spot.outerConeAngle = outerCone;
  spot.range = range;
  return spot;
}

Light pointLight(const std::string& name, const glm::dvec3& position, double range) {
  Light point;
  point.name = name;
  point.type = LightType::Point;
  point.position = position;
  point.range = range;
  return point;
}

WorldGeometry groundAndRidge() {
  WorldGeometry world;
  world.positions = {{-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}, {0, 2, 0}};
  world.indices = {0, 1, 2, 0, 2, 3, 0, 1, 4};
  for (const auto& p : world.positions) world.bounds.extend(p);
  return world;
}

void classifyMeshes(Scene& scene) {
  for (Mesh& mesh : scene.meshes) classifyMesh(mesh);
}

ToolResult runTool(const std::string& commandLine) {
  ToolResult result;
  FILE* pipe = ::popen((commandLine + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return result;
}

}  // namespace cpvs::test
