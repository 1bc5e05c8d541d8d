// Scene import (glTF), closedness classification, flattening and mesh exclusion; cpvs-info end to end.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include "libcpvs/import/accessor_types.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/base/error.h"
#include "libcpvs/scene/mesh_topology.h"
#include "libcpvs/scene/scene.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using nlohmann::json;

constexpr int kByte = 5120, kUnsignedByte = 5121, kShort = 5122, kUnsignedShort = 5123, kUnsignedInt = 5125,
              kFloat = 5126;
const std::string kAssimpModels = "/usr/share/assimp/models/glTF2/";

// ---------------------------------------------------------------------------------------------------------
// Helpers

Mesh boxMesh(const glm::vec3& lo = glm::vec3(0.0f), const glm::vec3& hi = glm::vec3(1.0f)) {
  Scene scene;
  test::addBox(scene, "box", lo, hi);
  return scene.meshes[0];
}

void appendMesh(Mesh& to, const Mesh& from) {
  const uint32_t base = uint32_t(to.positions.size());
  to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
  for (uint32_t index : from.indices) to.indices.push_back(base + index);
}

// Six times the signed volume enclosed by triangles [first, last) (positive when they face outward).
double signedVolume(const WorldGeometry& world, size_t first, size_t last) {
  double sixVolume = 0.0;
  for (size_t t = first; t < last; ++t) {
    const glm::dvec3& a = world.positions[world.indices[3 * t]];
    const glm::dvec3& b = world.positions[world.indices[3 * t + 1]];
    const glm::dvec3& c = world.positions[world.indices[3 * t + 2]];
    sixVolume += glm::dot(a, glm::cross(b, c));
  }
  return sixVolume / 6.0;
}

glm::dvec3 triangleNormal(const WorldGeometry& world, size_t t) {
  const glm::dvec3& a = world.positions[world.indices[3 * t]];
  const glm::dvec3& b = world.positions[world.indices[3 * t + 1]];
  const glm::dvec3& c = world.positions[world.indices[3 * t + 2]];
  return glm::normalize(glm::cross(b - a, c - a));
}

const Mesh* findMesh(const Scene& scene, const std::string& name) {
  for (const Mesh& mesh : scene.meshes)
    if (mesh.name == name) return &mesh;
  return nullptr;
}

size_t worldTriangles(const Scene& scene) {
  size_t triangles = 0;
  for (const Instance& instance : scene.instances) triangles += scene.meshes[instance.mesh].triangleCount();
  return triangles;
}

void expectNear(const glm::dvec3& actual, const glm::dvec3& expected, double tolerance = 1e-6) {
  EXPECT_NEAR(actual.x, expected.x, tolerance);
  EXPECT_NEAR(actual.y, expected.y, tolerance);
  EXPECT_NEAR(actual.z, expected.z, tolerance);
}

// Expects importGltf(path) to fail with InputInvalid, a message naming the file and containing `detail`.
void expectInvalid(const std::string& path, const std::string& detail = "") {
  try {
    importGltf(path);
    ADD_FAILURE() << path << ": imported without an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
    const std::string message = e.what();
    EXPECT_NE(message.find(std::filesystem::path(path).filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find(detail), std::string::npos) << "expected '" << detail << "' in: " << message;
  }
}

// Builds small glTF files (JSON + external .bin) for the tests.
class GltfBuilder {
public:
  GltfBuilder() { gltf_ = {{"asset", {{"version", "2.0"}}}}; }

  int addView(const void* data, size_t bytes, size_t stride = 0) {
    while (buffer_.size() % 4) buffer_.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", buffer_.size()}, {"byteLength", bytes}};
    if (stride) view["byteStride"] = stride;
    const auto* begin = static_cast<const unsigned char*>(data);
    buffer_.insert(buffer_.end(), begin, begin + bytes);
    return push("bufferViews", view);
  }
  int addAccessor(json accessor) { return push("accessors", std::move(accessor)); }
  int addPositions(const std::vector<glm::vec3>& positions) {
    const int view = addView(positions.data(), positions.size() * sizeof(glm::vec3));
    return addAccessor({{"bufferView", view}, {"componentType", kFloat}, {"count", positions.size()}, {"type", "VEC3"}});
  }
  int addIndices(const std::vector<uint32_t>& indices, int componentType = kUnsignedInt) {
    std::vector<unsigned char> bytes;
    for (uint32_t index : indices) {
      const size_t size = componentType == kUnsignedByte ? 1 : componentType == kUnsignedShort ? 2 : 4;
      for (size_t b = 0; b < size; ++b) bytes.push_back((index >> (8 * b)) & 0xff);
    }
    const int view = addView(bytes.data(), bytes.size());
    return addAccessor({{"bufferView", view}, {"componentType", componentType}, {"count", indices.size()}, {"type", "SCALAR"}});
  }
  int addMesh(const std::string& name, json primitives) {
    return push("meshes", {{"name", name}, {"primitives", std::move(primitives)}});
  }
  int addNode(json node) { return push("nodes", std::move(node)); }
  json& root() { return gltf_; }

  // Writes <dir>/<name>.gltf and its .bin; a scene with every parentless node is added when there is none.
  std::string write(const std::string& dir, const std::string& name) {
    if (!gltf_.contains("scenes") && gltf_.contains("nodes")) {
      std::set<int> children;
      for (const json& node : gltf_["nodes"])
        if (node.contains("children"))
          for (const json& child : node["children"]) children.insert(child.get<int>());
      json roots = json::array();
      for (int i = 0; i < int(gltf_["nodes"].size()); ++i)
        if (!children.count(i)) roots.push_back(i);
      gltf_["scenes"] = json::array({{{"nodes", roots}}});
    }
    if (!buffer_.empty() && !gltf_.contains("buffers"))
      gltf_["buffers"] = json::array({{{"byteLength", buffer_.size()}, {"uri", name + ".bin"}}});
    std::ofstream(dir + "/" + name + ".bin", std::ios::binary)
        .write(reinterpret_cast<const char*>(buffer_.data()), std::streamsize(buffer_.size()));
    const std::string path = dir + "/" + name + ".gltf";
    std::ofstream(path) << gltf_.dump(1);
    return path;
  }

private:
  int push(const char* key, json value) {
    if (!gltf_.contains(key)) gltf_[key] = json::array();
    gltf_[key].push_back(std::move(value));
    return int(gltf_[key].size()) - 1;
  }
  json gltf_;
  std::vector<unsigned char> buffer_;
};

// A unit quad in z = 0, counter-clockwise seen from +Z.
const std::vector<glm::vec3> kQuad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

// A builder with one mesh "Quad" (indexed triangles) used by one node "QuadNode".
GltfBuilder quadScene() {
  GltfBuilder gltf;
  const int positions = gltf.addPositions(kQuad);
  const int indices = gltf.addIndices({0, 1, 2, 0, 2, 3});
  gltf.addMesh("Quad", json::array({{{"attributes", {{"POSITION", positions}}}, {"indices", indices}}}));
  gltf.addNode({{"name", "QuadNode"}, {"mesh", 0}});
  return gltf;
}

// ---------------------------------------------------------------------------------------------------------
// classifyMesh

TEST(ImportClassify, ClosedBox) {
  Mesh box = boxMesh();
  classifyMesh(box);
  EXPECT_TRUE(box.closed);
  EXPECT_FALSE(box.insideOut);
  EXPECT_EQ(box.boundaryEdges, 0u);
  EXPECT_EQ(box.nonManifoldEdges, 0u);
  EXPECT_EQ(box.inconsistentEdges, 0u);
}

TEST(ImportClassify, InsideOutBoxIsClosedAndFlagged) {
  Mesh box = boxMesh();
  for (size_t t = 0; t < box.indices.size(); t += 3) std::swap(box.indices[t + 1], box.indices[t + 2]);
  classifyMesh(box);
  EXPECT_TRUE(box.closed);
  EXPECT_TRUE(box.insideOut);
}

TEST(ImportClassify, OpenBoxHasBoundaryEdges) {
  Mesh box = boxMesh();
  box.indices.resize(box.indices.size() - 6);  // drop the last face
  classifyMesh(box);
  EXPECT_FALSE(box.closed);
  EXPECT_EQ(box.boundaryEdges, 4u);
  EXPECT_EQ(box.nonManifoldEdges, 0u);
  EXPECT_EQ(box.inconsistentEdges, 0u);
}

TEST(ImportClassify, FlippedTriangleIsInconsistent) {
  Mesh box = boxMesh();
  std::swap(box.indices[1], box.indices[2]);
  classifyMesh(box);
  EXPECT_FALSE(box.closed);
  EXPECT_EQ(box.inconsistentEdges, 3u);
  EXPECT_EQ(box.boundaryEdges, 0u);
  EXPECT_EQ(box.nonManifoldEdges, 0u);
}

TEST(ImportClassify, BoxesSharingAnEdgeAreNonManifold) {
  Mesh boxes = boxMesh({0, 0, 0}, {1, 1, 1});
  appendMesh(boxes, boxMesh({1, 1, 0}, {2, 2, 1}));  // touches the first along x = y = 1
  classifyMesh(boxes);
  EXPECT_FALSE(boxes.closed);
  EXPECT_EQ(boxes.nonManifoldEdges, 1u);
  EXPECT_EQ(boxes.boundaryEdges, 0u);
  EXPECT_EQ(boxes.inconsistentEdges, 0u);
}

TEST(ImportClassify, WeldsUnsharedCornersAndNegativeZero) {
  const Mesh shared = boxMesh({0, 0, 0}, {1, 1, 1});
  Mesh unshared;  // every triangle has its own corners, and some zeros are negative
  for (size_t i = 0; i < shared.indices.size(); ++i) {
    glm::vec3 p = shared.positions[shared.indices[i]];
    if (i % 2)
      for (int c = 0; c < 3; ++c)
        if (p[c] == 0.0f) p[c] = -0.0f;
    unshared.positions.push_back(p);
    unshared.indices.push_back(uint32_t(i));
  }
  classifyMesh(unshared);
  EXPECT_TRUE(unshared.closed);
  EXPECT_FALSE(unshared.insideOut);
}

TEST(ImportClassify, DegenerateTrianglesAreIgnored) {
  Mesh box = boxMesh();
  box.indices.insert(box.indices.end(), {0, 0, 1, 2, 5, 2});
  classifyMesh(box);
  EXPECT_TRUE(box.closed);

  Mesh onlyDegenerate;
  onlyDegenerate.positions = {{0, 0, 0}, {1, 0, 0}};
  onlyDegenerate.indices = {0, 1, 1};
  classifyMesh(onlyDegenerate);
  EXPECT_FALSE(onlyDegenerate.closed);
}

TEST(ImportClassify, LargeClosedTorusGrid) {
  // A torus as a 400 x 300 quad grid: 240,000 triangles, closed, every edge shared by two.
  const int major = 400, minor = 300;
  Mesh torus;
  for (int i = 0; i < major; ++i)
    for (int j = 0; j < minor; ++j) {
      const double u = 2 * M_PI * i / major, v = 2 * M_PI * j / minor;
      torus.positions.push_back(glm::vec3((3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v)));
    }
  auto at = [&](int i, int j) { return uint32_t((i % major) * minor + (j % minor)); };
  for (int i = 0; i < major; ++i)
    for (int j = 0; j < minor; ++j)
      torus.indices.insert(torus.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1),
                                                 at(i, j + 1)});
  classifyMesh(torus);
  EXPECT_TRUE(torus.closed);
  EXPECT_FALSE(torus.insideOut);
  torus.indices.resize(torus.indices.size() - 3);
  classifyMesh(torus);
  EXPECT_FALSE(torus.closed);
  EXPECT_EQ(torus.boundaryEdges, 3u);
}

