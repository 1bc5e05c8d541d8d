#pragma once
// The glTF importer's state, shared by the files that import one concern each (docs/architecture.md,
// "import/"). importGltf() (gltf_import.cpp) runs one GltfImporter per file; its members are defined where
// their concern lives, as the groups below say. Internal to libcpvs/import.
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "libcpvs/import/compressed_geometry.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/import/materials.h"
#include "libcpvs/base/error.h"

namespace cpvs::gltf {

// Extensions and extras read by more than one concern.
inline constexpr const char* kLightsExtension = "KHR_lights_punctual";
inline constexpr const char* kInstancingExtension = "EXT_mesh_gpu_instancing";
// A node's or material's `extras` member that, set to false, keeps it from casting shadows (docs/alpha.md).
inline constexpr const char* kCastsShadowsExtra = "cpvs_casts_shadows";

class GltfImporter {
public:
  GltfImporter(std::string path, const ImportOptions& options) : path_(std::move(path)), options_(options) {}

  Scene run();

private:
  [[noreturn]] void fail(const std::string& message) const {
    throw Error(ErrorCategory::InvalidInput, path_ + ": " + message);
  }
  void warn(const std::string& message) { scene_.warnings.push_back(path_ + ": " + message); }
  void warnOnce(const std::string& message) {
    if (warnedOnce_.insert(message).second) warn(message);
  }
  // One warning per image that cannot be used, however many materials and primitives use it: what is wrong
  // with it, then each of its consequences once.
  // `user` names the material that met it first ("material 'LeafMat'").
  void warnAboutImage(int source, const std::string& user, const std::string& why, const std::string& consequence);

  // The driver (gltf_import.cpp): loading the file, the scene walk, what each node places.
  void load();
  std::string describeNode(int index) const;
  double finiteNumber(const tinygltf::Value& value, const std::string& what) const;
  std::vector<int> rootNodes() const;
  void traverse(const std::vector<int>& roots);
  bool castsShadows(const tinygltf::Node& node, const std::string& what) const;
  void place(int index, const glm::dmat4& worldFromLocal);

  // Extension lists (json_checks.cpp).
  void checkRequiredExtensions();

  // KHR_lights_punctual (lights.cpp).
  void parseLights();
  void placeLight(int index, const glm::dmat4& worldFromLocal);

  // Node transforms and EXT_mesh_gpu_instancing (instancing.cpp).
  glm::dmat4 localTransform(int index) const;
  void placeGpuInstances(int index);
  std::vector<glm::dmat4> gpuInstanceTransforms(int index, const tinygltf::Value& extension) const;

  // Cameras (cameras.cpp).
  void placeCamera(int nodeIndex, int cameraIndex, const glm::dmat4& worldFromLocal);

  // Primitives into meshes (primitives.cpp).
  const std::vector<uint32_t>& meshIds(int meshIndex);
  std::optional<Mesh> importPrimitive(const tinygltf::Primitive& primitive, const std::string& meshName,
                                      size_t primitiveIndex, bool severalPrimitives);

  // Accessors (accessors.cpp; decodeAccessor, a template, in accessors.h).
  const tinygltf::Accessor& accessor(int index, const std::string& what) const;
  const unsigned char* viewBytes(int viewIndex, size_t offset, size_t count, size_t elementSize, size_t stride,
                                 const std::string& what) const;
  template <typename Out, typename Convert>
  std::vector<Out> decodeAccessor(int index, const std::string& what, Convert convert) const;
  std::vector<glm::vec3> readPositions(int index, const std::string& where) const;
  std::vector<uint32_t> readIndices(int index, const std::string& where) const;

  // Materials: base colour, textures, alpha-tested casters, exclusions (materials.cpp).
  glm::vec4 baseColorOf(const tinygltf::Primitive& primitive, const std::string& where);
  void attachBaseColorTexture(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh);
  std::set<int> alphaTestedImages(const nlohmann::json& root) const;
  void attachCasterAlpha(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh);
  TextureWrap wrapOf(int wrap, const std::string& what) const;
  glm::dmat3 textureTransform(const tinygltf::Value& value, const std::string& what, int& texCoord) const;
  std::shared_ptr<const AlphaImage> alphaOfImage(int source, std::string& why);
  std::string describeImage(int source) const;
  std::string whyImageHasNoBytes(int source) const;  // gltf_import.cpp
  std::vector<float> texCoords(const tinygltf::Primitive& primitive, int set, const Mesh& mesh,
                               const std::string& where, std::string& problem) const;
  int32_t textureOfImage(int source, std::string& why);
  void applyMaterialExclusions();

  std::string path_;
  ImportOptions options_;
  ImageKeeping imageKeeping_;                 // encoded images by index, until decoded
  std::map<int, std::shared_ptr<const AlphaImage>> alphaOfImage_;  // decoded alpha channels
  std::map<std::string, int32_t> coverageMaskOf_;  // (image, sampler, factor, cutoff) -> Scene::coverageMasks
  size_t gpuInstancesPlaced_ = 0;                  // by EXT_mesh_gpu_instancing nodes, scene-wide
  std::map<int, int32_t> textureOfImage_;     // image index -> Scene::textures index (-1: failed)
  std::map<int, std::string> imageFailures_;  // image index -> why it failed
  tinygltf::Model model_;
  Scene scene_;
  std::vector<Light> lightDefinitions_;
  std::vector<std::optional<std::vector<uint32_t>>> meshCache_;
  gltf::MeshoptPlan meshopt_;     // meshopt-compressed views, decoded once tinygltf has loaded the buffers
  std::set<int> dracoAccessors_;  // accessors already filled from a Draco stream
  std::vector<int> dracoIndices_;  // Draco indices accessors given a placeholder bufferView for tinygltf
  std::set<std::string> warnedOnce_;
  std::map<int, size_t> imageWarnings_;  // image index -> its warning in scene_.warnings
  struct {
    size_t triangles = 0, primitives = 0;
    std::string first;
  } degenerate_;  // reported once, not per primitive
};

}  // namespace cpvs::gltf
