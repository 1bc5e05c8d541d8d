// cpvs-scenegen: runs the generator, loads its .glb files with tinygltf and checks what the benchmark
// relies on: closedness (a weld + directed-edge test written here, independent of the generator and of
// the importer), outward orientation, the triangle budget, determinism, lights and their directions, and
// the command line's exit codes; the alpha-test scene against its specification (docs/scenegen.md), the
// foliage level's instancing and leaf texture, --gpu-instancing against plain nodes, and the bytes of the
// older scenes against recorded hashes.

// tinygltf is compiled into this test under its own namespace name, so that it cannot clash with the
// copy the cpvs library may compile (a second TINYGLTF_IMPLEMENTATION would be a duplicate definition).
// Its own image decoding is off; images are decoded by the stb_image compiled here (static, file-local).
#define tinygltf cpvs_scenegen_test_tinygltf
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
#undef tinygltf
namespace gltf = cpvs_scenegen_test_tinygltf;

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

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
#include <tuple>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

// Decodes an embedded image as RGBA8 with stb_image (independent of the generator's PNG encoder).
bool decodeImage(gltf::Image* image, const int, std::string* err, std::string*, int, int, const unsigned char* bytes,
                 int size, void*) {
  int w = 0, h = 0, channels = 0;
  unsigned char* pixels = stbi_load_from_memory(bytes, size, &w, &h, &channels, 4);
  if (!pixels) {
    if (err) *err += std::string("stb_image: ") + stbi_failure_reason() + "\n";
    return false;
  }
  image->width = w;
  image->height = h;
  image->component = 4;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image.assign(pixels, pixels + static_cast<std::size_t>(w) * h * 4);
  stbi_image_free(pixels);
  return true;
}