// ---------------------------------------------------------------------------------------------------------
// flatten and excludeMeshes

TEST(ImportFlatten, InsideOutMeshFacesOutward) {
  Scene scene;
  test::addBox(scene, "box", {0, 0, 0}, {1, 1, 1});
  Mesh& box = scene.meshes[0];
  for (size_t t = 0; t < box.indices.size(); t += 3) std::swap(box.indices[t + 1], box.indices[t + 2]);
  test::classifyMeshes(scene);
  ASSERT_TRUE(box.insideOut);
  const WorldGeometry world = flatten(scene);
  EXPECT_EQ(world.closedTriangleCount, 12u);
  EXPECT_NEAR(signedVolume(world, 0, 12), 1.0, 1e-9);
}

TEST(ImportFlatten, ClosedTrianglesFirstAndMirroredOpenKeepsFront) {
  Scene scene;
  test::addQuad(scene, "ground", {0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0});  // front face +Y
  test::addBox(scene, "box", {0, 0, 0}, {1, 1, 1});
  scene.instances[0].worldFromLocal = glm::scale(glm::dmat4(1.0), glm::dvec3(-1, 1, 1));  // mirrored
  test::classifyMeshes(scene);
  const WorldGeometry world = flatten(scene);
  ASSERT_EQ(world.triangleCount(), 14u);
  EXPECT_EQ(world.closedTriangleCount, 12u);
  EXPECT_TRUE(world.isClosed(11));
  EXPECT_FALSE(world.isClosed(12));
  expectNear(triangleNormal(world, 12), {0, 1, 0});
  expectNear(triangleNormal(world, 13), {0, 1, 0});
  expectNear(world.bounds.min, {-1, 0, 0});
  expectNear(world.bounds.max, {1, 1, 1});
}

TEST(ImportFlatten, UnusedVerticesDoNotWidenBounds) {
  Scene scene;
  test::addQuad(scene, "quad", {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
  scene.meshes[0].positions.push_back({100, 100, 100});
  const WorldGeometry world = flatten(scene);
  expectNear(world.bounds.max, {1, 1, 0});
  EXPECT_EQ(world.positions.size(), 4u);
}

TEST(ImportExclude, RemovesMeshesAndRemapsInstances) {
  Scene scene;
  test::addBox(scene, "Circle#0", {0, 0, 0}, {1, 1, 1});
  test::addBox(scene, "Circle#1", {2, 0, 0}, {3, 1, 1});
  test::addBox(scene, "Circle2", {4, 0, 0}, {5, 1, 1});
  test::addBox(scene, "Other", {6, 0, 0}, {7, 1, 1});
  excludeMeshes(scene, {"Circle"});  // every primitive of the glTF mesh "Circle", not "Circle2"
  ASSERT_EQ(scene.meshes.size(), 2u);
  EXPECT_EQ(scene.meshes[0].name, "Circle2");
  ASSERT_EQ(scene.instances.size(), 2u);
  EXPECT_EQ(scene.instances[1].mesh, 1u);
  EXPECT_EQ(scene.instances[1].node, "Other");

  excludeMeshes(scene, {"Other"});
  ASSERT_EQ(scene.instances.size(), 1u);
  EXPECT_EQ(scene.instances[0].mesh, 0u);
}

TEST(ImportExclude, SinglePrimitiveAndUnknownName) {
  Scene scene;
  test::addBox(scene, "Circle#0", {0, 0, 0}, {1, 1, 1});
  test::addBox(scene, "Circle#1", {2, 0, 0}, {3, 1, 1});
  excludeMeshes(scene, {"Circle#1"});
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].name, "Circle#0");
  try {
    excludeMeshes(scene, {"Circ"});
    ADD_FAILURE() << "an unknown mesh name was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidArgument);
    EXPECT_NE(std::string(e.what()).find("Circ"), std::string::npos);
  }
  EXPECT_EQ(scene.meshes.size(), 1u);
}

// ---------------------------------------------------------------------------------------------------------
// Shipped scenes

TEST(ImportScenes, TorusKnotIsOneClosedMesh) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].triangleCount(), 2880u);
  EXPECT_TRUE(scene.meshes[0].closed);
  EXPECT_FALSE(scene.meshes[0].insideOut);
  const WorldGeometry world = flatten(scene);
  EXPECT_EQ(world.closedTriangleCount, 2880u);
  EXPECT_GT(signedVolume(world, 0, world.closedTriangleCount), 0.0);
}

