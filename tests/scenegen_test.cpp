// cpvs-scenegen: runs the generator, loads its .glb files with tinygltf and checks what the benchmark
// relies on: closedness (a weld + directed-edge test written here, independent of the generator and of
// the importer), outward orientation, the triangle budget, determinism, lights and their directions, and
// the command line's exit codes.

// tinygltf is compiled into this test under its own namespace name, so that it cannot clash with the
// copy the cpvs library may compile (a second TINYGLTF_IMPLEMENTATION would be a duplicate definition).
// No image decoding is needed.
#define tinygltf cpvs_scenegen_test_tinygltf
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
#undef tinygltf
namespace gltf = cpvs_scenegen_test_tinygltf;

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "support/test_support.h"

namespace {

using cpvs::test::runTool;
using cpvs::test::tempDir;
using cpvs::test::toolPath;

std::string generator() { return toolPath("cpvs-scenegen"); }

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Runs the generator; fails the test (and returns false) when it does not exit with 0.
bool generate(const std::string& args, std::string* output = nullptr) {
  const cpvs::test::ToolResult r = runTool(generator() + " " + args);
  EXPECT_EQ(r.exitCode, 0) << args << "\n" << r.output;
  if (output) *output = r.output;
  return r.exitCode == 0;
}

gltf::Model load(const std::string& path) {
  gltf::TinyGLTF loader;
  gltf::Model model;
  std::string err, warn;
  const bool ok = loader.LoadBinaryFromFile(&model, &err, &warn, path);
  EXPECT_TRUE(ok) << path << ": " << err;
  EXPECT_TRUE(warn.empty()) << warn;
  return model;
}

struct Triangles {
  std::vector<glm::vec3> positions;
  std::vector<std::uint32_t> indices;
};

// The triangles of one mesh (all its primitives), checking the layout the generator promises.
Triangles meshTriangles(const gltf::Model& model, const gltf::Mesh& mesh) {
  Triangles t;
  for (const gltf::Primitive& prim : mesh.primitives) {
    EXPECT_EQ(prim.mode, TINYGLTF_MODE_TRIANGLES);
    const gltf::Accessor& pa = model.accessors.at(static_cast<std::size_t>(prim.attributes.at("POSITION")));
    const gltf::Accessor& ia = model.accessors.at(static_cast<std::size_t>(prim.indices));
    EXPECT_EQ(pa.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
    EXPECT_EQ(pa.type, TINYGLTF_TYPE_VEC3);
    EXPECT_EQ(ia.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    const gltf::BufferView& pv = model.bufferViews.at(static_cast<std::size_t>(pa.bufferView));
    const gltf::BufferView& iv = model.bufferViews.at(static_cast<std::size_t>(ia.bufferView));
    const std::vector<unsigned char>& pb = model.buffers.at(static_cast<std::size_t>(pv.buffer)).data;
    const std::vector<unsigned char>& ib = model.buffers.at(static_cast<std::size_t>(iv.buffer)).data;
    const std::size_t pStart = pv.byteOffset + pa.byteOffset, iStart = iv.byteOffset + ia.byteOffset;
    if (pStart + pa.count * 12 > pb.size() || iStart + ia.count * 4 > ib.size()) {
      ADD_FAILURE() << "accessor out of its buffer in mesh " << mesh.name;
      return t;
    }
    const std::uint32_t base = static_cast<std::uint32_t>(t.positions.size());
    for (std::size_t i = 0; i < pa.count; ++i) {
      glm::vec3 p;
      std::memcpy(&p, pb.data() + pStart + i * 12, 12);
      EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
      t.positions.push_back(p);
    }
    EXPECT_EQ(ia.count % 3, 0u);
    for (std::size_t i = 0; i < ia.count; ++i) {
      std::uint32_t v;
      std::memcpy(&v, ib.data() + iStart + i * 4, 4);
      EXPECT_LT(v, pa.count);
      t.indices.push_back(base + v);
    }
  }
  return t;
}

struct Topology {
  bool closed = false;           // every edge in exactly two triangles, in opposite directions
  std::size_t degenerate = 0;    // triangles with a repeated welded vertex
  std::size_t components = 0;    // edge-connected components
  double minComponentVolume = 0;  // the smallest signed volume of a component (> 0: outward)
};

// Welds vertices by exact position, then counts directed edges: the mesh is closed when each directed
// edge occurs once and its reverse occurs once.
Topology topology(const Triangles& t) {
  Topology r;
  std::map<std::array<float, 3>, std::uint32_t> weld;
  std::vector<std::uint32_t> id(t.positions.size());
  std::vector<glm::dvec3> welded;
  for (std::size_t i = 0; i < t.positions.size(); ++i) {
    const std::array<float, 3> key{t.positions[i].x, t.positions[i].y, t.positions[i].z};
    const auto [it, inserted] = weld.emplace(key, static_cast<std::uint32_t>(welded.size()));
    if (inserted) welded.push_back(glm::dvec3(t.positions[i]));
    id[i] = it->second;
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  std::vector<std::uint32_t> parent(welded.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  const std::size_t n = t.indices.size() / 3;
  for (std::size_t f = 0; f < n; ++f) {
    const std::uint32_t v[3] = {id[t.indices[3 * f]], id[t.indices[3 * f + 1]], id[t.indices[3 * f + 2]]};
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) {
      ++r.degenerate;
      continue;
    }
    for (int e = 0; e < 3; ++e) {
      ++directed[{v[e], v[(e + 1) % 3]}];
      parent[find(v[e])] = find(v[(e + 1) % 3]);
    }
  }
  r.closed = n > 0 && r.degenerate == 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (count != 1 || reverse == directed.end() || reverse->second != 1) {
      r.closed = false;
      break;
    }
  }
  std::map<std::uint32_t, double> volume;  // per component root
  for (std::size_t f = 0; f < n; ++f) {
    const glm::dvec3 a = welded[id[t.indices[3 * f]]], b = welded[id[t.indices[3 * f + 1]]],
                     c = welded[id[t.indices[3 * f + 2]]];
    volume[find(id[t.indices[3 * f]])] += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  r.components = volume.size();
  r.minComponentVolume = volume.empty() ? 0.0 : std::numeric_limits<double>::max();
  for (const auto& [root, v] : volume) r.minComponentVolume = std::min(r.minComponentVolume, v);
  return r;
}

std::uint64_t instancedTriangles(const gltf::Model& model) {
  std::uint64_t total = 0;
  for (const gltf::Node& node : model.nodes) {
    EXPECT_TRUE(node.children.empty());  // the generator writes a flat list of roots
    if (node.mesh < 0) continue;
    for (const gltf::Primitive& p : model.meshes.at(static_cast<std::size_t>(node.mesh)).primitives)
      total += model.accessors.at(static_cast<std::size_t>(p.indices)).count / 3;
  }
  return total;
}

glm::dquat nodeRotation(const gltf::Node& node) {
  if (node.rotation.empty()) return glm::dquat(1.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(node.rotation.size(), 4u);
  return glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);  // w, x, y, z
}

// The direction a light node shines: its local -Z rotated by the node's quaternion.
glm::dvec3 lightDirection(const gltf::Node& node) { return nodeRotation(node) * glm::dvec3(0.0, 0.0, -1.0); }

int lightOf(const gltf::Node& node) {
  const auto it = node.extensions.find("KHR_lights_punctual");
  if (it == node.extensions.end() || !it->second.Has("light")) return -1;
  return it->second.Get("light").GetNumberAsInt();
}

void expectWithinBudget(std::uint64_t actual, std::uint64_t requested) {
  EXPECT_GE(static_cast<double>(actual), 0.8 * static_cast<double>(requested));
  EXPECT_LE(static_cast<double>(actual), 1.2 * static_cast<double>(requested));
}

void expectSun(const gltf::Model& model) {
  ASSERT_EQ(model.lights.size(), 1u);
  EXPECT_EQ(model.lights[0].type, "directional");
  int nodes = 0;
  for (const gltf::Node& node : model.nodes) {
    if (lightOf(node) != 0) continue;
    ++nodes;
    const glm::dvec3 want = glm::normalize(glm::dvec3(-0.4, -1.0, -0.3));
    const glm::dvec3 got = lightDirection(node);
    EXPECT_NEAR(glm::length(got), 1.0, 1e-9);
    EXPECT_NEAR(got.x, want.x, 1e-9);
    EXPECT_NEAR(got.y, want.y, 1e-9);
    EXPECT_NEAR(got.z, want.z, 1e-9);
  }
  EXPECT_EQ(nodes, 1);
}

TEST(Scenegen, ClosedCityIsWatertightOutwardAndOnBudget) {
  const std::string dir = tempDir();
  std::string out;
  ASSERT_TRUE(generate("city --triangles 30000 --seed 7 -o " + dir + "/city.glb", &out));
  EXPECT_NE(out.find("triangles"), std::string::npos) << out;
  const gltf::Model model = load(dir + "/city.glb");
  EXPECT_EQ(model.asset.version, "2.0");
  EXPECT_EQ(model.asset.generator.rfind("cpvs-scenegen ", 0), 0u) << model.asset.generator;
  ASSERT_GE(model.meshes.size(), 5u);
  for (const gltf::Mesh& mesh : model.meshes) {
    const Topology t = topology(meshTriangles(model, mesh));
    EXPECT_TRUE(t.closed) << mesh.name;
    EXPECT_EQ(t.degenerate, 0u) << mesh.name;
    EXPECT_GT(t.minComponentVolume, 0.0) << mesh.name << ": a component faces inwards";
  }
  const std::uint64_t triangles = instancedTriangles(model);
  expectWithinBudget(triangles, 30000);
  EXPECT_NE(out.find(std::to_string(triangles) + " triangles"), std::string::npos) << out;
  expectSun(model);

  // Instancing: some mesh is placed more than once, some instance is rotated.
  std::map<int, int> uses;
  bool rotated = false;
  for (const gltf::Node& node : model.nodes) {
    if (node.mesh >= 0) ++uses[node.mesh];
    if (node.mesh >= 0 && !node.rotation.empty()) rotated = true;
  }
  EXPECT_TRUE(std::any_of(uses.begin(), uses.end(), [](const auto& u) { return u.second > 1; }));
  EXPECT_TRUE(rotated);
}

TEST(Scenegen, LandscapeIsWatertightOutwardAndOnBudget) {
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("landscape --triangles 20000 --seed 3 -o " + dir + "/land.glb"));
  const gltf::Model model = load(dir + "/land.glb");
  ASSERT_FALSE(model.meshes.empty());
  for (const gltf::Mesh& mesh : model.meshes) {
    const Topology t = topology(meshTriangles(model, mesh));
    EXPECT_TRUE(t.closed) << mesh.name;
    EXPECT_EQ(t.components, 1u) << mesh.name;
    EXPECT_GT(t.minComponentVolume, 0.0) << mesh.name;
  }
  expectWithinBudget(instancedTriangles(model), 20000);
  expectSun(model);
}

TEST(Scenegen, OpenCityHasNoClosedMeshAndTheSameLayout) {
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("open-city --triangles 30000 --seed 7 -o " + dir + "/open.glb"));
  ASSERT_TRUE(generate("city --triangles 30000 --seed 7 -o " + dir + "/closed.glb"));
  const gltf::Model open = load(dir + "/open.glb");
  const gltf::Model closed = load(dir + "/closed.glb");
  ASSERT_FALSE(open.meshes.empty());
  for (const gltf::Mesh& mesh : open.meshes) {
    const Topology t = topology(meshTriangles(open, mesh));
    EXPECT_FALSE(t.closed) << mesh.name;
    EXPECT_EQ(t.degenerate, 0u) << mesh.name;
  }
  const std::uint64_t openTriangles = instancedTriangles(open);
  const std::uint64_t closedTriangles = instancedTriangles(closed);
  EXPECT_LT(openTriangles, closedTriangles);
  EXPECT_GT(openTriangles, closedTriangles / 3);
  // Same layout: the same instances at the same places.
  ASSERT_EQ(open.nodes.size(), closed.nodes.size());
  for (std::size_t i = 0; i < open.nodes.size(); ++i) {
    EXPECT_EQ(open.nodes[i].name, closed.nodes[i].name);
    EXPECT_EQ(open.nodes[i].translation, closed.nodes[i].translation);
    EXPECT_EQ(open.nodes[i].rotation, closed.nodes[i].rotation);
  }
  expectSun(open);
}

TEST(Scenegen, SameSeedSameBytesOtherSeedOtherBytes) {
  const std::string dir = tempDir();
  for (const std::string kind : {"city", "landscape", "city-spots"}) {
    ASSERT_TRUE(generate(kind + " --triangles 10000 --seed 11 -o " + dir + "/a.glb"));
    ASSERT_TRUE(generate(kind + " --triangles 10000 --seed 11 -o " + dir + "/b.glb"));
    ASSERT_TRUE(generate(kind + " --triangles 10000 --seed 12 -o " + dir + "/c.glb"));
    const std::string a = readBytes(dir + "/a.glb"), b = readBytes(dir + "/b.glb"), c = readBytes(dir + "/c.glb");
    EXPECT_GT(a.size(), 1000u) << kind;
    EXPECT_EQ(a, b) << kind;
    EXPECT_NE(a, c) << kind;
    // Only the output file itself is left behind (no temporaries).
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 3)
        << kind;
  }
}

TEST(Scenegen, CitySpotsCarryDownwardSpotLights) {
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("city-spots --triangles 20000 --lights 40 --seed 5 -o " + dir + "/spots.glb"));
  const gltf::Model model = load(dir + "/spots.glb");
  ASSERT_EQ(model.lights.size(), 40u);
  EXPECT_NE(std::find(model.extensionsUsed.begin(), model.extensionsUsed.end(), "KHR_lights_punctual"),
            model.extensionsUsed.end());
  for (const gltf::Mesh& mesh : model.meshes) EXPECT_TRUE(topology(meshTriangles(model, mesh)).closed) << mesh.name;
  std::set<int> seen;
  for (const gltf::Node& node : model.nodes) {
    const int index = lightOf(node);
    if (index < 0) continue;
    ASSERT_LT(index, 40);
    EXPECT_TRUE(seen.insert(index).second) << "light " << index << " placed twice";
    const gltf::Light& light = model.lights[static_cast<std::size_t>(index)];
    EXPECT_EQ(light.type, "spot") << light.name;
    EXPECT_GT(light.spot.outerConeAngle, 0.1) << light.name;
    EXPECT_LE(light.spot.outerConeAngle, 3.14159265358979 / 2.0) << light.name;
    EXPECT_GE(light.spot.innerConeAngle, 0.0) << light.name;
    EXPECT_LT(light.spot.innerConeAngle, light.spot.outerConeAngle) << light.name;
    EXPECT_EQ(light.color.size(), 3u);
    EXPECT_GT(light.intensity, 0.0);

    const glm::dquat q = nodeRotation(node);
    EXPECT_NEAR(glm::length(q), 1.0, 1e-9) << light.name;
    const glm::dvec3 d = lightDirection(node);
    EXPECT_LT(d.y, -0.9) << light.name << ": a street light should point mostly down";
    ASSERT_EQ(node.translation.size(), 3u);
    const glm::dvec3 p(node.translation[0], node.translation[1], node.translation[2]);
    EXPECT_GT(p.y, 10.0) << light.name;
    EXPECT_LE(std::abs(p.x), 500.0) << light.name;
    EXPECT_LE(std::abs(p.z), 500.0) << light.name;
    // The cone reaches the ground: the axis hits y = 0 within the range, as do the cone's edges.
    const double axisDistance = p.y / -d.y;
    EXPECT_GT(light.range, axisDistance) << light.name;
    EXPECT_GT(light.range, p.y / std::cos(std::min(1.45, std::acos(-d.y) + light.spot.outerConeAngle)))
        << light.name;
  }
  EXPECT_EQ(seen.size(), 40u);
}