gltf::Model load(const std::string& path) {
  gltf::TinyGLTF loader;
  loader.SetImageLoader(decodeImage, nullptr);
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

// The node's EXT_mesh_gpu_instancing attribute `semantic` (TRANSLATION, ROTATION, SCALE), or -1.
int instanceAttribute(const gltf::Node& node, const char* semantic) {
  const auto it = node.extensions.find("EXT_mesh_gpu_instancing");
  if (it == node.extensions.end() || !it->second.Has("attributes")) return -1;
  const gltf::Value& attributes = it->second.Get("attributes");
  return attributes.Has(semantic) ? attributes.Get(semantic).GetNumberAsInt() : -1;
}

bool instanced(const gltf::Node& node) { return node.extensions.count("EXT_mesh_gpu_instancing") > 0; }

// A float accessor's values, `components` per element, checked to be tightly packed inside its buffer.
std::vector<float> floats(const gltf::Model& model, int index, int type, int components) {
  const gltf::Accessor& a = model.accessors.at(static_cast<std::size_t>(index));
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  EXPECT_EQ(a.type, type);
  EXPECT_FALSE(a.normalized);
  const gltf::BufferView& v = model.bufferViews.at(static_cast<std::size_t>(a.bufferView));
  const std::vector<unsigned char>& b = model.buffers.at(static_cast<std::size_t>(v.buffer)).data;
  const std::size_t start = v.byteOffset + a.byteOffset, bytes = a.count * components * sizeof(float);
  std::vector<float> out(a.count * static_cast<std::size_t>(components));
  const std::size_t stride = static_cast<std::size_t>(components) * sizeof(float);
  if (start + bytes > b.size() || a.byteOffset + bytes > v.byteLength || (v.byteStride != 0 && v.byteStride != stride)) {
    ADD_FAILURE() << "accessor " << index << " out of its buffer view";
    return out;
  }
  std::memcpy(out.data(), b.data() + start, bytes);
  return out;
}

// How many copies of its mesh a node draws: its GPU instances (all attributes of one count), else one.
std::size_t copies(const gltf::Model& model, const gltf::Node& node) {
  if (!instanced(node)) return 1;
  std::size_t count = 0;
  bool first = true;
  for (const char* semantic : {"TRANSLATION", "ROTATION", "SCALE"}) {
    const int a = instanceAttribute(node, semantic);
    if (a < 0) continue;
    const std::size_t n = model.accessors.at(static_cast<std::size_t>(a)).count;
    if (!first) {
      EXPECT_EQ(n, count) << node.name << ": " << semantic << " has another count";
    }
    count = n;
    first = false;
  }
  EXPECT_FALSE(first) << node.name << ": EXT_mesh_gpu_instancing without attributes";
  return count;
}

std::uint64_t instancedTriangles(const gltf::Model& model) {
  std::uint64_t total = 0;
  for (const gltf::Node& node : model.nodes) {
    EXPECT_TRUE(node.children.empty());  // the generator writes a flat list of roots
    if (node.mesh < 0) continue;
    for (const gltf::Primitive& p : model.meshes.at(static_cast<std::size_t>(node.mesh)).primitives)
      total += model.accessors.at(static_cast<std::size_t>(p.indices)).count / 3 * copies(model, node);
  }
  return total;
}

// One placement of a mesh: float translation and rotation (x, y, z, w), as a float reader takes them.
using Placement = std::tuple<int, std::array<float, 3>, std::array<float, 4>>;

// Every placement of every mesh in the file: plain mesh nodes and GPU instances (whose scale must be 1 and
// whose node must be at identity).
std::vector<Placement> placements(const gltf::Model& model) {
  std::vector<Placement> out;
  for (const gltf::Node& node : model.nodes) {
    if (node.mesh < 0) continue;
    if (!instanced(node)) {
      std::array<float, 3> t{0.0f, 0.0f, 0.0f};
      std::array<float, 4> r{0.0f, 0.0f, 0.0f, 1.0f};
      for (std::size_t k = 0; k < node.translation.size(); ++k) t[k] = static_cast<float>(node.translation[k]);
      for (std::size_t k = 0; k < node.rotation.size(); ++k) r[k] = static_cast<float>(node.rotation[k]);
      EXPECT_TRUE(node.scale.empty()) << node.name;
      out.emplace_back(node.mesh, t, r);
      continue;
    }
    EXPECT_TRUE(node.translation.empty() && node.rotation.empty() && node.scale.empty()) << node.name;
    const std::size_t n = copies(model, node);
    const std::vector<float> t = floats(model, instanceAttribute(node, "TRANSLATION"), TINYGLTF_TYPE_VEC3, 3);
    const std::vector<float> r = floats(model, instanceAttribute(node, "ROTATION"), TINYGLTF_TYPE_VEC4, 4);
    const std::vector<float> s = floats(model, instanceAttribute(node, "SCALE"), TINYGLTF_TYPE_VEC3, 3);
    for (std::size_t i = 0; i < n && 4 * i + 3 < r.size() && 3 * i + 2 < t.size(); ++i) {
      EXPECT_TRUE(s[3 * i] == 1.0f && s[3 * i + 1] == 1.0f && s[3 * i + 2] == 1.0f) << node.name << " " << i;
      out.emplace_back(node.mesh, std::array<float, 3>{t[3 * i], t[3 * i + 1], t[3 * i + 2]},
                       std::array<float, 4>{r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The file's JSON chunk, parsed.
nlohmann::json glbJson(const std::string& bytes) {
  if (bytes.size() < 20) return nlohmann::json();
  std::uint32_t length = 0;
  std::memcpy(&length, bytes.data() + 12, 4);
  return nlohmann::json::parse(bytes.substr(20, length));
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

// A level of ten million triangles: the densest layout with finer facades reaches the budget (no "tops out").
TEST(Scenegen, CityReachesTenMillionTriangles) {
  const std::string dir = tempDir();
  std::string out;
  ASSERT_TRUE(generate("city --triangles 10000000 -o " + dir + "/city.glb", &out));
  EXPECT_EQ(out.find("tops out"), std::string::npos) << out;
  const size_t colon = out.find("city: ");
  ASSERT_NE(colon, std::string::npos) << out;
  expectWithinBudget(std::stoull(out.substr(colon + 6)), 10000000);
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

// --point-lights: the same city and places, point lights (ManyPSMs' scene: 120 lights, 720 views) whose range
// reaches the ground below them.
TEST(Scenegen, CitySpotsCanCarryPointLightsInstead) {
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("city-spots --triangles 20000 --lights 12 --seed 5 -o " + dir + "/spots.glb"));
  ASSERT_TRUE(generate("city-spots --triangles 20000 --lights 12 --seed 5 --point-lights -o " + dir + "/points.glb"));
  const gltf::Model spots = load(dir + "/spots.glb"), points = load(dir + "/points.glb");
  ASSERT_EQ(points.lights.size(), 12u);
  ASSERT_EQ(points.nodes.size(), spots.nodes.size());
  EXPECT_EQ(points.meshes.size(), spots.meshes.size());
  for (size_t i = 0; i < points.nodes.size(); ++i) {
    const int index = lightOf(points.nodes[i]);
    if (index < 0) continue;
    const gltf::Light& light = points.lights[static_cast<std::size_t>(index)];
    EXPECT_EQ(light.type, "point") << light.name;
    EXPECT_EQ(points.nodes[i].translation, spots.nodes[i].translation) << light.name;
    EXPECT_GT(light.range, points.nodes[i].translation[1]) << light.name << " does not reach the ground";
  }
  EXPECT_EQ(runTool(generator() + " city --point-lights -o " + dir + "/no.glb").exitCode, 1);
}

// --ground-tiles: the same buildings, the ground slab as N x N placements of one closed tile covering the
// same square (so caster culling can leave out ground that a map does not need).
TEST(Scenegen, GroundTilesCoverTheSlabsSquare) {
  const std::string dir = tempDir();
  ASSERT_TRUE(generate("city --triangles 20000 -o " + dir + "/plain.glb"));
  ASSERT_TRUE(generate("city --triangles 20000 --ground-tiles 4 -o " + dir + "/tiled.glb"));
  const gltf::Model plain = load(dir + "/plain.glb"), tiled = load(dir + "/tiled.glb");
  ASSERT_EQ(tiled.meshes.size(), plain.meshes.size());
  EXPECT_EQ(tiled.meshes[0].name, "ground_tile");
  EXPECT_TRUE(topology(meshTriangles(tiled, tiled.meshes[0])).closed);
  size_t tiles = 0;
  double lo = 1e9, hi = -1e9;
  for (const gltf::Node& node : tiled.nodes) {
    if (node.mesh != 0) continue;
    ++tiles;
    ASSERT_EQ(node.translation.size(), 3u);
    lo = std::min(lo, node.translation[0]);
    hi = std::max(hi, node.translation[0]);
  }
  EXPECT_EQ(tiles, 16u);
  EXPECT_DOUBLE_EQ(lo, -520.0 + 130.0);  // tile centres: the slab's 1040 in four
  EXPECT_DOUBLE_EQ(hi, 520.0 - 130.0);
  EXPECT_EQ(tiled.nodes.size(), plain.nodes.size() + 15);
  EXPECT_EQ(runTool(generator() + " landscape --ground-tiles 4 -o " + dir + "/no.glb").exitCode, 1);
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

// ---- the older scenes' bytes ---------------------------------------------------------------------------

// FNV-1a over the JSON chunk (with asset.generator's version taken out, and no padding) and the BIN chunk.
std::uint64_t stableHash(const std::string& bytes) {
  if (bytes.size() < 28) return 0;
  std::uint32_t length = 0;
  std::memcpy(&length, bytes.data() + 12, 4);
  std::string text = bytes.substr(20, length);
  while (!text.empty() && text.back() == ' ') text.pop_back();
  const std::string key = "\"generator\":\"cpvs-scenegen ";
  const std::size_t at = text.find(key);
  if (at != std::string::npos) {
    const std::size_t end = text.find('"', at + key.size());
    text.replace(at, end + 1 - at, "\"generator\":\"cpvs-scenegen\"");
  }
  std::uint64_t h = 0xcbf29ce484222325ull;
  const auto mix = [&h](const std::string& s, std::size_t from) {
    for (std::size_t i = from; i < s.size(); ++i) {
      h ^= static_cast<unsigned char>(s[i]);
      h *= 0x100000001b3ull;
    }
  };
  mix(text, 0);
  mix(bytes, 20 + std::size_t{length} + 8);
  return h;
}

TEST(Scenegen, OlderScenesKeepTheirBytes) {
  // Recorded when materials, textures and GPU instancing were added to the writer and mesh nodes' transforms
  // became 32-bit float values (so that an EXT_mesh_gpu_instancing rewrite keeps them exactly): a scene must not
  // change by accident. (A deliberate change of these generators updates the hashes here.)
  const std::string dir = tempDir();
  const std::pair<const char*, std::uint64_t> expected[] = {{"city", 0xfc53c7ab7739559aull},
                                                            {"open-city", 0xdc130fd2c9168e82ull},
                                                            {"landscape", 0x2080408ad7edddf3ull},
                                                            {"city-spots", 0xac2ffef3aaa18bddull}};
  for (const auto& [kind, hash] : expected) {
    const std::string path = dir + "/" + kind + ".glb";
    ASSERT_TRUE(generate(std::string(kind) + " --triangles 20000 --seed 3 -o " + path));
    EXPECT_EQ(stableHash(readBytes(path)), hash) << kind << ": 0x" << std::hex << stableHash(readBytes(path));
  }
}

// ---- alpha-test ----------------------------------------------------------------------------------------

const gltf::Material& materialOf(const gltf::Model& model, const gltf::Mesh& mesh) {
  static const gltf::Material none;
  if (mesh.primitives.size() != 1 || mesh.primitives[0].material < 0) {
    ADD_FAILURE() << mesh.name << ": not one primitive with a material";
    return none;
  }
  return model.materials.at(static_cast<std::size_t>(mesh.primitives[0].material));
}

// Checks what stb_image does not: every chunk's CRC-32 and the zlib stream's Adler-32 (strict decoders
// such as libpng reject a file where either is wrong). Returns an empty string or what is wrong.
std::string pngChecksumsWrong(const std::vector<unsigned char>& png) {
  std::uint32_t table[256];
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  const auto be32 = [&](std::size_t at) {
    return (std::uint32_t{png[at]} << 24) | (std::uint32_t{png[at + 1]} << 16) | (std::uint32_t{png[at + 2]} << 8) |
           std::uint32_t{png[at + 3]};
  };
  static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (png.size() < 8 || std::memcmp(png.data(), signature, 8) != 0) return "no PNG signature";
  std::string idat;
  std::size_t at = 8;
  bool ended = false;
  while (at + 12 <= png.size() && !ended) {
    const std::uint32_t length = be32(at);
    if (at + 12 + length > png.size()) return "a chunk runs past the end";
    std::uint32_t crc = 0xFFFFFFFFu;
    for (std::size_t i = at + 4; i < at + 8 + length; ++i) crc = table[(crc ^ png[i]) & 0xFFu] ^ (crc >> 8);
    const std::string type(reinterpret_cast<const char*>(&png[at + 4]), 4);
    if ((crc ^ 0xFFFFFFFFu) != be32(at + 8 + length)) return "bad CRC in chunk " + type;
    if (type == "IDAT") idat.append(reinterpret_cast<const char*>(&png[at + 8]), length);
    ended = type == "IEND";
    at += 12 + length;
  }
  if (!ended) return "no IEND";
  if (idat.size() < 6) return "no image data";
  int size = 0;
  char* raw = stbi_zlib_decode_malloc(idat.data(), static_cast<int>(idat.size()), &size);
  if (!raw) return "the zlib stream does not decode";
  std::uint32_t a = 1, b = 0;
  for (int i = 0; i < size; ++i) {
    a = (a + static_cast<unsigned char>(raw[i])) % 65521u;
    b = (b + a) % 65521u;
  }
  STBI_FREE(raw);
  const std::size_t end = idat.size();
  const std::uint32_t stored = (std::uint32_t{static_cast<unsigned char>(idat[end - 4])} << 24) |
                               (std::uint32_t{static_cast<unsigned char>(idat[end - 3])} << 16) |
                               (std::uint32_t{static_cast<unsigned char>(idat[end - 2])} << 8) |
                               std::uint32_t{static_cast<unsigned char>(idat[end - 1])};
  return stored == ((b << 16) | a) ? "" : "bad Adler-32";
}

// A texture's decoded RGBA texels and its sampler.
struct Texture {
  int width = 0, height = 0;
  std::vector<unsigned char> rgba;
  gltf::Sampler sampler;
  std::string name, mimeType;
};

Texture textureOf(const gltf::Model& model, int index) {
  Texture t;
  if (index < 0 || static_cast<std::size_t>(index) >= model.textures.size()) {
    ADD_FAILURE() << "no texture " << index;
    return t;
  }
  const gltf::Texture& tex = model.textures[static_cast<std::size_t>(index)];
  const gltf::Image& image = model.images.at(static_cast<std::size_t>(tex.source));
  EXPECT_GE(image.bufferView, 0) << "the image is embedded in the BIN chunk";
  EXPECT_EQ(image.component, 4);
  if (image.bufferView >= 0) {
    const gltf::BufferView& v = model.bufferViews.at(static_cast<std::size_t>(image.bufferView));
    const std::vector<unsigned char>& buffer = model.buffers.at(static_cast<std::size_t>(v.buffer)).data;
    EXPECT_EQ(v.target, 0) << "an image's buffer view has no target";
    const std::vector<unsigned char> png(buffer.begin() + static_cast<std::ptrdiff_t>(v.byteOffset),
                                         buffer.begin() + static_cast<std::ptrdiff_t>(v.byteOffset + v.byteLength));
    EXPECT_EQ(pngChecksumsWrong(png), "") << tex.name;
  }
  t.width = image.width;
  t.height = image.height;
  t.rgba = image.image;
  t.name = tex.name;
  t.mimeType = image.mimeType;
  if (tex.sampler >= 0) t.sampler = model.samplers.at(static_cast<std::size_t>(tex.sampler));
  return t;
}

TEST(Scenegen, AlphaTestSceneFollowsItsSpecification) {
  const std::string dir = tempDir();
  std::string out;
  ASSERT_TRUE(generate("alpha-test -o " + dir + "/a.glb", &out));
  ASSERT_TRUE(generate("alpha-test -o " + dir + "/b.glb"));
  const std::string bytes = readBytes(dir + "/a.glb");
  EXPECT_EQ(bytes, readBytes(dir + "/b.glb"));
  EXPECT_NE(out.find("alpha-test: 8 triangles"), std::string::npos) << out;

  // The JSON as written: materials, alpha modes, the texture.
  const nlohmann::json j = glbJson(bytes);
  ASSERT_TRUE(j.is_object());
  std::map<std::string, nlohmann::json> materials;
  for (const nlohmann::json& m : j.at("materials")) materials[m.at("name").get<std::string>()] = m;
  ASSERT_EQ(materials.size(), 4u);
  EXPECT_EQ(materials.at("Ground").at("alphaMode"), "OPAQUE");
  EXPECT_EQ(materials.at("Ground").at("pbrMetallicRoughness").at("baseColorFactor"), nlohmann::json({1.0, 1.0, 1.0, 1.0}));
  EXPECT_FALSE(materials.at("Ground").at("pbrMetallicRoughness").contains("baseColorTexture"));
  EXPECT_EQ(materials.at("LeafMask").at("alphaMode"), "MASK");
  EXPECT_EQ(materials.at("LeafMask").at("alphaCutoff"), 0.5);
  EXPECT_EQ(materials.at("LeafMask").at("doubleSided"), true);
  EXPECT_EQ(materials.at("LeafMask").at("pbrMetallicRoughness").at("baseColorFactor"), nlohmann::json({1.0, 1.0, 1.0, 1.0}));
  EXPECT_EQ(materials.at("ClearGlass").at("alphaMode"), "BLEND");
  EXPECT_EQ(materials.at("ClearGlass").at("doubleSided"), true);
  EXPECT_EQ(materials.at("ClearGlass").at("pbrMetallicRoughness").at("baseColorFactor"), nlohmann::json({0.8, 0.9, 1.0, 0.1}));
  EXPECT_FALSE(materials.at("ClearGlass").at("pbrMetallicRoughness").contains("baseColorTexture"));
  EXPECT_FALSE(materials.at("ClearGlass").contains("alphaCutoff"));
  EXPECT_EQ(materials.at("CheckerOpaque").at("alphaMode"), "OPAQUE");
  for (const char* name : {"LeafMask", "CheckerOpaque"}) {
    const nlohmann::json& info = materials.at(name).at("pbrMetallicRoughness").at("baseColorTexture");
    EXPECT_EQ(info.at("index"), 0) << name;
    EXPECT_EQ(info.at("texCoord"), 0) << name;
  }
  ASSERT_EQ(j.at("textures").size(), 1u);
  ASSERT_EQ(j.at("images").size(), 1u);
  EXPECT_EQ(j.at("images")[0].at("mimeType"), "image/png");
  EXPECT_EQ(j.at("images")[0].at("name"), "Checker");
  EXPECT_EQ(j.at("samplers")[0], nlohmann::json({{"magFilter", 9728}, {"minFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33071}}));
  EXPECT_FALSE(j.contains("extensionsRequired"));

  // The geometry, loaded.
  const gltf::Model model = load(dir + "/a.glb");
  ASSERT_EQ(model.meshes.size(), 4u);
  ASSERT_EQ(model.nodes.size(), 5u);
  struct Quad {
    const char* mesh;
    const char* material;
    float x0, x1, z0, z1, y;
    bool uv;
    float u0;  // u = (x - u0) / 2, v = (z + 1) / 2
  };
  const Quad quads[] = {{"Ground", "Ground", -4.0f, 4.0f, -4.0f, 4.0f, 0.0f, false, 0.0f},
                        {"MaskCard", "LeafMask", -3.5f, -1.5f, -1.0f, 1.0f, 1.0f, true, -3.5f},
                        {"GlassPane", "ClearGlass", -1.0f, 1.0f, -1.0f, 1.0f, 1.0f, false, 0.0f},
                        {"OpaqueCard", "CheckerOpaque", 1.5f, 3.5f, -1.0f, 1.0f, 1.0f, true, 1.5f}};
  for (const Quad& q : quads) {
    const auto mesh = std::find_if(model.meshes.begin(), model.meshes.end(),
                                   [&](const gltf::Mesh& m) { return m.name == q.mesh; });
    ASSERT_NE(mesh, model.meshes.end()) << q.mesh;
    EXPECT_EQ(materialOf(model, *mesh).name, q.material);
    const int index = static_cast<int>(mesh - model.meshes.begin());
    int nodes = 0;
    for (const gltf::Node& node : model.nodes) {
      if (node.mesh != index) continue;
      ++nodes;
      EXPECT_TRUE(node.translation.empty() && node.rotation.empty() && node.scale.empty() && node.matrix.empty())
          << q.mesh << ": not at identity";
      EXPECT_FALSE(instanced(node));
    }
    EXPECT_EQ(nodes, 1) << q.mesh;
    const Triangles t = meshTriangles(model, *mesh);
    ASSERT_EQ(t.positions.size(), 4u) << q.mesh;
    ASSERT_EQ(t.indices.size(), 6u) << q.mesh;
    std::set<std::pair<float, float>> corners;
    for (const glm::vec3& p : t.positions) {
      EXPECT_EQ(p.y, q.y) << q.mesh;
      EXPECT_TRUE(p.x == q.x0 || p.x == q.x1) << q.mesh << " x " << p.x;
      EXPECT_TRUE(p.z == q.z0 || p.z == q.z1) << q.mesh << " z " << p.z;
      corners.insert({p.x, p.z});
    }
    EXPECT_EQ(corners.size(), 4u) << q.mesh;
    double area = 0.0;
    for (int f = 0; f < 2; ++f) {
      const glm::dvec3 a(t.positions[t.indices[3 * f]]), b(t.positions[t.indices[3 * f + 1]]),
          c(t.positions[t.indices[3 * f + 2]]);
      const glm::dvec3 n = glm::cross(b - a, c - a);
      EXPECT_GT(n.y, 0.0) << q.mesh << ": triangle " << f << " is not counter-clockwise seen from +y";
      area += 0.5 * glm::length(n);
    }
    EXPECT_DOUBLE_EQ(area, (q.x1 - q.x0) * (q.z1 - q.z0)) << q.mesh;
    const gltf::Primitive& prim = mesh->primitives[0];
    const auto uv = prim.attributes.find("TEXCOORD_0");
    ASSERT_EQ(uv != prim.attributes.end(), q.uv) << q.mesh;
    if (!q.uv) continue;
    const std::vector<float> uvs = floats(model, uv->second, TINYGLTF_TYPE_VEC2, 2);
    ASSERT_EQ(uvs.size(), 8u);
    for (std::size_t i = 0; i < 4; ++i) {
      EXPECT_EQ(uvs[2 * i], (t.positions[i].x - q.u0) / 2.0f) << q.mesh << " vertex " << i;
      EXPECT_EQ(uvs[2 * i + 1], (t.positions[i].z + 1.0f) / 2.0f) << q.mesh << " vertex " << i;
    }
  }

  // The checker: texel (i, j), row 0 the image's top, green with alpha 255 where i + j is even, 0 where odd.
  const gltf::Material& mask = materialOf(model, model.meshes[1]);
  const Texture checker = textureOf(model, mask.pbrMetallicRoughness.baseColorTexture.index);
  EXPECT_EQ(checker.name, "Checker");
  EXPECT_EQ(checker.mimeType, "image/png");
  EXPECT_EQ(checker.sampler.magFilter, TINYGLTF_TEXTURE_FILTER_NEAREST);
  EXPECT_EQ(checker.sampler.minFilter, TINYGLTF_TEXTURE_FILTER_NEAREST);
  EXPECT_EQ(checker.sampler.wrapS, TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE);
  EXPECT_EQ(checker.sampler.wrapT, TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE);
  ASSERT_EQ(checker.width, 8);
  ASSERT_EQ(checker.height, 8);
  ASSERT_EQ(checker.rgba.size(), 256u);
  for (int row = 0; row < 8; ++row) {
    for (int col = 0; col < 8; ++col) {
      const unsigned char* texel = &checker.rgba[static_cast<std::size_t>(4 * (8 * row + col))];
      EXPECT_EQ(texel[0], 51);
      EXPECT_EQ(texel[1], 153);
      EXPECT_EQ(texel[2], 51);
      EXPECT_EQ(texel[3], (col + row) % 2 == 0 ? 255 : 0) << "texel " << col << ", " << row;
    }
  }

  // The sun: the only light, directional, intensity 1, shining straight down from a node at the origin.
  ASSERT_EQ(model.lights.size(), 1u);
  EXPECT_EQ(model.lights[0].type, "directional");
  EXPECT_EQ(model.lights[0].name, "Sun");
  EXPECT_EQ(model.lights[0].intensity, 1.0);
  for (const gltf::Node& node : model.nodes) {
    if (lightOf(node) != 0) continue;
    EXPECT_EQ(node.name, "Sun");
    EXPECT_TRUE(node.translation.empty());
    const glm::dvec3 d = lightDirection(node);
    EXPECT_NEAR(d.x, 0.0, 1e-12);
    EXPECT_NEAR(d.y, -1.0, 1e-12);
    EXPECT_NEAR(d.z, 0.0, 1e-12);
  }
}

// ---- foliage ---------------------------------------------------------------------------------------------

TEST(Scenegen, FoliageInstancesLeafCardsWithAMaskedTexture) {
  const std::string dir = tempDir();
  std::string out;
  ASSERT_TRUE(generate("foliage -o " + dir + "/a.glb", &out));
  ASSERT_TRUE(generate("foliage -o " + dir + "/b.glb"));
  ASSERT_TRUE(generate("foliage --seed 2 -o " + dir + "/c.glb"));
  const std::string bytes = readBytes(dir + "/a.glb");
  EXPECT_EQ(bytes, readBytes(dir + "/b.glb"));
  EXPECT_NE(bytes, readBytes(dir + "/c.glb"));

  const gltf::Model model = load(dir + "/a.glb");
  for (const char* ext : {"EXT_mesh_gpu_instancing", "KHR_lights_punctual"})
    EXPECT_NE(std::find(model.extensionsUsed.begin(), model.extensionsUsed.end(), ext), model.extensionsUsed.end()) << ext;
  EXPECT_EQ(model.extensionsRequired, std::vector<std::string>{"EXT_mesh_gpu_instancing"});

  // Budget: the default is 200,000 triangles after instancing, and the summary says how many.
  const std::uint64_t triangles = instancedTriangles(model);
  expectWithinBudget(triangles, 200000);
  EXPECT_NE(out.find("foliage: " + std::to_string(triangles) + " triangles"), std::string::npos) << out;

  std::size_t crowns = 0, trees = 0, leafTexture = 0;
  bool leafTextureSeen = false, glassSeen = false;
  for (const gltf::Node& node : model.nodes) {
    if (node.mesh < 0) continue;
    const gltf::Mesh& mesh = model.meshes.at(static_cast<std::size_t>(node.mesh));
    const gltf::Material& material = materialOf(model, mesh);
    if (material.alphaMode == "BLEND") {  // glass: clear, untextured, casts no shadow when clipped at 0.5
      glassSeen = true;
      EXPECT_LT(material.pbrMetallicRoughness.baseColorFactor.at(3), 0.5) << material.name;
      EXPECT_LT(material.pbrMetallicRoughness.baseColorTexture.index, 0) << material.name;
    }
    if (!instanced(node)) {
      EXPECT_NE(material.alphaMode, "MASK") << mesh.name;
      continue;
    }
    // Every instanced node: three float attributes of one count, unit rotations about y, uniform scale
    // 0.8 .. 1.3, trees on the ground inside the level.
    const std::size_t n = copies(model, node);
    EXPECT_GT(n, 0u) << node.name;
    const std::vector<float> t = floats(model, instanceAttribute(node, "TRANSLATION"), TINYGLTF_TYPE_VEC3, 3);
    const std::vector<float> r = floats(model, instanceAttribute(node, "ROTATION"), TINYGLTF_TYPE_VEC4, 4);
    const std::vector<float> s = floats(model, instanceAttribute(node, "SCALE"), TINYGLTF_TYPE_VEC3, 3);
    ASSERT_EQ(t.size(), 3 * n);
    ASSERT_EQ(r.size(), 4 * n);
    ASSERT_EQ(s.size(), 3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_EQ(t[3 * i + 1], 0.0f);
      EXPECT_LE(std::abs(t[3 * i]), 200.0f);
      EXPECT_LE(std::abs(t[3 * i + 2]), 200.0f);
      EXPECT_EQ(r[4 * i], 0.0f);
      EXPECT_EQ(r[4 * i + 2], 0.0f);
      EXPECT_NEAR(std::hypot(r[4 * i + 1], r[4 * i + 3]), 1.0, 1e-6);
      EXPECT_TRUE(s[3 * i] == s[3 * i + 1] && s[3 * i] == s[3 * i + 2]);
      EXPECT_GE(s[3 * i], 0.8f - 1e-6f);
      EXPECT_LE(s[3 * i], 1.3f + 1e-6f);
    }
    if (material.alphaMode == "OPAQUE") {  // a trunk: a closed, outward solid
      const Topology topo = topology(meshTriangles(model, mesh));
      EXPECT_TRUE(topo.closed) << mesh.name;
      EXPECT_GT(topo.minComponentVolume, 0.0) << mesh.name;
      trees += n;
      continue;
    }
    // A crown: 20 .. 60 leaf cards of two triangles, masked, double-sided, textured over [0, 1]^2.
    ++crowns;
    EXPECT_EQ(material.alphaMode, "MASK") << mesh.name;
    EXPECT_EQ(material.alphaCutoff, 0.5);
    EXPECT_TRUE(material.doubleSided);
    const std::uint64_t faces = meshTriangles(model, mesh).indices.size() / 3;
    EXPECT_GE(faces, 40u) << mesh.name;
    EXPECT_LE(faces, 120u) << mesh.name;
    const gltf::Primitive& prim = mesh.primitives.at(0);
    ASSERT_TRUE(prim.attributes.count("TEXCOORD_0")) << mesh.name;
    for (const float c : floats(model, prim.attributes.at("TEXCOORD_0"), TINYGLTF_TYPE_VEC2, 2)) {
      EXPECT_GE(c, 0.0f);
      EXPECT_LE(c, 1.0f);
    }
    const int texture = material.pbrMetallicRoughness.baseColorTexture.index;
    ASSERT_GE(texture, 0) << mesh.name;
    if (leafTextureSeen) {
      EXPECT_EQ(static_cast<std::size_t>(texture), leafTexture);
    }
    leafTexture = static_cast<std::size_t>(texture);
    leafTextureSeen = true;
  }
  EXPECT_TRUE(glassSeen);
  EXPECT_GE(crowns, 2u);
  EXPECT_LE(crowns, 4u);
  EXPECT_GE(trees, 1000u) << "trunk instances";

  // The leaf texture: RGBA, alpha 0 or 255 only, about half the texels covered.
  ASSERT_TRUE(leafTextureSeen);
  const Texture leaves = textureOf(model, static_cast<int>(leafTexture));
  EXPECT_EQ(leaves.mimeType, "image/png");
  EXPECT_GE(leaves.width, 64);
  EXPECT_GE(leaves.height, 64);
  ASSERT_EQ(leaves.rgba.size(), static_cast<std::size_t>(leaves.width) * leaves.height * 4);
  std::size_t covered = 0, other = 0;
  for (std::size_t i = 3; i < leaves.rgba.size(); i += 4) {
    covered += leaves.rgba[i] == 255;
    other += leaves.rgba[i] != 255 && leaves.rgba[i] != 0;
  }
  const double coverage = static_cast<double>(covered) / (static_cast<double>(leaves.width) * leaves.height);
  EXPECT_GE(coverage, 0.3);
  EXPECT_LE(coverage, 0.7);
  EXPECT_EQ(other, 0u);

  // Lights: a sun and 16 spots pointing down.
  ASSERT_EQ(model.lights.size(), 17u);
  std::size_t spots = 0;
  for (const gltf::Node& node : model.nodes) {
    const int light = lightOf(node);
    if (light < 0 || model.lights.at(static_cast<std::size_t>(light)).type != "spot") continue;
    ++spots;
    EXPECT_LT(lightDirection(node).y, -0.9) << node.name;
    EXPECT_GT(model.lights[static_cast<std::size_t>(light)].range, 20.0);
  }
  EXPECT_EQ(spots, 16u);
}

// ---- --gpu-instancing -------------------------------------------------------------------------------------

TEST(Scenegen, GpuInstancingPlacesTheSameMeshesAtTheSameTransforms) {
  const std::string dir = tempDir();
  for (const std::string args : {"city --triangles 30000 --seed 7", "open-city --triangles 20000 --seed 5",
                                 "city-spots --triangles 20000 --lights 12 --seed 4"}) {
    std::string plainOut, instancedOut;
    ASSERT_TRUE(generate(args + " -o " + dir + "/plain.glb", &plainOut));
    ASSERT_TRUE(generate(args + " --gpu-instancing -o " + dir + "/inst.glb", &instancedOut));
    const gltf::Model plain = load(dir + "/plain.glb");
    const gltf::Model inst = load(dir + "/inst.glb");
    EXPECT_TRUE(plain.extensionsRequired.empty()) << args;
    EXPECT_EQ(inst.extensionsRequired, std::vector<std::string>{"EXT_mesh_gpu_instancing"}) << args;

    // The same triangles after instancing, as counted here and as printed.
    const std::uint64_t triangles = instancedTriangles(plain);
    EXPECT_EQ(instancedTriangles(inst), triangles) << args;
    const std::string count = std::to_string(triangles) + " triangles";
    EXPECT_NE(plainOut.find(count), std::string::npos) << plainOut;
    EXPECT_NE(instancedOut.find(count), std::string::npos) << instancedOut;

    // The same meshes, each placed by one instanced node, at bit-identical float transforms.
    const nlohmann::json a = glbJson(readBytes(dir + "/plain.glb")), b = glbJson(readBytes(dir + "/inst.glb"));
    EXPECT_EQ(a.at("meshes"), b.at("meshes")) << args;
    std::set<int> meshNodes;
    for (const gltf::Node& node : inst.nodes) {
      if (node.mesh < 0) continue;
      EXPECT_TRUE(instanced(node)) << node.name;
      EXPECT_TRUE(meshNodes.insert(node.mesh).second) << "mesh " << node.mesh << " has two nodes";
    }
    EXPECT_EQ(meshNodes.size(), inst.meshes.size()) << args;
    const std::vector<Placement> p = placements(plain), q = placements(inst);
    EXPECT_EQ(p.size(), q.size()) << args;
    EXPECT_TRUE(p == q) << args << ": the instances differ from the nodes";

    // The lights are unchanged, on their own nodes.
    std::vector<nlohmann::json> lightsA, lightsB;
    for (const nlohmann::json& n : a.at("nodes"))
      if (!n.contains("mesh")) lightsA.push_back(n);
    for (const nlohmann::json& n : b.at("nodes"))
      if (!n.contains("mesh")) lightsB.push_back(n);
    EXPECT_FALSE(lightsA.empty());
    EXPECT_EQ(lightsA, lightsB) << args;
    EXPECT_EQ(a.at("extensions"), b.at("extensions")) << args;
  }
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
  EXPECT_EQ(runTool(generator() + " foliage --lights 0 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " landscape --lights 3 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " alpha-test --lights 3 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " alpha-test --triangles 10000 -o " + dir + "/x.glb").exitCode, 1);
  EXPECT_EQ(runTool(generator() + " alpha-test --seed 2 -o " + dir + "/x.glb").exitCode, 1);
  for (const char* kind : {"landscape", "foliage", "alpha-test"})
    EXPECT_EQ(runTool(generator() + " " + kind + " --gpu-instancing -o " + dir + "/x.glb").exitCode, 1) << kind;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.glb"));
  const cpvs::test::ToolResult missing =
      runTool(generator() + " city --triangles 5000 -o " + dir + "/no/such/dir/x.glb");
  EXPECT_EQ(missing.exitCode, 3) << missing.output;
  EXPECT_NE(missing.output.find("no/such/dir/x.glb"), std::string::npos) << missing.output;
}

}  // namespace
