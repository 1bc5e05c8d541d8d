// Accessors of a glTF file: the bounds-checked bytes of a buffer view, and POSITION and index accessors (the
// other attributes are read where they are used, with GltfImporter::decodeAccessor).
#include "libcpvs/import/accessors.h"

#include <cmath>

namespace cpvs::gltf {

const tinygltf::Accessor& GltfImporter::accessor(int index, const std::string& what) const {
  if (index < 0 || size_t(index) >= model_.accessors.size())
    fail(what + ": accessor " + std::to_string(index) + " does not exist");
  return model_.accessors[size_t(index)];
}

// The bytes of `count` elements of `elementSize` bytes, `stride` apart, from `offset` in a buffer view;
// every bound is checked (without overflow) before anything is read.
const unsigned char* GltfImporter::viewBytes(int viewIndex, size_t offset, size_t count, size_t elementSize,
                                             size_t stride, const std::string& what) const {
  if (viewIndex < 0 || size_t(viewIndex) >= model_.bufferViews.size())
    fail(what + ": bufferView " + std::to_string(viewIndex) + " does not exist");
  const tinygltf::BufferView& view = model_.bufferViews[size_t(viewIndex)];
  const std::string viewName = "bufferView " + std::to_string(viewIndex);
  if (view.buffer < 0 || size_t(view.buffer) >= model_.buffers.size())
    fail(viewName + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const std::vector<unsigned char>& buffer = model_.buffers[size_t(view.buffer)].data;
  if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset)
    fail(viewName + " (bytes " + std::to_string(view.byteOffset) + " + " + std::to_string(view.byteLength) +
         ") does not fit in buffer " + std::to_string(view.buffer) + " (" + std::to_string(buffer.size()) +
         " bytes)");
  if (count == 0) return nullptr;
  const size_t length = view.byteLength;
  if (offset > length || elementSize > length - offset || (count - 1) > (length - offset - elementSize) / stride)
    fail(what + ": " + std::to_string(count) + " elements of " + std::to_string(elementSize) + " bytes, " +
         std::to_string(stride) + " apart from byte " + std::to_string(offset) + ", overrun " + viewName + " (" +
         std::to_string(length) + " bytes)");
  return buffer.data() + view.byteOffset + offset;
}

std::vector<glm::vec3> GltfImporter::readPositions(int index, const std::string& where) const {
  const std::string what = where + ": POSITION accessor " + std::to_string(index);
  const tinygltf::Accessor& source = accessor(index, where + ": POSITION");
  if (source.type != TINYGLTF_TYPE_VEC3) fail(what + " is " + typeName(source.type) + ", expected VEC3");
  const int componentType = source.componentType;
  const bool quantized = componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
                         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                         componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
                         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  if (componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !quantized)
    fail(what + " has componentType " + componentTypeName(componentType) +
         ", expected FLOAT (or BYTE/SHORT and unsigned under KHR_mesh_quantization)");
  const bool normalized = source.normalized;
  const std::vector<float> values = decodeAccessor<float>(
      index, what, [&](const unsigned char* bytes) { return componentAsFloat(bytes, componentType, normalized); });
  std::vector<glm::vec3> positions(values.size() / 3);
  for (size_t i = 0; i < positions.size(); ++i) {
    positions[i] = glm::vec3(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(positions[i][c]))
        fail(what + ": vertex " + std::to_string(i) + " is not finite (" + std::to_string(positions[i][c]) + ")");
  }
  return positions;
}

std::vector<uint32_t> GltfImporter::readIndices(int index, const std::string& where) const {
  const std::string what = where + ": indices accessor " + std::to_string(index);
  const tinygltf::Accessor& source = accessor(index, where + ": indices");
  if (source.type != TINYGLTF_TYPE_SCALAR) fail(what + " is " + typeName(source.type) + ", expected SCALAR");
  const int componentType = source.componentType;
  if (!isIndexComponentType(componentType))
    fail(what + " has componentType " + componentTypeName(componentType) +
         ", expected UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT");
  return decodeAccessor<uint32_t>(
      index, what, [&](const unsigned char* bytes) { return componentAsIndex(bytes, componentType); });
}

}  // namespace cpvs::gltf
