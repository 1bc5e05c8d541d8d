// Import of what glTF pipelines ship: EXT/KHR_meshopt_compression, KHR_draco_mesh_compression and
// EXT_mesh_gpu_instancing, each against the uncompressed scene or a reference decoder's output (the files in
// tests/data/compressed/, made as its README.md says); hostile streams; unsupported geometry extensions.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/base/error.h"
#include "libcpvs/scene/scene.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using nlohmann::json;

std::string compressed(const std::string& name) { return test::sourcePath("tests/data/compressed/" + name); }

std::vector<unsigned char> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// A GLB as its JSON and its BIN chunk, and back.
struct Glb {
  json gltf;
  std::vector<unsigned char> bin;
};

uint32_t readU32(const std::vector<unsigned char>& bytes, size_t at) {
  uint32_t value;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

Glb readGlb(const std::string& path) {
  const std::vector<unsigned char> bytes = readBytes(path);
  const uint32_t jsonLength = readU32(bytes, 12);
  Glb glb;
  glb.gltf = json::parse(bytes.begin() + 20, bytes.begin() + 20 + jsonLength);
  const size_t binAt = 20 + jsonLength;
  if (binAt + 8 <= bytes.size()) glb.bin.assign(bytes.begin() + std::ptrdiff_t(binAt + 8), bytes.begin() + std::ptrdiff_t(binAt + 8 + readU32(bytes, binAt)));
  return glb;
}

void writeGlb(const std::string& path, const Glb& glb) {
  std::string text = glb.gltf.dump();
  while (text.size() % 4) text += ' ';
  std::vector<unsigned char> bin = glb.bin;
  while (bin.size() % 4) bin.push_back(0);
  std::vector<unsigned char> out;
  auto u32 = [&](uint32_t v) {
    for (int b = 0; b < 4; ++b) out.push_back((v >> (8 * b)) & 0xff);
  };
  u32(0x46546C67u), u32(2), u32(uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  u32(uint32_t(text.size())), u32(0x4E4F534Au);
  out.insert(out.end(), text.begin(), text.end());
  u32(uint32_t(bin.size())), u32(0x004E4942u);
  out.insert(out.end(), bin.begin(), bin.end());
  writeBytes(path, out);
}

size_t worldTriangles(const Scene& scene) {
  size_t triangles = 0;
  for (const Instance& instance : scene.instances) triangles += scene.meshes[instance.mesh].triangleCount();
  return triangles;
}

// Triangle t of `indices` turned so that its smallest index comes first (winding kept).
std::vector<uint32_t> rotatedTriangles(std::vector<uint32_t> indices) {
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    const auto first = indices.begin() + std::ptrdiff_t(t);
    std::rotate(first, std::min_element(first, first + 3), first + 3);
  }
  return indices;
}

// The two scenes hold the same meshes (positions bit for bit; indices too, or triangle by triangle up to a
// rotation that keeps the winding where `rotatedTriangles`: meshopt's TRIANGLES codec may rotate them),
// instances and lights.
void expectSameScene(const Scene& actual, const Scene& expected, bool rotatedTriangles = false) {
  ASSERT_EQ(actual.meshes.size(), expected.meshes.size());
  for (size_t m = 0; m < expected.meshes.size(); ++m) {
    const Mesh& a = actual.meshes[m];
    const Mesh& e = expected.meshes[m];
    EXPECT_EQ(a.name, e.name);
    ASSERT_EQ(a.positions.size(), e.positions.size()) << e.name;
    EXPECT_TRUE(std::memcmp(a.positions.data(), e.positions.data(), e.positions.size() * sizeof(glm::vec3)) == 0) << e.name;
    if (rotatedTriangles)
      EXPECT_EQ(cpvs::rotatedTriangles(a.indices), cpvs::rotatedTriangles(e.indices)) << e.name;
    else
      EXPECT_EQ(a.indices, e.indices) << e.name;
    EXPECT_EQ(a.closed, e.closed) << e.name;
  }
  ASSERT_EQ(actual.instances.size(), expected.instances.size());
  for (size_t i = 0; i < expected.instances.size(); ++i) {
    EXPECT_EQ(actual.instances[i].mesh, expected.instances[i].mesh);
    EXPECT_EQ(actual.instances[i].node, expected.instances[i].node);
    EXPECT_TRUE(actual.instances[i].worldFromLocal == expected.instances[i].worldFromLocal) << i;
  }
  EXPECT_EQ(actual.lights.size(), expected.lights.size());
}

// Same triangle counts, and every vertex within `tolerance` of the uncompressed one (the encoder quantized it).
void expectCloseScene(const Scene& actual, const Scene& expected, double tolerance) {
  EXPECT_EQ(worldTriangles(actual), worldTriangles(expected));
  const WorldGeometry a = flatten(actual), e = flatten(expected);
  EXPECT_EQ(a.triangleCount(), e.triangleCount());
  EXPECT_EQ(a.closedTriangleCount, e.closedTriangleCount);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(a.bounds.min[c], e.bounds.min[c], tolerance);
    EXPECT_NEAR(a.bounds.max[c], e.bounds.max[c], tolerance);
  }
}

