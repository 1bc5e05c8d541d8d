// Ground sheets (libcpvs/scene/ground_sheet.h): which open meshes are taken as the top of solid ground, and what
// closing them adds to the world geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/mesh_topology.h"
#include "libcpvs/scene/scene.h"
#include "libcpvs/scene/surface_samples.h"
#include "libcpvs/views/view_fitting.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using Height = std::function<double(double, double)>;

// An n x n grid of quads over [x0, x1] x [z0, z1] at heights h(x, z), facing +y (or -y when `down`), with the
// cells for which `skip(i, j)` holds left out.
void addSheet(Scene& scene, const std::string& name, double x0, double z0, double x1, double z1, int n,
              const Height& h, bool down = false, const std::function<bool(int, int)>& skip = {}) {
  Mesh mesh;
  mesh.name = name;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = x0 + (x1 - x0) * i / n, z = z0 + (z1 - z0) * j / n;
      mesh.positions.push_back(glm::vec3(float(x), float(h(x, z)), float(z)));
    }
  auto at = [&](int i, int j) { return uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (skip && skip(i, j)) continue;
      // (i, j+1) -> (i+1, j+1) -> (i+1, j) runs counter-clockwise seen from +y.
      const uint32_t a = at(i, j + 1), b = at(i + 1, j + 1), c = at(i + 1, j), d = at(i, j);
      if (down)
        mesh.indices.insert(mesh.indices.end(), {a, c, b, a, d, c});
      else
        mesh.indices.insert(mesh.indices.end(), {a, b, c, a, c, d});
    }
  scene.meshes.push_back(mesh);
  scene.instances.push_back({uint32_t(scene.meshes.size() - 1), glm::dmat4(1.0), name});
}

double hills(double x, double z) { return 0.8 * std::sin(0.7 * x) * std::cos(0.5 * z) + 1.0; }

// The closed range of the world from the first ground triangle on, as one mesh: it must be a closed solid
// that faces out.
Mesh groundSolid(const WorldGeometry& world) {
  Mesh mesh;
  mesh.name = "ground solid";
  for (size_t t = world.groundBegin; t < world.closingEnd; ++t)
    for (int k = 0; k < 3; ++k) {
      mesh.indices.push_back(uint32_t(mesh.positions.size()));
      mesh.positions.push_back(glm::vec3(world.positions[world.indices[3 * t + k]]));
    }
  classifyMesh(mesh);
  return mesh;
}

TEST(GroundSheet, HeightFieldSpanningTheSceneIsClosedIntoAnOutwardSolid) {
  Scene scene;
  test::addBox(scene, "crate", {-2, 3, -2}, {-1, 4, -1});
  addSheet(scene, "terrain", -10, -8, 10, 8, 24, hills);
  test::addQuad(scene, "awning", {1, 4, 2}, {4, 4, 2}, {4, 4, -1}, {1, 4, -1});
  test::classifyMeshes(scene);
  const WorldGeometry open = flatten(scene, GroundSheets::Off);
  const WorldGeometry world = flatten(scene);

  ASSERT_EQ(world.groundSheets.size(), 1u);  // the awning is a height field too, but spans nothing
  const GroundSheet& g = world.groundSheets[0];
  EXPECT_EQ(g.mesh, "terrain");
  EXPECT_TRUE(g.used) << g.reason;
  EXPECT_EQ(g.axis, 1);
  EXPECT_EQ(g.sign, 1);
  // Skirt: two triangles per boundary edge (4 x 24 of them), bottom: one.
  EXPECT_EQ(g.closingTriangles, 3u * 96u);

  EXPECT_EQ(world.groundBegin, 12u);  // the crate, then the sheet, then its closing, then the awning
  EXPECT_EQ(world.closingBegin, 12u + 2u * 24u * 24u);
  EXPECT_EQ(world.closingEnd - world.closingBegin, g.closingTriangles);
  EXPECT_EQ(world.closedTriangleCount, world.closingEnd);
  EXPECT_EQ(world.closedMeshTriangleCount(), 12u);
  EXPECT_EQ(world.sceneTriangleCount(), open.triangleCount());
  EXPECT_EQ(world.triangleCount(), open.triangleCount() + g.closingTriangles);
  EXPECT_EQ(world.bounds.min, open.bounds.min);  // the closing lies outside the scene's bounds
  EXPECT_EQ(world.bounds.max, open.bounds.max);

  const Mesh solid = groundSolid(world);
  EXPECT_TRUE(solid.closed) << solid.boundaryEdges << " boundary, " << solid.inconsistentEdges << " inconsistent";
  EXPECT_FALSE(solid.insideOut);
  // The bottom lies one scene diagonal under the scene.
  double lowest = INFINITY;
  for (size_t t = world.closingBegin; t < world.closingEnd; ++t)
    for (int k = 0; k < 3; ++k) lowest = std::min(lowest, world.positions[world.indices[3 * t + k]].y);
  EXPECT_NEAR(lowest, open.bounds.min.y - glm::length(open.bounds.extent()), 1e-9);
}

