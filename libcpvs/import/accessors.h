#pragma once
// Reading glTF accessors (glTF 2.0 specification, "Accessors"): components as float or index, with
// KHR_mesh_quantization's normalized integers, and GltfImporter::decodeAccessor, which every attribute reader
// uses (a template: each caller converts components its own way). Sizes come from accessor_types.h.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include <tiny_gltf.h>

#include "libcpvs/import/accessor_types.h"
#include "libcpvs/import/gltf_importer.h"

namespace cpvs::gltf {

static_assert(std::endian::native == std::endian::little, "glTF buffers are read in place as little-endian");

// An accessor without a bufferView is all zeros (plus sparse values); its count costs memory but no file
// bytes, so it is capped to keep hostile files from exhausting memory.
inline constexpr size_t kMaxZeroInitialisedElements = size_t(1) << 24;

template <typename T>
T loadUnaligned(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof value);
  return value;
}

// An integer component as float: normalized, divided by the type's largest value (and at least -1 for signed
// types, whose smallest value has no positive twin).
template <class T>
inline float integerAsFloat(const unsigned char* bytes, bool normalized) {
  const float v = loadUnaligned<T>(bytes);
  if (!normalized) return v;
  const float scaled = v / float(std::numeric_limits<T>::max());
  return std::is_signed_v<T> ? std::max(scaled, -1.0f) : scaled;
}

// One component as float; normalized integers follow the glTF/KHR_mesh_quantization rules.
inline float componentAsFloat(const unsigned char* bytes, int componentType, bool normalized) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return integerAsFloat<int8_t>(bytes, normalized);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return integerAsFloat<uint8_t>(bytes, normalized);
    case TINYGLTF_COMPONENT_TYPE_SHORT: return integerAsFloat<int16_t>(bytes, normalized);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return integerAsFloat<uint16_t>(bytes, normalized);
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return loadUnaligned<float>(bytes);
    default: return 0.0f;  // callers accept only the types above
  }
}

inline uint32_t componentAsIndex(const unsigned char* bytes, int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return loadUnaligned<uint8_t>(bytes);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return loadUnaligned<uint16_t>(bytes);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return loadUnaligned<uint32_t>(bytes);
    default: return 0;  // callers accept only the types above
  }
}

inline bool isIndexComponentType(int componentType) {
  return componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
}

// All elements of an accessor, components in order, sparse substitutions applied.
template <typename Out, typename Convert>
std::vector<Out> GltfImporter::decodeAccessor(int index, const std::string& what, Convert convert) const {
  const tinygltf::Accessor& source = accessor(index, what);
  const size_t components = componentCount(source.type);
  const size_t size = componentSize(source.componentType);
  const size_t elementSize = components * size;
  if (elementSize == 0)
    fail(what + ": accessor " + std::to_string(index) + " is " + typeName(source.type) + " of componentType " +
         componentTypeName(source.componentType) + " (" + std::to_string(source.componentType) +
         "), which is not a glTF 2.0 accessor format");
  if (source.count > kMaxElements) fail(what + ": count " + std::to_string(source.count) + " is too large");
  if (source.bufferView < 0 && source.count > kMaxZeroInitialisedElements)
    fail(what + ": count " + std::to_string(source.count) + " without a bufferView is too large");

  // Validate the byte range before allocating, so a huge count in a small file fails instead of exhausting memory.
  const unsigned char* bytes = nullptr;
  size_t stride = elementSize;
  if (source.bufferView >= 0 && source.count > 0) {
    if (size_t(source.bufferView) < model_.bufferViews.size() && model_.bufferViews[size_t(source.bufferView)].byteStride)
      stride = model_.bufferViews[size_t(source.bufferView)].byteStride;
    if (stride < elementSize)
      fail(what + ": byteStride " + std::to_string(stride) + " is smaller than one element (" +
           std::to_string(elementSize) + " bytes)");
    bytes = viewBytes(source.bufferView, source.byteOffset, source.count, elementSize, stride, what);
  }
  std::vector<Out> out(source.count * components, Out{});  // zeros where there is no bufferView
  if (bytes)
    for (size_t i = 0; i < source.count; ++i)
      for (size_t c = 0; c < components; ++c) out[i * components + c] = convert(bytes + i * stride + c * size);
  if (source.sparse.isSparse) {
    const auto& sparse = source.sparse;
    const std::string sparseWhat = what + " (sparse)";
    if (sparse.count < 0 || size_t(sparse.count) > source.count)
      fail(sparseWhat + ": count " + std::to_string(sparse.count) + " is not in [0, " +
           std::to_string(source.count) + "]");
    if (!isIndexComponentType(sparse.indices.componentType))
      fail(sparseWhat + ": indices componentType " + std::to_string(sparse.indices.componentType) +
           " is not an unsigned integer type");
    if (sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0) fail(sparseWhat + ": negative byteOffset");
    const size_t count = size_t(sparse.count);
    const size_t indexSize = componentSize(sparse.indices.componentType);
    const unsigned char* indices = viewBytes(sparse.indices.bufferView, size_t(sparse.indices.byteOffset), count,
                                             indexSize, indexSize, sparseWhat + " indices");
    const unsigned char* values = viewBytes(sparse.values.bufferView, size_t(sparse.values.byteOffset), count,
                                            elementSize, elementSize, sparseWhat + " values");
    for (size_t k = 0; k < count; ++k) {
      const uint32_t target = componentAsIndex(indices + k * indexSize, sparse.indices.componentType);
      if (target >= source.count)
        fail(sparseWhat + ": index " + std::to_string(target) + " out of range (" + std::to_string(source.count) +
             " elements)");
      for (size_t c = 0; c < components; ++c)
        out[size_t(target) * components + c] = convert(values + k * elementSize + c * size);
    }
  }
  return out;
}

}  // namespace cpvs::gltf