// Expects importGltf(path) to throw `category` with a message naming the file and containing `detail`.
void expectError(const std::string& path, ErrorCategory category, const std::string& detail) {
  try {
    importGltf(path);
    ADD_FAILURE() << path << ": imported without an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), category) << e.what();
    const std::string message = e.what();
    EXPECT_NE(message.find(std::filesystem::path(path).filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find(detail), std::string::npos) << "expected '" << detail << "' in: " << message;
  }
}

// ---------------------------------------------------------------------------------------------------------
// meshopt

TEST(CompressedImport, LosslessKhrMeshoptGlbEqualsTheUncompressedScene) {
  // Every view compressed as stored (ATTRIBUTES with an interleaved stride, TRIANGLES, one plain view), a
  // tagged fallback buffer: the import is the original's, bit for bit (triangles maybe rotated).
  const Scene scene = importGltf(compressed("tiny_meshopt_khr.glb"));
  expectSameScene(scene, importGltf(test::sourcePath("data/scenes/Tiny/tiny.gltf")), /*rotatedTriangles=*/true);
  EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
}

TEST(CompressedImport, LosslessMeshoptGltfWithAnUntaggedFallbackBufferEqualsTheUncompressedScene) {
  // A .gltf whose fallback buffer has neither uri nor tag (tinygltf alone refuses it), INDICES mode.
  const Scene scene = importGltf(compressed("torusknot_meshopt_lossless.gltf"));
  expectSameScene(scene, importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf")));
}

TEST(CompressedImport, FilteredMeshoptEqualsTheReferenceDecoder) {
  // gltf-transform meshopt: quantized, reordered, OCTAHEDRAL normals; against glTF-Transform's own decode.
  const Scene scene = importGltf(compressed("torusknot_meshopt.glb"));
  expectSameScene(scene, importGltf(compressed("torusknot_meshopt_decoded.glb")));
  expectCloseScene(scene, importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf")), 1e-3);
}

// ---------------------------------------------------------------------------------------------------------
// Draco

TEST(CompressedImport, DracoEqualsTheReferenceDecoderAndTheSceneWithinItsQuantization) {
  const Scene scene = importGltf(compressed("torusknot_draco.glb"));
  expectSameScene(scene, importGltf(compressed("torusknot_draco_decoded.glb")));
  // 16-bit positions over a knot about 41 units wide: steps of 6e-4.
  expectCloseScene(scene, importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf")), 6e-4);
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_TRUE(scene.meshes[0].closed);
}

TEST(CompressedImport, SequentialDracoWithSeveralMeshesInstancesAndLights) {
  const Scene scene = importGltf(compressed("tiny_draco.glb"));
  const Scene original = importGltf(test::sourcePath("data/scenes/Tiny/tiny.gltf"));
  expectCloseScene(scene, original, 1e-3);
  EXPECT_EQ(scene.instances.size(), original.instances.size());
  EXPECT_EQ(scene.lights.size(), 2u);
}

// ---------------------------------------------------------------------------------------------------------
// EXT_mesh_gpu_instancing

TEST(CompressedImport, GpuInstancesReplaceTheNodesOwnPlacement) {
  // gltf-transform instance: the box's two nodes (one mirrored by scale (-1, 2, 1)) became one node with
  // TRANSLATION and SCALE; the world is the original's.
  const Scene scene = importGltf(compressed("tiny_instanced.glb"));
  const Scene original = importGltf(test::sourcePath("data/scenes/Tiny/tiny.gltf"));
  EXPECT_EQ(scene.instances.size(), original.instances.size());
  expectCloseScene(scene, original, 1e-6);
  std::vector<std::string> names;
  for (const Instance& instance : scene.instances) names.push_back(instance.node);
  EXPECT_NE(std::find(names.begin(), names.end(), "node4[0]"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "node4[1]"), names.end());
  EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
}

TEST(CompressedImport, InstancedMeshoptCityHasTheOriginalsInstancesAndTriangles) {
  // The generated city rewritten with gltf-transform instance, then meshopt (QUATERNION rotations,
  // EXPONENTIAL translations and scales): the counts cpvs-info gave for the original.
  const Scene scene = importGltf(compressed("city_instanced_meshopt.glb"));
  EXPECT_EQ(scene.instances.size(), 66u);
  EXPECT_EQ(worldTriangles(scene), 4986u);
}

// ---------------------------------------------------------------------------------------------------------
// The gltfpack-compressed dioramas (data/SOURCES.md)

TEST(CompressedImport, GltfpackDioramasImportAndBake) {
  const std::string macross = test::sourcePath("data/scenes/MacrossCityDiorama/scene.glb");
  const std::string garden = test::sourcePath("data/scenes/JapaneseBridgeGarden/scene.glb");
  EXPECT_EQ(worldTriangles(importGltf(macross)), 102822u);
  EXPECT_EQ(worldTriangles(importGltf(garden)), 21883u);
  const std::string dir = test::tempDir();
  for (const std::string& scene : {macross, garden}) {
    const test::ToolResult bake = test::runTool(test::toolPath("cpvs-bake") + " " + scene + " -o " + dir +
                                                "/diorama.cpvs --sun 0.3,-1,0.2 -r 1k --quiet");
    EXPECT_EQ(bake.exitCode, 0) << scene << ": " << bake.output;
  }
}

// ---------------------------------------------------------------------------------------------------------
// Hostile and unsupported input

class CompressedBadInput : public ::testing::Test {
protected:
  std::string dir = test::tempDir();

  // A copy of the lossless TorusKnot .gltf (JSON and .bin) with `edit` applied to either.
  std::string meshoptGltf(const std::string& name, const std::function<void(json&, std::vector<unsigned char>&)>& edit) {
    json gltf = json::parse(readBytes(compressed("torusknot_meshopt_lossless.gltf")));
    std::vector<unsigned char> bin = readBytes(compressed("torusknot_meshopt_lossless.bin"));
    gltf["buffers"][0]["uri"] = name + ".bin";
    edit(gltf, bin);
    writeBytes(dir + "/" + name + ".bin", bin);
    std::ofstream(dir + "/" + name + ".gltf") << gltf.dump();
    return dir + "/" + name + ".gltf";
  }
  std::string glb(const std::string& source, const std::string& name, const std::function<void(Glb&)>& edit) {
    Glb file = readGlb(compressed(source));
    edit(file);
    writeGlb(dir + "/" + name, file);
    return dir + "/" + name;
  }
  int infoExitCode(const std::string& path, std::string* output = nullptr) {
    const test::ToolResult result = test::runTool(test::toolPath("cpvs-info") + " " + path);
    if (output) *output = result.output;
    return result.exitCode;
  }
};

TEST_F(CompressedBadInput, CorruptMeshoptStreamsNameTheBufferView) {
  auto streamAt = [](const json& gltf, int view) {
    return gltf["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]["byteOffset"].get<size_t>();
  };
  const std::string header = meshoptGltf("bad_header", [&](json& gltf, std::vector<unsigned char>& bin) {
    bin[streamAt(gltf, 1)] = 0x17;
  });
  expectError(header, ErrorCategory::InvalidInput, "bufferView 1 (EXT_meshopt_compression, ATTRIBUTES): corrupt stream");
  std::string output;
  EXPECT_EQ(infoExitCode(header, &output), 2) << output;
  EXPECT_NE(output.find("bufferView 1"), std::string::npos) << output;

  // A stream cut short: the decoder runs out of bytes.
  const std::string cut = meshoptGltf("cut", [&](json& gltf, std::vector<unsigned char>&) {
    gltf["bufferViews"][3]["extensions"]["EXT_meshopt_compression"]["byteLength"] = 100;
  });
  expectError(cut, ErrorCategory::InvalidInput, "bufferView 3 (EXT_meshopt_compression, INDICES): corrupt stream");
  EXPECT_EQ(infoExitCode(cut), 2);

  // Garbage in the middle of a stream: an error or garbage values, never a crash (ASan runs check).
  for (size_t at = 1; at < 2000; at += 97) {
    const std::string garbled = meshoptGltf("garbled", [&](json& gltf, std::vector<unsigned char>& bin) {
      bin[streamAt(gltf, 3) + at % 8000] ^= 0x5a;
    });
    try {
      importGltf(garbled);
    } catch (const Error& e) {
      EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
    }
  }

  // A count the stream cannot hold is refused before anything is allocated for it.
  const std::string huge = meshoptGltf("huge", [&](json& gltf, std::vector<unsigned char>&) {
    gltf["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = 1000000000;
    gltf["bufferViews"][0]["byteLength"] = 4000000000u;
    gltf["buffers"][1]["byteLength"] = 4000000000u;
  });
  expectError(huge, ErrorCategory::InvalidInput, "more elements than a stream of that size can encode");

  // A mode or stride the extension does not allow.
  const std::string mode = meshoptGltf("mode", [&](json& gltf, std::vector<unsigned char>&) {
    gltf["bufferViews"][2]["extensions"]["EXT_meshopt_compression"]["mode"] = "QUADS";
  });
  expectError(mode, ErrorCategory::InvalidInput, "bufferView 2: EXT_meshopt_compression mode 'QUADS'");
  const std::string stride = meshoptGltf("stride", [&](json& gltf, std::vector<unsigned char>&) {
    gltf["bufferViews"][2]["extensions"]["EXT_meshopt_compression"]["filter"] = "QUATERNION";
  });
  expectError(stride, ErrorCategory::InvalidInput, "filter QUATERNION needs byteStride 8");

  // A plain view that reads the fallback buffer, which has no data.
  const std::string plain = meshoptGltf("plain", [&](json& gltf, std::vector<unsigned char>&) {
    gltf["buffers"][1]["extensions"]["EXT_meshopt_compression"]["fallback"] = true;
    gltf["bufferViews"].push_back({{"buffer", 1}, {"byteLength", 4}});
  });
  expectError(plain, ErrorCategory::InvalidInput, "bufferView 4 has no meshopt extension but reads buffer 1");
}

TEST_F(CompressedBadInput, AVertexStreamOfAVersionTheLibraryCannotDecodeIsNamed) {
  const std::string v1 = meshoptGltf("version1", [&](json& gltf, std::vector<unsigned char>& bin) {
    for (json& view : gltf["bufferViews"]) {
      view["extensions"]["KHR_meshopt_compression"] = view["extensions"]["EXT_meshopt_compression"];
      view["extensions"].erase("EXT_meshopt_compression");
    }
    gltf["extensionsUsed"] = gltf["extensionsRequired"] = {"KHR_meshopt_compression"};
    bin[gltf["bufferViews"][0]["extensions"]["KHR_meshopt_compression"]["byteOffset"].get<size_t>()] = 0xa1;
  });
  expectError(v1, ErrorCategory::InvalidInput, "bufferView 0 (KHR_meshopt_compression, ATTRIBUTES): vertex stream version 1");
}

TEST_F(CompressedBadInput, CorruptDracoStreamsNameTheMeshAndPrimitive) {
  // Bytes of the second mesh's stream overwritten: the decoder fails, or what it gives is checked.
  int errors = 0;
  for (size_t at = 0; at < 200; at += 7) {
    const std::string path = glb("tiny_draco.glb", "bad_draco.glb", [&](Glb& file) {
      const json& view = file.gltf["bufferViews"][1];
      const size_t offset = view.value("byteOffset", size_t(0));
      if (at < view["byteLength"].get<size_t>()) file.bin[offset + at] ^= 0xff;
    });
    try {
      importGltf(path);
    } catch (const Error& e) {
      ++errors;
      EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
      EXPECT_NE(std::string(e.what()).find("primitive 0"), std::string::npos) << e.what();
    }
  }
  EXPECT_GT(errors, 0);

  // The stream cut to its first bytes.
  const std::string cut = glb("tiny_draco.glb", "cut_draco.glb", [&](Glb& file) {
    file.gltf["bufferViews"][1]["byteLength"] = 20;
  });
  const std::string mesh = readGlb(compressed("tiny_draco.glb")).gltf["meshes"][1]["name"].get<std::string>();
  expectError(cut, ErrorCategory::InvalidInput, "mesh '" + mesh + "' primitive 0: KHR_draco_mesh_compression: corrupt Draco stream in bufferView 1");
  std::string output;
  EXPECT_EQ(infoExitCode(cut, &output), 2) << output;

  // An accessor count that disagrees with the stream.
  const std::string count = glb("tiny_draco.glb", "count_draco.glb", [&](Glb& file) {
    file.gltf["accessors"][1]["count"] = 9;
  });
  expectError(count, ErrorCategory::InvalidInput, "POSITION accessor 1 has count 9, the Draco stream 8 points");
}

TEST_F(CompressedBadInput, InstanceAttributeCountsMustAgree) {
  const std::string path = glb("tiny_instanced.glb", "mismatch.glb", [&](Glb& file) {
    const int scale = file.gltf["nodes"][4]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["SCALE"];
    file.gltf["accessors"][scale]["count"] = 1;
  });
  expectError(path, ErrorCategory::InvalidInput,
              "node 4: EXT_mesh_gpu_instancing: the attributes' accessors differ in count: SCALE (accessor 6, count 1), "
              "TRANSLATION (accessor 5, count 2)");
  EXPECT_EQ(infoExitCode(path), 2);

  const std::string rotation = glb("tiny_instanced.glb", "rotation.glb", [&](Glb& file) {
    file.gltf["nodes"][4]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["ROTATION"] = 5;  // a VEC3
  });
  expectError(rotation, ErrorCategory::InvalidInput, "ROTATION accessor 5 is VEC3, expected VEC4");
}

TEST_F(CompressedBadInput, UnsupportedGeometryExtensionsAreRefusedWithHowToConvert) {
  for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
    json gltf = json::parse(readBytes(test::sourcePath("data/scenes/Tiny/tiny.gltf")));
    gltf[list] = {"KHR_node_visibility"};
    const std::string path = dir + "/visibility_" + list + ".gltf";
    std::ofstream(path) << gltf.dump();
    expectError(path, ErrorCategory::NotSupported, std::string(list) + " names KHR_node_visibility, which changes the geometry");
    std::string output;
    EXPECT_EQ(infoExitCode(path, &output), 5) << output;
    EXPECT_NE(output.find("KHR_node_visibility"), std::string::npos) << output;
  }
  // Refused before any buffer is read: a missing .bin does not matter.
  json gltf = json::parse(readBytes(compressed("torusknot_meshopt_lossless.gltf")));
  gltf["buffers"][0]["uri"] = "nowhere.bin";
  gltf["extensionsUsed"].push_back("KHR_mesh_primitive_restart");
  std::ofstream(dir + "/restart.gltf") << gltf.dump();
  expectError(dir + "/restart.gltf", ErrorCategory::NotSupported, "KHR_mesh_primitive_restart");
  // Material extensions are no reason to refuse a file.
  json material = json::parse(readBytes(test::sourcePath("data/scenes/Tiny/tiny.gltf")));
  material["extensionsUsed"] = {"KHR_materials_pbrSpecularGlossiness", "KHR_materials_unlit"};
  std::ofstream(dir + "/material.gltf") << material.dump();
  EXPECT_EQ(importGltf(dir + "/material.gltf").meshes.size(), 2u);
}

}  // namespace
}  // namespace cpvs
