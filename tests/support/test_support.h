#pragma once
// Helpers shared by the tests: paths, small procedural scenes, running the tools.
#include <string>

#include <glm/glm.hpp>
#include <gtest/gtest.h>

#include "libcpvs/base/error.h"
#include "libcpvs/scene/scene.h"

// Runs `expr` (a bake, a sweep, a renderer): where OSMesa is missing the test is skipped, not failed.
#define SKIP_WITHOUT_OSMESA(expr)                                                                      \
  try {                                                                                                \
    expr;                                                                                              \
  } catch (const ::cpvs::Error& e) {                                                                   \
    if (e.category() == ::cpvs::ErrorCategory::NotSupported) GTEST_SKIP() << "no OSMesa here: " << e.what(); \
    throw;                                                                                             \
  }

namespace cpvs::test {

std::string sourcePath(const std::string& relative);  // inside the source tree (data/, tests/)
std::string toolPath(const std::string& tool);        // build/bin/<tool>
// A fresh directory for this test; removed when the test process ends if all its tests passed (kept, and
// named on stderr, when one failed or CPVS_KEEP_TEST_DIRS=1).
std::string tempDir();

// Appends an axis-aligned closed box (12 triangles, outward CCW) as a new mesh with one instance.
void addBox(Scene& scene, const std::string& name, const glm::dvec3& min, const glm::dvec3& max);
// Appends an open single-sided quad (2 triangles) with the given corners in CCW order.
void addQuad(Scene& scene, const std::string& name, const glm::dvec3& a, const glm::dvec3& b,
             const glm::dvec3& c, const glm::dvec3& d);
// Decides closedness of every mesh the way the importer does.
void classifyMeshes(Scene& scene);

// Lights for test scenes; directions are normalised.
Light sunLight(const std::string& name, const glm::dvec3& direction);
Light spotLight(const std::string& name, const glm::dvec3& position, const glm::dvec3& direction, double outerCone,
                double range);

Light pointLight(const std::string& name, const glm::dvec3& position, double range);
// A 10 x 10 ground square at y = 0 with a ridge triangle up to y = 2: a small world for the mapping tests.
WorldGeometry groundAndRidge();

struct ToolResult {
  int exitCode = -1;
  std::string output;  // stdout and stderr together
};
ToolResult runTool(const std::string& commandLine);

}  // namespace cpvs::test