TEST(ImportScenes, TerrainIsOpen) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/Terrain/terrain.gltf"));
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].triangleCount(), 5202u);
  EXPECT_FALSE(scene.meshes[0].closed);
  EXPECT_EQ(scene.meshes[0].boundaryEdges, 204u);
  EXPECT_EQ(flatten(scene, GroundSheets::Off).closedTriangleCount, 0u);
  // A height field over the whole scene: closed into solid ground by default (ground_sheet_test.cpp).
  const WorldGeometry world = flatten(scene);
  ASSERT_EQ(world.groundSheets.size(), 1u);
  EXPECT_TRUE(world.groundSheets[0].used);
}

TEST(ImportScenes, SubpassSceneOpaqueIsMixedAndUpsideDown) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf"));
  EXPECT_EQ(scene.meshes.size(), 16u);
  std::set<std::string> closed;
  size_t uniqueTriangles = 0;
  for (const Mesh& mesh : scene.meshes) {
    uniqueTriangles += mesh.triangleCount();
    if (mesh.closed) closed.insert(mesh.name);
  }
  EXPECT_EQ(uniqueTriangles, 11132u);
  EXPECT_EQ(closed, (std::set<std::string>{"Sponge", "Cube.003", "Cylinder", "Cylinder.002", "Cylinder.003",
                                           "Cylinder.004", "Sphere", "Sphere.003"}));
  // Primitives of a multi-primitive glTF mesh get a "#index" suffix.
  ASSERT_NE(findMesh(scene, "Cube.002#1"), nullptr);
  const Mesh* circle = findMesh(scene, "Circle");
  ASSERT_NE(circle, nullptr);
  EXPECT_EQ(circle->nonManifoldEdges, 128u);
  EXPECT_EQ(circle->boundaryEdges, 0u);
  EXPECT_EQ(worldTriangles(scene), 23388u);
  const WorldGeometry world = flatten(scene);
  EXPECT_EQ(world.triangleCount(), 23388u);
  // Authored with -Y up: the floor is at the top, the buildings hang below it.
  EXPECT_LT(world.bounds.max.y, 0.5);
  EXPECT_LT(world.bounds.min.y, -9.0);
}

TEST(ImportScenes, FlightHelmetClosedParts) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/FlightHelmet/FlightHelmet.gltf"));
  EXPECT_EQ(scene.meshes.size(), 6u);
  std::set<std::string> closed;
  for (const Mesh& mesh : scene.meshes)
    if (mesh.closed) closed.insert(mesh.name);
  EXPECT_EQ(closed, (std::set<std::string>{"GlassPlastic_low", "LeatherParts_low", "Lenses_low"}));
  EXPECT_EQ(worldTriangles(scene), 94722u);
  EXPECT_EQ(findMesh(scene, "Hose_low")->boundaryEdges, 32u);
  // Missing textures are not worth a word, except where an alpha-tested material (the BLEND lenses) needs one.
  ASSERT_EQ(scene.warnings.size(), 1u) << scene.warnings.front();
  EXPECT_NE(scene.warnings[0].find("material 'LensesMat'"), std::string::npos) << scene.warnings[0];
  EXPECT_NE(scene.warnings[0].find("alpha is taken as 1"), std::string::npos) << scene.warnings[0];
}

TEST(ImportScenes, JapaneseTempleIsOpen) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/JapaneseTemple/scene.gltf"));
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].triangleCount(), 29696u);
  EXPECT_FALSE(scene.meshes[0].closed);
  EXPECT_EQ(scene.meshes[0].boundaryEdges, 3618u);
}

TEST(ImportScenes, BinaryGlb) {
  const std::string path = kAssimpModels + "2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is not installed (Debian assimp-testmodels)";
  const Scene scene = importGltf(path);
  EXPECT_EQ(scene.meshes.size(), 34u);
  EXPECT_EQ(scene.instances.size(), 115u);
  EXPECT_GT(worldTriangles(scene), 100000u);
}

// ---------------------------------------------------------------------------------------------------------
// The hand-made Tiny scene: instancing, mirrored instance, lights

TEST(ImportTiny, InstancingAndMirroredBoxFaceOutward) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/Tiny/tiny.gltf"));
  EXPECT_EQ(scene.source, test::sourcePath("data/scenes/Tiny/tiny.gltf"));
  EXPECT_TRUE(scene.warnings.empty());
  ASSERT_EQ(scene.meshes.size(), 2u);
  const Mesh* box = findMesh(scene, "Box");
  const Mesh* ground = findMesh(scene, "Ground");
  ASSERT_TRUE(box && ground);
  EXPECT_TRUE(box->closed);
  EXPECT_FALSE(ground->closed);
  EXPECT_EQ(ground->boundaryEdges, 4u);

  ASSERT_EQ(scene.instances.size(), 3u);
  EXPECT_EQ(scene.instances[0].node, "BoxA");
  EXPECT_EQ(scene.instances[1].node, "BoxB");
  EXPECT_EQ(scene.instances[0].mesh, scene.instances[1].mesh);
  EXPECT_LT(glm::determinant(scene.instances[1].worldFromLocal), 0.0);

  const WorldGeometry world = flatten(scene, GroundSheets::Off);
  ASSERT_EQ(world.triangleCount(), 26u);
  EXPECT_EQ(world.closedTriangleCount, 24u);
  EXPECT_NEAR(signedVolume(world, 0, 12), 1.0, 1e-9);   // BoxA, unit cube
  EXPECT_NEAR(signedVolume(world, 12, 24), 2.0, 1e-9);  // BoxB, scale (-1, 2, 1): flipped back outward
  expectNear(triangleNormal(world, 24), {0, 1, 0});     // the ground faces up
  expectNear(world.bounds.min, {-5, 0, -5});
  expectNear(world.bounds.max, {5, 2, 5});
}

TEST(ImportTiny, Lights) {
  const Scene scene = importGltf(test::sourcePath("data/scenes/Tiny/tiny.gltf"));
  ASSERT_EQ(scene.lights.size(), 2u);
  const Light& sun = scene.lights[0];
  EXPECT_EQ(sun.name, "Sun");
  EXPECT_EQ(sun.type, LightType::Directional);
  expectNear(sun.direction, glm::normalize(glm::dvec3(0, -1, -1)));
  expectNear(glm::dvec3(sun.color), {1.0, 0.95, 0.9});
  EXPECT_FLOAT_EQ(sun.intensity, 3.0f);

  const Light& spot = scene.lights[1];
  EXPECT_EQ(spot.name, "SpotNode");  // the light has no name: the node's
  EXPECT_EQ(spot.type, LightType::Spot);
  expectNear(spot.position, {0, 4, 0});
  expectNear(spot.direction, {0, -1, 0});
  EXPECT_DOUBLE_EQ(spot.outerConeAngle, 0.6);
  EXPECT_DOUBLE_EQ(spot.innerConeAngle, 0.0);
  EXPECT_TRUE(std::isinf(spot.range));
  expectNear(glm::dvec3(spot.color), {1, 1, 1});
  EXPECT_FLOAT_EQ(spot.intensity, 1.0f);
  EXPECT_STREQ(lightTypeName(spot.type), "spot");
}

// ---------------------------------------------------------------------------------------------------------
// Generated glTF files: primitive modes, accessors, hierarchy, scenes, lights

TEST(ImportGltf, StripAndFanBecomeTrianglesWithTheSameWinding) {
  GltfBuilder gltf;
  const int stripPositions = gltf.addPositions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}});
  const int fanPositions = gltf.addPositions({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}});
  gltf.addMesh("Strip", json::array({{{"attributes", {{"POSITION", stripPositions}}}, {"mode", 5}}}));
  gltf.addMesh("Fan", json::array({{{"attributes", {{"POSITION", fanPositions}}}, {"mode", 6}}}));
  gltf.addNode({{"mesh", 0}});
  gltf.addNode({{"mesh", 1}});
  const Scene scene = importGltf(gltf.write(test::tempDir(), "modes"));
  const Mesh* strip = findMesh(scene, "Strip");
  const Mesh* fan = findMesh(scene, "Fan");
  ASSERT_TRUE(strip && fan);
  EXPECT_EQ(strip->indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2}));
  EXPECT_EQ(fan->indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  const WorldGeometry world = flatten(scene);
  for (size_t t = 0; t < world.triangleCount(); ++t) expectNear(triangleNormal(world, t), {0, 0, 1});
}

