// Where a node puts its mesh: the node's local transform, and EXT_mesh_gpu_instancing, which places the mesh
// once per instance instead of once.
#include <cmath>
#include <map>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "libcpvs/import/accessor_types.h"
#include "libcpvs/import/accessors.h"
#include "libcpvs/import/gltf_importer.h"

namespace cpvs::gltf {
namespace {

// Instances one EXT_mesh_gpu_instancing node may add (instances times primitives): each costs memory.
constexpr size_t kMaxGpuInstances = size_t(1) << 22;

}  // namespace

glm::dmat4 GltfImporter::localTransform(int index) const {
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  glm::dmat4 local(1.0);
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16)
      fail(describeNode(index) + ": matrix has " + std::to_string(node.matrix.size()) + " numbers, expected 16");
    local = glm::make_mat4(node.matrix.data());  // both column-major
  } else {
    auto checkSize = [&](const std::vector<double>& values, size_t expected, const char* what) {
      if (!values.empty() && values.size() != expected)
        fail(describeNode(index) + ": " + what + " has " + std::to_string(values.size()) + " numbers, expected " +
             std::to_string(expected));
      return !values.empty();
    };
    glm::dmat4 translation(1.0), rotation(1.0), scale(1.0);
    if (checkSize(node.translation, 3, "translation"))
      translation = glm::translate(glm::dmat4(1.0), glm::make_vec3(node.translation.data()));
    if (checkSize(node.rotation, 4, "rotation")) {
      const auto& r = node.rotation;  // glTF order: x, y, z, w
      glm::dquat q(r[3], r[0], r[1], r[2]);
      const double length = glm::length(q);
      if (!(length > 0.0) || !std::isfinite(length))
        fail(describeNode(index) + ": rotation is not a valid quaternion");
      rotation = glm::mat4_cast(q / length);
    }
    if (checkSize(node.scale, 3, "scale")) scale = glm::scale(glm::dmat4(1.0), glm::make_vec3(node.scale.data()));
    local = translation * rotation * scale;
  }
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(local[c][r])) fail(describeNode(index) + ": transform is not finite");
  return local;
}

// EXT_mesh_gpu_instancing: the node's mesh is placed once per instance instead of once. The instances
// replace the ones place() has just added for the node (the last of scene_.instances), each moved by its
// instance transform (world = node * T * R * S) and named "<node>[<k>]".
void GltfImporter::placeGpuInstances(int index) {
  const tinygltf::Node& node = model_.nodes[size_t(index)];
  const auto extension = node.extensions.find(kInstancingExtension);
  if (extension == node.extensions.end()) return;
  const std::vector<glm::dmat4> transforms = gpuInstanceTransforms(index, extension->second);
  const size_t primitives = meshIds(node.mesh).size();
  if (primitives > scene_.instances.size()) return;
  if (transforms.size() * primitives > kMaxGpuInstances)
    fail(describeNode(index) + ": " + kInstancingExtension + " places " + std::to_string(transforms.size()) +
         " instances of " + std::to_string(primitives) + " primitives, more than " + std::to_string(kMaxGpuInstances));
  // One cap for the whole scene too: nodes may share one accessor (even one without bytes in the file).
  gpuInstancesPlaced_ += transforms.size() * primitives;
  if (gpuInstancesPlaced_ > kMaxGpuInstances)
    fail(describeNode(index) + ": " + kInstancingExtension + ": the scene's nodes place more than " +
         std::to_string(kMaxGpuInstances) + " instances in all");
  const std::vector<Instance> placed(scene_.instances.end() - std::ptrdiff_t(primitives), scene_.instances.end());
  scene_.instances.resize(scene_.instances.size() - primitives);
  for (size_t k = 0; k < transforms.size(); ++k)
    for (const Instance& one : placed) {
      Instance instance = one;
      instance.worldFromLocal = one.worldFromLocal * transforms[k];
      instance.node = one.node + "[" + std::to_string(k) + "]";
      scene_.instances.push_back(std::move(instance));
    }
}