TEST(Scenegen, LightQuaternionTurnsMinusZIntoTheDirection) {
  // Independent of the generator's own arithmetic: the quaternion written for the sun must satisfy
  // glm's convention (w, x, y, z) and glTF's (x, y, z, w) order; checked above through expectSun. Here:
  // the tilted spots of two seeds cover a spread of directions, all unit and downward.
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("city-spots --triangles 8000 --lights 100 --seed 99 -o " + dir + "/s.glb"));
  const gltf::Model model = load(dir + "/s.glb");
  double minY = 0.0, maxY = -1.0;
  for (const gltf::Node& node : model.nodes) {
    if (lightOf(node) < 0) continue;
    const glm::dvec3 d = lightDirection(node);
    EXPECT_NEAR(glm::length(d), 1.0, 1e-9);
    minY = std::min(minY, d.y);
    maxY = std::max(maxY, d.y);
  }
  EXPECT_LT(minY, -0.999);  // some point nearly straight down
  EXPECT_GT(maxY, -0.99);   // some are tilted
  EXPECT_LT(maxY, -0.9);
}

TEST(Scenegen, CommandLineExitCodes) {
  const std::string dir = tempDir();
  EXPECT_EQ(runTool(generator() + " --help").exitCode, 0);
  const cpvs::test::ToolResult version = runTool(generator() + " --version");
  EXPECT_EQ(version.exitCode, 0);
  EXPECT_NE(version.output.find("cpvs-scenegen"), std::string::npos);
  EXPECT_EQ(runTool(generator()).exitCode, 1);
  EXPECT_EQ(runTool(generator() + " village -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " city").exitCode, 1);  // no output
  EXPECT_EQ(runTool(generator() + " city --triangles 30000000 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " city --triangles -5 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " city --lights 3 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " city-spots --lights 0 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.glb"));
  const cpvs::test::ToolResult missing =
      runTool(generator() + " city --triangles 5000 -o " + dir + "/no/such/dir/x.glb");
  EXPECT_EQ(missing.exitCode, 3) << missing.output;
  EXPECT_NE(missing.output.find("no/such/dir/x.glb"), std::string::npos) << missing.output;
}

}  // namespace