TEST(GroundSheet, ASheetFacingDownIsTheUndersideOfASolidAbove) {
  Scene scene;
  test::addBox(scene, "crate", {-2, -3, -2}, {-1, -2, -1});
  addSheet(scene, "ceiling", -5, -5, 5, 5, 6, [](double x, double) { return 0.1 * x; }, true);
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene);
  ASSERT_EQ(world.groundSheets.size(), 1u);
  EXPECT_TRUE(world.groundSheets[0].used) << world.groundSheets[0].reason;
  EXPECT_EQ(world.groundSheets[0].sign, -1);
  const Mesh solid = groundSolid(world);
  EXPECT_TRUE(solid.closed);
  EXPECT_FALSE(solid.insideOut);
  for (size_t t = world.closingBegin; t < world.closingEnd; ++t)
    for (int k = 0; k < 3; ++k) EXPECT_GE(world.positions[world.indices[3 * t + k]].y, -0.5 - 1e-6);
}

// What is not taken as ground: reported only when it is a height field spanning the scene.
TEST(GroundSheet, NotGroundWhenItHasAHoleDoesNotSpanTheSceneOrCoversBuriedGeometry) {
  auto decide = [](const std::function<void(Scene&)>& build) {
    Scene scene;
    build(scene);
    test::classifyMeshes(scene);
    return flatten(scene);
  };
  auto flat = [](double, double) { return 0.0; };

  // A hole (an interior cell left out): its outline is not its rectangle.
  WorldGeometry w = decide([&](Scene& s) { addSheet(s, "holed", -4, -4, 4, 4, 8, flat, false, [](int i, int j) { return i == 3 && j == 4; }); });
  EXPECT_TRUE(w.groundSheets.empty());
  EXPECT_EQ(w.closedTriangleCount, 0u);

  // Geometry beyond the sheet's rectangle: the ground does not reach the edge of the world.
  w = decide([&](Scene& s) {
    addSheet(s, "ground", -4, -4, 4, 4, 4, flat);
    test::addBox(s, "beyond", {3, 0, 3}, {5, 1, 5});
  });
  EXPECT_TRUE(w.groundSheets.empty());
  EXPECT_EQ(w.closedTriangleCount, 12u);

  // A basement under the ground: reported, not used, and the message names it.
  w = decide([&](Scene& s) {
    addSheet(s, "ground", -4, -4, 4, 4, 4, flat);
    test::addBox(s, "basement", {-1, -3, -1}, {1, -1, 1});
    test::addBox(s, "house", {-1, 0, -1}, {1, 2, 1});
  });
  ASSERT_EQ(w.groundSheets.size(), 1u);
  EXPECT_FALSE(w.groundSheets[0].used);
  EXPECT_NE(w.groundSheets[0].reason.find("'basement'"), std::string::npos) << w.groundSheets[0].reason;
  EXPECT_EQ(w.closedTriangleCount, 24u);
  EXPECT_EQ(w.closingEnd, w.closingBegin);

  // A post sunk a little (less than 1e-3 of the scene's diagonal) does not count as buried.
  w = decide([&](Scene& s) {
    addSheet(s, "ground", -4, -4, 4, 4, 4, flat);
    test::addBox(s, "post", {0, -0.005, 0}, {0.2, 3, 0.2});
  });
  ASSERT_EQ(w.groundSheets.size(), 1u);
  EXPECT_TRUE(w.groundSheets[0].used) << w.groundSheets[0].reason;

  // Off: nothing is examined or closed.
  Scene scene;
  addSheet(scene, "ground", -4, -4, 4, 4, 4, flat);
  test::classifyMeshes(scene);
  const WorldGeometry off = flatten(scene, GroundSheets::Off);
  EXPECT_TRUE(off.groundSheets.empty());
  EXPECT_EQ(off.closedTriangleCount, 0u);
  EXPECT_EQ(off.closingEnd, 0u);
}