TEST(ImportGltf, IndexTypesModesAndNoIndices) {
  GltfBuilder gltf;
  const int positions = gltf.addPositions(kQuad);
  const std::vector<uint32_t> quad = {0, 1, 2, 0, 2, 3};
  json primitives = json::array();
  for (int type : {kUnsignedByte, kUnsignedShort, kUnsignedInt})
    primitives.push_back({{"attributes", {{"POSITION", positions}}}, {"indices", gltf.addIndices(quad, type)}, {"mode", 4}});
  const int soup = gltf.addPositions({kQuad[0], kQuad[1], kQuad[2], kQuad[0], kQuad[2], kQuad[3]});
  primitives.push_back({{"attributes", {{"POSITION", soup}}}});  // no indices, no mode
  primitives.push_back({{"attributes", {{"POSITION", positions}}}, {"mode", 1}});  // lines
  gltf.addMesh("Quads", primitives);
  gltf.addNode({{"mesh", 0}});
  const Scene scene = importGltf(gltf.write(test::tempDir(), "indices"));
  ASSERT_EQ(scene.meshes.size(), 4u);  // the lines are skipped
  for (int p = 0; p < 3; ++p) {
    const Mesh* mesh = findMesh(scene, "Quads#" + std::to_string(p));
    ASSERT_NE(mesh, nullptr);
    EXPECT_EQ(mesh->indices, quad);
  }
  const Mesh* soupMesh = findMesh(scene, "Quads#3");
  ASSERT_NE(soupMesh, nullptr);
  EXPECT_EQ(soupMesh->indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  ASSERT_EQ(scene.warnings.size(), 1u);
  EXPECT_NE(scene.warnings[0].find("Quads' primitive 4: LINES skipped"), std::string::npos) << scene.warnings[0];

  // --exclude-mesh with the glTF mesh name drops every primitive.
  Scene excluded = scene;
  test::addBox(excluded, "Other", {0, 0, 0}, {1, 1, 1});
  excludeMeshes(excluded, {"Quads"});
  ASSERT_EQ(excluded.meshes.size(), 1u);
  EXPECT_EQ(excluded.meshes[0].name, "Other");
}

TEST(ImportGltf, QuantizedAndSparsePositions) {
  GltfBuilder gltf;
  // KHR_mesh_quantization: normalized SHORT positions.
  const int16_t shorts[] = {0, 0, 0, 0, 32767, 0, 0, 0, 32767, -32767, 0, 0};  // VEC3 + padding: stride 8
  const int quantizedView = gltf.addView(shorts, sizeof shorts, 8);
  const int quantized = gltf.addAccessor(
      {{"bufferView", quantizedView}, {"componentType", kShort}, {"normalized", true}, {"count", 3}, {"type", "VEC3"}});
  // A sparse accessor on top of the quad: vertex 2 moved to (5, 6, 7).
  const int base = gltf.addPositions(kQuad);
  const uint8_t sparseIndex[] = {2};
  const float sparseValue[] = {5, 6, 7};
  const int indexView = gltf.addView(sparseIndex, sizeof sparseIndex);
  const int valueView = gltf.addView(sparseValue, sizeof sparseValue);
  json sparse = {{"count", 1},
                 {"indices", {{"bufferView", indexView}, {"componentType", kUnsignedByte}}},
                 {"values", {{"bufferView", valueView}}}};
  json sparseAccessor = gltf.root()["accessors"][base];
  sparseAccessor["sparse"] = sparse;
  const int sparsePositions = gltf.addAccessor(sparseAccessor);
  // Sparse without a bufferView: zeros with vertex 2 replaced.
  const int zeroPositions = gltf.addAccessor({{"componentType", kFloat}, {"count", 4}, {"type", "VEC3"}, {"sparse", sparse}});
  const int indices = gltf.addIndices({0, 1, 2});
  json primitives = json::array();
  for (int positions : {quantized, sparsePositions, zeroPositions})
    primitives.push_back({{"attributes", {{"POSITION", positions}}}, {"indices", indices}});
  gltf.addMesh("M", primitives);
  gltf.addNode({{"mesh", 0}});
  gltf.root()["extensionsUsed"] = {"KHR_mesh_quantization"};
  gltf.root()["extensionsRequired"] = {"KHR_mesh_quantization"};
  const Scene scene = importGltf(gltf.write(test::tempDir(), "accessors"));
  ASSERT_EQ(scene.meshes.size(), 3u);
  expectNear(glm::dvec3(scene.meshes[0].positions[2]), {1, -1, 0});
  expectNear(glm::dvec3(scene.meshes[1].positions[2]), {5, 6, 7});
  expectNear(glm::dvec3(scene.meshes[1].positions[3]), {0, 1, 0});
  expectNear(glm::dvec3(scene.meshes[2].positions[2]), {5, 6, 7});
  expectNear(glm::dvec3(scene.meshes[2].positions[1]), {0, 0, 0});
  EXPECT_TRUE(scene.warnings.empty());
}

TEST(ImportGltf, HierarchyInstancingAndSceneChoice) {
  GltfBuilder gltf = quadScene();
  gltf.root()["nodes"][0]["translation"] = {0, 0, 5};
  // Node 1: parent at (10, 0, 0) rotated 90 degrees about Z; its child scales by 2 and uses the quad.
  const double s = std::sqrt(0.5);
  gltf.addNode({{"name", "Parent"}, {"translation", {10, 0, 0}}, {"rotation", {0, 0, s, s}}, {"children", {2}}});
  gltf.addNode({{"name", "Child"}, {"scale", {2, 2, 2}}, {"mesh", 0}});
  gltf.addNode({{"name", "Elsewhere"}, {"mesh", 0}});
  gltf.root()["scenes"] = json::array({{{"nodes", {3}}}, {{"nodes", {0, 1}}}});
  gltf.root()["scene"] = 1;
  const std::string dir = test::tempDir();
  const Scene scene = importGltf(gltf.write(dir, "hierarchy"));
  ASSERT_EQ(scene.meshes.size(), 1u);  // decoded once
  ASSERT_EQ(scene.instances.size(), 2u);
  EXPECT_EQ(scene.instances[1].node, "Child");
  // Quad corner (1, 0, 0): scaled to (2, 0, 0), rotated to (0, 2, 0), moved to (10, 2, 0).
  expectNear(glm::dvec3(scene.instances[1].worldFromLocal * glm::dvec4(1, 0, 0, 1)), {10, 2, 0});
  expectNear(glm::dvec3(scene.instances[0].worldFromLocal * glm::dvec4(1, 0, 0, 1)), {1, 0, 5});

  gltf.root().erase("scene");  // then scene 0
  const Scene first = importGltf(gltf.write(dir, "scene0"));
  ASSERT_EQ(first.instances.size(), 1u);
  EXPECT_EQ(first.instances[0].node, "Elsewhere");

  gltf.root().erase("scenes");  // then every root node; the builder would add a scene, so write by hand
  std::ofstream(dir + "/roots.gltf") << gltf.root().dump();
  const Scene roots = importGltf(dir + "/roots.gltf");
  std::set<std::string> nodes;
  for (const Instance& instance : roots.instances) nodes.insert(instance.node);
  EXPECT_EQ(nodes, (std::set<std::string>{"QuadNode", "Child", "Elsewhere"}));
}

TEST(ImportGltf, MatrixTransformAndLightDefaults) {
  GltfBuilder gltf = quadScene();
  gltf.root()["nodes"][0]["matrix"] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 4, 5, 1};
  gltf.root()["extensions"]["KHR_lights_punctual"]["lights"] =
      json::array({{{"type", "point"}}, {{"type", "spot"}, {"name", "Named"}, {"range", 7.5}, {"spot", json::object()}}});
  gltf.addNode({{"translation", {1, 2, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  gltf.addNode({{"name", "SpotHolder"}, {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
  const Scene scene = importGltf(gltf.write(test::tempDir(), "lights"));
  expectNear(glm::dvec3(scene.instances[0].worldFromLocal * glm::dvec4(1, 1, 0, 1)), {5, 5, 5});
  ASSERT_EQ(scene.lights.size(), 2u);
  const Light& point = scene.lights[0];
  EXPECT_EQ(point.name, "light0");  // neither the light nor the node has a name
  EXPECT_EQ(point.type, LightType::Point);
  expectNear(point.position, {1, 2, 3});
  EXPECT_TRUE(std::isinf(point.range));
  EXPECT_FLOAT_EQ(point.intensity, 1.0f);
  expectNear(glm::dvec3(point.color), {1, 1, 1});
  const Light& spot = scene.lights[1];
  EXPECT_EQ(spot.name, "Named");
  EXPECT_DOUBLE_EQ(spot.range, 7.5);
  EXPECT_NEAR(spot.outerConeAngle, M_PI / 4, 1e-12);
  EXPECT_DOUBLE_EQ(spot.innerConeAngle, 0.0);
  expectNear(spot.direction, {0, 0, -1});
}

TEST(ImportGltf, SpecularGlossinessMaterialsShowTheirDiffuseColour) {
  GltfBuilder gltf = quadScene();
  gltf.root()["materials"] = json::array(
      {{{"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 1.0, 1.0, 0.75}}}},
        {"extensions", {{"KHR_materials_pbrSpecularGlossiness", {{"diffuseFactor", {0.8, 0.09, 0.08, 1.0}},
                                                                 {"glossinessFactor", 0.2}}}}}}});
  gltf.root()["extensionsUsed"] = json::array({"KHR_materials_pbrSpecularGlossiness"});
  gltf.root()["meshes"][0]["primitives"][0]["material"] = 0;
  const std::string dir = test::tempDir();
  const Scene scene = importGltf(gltf.write(dir, "specgloss"));
  // The colour from diffuseFactor; the alpha (what alpha testing reads) stays the metallic-roughness factor's.
  EXPECT_EQ(scene.meshes[0].baseColor, glm::vec4(0.8f, 0.09f, 0.08f, 0.75f));
  // A malformed diffuseFactor names the material and the member.
  gltf.root()["materials"][0]["extensions"]["KHR_materials_pbrSpecularGlossiness"]["diffuseFactor"] = {0.5, 0.5};
  const std::string bad = gltf.write(dir, "specgloss-bad");
  try {
    importGltf(bad);
    FAIL() << "accepted a diffuseFactor of two numbers";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("material 0 KHR_materials_pbrSpecularGlossiness.diffuseFactor is not an array "
                                         "of 4 numbers"),
              std::string::npos)
        << e.what();
  }
}

TEST(ImportGltf, CamerasAndBaseColours) {
  GltfBuilder gltf = quadScene();
  gltf.root()["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.25, 1.0, 1.0}}}}}});
  gltf.root()["meshes"][0]["primitives"][0]["material"] = 0;
  gltf.root()["cameras"] = json::array({{{"type", "perspective"}, {"name", "Overview"},
                                         {"perspective", {{"yfov", 0.7}, {"znear", 0.1}, {"zfar", 500.0}}}},
                                        {{"type", "orthographic"}, {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"znear", 0}, {"zfar", 1}}}}});
  // Rotated a quarter turn about +Y: looks along -X with +Y up.
  gltf.addNode({{"translation", {1, 2, 3}}, {"rotation", {0, 0.7071067811865476, 0, 0.7071067811865476}}, {"camera", 0}});
  gltf.addNode({{"camera", 1}});
  const std::string dir = test::tempDir();
  const Scene scene = importGltf(gltf.write(dir, "cameras"));
  EXPECT_EQ(scene.meshes[0].baseColor, glm::vec4(0.5f, 0.25f, 1.0f, 1.0f));
  ASSERT_EQ(scene.cameras.size(), 1u);  // the orthographic one is skipped with a warning
  const Camera& c = scene.cameras[0];
  EXPECT_EQ(c.name, "Overview");
  expectNear(c.eye, {1, 2, 3});
  expectNear(c.forward, {-1, 0, 0});
  expectNear(c.up, {0, 1, 0});
  EXPECT_DOUBLE_EQ(c.yfov, 0.7);
  EXPECT_DOUBLE_EQ(c.zfar, 500.0);
  bool warned = false;
  for (const std::string& w : scene.warnings) warned |= w.find("orthographic") != std::string::npos;
  EXPECT_TRUE(warned);

  // What only the viewer uses never fails an import: a bad camera is skipped, a colour clamped, with warnings.
  gltf.root()["cameras"][0]["perspective"]["yfov"] = -1.0;
  gltf.root()["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {2.0, 0.0, 0.0, 1.0};
  const Scene lenient = importGltf(gltf.write(dir, "bad_camera_and_colour"));
  EXPECT_TRUE(lenient.cameras.empty());
  EXPECT_EQ(lenient.meshes[0].baseColor, glm::vec4(1.0f, 0.0f, 0.0f, 1.0f));
  std::string all;
  for (const std::string& w : lenient.warnings) all += w + "\n";
  EXPECT_NE(all.find("yfov must be in (0, pi)"), std::string::npos) << all;
  EXPECT_NE(all.find("baseColorFactor[0] is not in [0, 1]; clamped"), std::string::npos) << all;
}

TEST(ImportGltf, BaseColourTexturesOnlyWhenAsked) {
  GltfBuilder gltf = quadScene();
  const std::vector<float> uvs = {0, 0, 1, 0, 1, 1, 0, 1};
  const int uvView = gltf.addView(uvs.data(), uvs.size() * sizeof(float));
  const int uvAccessor = gltf.addAccessor({{"bufferView", uvView}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}});
  gltf.root()["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = uvAccessor;
  gltf.root()["meshes"][0]["primitives"][0]["material"] = 0;
  gltf.root()["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}});
  gltf.root()["textures"] = json::array({{{"source", 0}}});
  gltf.root()["images"] = json::array({{{"uri", "texture.png"}}});
  const std::string dir = test::tempDir();
  RgbImage image;  // 2 x 2: red, green / blue, white
  image.width = image.height = 2;
  image.pixels = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
  std::ofstream(dir + "/texture.png", std::ios::binary) << encodePng(image);
  const std::string path = gltf.write(dir, "textured");

  const Scene plain = importGltf(path);  // the bake's import: no image is read
  EXPECT_TRUE(plain.textures.empty());
  EXPECT_TRUE(plain.meshes[0].uvs.empty());
  EXPECT_EQ(plain.meshes[0].baseColorTexture, -1);
  ImportOptions options;
  options.loadBaseColorTextures = true;
  const Scene textured = importGltf(path, options);
  ASSERT_EQ(textured.textures.size(), 1u);
  EXPECT_EQ(textured.textures[0].width, 2u);
  EXPECT_EQ(std::vector<uint8_t>(textured.textures[0].rgba.begin(), textured.textures[0].rgba.begin() + 8),
            (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255}));
  EXPECT_EQ(textured.meshes[0].baseColorTexture, 0);
  ASSERT_EQ(textured.meshes[0].uvs.size(), 4u);
  EXPECT_EQ(textured.meshes[0].uvs[2], glm::vec2(1, 1));

  // A damaged image: a warning naming it, no texture, the import goes on.
  std::ofstream(dir + "/texture.png", std::ios::binary) << "not a png";
  const Scene damaged = importGltf(path, options);
  EXPECT_TRUE(damaged.textures.empty());
  EXPECT_EQ(damaged.meshes[0].baseColorTexture, -1);
  std::string all;
  for (const std::string& w : damaged.warnings) all += w + "\n";
  EXPECT_NE(all.find("texture.png"), std::string::npos) << all;
}

// ---------------------------------------------------------------------------------------------------------
// Malformed input: every case is an Error(InputInvalid) that names the file, never a crash

// One table of accessor formats for the importer and the Draco decoder: glTF 2.0's six component types (INT and
// DOUBLE are OpenGL's, not glTF's) and seven element types.
TEST(ImportGltf, AccessorFormatsAreGltfs) {
  EXPECT_EQ(gltf::componentSize(5120), 1u);  // BYTE
  EXPECT_EQ(gltf::componentSize(5123), 2u);  // UNSIGNED_SHORT
  EXPECT_EQ(gltf::componentSize(5125), 4u);  // UNSIGNED_INT
  EXPECT_EQ(gltf::componentSize(5126), 4u);  // FLOAT
  EXPECT_EQ(gltf::componentSize(5124), 0u);  // INT
  EXPECT_EQ(gltf::componentSize(5130), 0u);  // DOUBLE
  EXPECT_STREQ(gltf::componentTypeName(5124), "INT");
  EXPECT_EQ(gltf::componentCount(TINYGLTF_TYPE_VEC3), 3u);
  EXPECT_EQ(gltf::componentCount(TINYGLTF_TYPE_MAT4), 16u);
  EXPECT_EQ(gltf::componentCount(-1), 0u);
  EXPECT_TRUE(gltf::isMatrixType(TINYGLTF_TYPE_MAT2));
  EXPECT_FALSE(gltf::isMatrixType(TINYGLTF_TYPE_VEC4));
  EXPECT_STREQ(gltf::typeName(TINYGLTF_TYPE_MAT3), "MAT3");
}

TEST(ImportMalformed, GeneratedFiles) {
  const std::string dir = test::tempDir();
  {
    GltfBuilder gltf = quadScene();
    const int bad = gltf.addIndices({0, 1, 7});
    gltf.root()["meshes"][0]["primitives"][0]["indices"] = bad;
    expectInvalid(gltf.write(dir, "index_range"), "mesh 'Quad' primitive 0: index 7 out of range (POSITION accessor 0 has 4 vertices)");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][0]["count"] = 5;  // one vertex more than the bufferView holds
    expectInvalid(gltf.write(dir, "accessor_overrun"), "overrun bufferView 0");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][0]["count"] = 4000000000u;  // must fail on the range, not exhaust memory
    expectInvalid(gltf.write(dir, "huge_count"), "overrun bufferView 0");
    gltf.root()["accessors"][0]["count"] = 5000000000u;
    expectInvalid(gltf.write(dir, "too_large_count"), "is too large");
    gltf.root()["accessors"][0].erase("bufferView");
    gltf.root()["accessors"][0]["count"] = 100000000u;
    expectInvalid(gltf.write(dir, "zero_count"), "without a bufferView is too large");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][0]["byteOffset"] = 4;
    gltf.root()["bufferViews"][0]["byteStride"] = 8;  // smaller than a VEC3 of floats
    expectInvalid(gltf.write(dir, "stride"), "byteStride 8");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["bufferViews"][0]["byteLength"] = 4096;  // past the end of the buffer
    expectInvalid(gltf.write(dir, "view_outside"), "does not fit in buffer 0");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["bufferViews"][0]["buffer"] = 3;
    expectInvalid(gltf.write(dir, "missing_buffer"), "buffer 3 does not exist");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["buffers"] = json::array({{{"byteLength", 48}, {"uri", "nowhere.bin"}}});
    expectInvalid(gltf.write(dir, "missing_bin"), "nowhere.bin");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["buffers"] = json::array({{{"byteLength", 4096}, {"uri", "too_small.bin"}}});
    expectInvalid(gltf.write(dir, "too_small"));  // the .bin is smaller than declared
  }
  {
    GltfBuilder gltf;
    const int positions = gltf.addPositions({{0, 0, 0}, {1, 0, 0}, {0, NAN, 0}});
    gltf.addMesh("NaN", json::array({{{"attributes", {{"POSITION", positions}}}}}));
    gltf.addNode({{"mesh", 0}});
    expectInvalid(gltf.write(dir, "nan"), "vertex 2 is not finite");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["nodes"][0]["mesh"] = "0";  // tinygltf alone would drop the mesh without a word
    expectInvalid(gltf.write(dir, "wrong_type"), "nodes[0].mesh is the string \"0\"");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["nodes"][0]["translation"] = {1, 2};
    expectInvalid(gltf.write(dir, "short_translation"), "nodes[0].translation has 2 elements");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][0]["type"] = "VEC7";
    expectInvalid(gltf.write(dir, "unknown_type"), "VEC7");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][0]["type"] = "VEC2";
    expectInvalid(gltf.write(dir, "vec2_positions"), "POSITION accessor 0 is VEC2, expected VEC3");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["accessors"][1]["componentType"] = kByte;
    expectInvalid(gltf.write(dir, "signed_indices"), "indices accessor 1 has componentType BYTE");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["meshes"][0]["primitives"][0]["mode"] = 1;  // lines only
    expectInvalid(gltf.write(dir, "lines_only"), "no triangles");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["nodes"][0]["children"] = {1};
    gltf.addNode({{"children", {0}}});
    gltf.root()["scenes"] = json::array({{{"nodes", {0}}}});
    expectInvalid(gltf.write(dir, "cycle"), "recursive node graph");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.addNode({{"children", {0}}});
    gltf.addNode({{"children", {0}}});
    gltf.root()["scenes"] = json::array({{{"nodes", {1, 2}}}});
    expectInvalid(gltf.write(dir, "two_parents"), "more than one parent");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["nodes"][0]["mesh"] = 9;
    expectInvalid(gltf.write(dir, "mesh_index"), "mesh 9 does not exist");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["extensions"]["KHR_lights_punctual"]["lights"] = json::array({{{"type", "area"}}});
    expectInvalid(gltf.write(dir, "light_type"), "type 'area'");
  }
  {
    GltfBuilder gltf = quadScene();
    gltf.root()["nodes"][0]["extensions"]["KHR_lights_punctual"]["light"] = 2;
    expectInvalid(gltf.write(dir, "light_index"), "is not the index of a light");
  }
  std::ofstream(dir + "/empty.gltf").flush();
  expectInvalid(dir + "/empty.gltf");
  const std::string garbage("glTF\x02\0\0\0\xff\xff\xff\x7f\x10\0\0\0JSON{\"asset\":", 29);
  std::ofstream(dir + "/garbage.glb", std::ios::binary) << garbage;
  expectInvalid(dir + "/garbage.glb");
  expectInvalid(dir + "/does_not_exist.gltf", "cannot open");
}

TEST(ImportMalformed, AssimpTestModels) {
  if (!std::filesystem::exists(kAssimpModels)) GTEST_SKIP() << "Debian assimp-testmodels is not installed";
  expectInvalid(kAssimpModels + "IndexOutOfRange/IndexOutOfRange.gltf", "index 255 out of range");
  expectInvalid(kAssimpModels + "IndexOutOfRange/AllIndicesOutOfRange.gltf", "out of range");
  expectInvalid(kAssimpModels + "BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "is not finite");
  expectInvalid(kAssimpModels + "wrongTypes/badArray.gltf", "meshes[0].primitives is an object");
  expectInvalid(kAssimpModels + "wrongTypes/badNumber.gltf");
  expectInvalid(kAssimpModels + "MissingBin/BoxTextured.gltf", "BoxTextured0.bin");
  expectInvalid(kAssimpModels + "RecursiveNodes/RecursiveNodes.gltf", "recursive node graph");
  expectInvalid(kAssimpModels + "TestNoRootNode/NoScene.gltf");
  // Wrong types in materials do not matter to shadows: these import.
  EXPECT_EQ(importGltf(kAssimpModels + "wrongTypes/badObject.gltf").meshes.size(), 1u);
}

// Mutated copies of the Tiny scene and truncated binaries either import or fail with InputInvalid.
TEST(ImportMalformed, MutationsNeverCrash) {
  std::ifstream in(test::sourcePath("data/scenes/Tiny/tiny.gltf"), std::ios::binary);
  const std::string original{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  const std::string dir = test::tempDir();
  std::mt19937 random(1234);
  const std::string replacements = "0123456789-.e\"[]{},:x";
  int failures = 0;
  for (int round = 0; round < 300; ++round) {
    std::string mutated = original;
    const int edits = 1 + int(random() % 3);
    for (int e = 0; e < edits; ++e) {
      size_t at = random() % mutated.size();
      // Aim at the structure, not at the base64 buffer.
      const size_t buffer = mutated.find("data:application");
      if (buffer != std::string::npos && at >= buffer) at = random() % buffer;
      mutated[at] = replacements[random() % replacements.size()];
    }
    const std::string path = dir + "/mutated.gltf";
    std::ofstream(path, std::ios::binary) << mutated;
    try {
      importGltf(path);
    } catch (const Error& e) {
      ++failures;
      EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
    }
  }
  EXPECT_GT(failures, 0);

  const std::string glb = kAssimpModels + "2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!std::filesystem::exists(glb)) return;
  std::ifstream glbIn(glb, std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(glbIn), std::istreambuf_iterator<char>()};
  for (size_t length : {size_t(0), size_t(3), size_t(12), size_t(20), size_t(100), bytes.size() / 2, bytes.size() - 1}) {
    const std::string path = dir + "/truncated.glb";
    std::ofstream(path, std::ios::binary) << bytes.substr(0, length);
    expectInvalid(path);
  }
}

// ---------------------------------------------------------------------------------------------------------
// cpvs-info end to end

TEST(ImportInfoTool, ExitCodesAndOutput) {
  const std::string tool = test::toolPath("cpvs-info");
  const std::string tiny = test::sourcePath("data/scenes/Tiny/tiny.gltf");

  const test::ToolResult good = test::runTool(tool + " " + tiny);
  EXPECT_EQ(good.exitCode, 0) << good.output;
  EXPECT_NE(good.output.find("Box: 12 triangles, closed"), std::string::npos) << good.output;
  EXPECT_NE(good.output.find("Ground: 2 triangles, open (4 boundary"), std::string::npos) << good.output;
  EXPECT_NE(good.output.find("spot 'SpotNode'"), std::string::npos) << good.output;

  const test::ToolResult asJson = test::runTool(tool + " --json " + tiny);
  ASSERT_EQ(asJson.exitCode, 0) << asJson.output;
  const json report = json::parse(asJson.output);
  EXPECT_EQ(report["totals"]["triangles"], 26);
  EXPECT_EQ(report["totals"]["closedTriangles"], 24);
  EXPECT_EQ(report["instances"].size(), 3u);
  EXPECT_EQ(report["lights"][1]["type"], "spot");
  EXPECT_TRUE(report["lights"][1]["range"].is_null());

  const test::ToolResult excluded = test::runTool(tool + " --json --exclude-mesh Box --sun 0,-1,0 " + tiny);
  ASSERT_EQ(excluded.exitCode, 0) << excluded.output;
  const json excludedReport = json::parse(excluded.output);
  EXPECT_EQ(excludedReport["totals"]["triangles"], 2);
  ASSERT_EQ(excludedReport["lights"].size(), 1u);
  EXPECT_EQ(excludedReport["lights"][0]["type"], "directional");

  const std::string dir = test::tempDir();
  std::ofstream(dir + "/broken.gltf") << "{ \"asset\": { \"version\": \"2.0\" }, ";
  const test::ToolResult broken = test::runTool(tool + " " + dir + "/broken.gltf");
  EXPECT_EQ(broken.exitCode, 2) << broken.output;
  EXPECT_NE(broken.output.find("broken.gltf"), std::string::npos) << broken.output;

  if (std::filesystem::exists(kAssimpModels + "IndexOutOfRange/IndexOutOfRange.gltf")) {
    const test::ToolResult outOfRange = test::runTool(tool + " " + kAssimpModels + "IndexOutOfRange/IndexOutOfRange.gltf");
    EXPECT_EQ(outOfRange.exitCode, 2) << outOfRange.output;
    EXPECT_NE(outOfRange.output.find("IndexOutOfRange.gltf"), std::string::npos) << outOfRange.output;
  }

  EXPECT_EQ(test::runTool(tool + " --exclude-mesh NoSuchMesh " + tiny).exitCode, 1);
  EXPECT_EQ(test::runTool(tool + " --no-such-option " + tiny).exitCode, 1);
  EXPECT_EQ(test::runTool(tool).exitCode, 1);
  const test::ToolResult help = test::runTool(tool + " --help");
  EXPECT_EQ(help.exitCode, 0);
  EXPECT_NE(help.output.find("Exit codes"), std::string::npos) << help.output;
  const test::ToolResult version = test::runTool(tool + " --version");
  EXPECT_EQ(version.exitCode, 0);
  EXPECT_NE(version.output.find("cpvs-info"), std::string::npos) << version.output;
}

// ---------------------------------------------------------------------------------------------------------
// Alpha-tested materials (docs/alpha.md)

// A grey + alpha PNG of `alpha` (row-major, width x height), as a file's bytes.
std::string alphaPng(uint32_t width, uint32_t height, const std::vector<uint8_t>& alpha) {
  std::vector<uint8_t> pixels;
  for (uint8_t a : alpha) pixels.insert(pixels.end(), {128, a});
  std::string bytes;
  stbi_write_png_to_func([](void* out, void* data, int size) { static_cast<std::string*>(out)->append(static_cast<char*>(data), size_t(size)); },
                         &bytes, int(width), int(height), 2, pixels.data(), int(width) * 2);
  return bytes;
}

// A PNG that is only a signature and an IHDR chunk claiming width x height.
std::string pngHeaderOnly(uint32_t width, uint32_t height) {
  std::string chunk = "IHDR";
  for (uint32_t v : {width, height})
    for (int b = 3; b >= 0; --b) chunk += char((v >> (8 * b)) & 0xff);
  chunk += std::string("\x08\x06\x00\x00\x00", 5);
  uint32_t crc = 0xffffffffu;  // CRC-32 of the chunk type and data, as PNG wants
  for (unsigned char c : chunk) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  std::string out = std::string("\x89PNG\r\n\x1a\n", 8) + std::string("\x00\x00\x00\x0d", 4) + chunk;
  for (int b = 3; b >= 0; --b) out += char((crc >> (8 * b)) & 0xff);
  return out;
}

// The unit quad with TEXCOORD_0 = (x, y) and TEXCOORD_1 = (2x, y), a MASK material reading image `leaf.png`
// (written with `imageBytes`) through `textureInfo`, and node and material extras.
std::string alphaQuad(const std::string& dir, const std::string& imageBytes, json textureInfo,
                      json materialExtras = nullptr, json nodeExtras = nullptr) {
  GltfBuilder gltf;
  const int positions = gltf.addPositions(kQuad);
  const int indices = gltf.addIndices({0, 1, 2, 0, 2, 3});
  std::vector<glm::vec2> uv0, uv1;
  for (const glm::vec3& p : kQuad) {
    uv0.push_back({p.x, p.y});
    uv1.push_back({2 * p.x, p.y});
  }
  const auto addUvs = [&](const std::vector<glm::vec2>& uvs) {
    const int view = gltf.addView(uvs.data(), uvs.size() * sizeof(glm::vec2));
    return gltf.addAccessor({{"bufferView", view}, {"componentType", kFloat}, {"count", uvs.size()}, {"type", "VEC2"}});
  };
  const int t0 = addUvs(uv0), t1 = addUvs(uv1);
  gltf.addMesh("Leaf", json::array({{{"attributes", {{"POSITION", positions}, {"TEXCOORD_0", t0}, {"TEXCOORD_1", t1}}},
                                     {"indices", indices}, {"material", 0}}}));
  json node = {{"name", "LeafNode"}, {"mesh", 0}};
  if (!nodeExtras.is_null()) node["extras"] = nodeExtras;
  gltf.addNode(node);
  json material = {{"name", "LeafMat"}, {"alphaMode", "MASK"}, {"pbrMetallicRoughness", {{"baseColorTexture", textureInfo}}}};
  if (!materialExtras.is_null()) material["extras"] = materialExtras;
  gltf.root()["materials"] = json::array({material});
  gltf.root()["textures"] = json::array({{{"source", 0}, {"sampler", 0}}});
  gltf.root()["samplers"] = json::array({{{"wrapS", 33071}, {"wrapT", 33071}}});
  gltf.root()["images"] = json::array({{{"uri", "leaf.png"}}});
  gltf.root()["extensionsUsed"] = json::array({"KHR_texture_transform"});
  std::ofstream(dir + "/leaf.png", std::ios::binary) << imageBytes;
  return gltf.write(dir, "leaf");
}

TEST(ImportAlpha, TextureTransformAndItsTexCoordSetGiveTheMaskCoordinates) {
  const std::string dir = test::tempDir();
  const std::string png = alphaPng(2, 1, {255, 0});
  // u' = 0.25 + 0.5 u of TEXCOORD_1 (2x): the quad's x in [0, 1] maps to u' in [0.25, 1.25].
  const Scene shifted = importGltf(alphaQuad(dir, png, {{"index", 0}, {"extensions", {{"KHR_texture_transform",
      {{"offset", {0.25, 0.0}}, {"scale", {0.5, 1.0}}, {"texCoord", 1}}}}}}));
  ASSERT_EQ(shifted.coverageMasks.size(), 1u);
  EXPECT_EQ(shifted.coverageMasks[0].blocks, (std::vector<uint8_t>{1, 0}));
  EXPECT_EQ(shifted.coverageMasks[0].wrapS, TextureWrap::ClampToEdge);
  const Mesh& mesh = shifted.meshes.at(0);
  ASSERT_EQ(mesh.coverageMask, 0);
  ASSERT_EQ(mesh.maskUvs.size(), 4u);
  EXPECT_FLOAT_EQ(mesh.maskUvs[1].x, 1.25f);  // corner (1, 0): TEXCOORD_1 (2, 0)
  EXPECT_FLOAT_EQ(mesh.maskUvs[1].y, 0.0f);
  // A quarter turn: u' = v, v' = -u (glTF's rotation is counter-clockwise in UV space).
  const Scene turned = importGltf(alphaQuad(test::tempDir(), png, {{"index", 0}, {"extensions", {{"KHR_texture_transform",
      {{"rotation", std::acos(-1.0) / 2}}}}}}));
  EXPECT_NEAR(turned.meshes.at(0).maskUvs[2].x, 1.0f, 1e-6);   // corner (1, 1): (u, v) = (1, 1) -> (1, -1)
  EXPECT_NEAR(turned.meshes.at(0).maskUvs[2].y, -1.0f, 1e-6);
  EXPECT_NEAR(turned.meshes.at(0).maskUvs[1].x, 0.0f, 1e-6);   // corner (1, 0) -> (0, -1)
  EXPECT_NEAR(turned.meshes.at(0).maskUvs[1].y, -1.0f, 1e-6);
}

TEST(ImportAlpha, AnImageThatIsNotAnImageWarnsAndCastsByTheFactor) {
  const std::string dir = test::tempDir();
  const std::string path = alphaQuad(dir, "this is not a PNG", {{"index", 0}});
  const Scene scene = importGltf(path);
  EXPECT_EQ(scene.meshes.at(0).coverageMask, -1);
  EXPECT_TRUE(scene.meshes.at(0).castsShadows);
  ASSERT_EQ(scene.warnings.size(), 1u);
  EXPECT_NE(scene.warnings[0].find("'leaf.png'"), std::string::npos) << scene.warnings[0];
  EXPECT_NE(scene.warnings[0].find("alpha is taken as 1"), std::string::npos) << scene.warnings[0];
  // The bake goes on, with the warning on stderr.
  const test::ToolResult bake = test::runTool(test::toolPath("cpvs-bake") + " " + path + " -o " + dir +
                                              "/leaf.cpvs -r 64 --sun 0,0,-1");
  EXPECT_EQ(bake.exitCode, 0) << bake.output;
  EXPECT_NE(bake.output.find("alpha is taken as 1"), std::string::npos) << bake.output;
}

TEST(ImportAlpha, AnEmptyOrMissingImageFileGivesOneWarningThatSaysWhatIsWrong) {
  const std::string dir = test::tempDir();
  const std::string path = alphaQuad(dir, "", {{"index", 0}});  // leaf.png exists and is empty
  ImportOptions viewer;  // cpvs-view also decodes the base-colour texture: the same image, one warning
  viewer.loadBaseColorTextures = true;
  for (const ImportOptions& options : {ImportOptions{}, viewer}) {
    const Scene scene = importGltf(path, options);
    ASSERT_EQ(scene.warnings.size(), 1u) << (scene.warnings.empty() ? "" : scene.warnings[0] + " | " + scene.warnings.back());
    EXPECT_EQ(scene.warnings[0].rfind(path + ": image 0 'leaf.png' (material 'LeafMat'): the file is empty; ", 0), 0u)
        << scene.warnings[0];
    EXPECT_NE(scene.warnings[0].find("alpha is taken as 1"), std::string::npos) << scene.warnings[0];
    EXPECT_EQ(scene.warnings[0].find("cpvs-view shows") != std::string::npos, options.loadBaseColorTextures)
        << scene.warnings[0];
  }
  // Through the tools: one warning, the scene's path once in it, nothing from the loader.
  const std::string cpvs = dir + "/leaf.cpvs", points = dir + "/points.csv";
  const test::ToolResult bake = test::runTool(test::toolPath("cpvs-bake") + " " + path + " -o " + cpvs +
                                              " -r 64 --sun 0,0,-1");
  ASSERT_EQ(bake.exitCode, 0) << bake.output;
  ASSERT_EQ(test::runTool(test::toolPath("cpvs-sample") + " " + path + " -n 100 -o " + points).exitCode, 0);
  const test::ToolResult query = test::runTool(test::toolPath("cpvs-query") + " " + cpvs + " --points " + points +
                                               " -o " + dir + "/v.csv --reference " + path);
  ASSERT_EQ(query.exitCode, 0) << query.output;
  for (const test::ToolResult& run : {bake, query}) {
    EXPECT_EQ(run.output.find("File is empty"), std::string::npos) << run.output;
    const size_t warning = run.output.find("warning: " + path + ": image 0 'leaf.png' (material 'LeafMat'): the file is empty");
    ASSERT_NE(warning, std::string::npos) << run.output;
    EXPECT_EQ(run.output.find("leaf.png", warning + 40 + path.size()), std::string::npos) << run.output;  // once
    const std::string line = run.output.substr(warning, run.output.find('\n', warning) - warning);
    EXPECT_EQ(line.find(path, line.find(path) + 1), std::string::npos) << line;
  }
  // A missing file is named as such.
  std::filesystem::remove(dir + "/leaf.png");
  const Scene missing = importGltf(path);
  ASSERT_EQ(missing.warnings.size(), 1u);
  EXPECT_NE(missing.warnings[0].find("leaf.png does not exist"), std::string::npos) << missing.warnings[0];
}

TEST(ImportAlpha, AHugePngHeaderWarnsWithoutAllocatingTheImage) {
  const std::string dir = test::tempDir();
  const Scene scene = importGltf(alphaQuad(dir, pngHeaderOnly(60000, 60000), {{"index", 0}}));
  ASSERT_EQ(scene.warnings.size(), 1u);
  EXPECT_NE(scene.warnings[0].find("60000x60000"), std::string::npos) << scene.warnings[0];
  EXPECT_EQ(scene.meshes.at(0).coverageMask, -1);
}

TEST(ImportAlpha, ExtrasFlagTurnsCastingOffForAMaterialOrANode) {
  const std::string png = alphaPng(2, 1, {255, 0});
  const json info = {{"index", 0}};
  const Scene byMaterial = importGltf(alphaQuad(test::tempDir(), png, info, {{"cpvs_casts_shadows", false}}));
  EXPECT_FALSE(byMaterial.meshes.at(0).castsShadows);
  EXPECT_EQ(byMaterial.meshes.at(0).coverageMask, 0);  // kept: cpvs-view still cuts it as a receiver
  EXPECT_EQ(flatten(byMaterial).triangleCount(), 0u);
  const std::string byNodePath = alphaQuad(test::tempDir(), png, info, nullptr, {{"cpvs_casts_shadows", false}});
  const Scene byNode = importGltf(byNodePath);
  EXPECT_TRUE(byNode.meshes.at(0).castsShadows);
  EXPECT_FALSE(byNode.instances.at(0).castsShadows);
  EXPECT_EQ(flatten(byNode).triangleCount(), 0u);
  // cpvs-info says so, per instance.
  const test::ToolResult report = test::runTool(test::toolPath("cpvs-info") + " " + byNodePath + " --json 2>/dev/null");
  ASSERT_EQ(report.exitCode, 0) << report.output;
  EXPECT_EQ(json::parse(report.output)["instances"][0]["castsShadows"], false) << report.output;
  const Scene casting = importGltf(alphaQuad(test::tempDir(), png, info, {{"cpvs_casts_shadows", true}}));
  EXPECT_EQ(flatten(casting).triangleCount(), 2u);
  expectInvalid(alphaQuad(test::tempDir(), png, info, nullptr, {{"cpvs_casts_shadows", "no"}}), "cpvs_casts_shadows");
}

}  // namespace
}  // namespace cpvs