// The instance transforms (T * R * S) of an EXT_mesh_gpu_instancing node: TRANSLATION and SCALE are VEC3
// (float, or the integer types KHR_mesh_quantization allows), ROTATION a VEC4 quaternion (float, or
// normalized byte or short); each defaults to the identity. Every attribute accessor must have the same count.
std::vector<glm::dmat4> GltfImporter::gpuInstanceTransforms(int index, const tinygltf::Value& extension) const {
  const std::string what = describeNode(index) + ": " + kInstancingExtension;
  if (!extension.IsObject() || !extension.Has("attributes") || !extension.Get("attributes").IsObject())
    fail(what + ".attributes is missing or not an object");
  const tinygltf::Value& attributes = extension.Get("attributes");
  std::map<std::string, int> accessors;
  for (const std::string& name : attributes.Keys()) {
    const tinygltf::Value& value = attributes.Get(name);
    if (!value.IsInt() || value.GetNumberAsInt() < 0) fail(what + ".attributes." + name + " is not an accessor index");
    accessors[name] = value.GetNumberAsInt();
  }
  if (accessors.empty()) fail(what + ".attributes is empty");
  std::string first;
  size_t count = 0;
  for (const auto& [name, accessorIndex] : accessors) {
    const size_t n = accessor(accessorIndex, what + " " + name).count;
    const std::string described = name + " (accessor " + std::to_string(accessorIndex) + ", count " + std::to_string(n) + ")";
    if (first.empty()) {
      first = described;
      count = n;
    } else if (n != count) {
      fail(what + ": the attributes' accessors differ in count: " + first + ", " + described);
    }
  }
  if (count > kMaxGpuInstances)
    fail(what + ": " + std::to_string(count) + " instances, more than " + std::to_string(kMaxGpuInstances));
  // The values of one attribute, `components` per instance; empty when the node does not have it.
  auto read = [&](const char* name, int type, bool rotation) -> std::vector<float> {
    const auto it = accessors.find(name);
    if (it == accessors.end()) return {};
    const std::string at = what + " " + name + " accessor " + std::to_string(it->second);
    const tinygltf::Accessor& source = accessor(it->second, at);
    if (source.type != type) fail(at + " is " + typeName(source.type) + ", expected " + typeName(type));
    const int componentType = source.componentType;
    const bool normalized = source.normalized;
    const bool allowed =
        componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
        (rotation ? normalized && (componentType == TINYGLTF_COMPONENT_TYPE_BYTE || componentType == TINYGLTF_COMPONENT_TYPE_SHORT)
                  : componentType == TINYGLTF_COMPONENT_TYPE_BYTE || componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                        componentType == TINYGLTF_COMPONENT_TYPE_SHORT || componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    if (!allowed)
      fail(at + " has componentType " + componentTypeName(componentType) + (normalized ? " (normalized)" : "") +
           (rotation ? ", expected FLOAT or normalized BYTE or SHORT" : ", expected FLOAT (or BYTE/SHORT and unsigned)"));
    std::vector<float> values = decodeAccessor<float>(
        it->second, at, [&](const unsigned char* bytes) { return componentAsFloat(bytes, componentType, normalized); });
    for (size_t i = 0; i < values.size(); ++i)
      if (!std::isfinite(values[i])) fail(at + ": instance " + std::to_string(i / (rotation ? 4 : 3)) + " is not finite");
    return values;
  };
  const std::vector<float> translation = read("TRANSLATION", TINYGLTF_TYPE_VEC3, false);
  const std::vector<float> rotation = read("ROTATION", TINYGLTF_TYPE_VEC4, true);
  const std::vector<float> scale = read("SCALE", TINYGLTF_TYPE_VEC3, false);
  std::vector<glm::dmat4> transforms(count, glm::dmat4(1.0));
  for (size_t k = 0; k < count; ++k) {
    glm::dmat4& m = transforms[k];
    if (!translation.empty())
      m = glm::translate(m, glm::dvec3(translation[3 * k], translation[3 * k + 1], translation[3 * k + 2]));
    if (!rotation.empty()) {
      const glm::dquat q(rotation[4 * k + 3], rotation[4 * k], rotation[4 * k + 1], rotation[4 * k + 2]);  // x, y, z, w
      const double length = glm::length(q);
      if (!(length > 0.0)) fail(what + ": instance " + std::to_string(k) + ": ROTATION is not a valid quaternion");
      m = m * glm::mat4_cast(q / length);
    }
    if (!scale.empty()) m = glm::scale(m, glm::dvec3(scale[3 * k], scale[3 * k + 1], scale[3 * k + 2]));
  }
  return transforms;
}

}  // namespace cpvs::gltf