TEST(GroundSheet, ClosingTrianglesAreNeverSampledNorFittedIntoAView) {
  Scene scene;
  test::addBox(scene, "crate", {-2, 3, -2}, {-1, 4, -1});
  addSheet(scene, "terrain", -10, -8, 10, 8, 16, hills);
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene), open = flatten(scene, GroundSheets::Off);
  ASSERT_GT(world.closingEnd, world.closingBegin);

  const std::vector<SurfaceSample> samples = sampleSurfaces(world, 20000, 7);
  ASSERT_EQ(samples.size(), 20000u);
  for (const SurfaceSample& s : samples) ASSERT_GE(s.position.y, open.bounds.min.y - 1e-9);

  Light sun;
  sun.type = LightType::Directional;
  sun.direction = glm::normalize(glm::dvec3(0.6, -0.5, 0.3));
  Light spot;
  spot.type = LightType::Spot;
  spot.position = {3, 9, 2};
  spot.direction = glm::normalize(glm::dvec3(-0.3, -1, -0.2));
  spot.outerConeAngle = 0.6;
  spot.range = 40;
  for (const Light& light : {sun, spot}) {
    const std::vector<LightView> a = makeLightViews(light, world, 1024), b = makeLightViews(light, open, 1024);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].viewFromWorld, b[i].viewFromWorld);
      EXPECT_EQ(a[i].xMin, b[i].xMin);
      EXPECT_EQ(a[i].xMax, b[i].xMax);
      EXPECT_EQ(a[i].yMin, b[i].yMin);
      EXPECT_EQ(a[i].yMax, b[i].yMax);
      EXPECT_EQ(a[i].near, b[i].near);
      EXPECT_EQ(a[i].far, b[i].far);
    }
  }
}

TEST(GroundSheet, ModeNames) {
  for (GroundSheets g : {GroundSheets::Auto, GroundSheets::Off}) EXPECT_EQ(parseGroundSheets(groundSheetsName(g)), g);
  EXPECT_STREQ(groundSheetsName(GroundSheets::Off), "off");
  EXPECT_THROW(parseGroundSheets("on"), Error);
}

TEST(GroundSheet, BundledScenes) {
  const Scene terrain = importGltf(test::sourcePath("data/scenes/Terrain/terrain.gltf"));
  const WorldGeometry t = flatten(terrain);
  ASSERT_EQ(t.groundSheets.size(), 1u);
  EXPECT_TRUE(t.groundSheets[0].used);
  EXPECT_EQ(t.groundSheets[0].closingTriangles, 3u * terrain.meshes[0].boundaryEdges);
  EXPECT_TRUE(groundSolid(t).closed);
  // Neither has a mesh that spans it as a height field.
  for (const char* path : {"data/scenes/TorusKnot/torusknot.gltf", "data/scenes/FlightHelmet/FlightHelmet.gltf"})
    EXPECT_TRUE(flatten(importGltf(test::sourcePath(path))).groundSheets.empty()) << path;
}

}  // namespace
}  // namespace cpvs
