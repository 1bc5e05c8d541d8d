#include "libcpvs/import/compressed_geometry.h"

#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>

#include <draco/compression/decode.h>
#include <meshoptimizer.h>

#include "libcpvs/import/accessor_types.h"
#include "libcpvs/base/error.h"

namespace cpvs::gltf {
namespace {

constexpr const char* kMeshoptExtensions[] = {"EXT_meshopt_compression", "KHR_meshopt_compression"};
constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";
constexpr size_t kMaxDecodedBytes = size_t(1) << 32;        // a glTF buffer holds at most 4 GiB
// libmeshoptimizer decodes vertex streams of these versions (0.23 added version 1, which
// KHR_meshopt_compression allows; Debian 12 ships 0.18).
constexpr int kMaxVertexCodecVersion = MESHOPTIMIZER_VERSION >= 230 ? 1 : 0;
// A version 0 attribute stream spends at least 2 header bits per 16 bytes of output (a group of 16 elements
// whose deltas in one byte position are all zero), so it cannot decode to more than 64 times its size; a
// triangle stream spends at least one byte per triangle, an index sequence at least one per index.
constexpr size_t kMaxAttributeExpansion = 64;

[[noreturn]] void fail(const std::string& path, const std::string& message) {
  throw Error(ErrorCategory::InvalidInput, path + ": " + message);
}

std::string viewName(int view) { return "bufferView " + std::to_string(view); }

bool isSize(const nlohmann::json& value) {
  return value.is_number_unsigned() || (value.is_number_integer() && value.get<int64_t>() >= 0);
}

size_t sizeMember(const std::string& path, const nlohmann::json& object, const char* key, const std::string& what,
                  std::optional<size_t> fallback = std::nullopt) {
  const auto it = object.find(key);
  if (it == object.end()) {
    if (fallback) return *fallback;
    fail(path, what + "." + key + " is missing");
  }
  if (!isSize(*it)) fail(path, what + "." + key + " is not a non-negative integer");
  const uint64_t value = it->get<uint64_t>();
  if (value > uint64_t(std::numeric_limits<size_t>::max() / 2)) fail(path, what + "." + key + " is too large");
  return size_t(value);
}

std::string stringMember(const std::string& path, const nlohmann::json& object, const char* key,
                         const std::string& what, const char* fallback = nullptr) {
  const auto it = object.find(key);
  if (it == object.end()) {
    if (fallback) return fallback;
    fail(path, what + "." + key + " is missing");
  }
  if (!it->is_string()) fail(path, what + "." + key + " is not a string");
  return it->get<std::string>();
}

// The meshopt extension object of a bufferView or buffer, and its name; null when it has none.
const nlohmann::json* meshoptExtension(const nlohmann::json& object, std::string* name = nullptr) {
  if (!object.is_object()) return nullptr;
  const auto extensions = object.find("extensions");
  if (extensions == object.end() || !extensions->is_object()) return nullptr;
  for (const char* extension : kMeshoptExtensions) {
    const auto it = extensions->find(extension);
    if (it != extensions->end()) {
      if (name) *name = extension;
      return &*it;
    }
  }
  return nullptr;
}

MeshoptView parseMeshoptView(const std::string& path, const nlohmann::json& view, int index,
                             const nlohmann::json& extension, const std::string& name, size_t bufferCount) {
  const std::string what = "bufferViews[" + std::to_string(index) + "].extensions." + name;
  if (!extension.is_object()) fail(path, what + " is not an object");
  const nlohmann::json& extensions = view["extensions"];
  if (extensions.contains(kMeshoptExtensions[0]) && extensions.contains(kMeshoptExtensions[1]))
    fail(path, viewName(index) + " uses both EXT_meshopt_compression and KHR_meshopt_compression");
  MeshoptView result;
  result.view = index;
  result.extension = name;
  const size_t buffer = sizeMember(path, extension, "buffer", what);
  if (buffer >= bufferCount)
    fail(path, what + ".buffer " + std::to_string(buffer) + " does not exist (the file has " +
                   std::to_string(bufferCount) + " buffers)");
  result.buffer = int(buffer);
  result.byteOffset = sizeMember(path, extension, "byteOffset", what, 0);
  result.byteLength = sizeMember(path, extension, "byteLength", what);
  result.byteStride = sizeMember(path, extension, "byteStride", what);
  result.count = sizeMember(path, extension, "count", what);
  result.mode = stringMember(path, extension, "mode", what);
  result.filter = stringMember(path, extension, "filter", what, "NONE");

  const std::string at = viewName(index) + " (" + name + ", " + result.mode + ")";
  const size_t stride = result.byteStride, count = result.count;
  if (result.mode == "ATTRIBUTES") {
    if (stride == 0 || stride % 4 != 0 || stride > 256)
      fail(path, at + ": byteStride " + std::to_string(stride) + " is not a multiple of 4 in [4, 256]");
  } else if (result.mode == "TRIANGLES" || result.mode == "INDICES") {
    if (stride != 2 && stride != 4) fail(path, at + ": byteStride " + std::to_string(stride) + " is not 2 or 4");
    if (result.mode == "TRIANGLES" && count % 3 != 0)
      fail(path, at + ": count " + std::to_string(count) + " is not a multiple of 3");
    if (result.filter != "NONE") fail(path, at + ": filter " + result.filter + " is only allowed for ATTRIBUTES");
  } else {
    fail(path, viewName(index) + ": " + name + " mode '" + result.mode +
                   "' is not ATTRIBUTES, TRIANGLES or INDICES");
  }
  if (result.filter == "OCTAHEDRAL") {
    if (stride != 4 && stride != 8) fail(path, at + ": filter OCTAHEDRAL needs byteStride 4 or 8, not " + std::to_string(stride));
  } else if (result.filter == "QUATERNION") {
    if (stride != 8) fail(path, at + ": filter QUATERNION needs byteStride 8, not " + std::to_string(stride));
  } else if (result.filter == "COLOR" && name == "KHR_meshopt_compression") {
    fail(path, at + ": filter COLOR, which the meshoptimizer library of this build (" +
                   std::to_string(MESHOPTIMIZER_VERSION / 100) + "." + std::to_string(MESHOPTIMIZER_VERSION % 100) +
                   ") cannot decode; decode the file first (e.g. `npx @gltf-transform/cli copy IN OUT`)");
  } else if (result.filter != "NONE" && result.filter != "EXPONENTIAL") {
    fail(path, at + ": unknown filter '" + result.filter + "'");
  }
  if (count > kMaxElements) fail(path, at + ": count " + std::to_string(count) + " is too large");
  if (count * stride > kMaxDecodedBytes)
    fail(path, at + ": " + std::to_string(count) + " elements of " + std::to_string(stride) +
                   " bytes are more than 4 GiB");
  // The decoded data replaces the view's contents, which accessors address through the view's byteLength.
  const auto parentLength = view.find("byteLength");
  if (parentLength == view.end() || !isSize(*parentLength) || parentLength->get<uint64_t>() != count * stride)
    fail(path, at + ": the bufferView's byteLength is not count * byteStride (" + std::to_string(count) + " * " +
                   std::to_string(stride) + ")");
  return result;
}

std::string hexByte(unsigned char byte) {
  static const char* digits = "0123456789abcdef";
  return std::string("0x") + digits[byte >> 4] + digits[byte & 15];
}

template <typename T>
void storeLittleEndian(unsigned char* to, T value) {
  std::memcpy(to, &value, sizeof value);  // glTF is little-endian, and so is every target cpvs builds for
}

// One point's attribute value converted to the accessor's component type, written at `to`.
bool convertDracoValue(const draco::PointAttribute& attribute, draco::AttributeValueIndex value, int componentType,
                       int components, unsigned char* to) {
  auto convert = [&](auto sample) {
    using T = decltype(sample);
    T values[4] = {};
    if (!attribute.ConvertValue<T>(value, int8_t(components), values)) return false;
    for (int c = 0; c < components; ++c) storeLittleEndian(to + size_t(c) * sizeof(T), values[c]);
    return true;
  };
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return convert(int8_t{});
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return convert(uint8_t{});
    case TINYGLTF_COMPONENT_TYPE_SHORT: return convert(int16_t{});
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return convert(uint16_t{});
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return convert(uint32_t{});
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return convert(float{});
    default: return false;
  }
}

// Appends `bytes` as a new buffer; returns its index.
int appendBuffer(tinygltf::Model& model, std::vector<unsigned char> bytes, const std::string& name) {
  tinygltf::Buffer buffer;
  buffer.name = name;
  buffer.data = std::move(bytes);
  model.buffers.push_back(std::move(buffer));
  return int(model.buffers.size()) - 1;
}

// Appends `bytes` as a new buffer with a bufferView over all of it; returns the view's index.
int appendView(tinygltf::Model& model, std::vector<unsigned char> bytes, const std::string& name) {
  tinygltf::BufferView view;
  view.name = name;
  view.byteOffset = 0;
  view.byteLength = bytes.size();
  view.buffer = appendBuffer(model, std::move(bytes), name);
  model.bufferViews.push_back(std::move(view));
  return int(model.bufferViews.size()) - 1;
}

}  // namespace

MeshoptPlan prepareMeshopt(const std::string& path, nlohmann::json& root, bool binary) {
  MeshoptPlan plan;
  if (!root.is_object()) return plan;
  const auto views = root.find("bufferViews");
  const auto buffers = root.find("buffers");
  if (views == root.end() || !views->is_array() || buffers == root.end() || !buffers->is_array()) return plan;
  const size_t bufferCount = buffers->size();

  // Which buffers compressed views' parents use, which buffers plain views use, which hold compressed bytes.
  std::vector<bool> parentOfCompressed(bufferCount, false), usedPlainly(bufferCount, false), source(bufferCount, false);
  std::vector<int> firstPlainView(bufferCount, -1);
  for (size_t i = 0; i < views->size(); ++i) {
    const nlohmann::json& view = (*views)[i];
    if (!view.is_object()) continue;  // checkJsonTypes names it
    std::string name;
    const nlohmann::json* extension = meshoptExtension(view, &name);
    const auto buffer = view.find("buffer");
    const bool validBuffer = buffer != view.end() && isSize(*buffer) && buffer->get<uint64_t>() < bufferCount;
    if (!extension) {
      if (validBuffer) {
        const size_t b = buffer->get<size_t>();
        usedPlainly[b] = true;
        if (firstPlainView[b] < 0) firstPlainView[b] = int(i);
      }
      continue;
    }
    MeshoptView compressed = parseMeshoptView(path, view, int(i), *extension, name, bufferCount);
    source[size_t(compressed.buffer)] = true;
    if (validBuffer) parentOfCompressed[buffer->get<size_t>()] = true;
    plan.views.push_back(std::move(compressed));
  }

  for (size_t b = 0; b < bufferCount; ++b) {
    const nlohmann::json& buffer = (*buffers)[b];
    if (!buffer.is_object()) continue;
    std::string name;
    const nlohmann::json* extension = meshoptExtension(buffer, &name);
    const bool tagged = extension && extension->is_object() && extension->contains("fallback") &&
                        (*extension)["fallback"].is_boolean() && (*extension)["fallback"].get<bool>();
    // Without a uri, a buffer has data only as a GLB's first buffer (the BIN chunk).
    const bool noData = !buffer.contains("uri") && (!binary || b > 0);
    const bool untaggedFallback = noData && parentOfCompressed[b] && !usedPlainly[b] && !source[b];
    if (!tagged && !untaggedFallback) continue;
    const std::string what = "buffer " + std::to_string(b) + " (a meshopt fallback buffer, which has no data)";
    if (usedPlainly[b])
      fail(path, viewName(firstPlainView[b]) + " has no meshopt extension but reads " + what);
    if (source[b]) fail(path, "a meshopt extension takes its compressed bytes from " + what);
    plan.fallbackBuffers.insert(int(b));
    nlohmann::json placeholder = {{"byteLength", 1}, {"uri", "data:application/octet-stream;base64,AA=="}};
    if (buffer.contains("name")) placeholder["name"] = buffer["name"];
    (*buffers)[b] = std::move(placeholder);
  }
  return plan;
}

void decodeMeshopt(const std::string& path, const MeshoptPlan& plan, tinygltf::Model& model) {
  // Views may share one compressed range: what they decode to is bounded in all, not only one by one.
  size_t decodedInAll = 0;
  for (const MeshoptView& compressed : plan.views) {
    const std::string at = viewName(compressed.view) + " (" + compressed.extension + ", " + compressed.mode + ")";
    if (size_t(compressed.view) >= model.bufferViews.size() || size_t(compressed.buffer) >= model.buffers.size())
      fail(path, at + ": the view or its buffer is missing after parsing");
    const std::vector<unsigned char>& buffer = model.buffers[size_t(compressed.buffer)].data;
    if (compressed.byteOffset > buffer.size() || compressed.byteLength > buffer.size() - compressed.byteOffset)
      fail(path, at + ": the compressed bytes " + std::to_string(compressed.byteOffset) + " + " +
                     std::to_string(compressed.byteLength) + " do not fit in buffer " +
                     std::to_string(compressed.buffer) + " (" + std::to_string(buffer.size()) + " bytes)");
    const unsigned char* stream = buffer.data() + compressed.byteOffset;
    const size_t length = compressed.byteLength, count = compressed.count, stride = compressed.byteStride;
    const std::string corrupt = at + ": corrupt stream (" + std::to_string(length) + " bytes for " +
                                std::to_string(count) + " elements of " + std::to_string(stride) + " bytes)";

    // Bound the output by what the stream can hold before allocating it.
    const bool attributes = compressed.mode == "ATTRIBUTES";
    const size_t limit = attributes ? length * kMaxAttributeExpansion
                                    : (compressed.mode == "TRIANGLES" ? length * 3 : length);
    if ((attributes ? count * stride : count) > limit)
      fail(path, corrupt + ": more elements than a stream of that size can encode");
    if (length == 0) fail(path, corrupt);
    if (attributes) {
      const unsigned char header = stream[0];
      if ((header & 0xf0) != 0xa0) fail(path, corrupt + ": header " + hexByte(header) + " is not a vertex stream's");
      if ((header & 0x0f) > kMaxVertexCodecVersion)
        fail(path, at + ": vertex stream version " + std::to_string(header & 0x0f) +
                       ", which the meshoptimizer library of this build (" + std::to_string(MESHOPTIMIZER_VERSION / 100) +
                       "." + std::to_string(MESHOPTIMIZER_VERSION % 100) + ") cannot decode; decode the file first "
                       "(e.g. `npx @gltf-transform/cli copy IN OUT`) or re-encode it as EXT_meshopt_compression");
    }

    decodedInAll += count * stride;
    if (decodedInAll > kMaxDecodedBytes)
      fail(path, at + ": the meshopt views decode to more than " + std::to_string(kMaxDecodedBytes) + " bytes in all");
    std::vector<unsigned char> decoded(count * stride);
    int status = 0;
    if (attributes) {
      status = meshopt_decodeVertexBuffer(decoded.data(), count, stride, stream, length);
      if (status == 0) {
        if (compressed.filter == "OCTAHEDRAL") meshopt_decodeFilterOct(decoded.data(), count, stride);
        else if (compressed.filter == "QUATERNION") meshopt_decodeFilterQuat(decoded.data(), count, stride);
        else if (compressed.filter == "EXPONENTIAL") meshopt_decodeFilterExp(decoded.data(), count, stride);
      }
    } else if (compressed.mode == "TRIANGLES") {
      status = meshopt_decodeIndexBuffer(decoded.data(), count, stride, stream, length);
    } else {
      status = meshopt_decodeIndexSequence(decoded.data(), count, stride, stream, length);
    }
    if (status != 0) fail(path, corrupt + ": meshoptimizer error " + std::to_string(status));

    // The decoded bytes take the compressed view's place; its own byteStride (for the accessors) is kept.
    const int decodedBuffer = appendBuffer(model, std::move(decoded), "decoded " + viewName(compressed.view));
    tinygltf::BufferView& target = model.bufferViews[size_t(compressed.view)];
    target.buffer = decodedBuffer;
    target.byteOffset = 0;
    target.byteLength = count * stride;
    target.extensions.erase(compressed.extension);
  }
  for (int fallback : plan.fallbackBuffers) model.buffers[size_t(fallback)].data.clear();
}

std::vector<int> prepareDracoIndices(nlohmann::json& root) {
  std::vector<int> patched;
  if (!root.is_object() || !root.contains("meshes") || !root["meshes"].is_array() || !root.contains("accessors") ||
      !root["accessors"].is_array() || !root.contains("bufferViews") || !root["bufferViews"].is_array())
    return patched;
  nlohmann::json& accessors = root["accessors"];
  const size_t views = root["bufferViews"].size();
  for (const nlohmann::json& mesh : root["meshes"]) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (const nlohmann::json& primitive : mesh["primitives"]) {
      if (!primitive.is_object() || !primitive.contains("indices") || !isSize(primitive["indices"])) continue;
      const auto extensions = primitive.find("extensions");
      if (extensions == primitive.end() || !extensions->is_object() || !extensions->contains(kDracoExtension)) continue;
      const nlohmann::json& draco = (*extensions)[kDracoExtension];
      if (!draco.is_object() || !draco.contains("bufferView") || !isSize(draco["bufferView"]) ||
          draco["bufferView"].get<uint64_t>() >= views)
        continue;  // decodeDracoPrimitive names the problem, or tinygltf does
      const uint64_t index = primitive["indices"].get<uint64_t>();
      if (index >= accessors.size() || !accessors[index].is_object() || accessors[index].contains("bufferView")) continue;
      accessors[index]["bufferView"] = draco["bufferView"];
      patched.push_back(int(index));
    }
  }
  return patched;
}

void restoreDracoIndices(const std::vector<int>& accessors, tinygltf::Model& model) {
  for (int index : accessors)
    if (size_t(index) < model.accessors.size()) model.accessors[size_t(index)].bufferView = -1;
}

namespace {

// An attribute the Draco extension names: the primitive's accessor for it, and the Draco attribute filling it.
struct DracoTarget {
  std::string name;
  int accessor;
  uint32_t uniqueId;
};

// The extension's `attributes` map, each name checked against the primitive's attributes.
std::vector<DracoTarget> dracoTargets(const std::string& path, const std::string& what,
                                      const tinygltf::Value& attributes, const tinygltf::Primitive& primitive) {
  std::vector<DracoTarget> targets;
  for (const std::string& name : attributes.Keys()) {
    const tinygltf::Value& id = attributes.Get(name);
    if (!id.IsInt() || id.GetNumberAsInt() < 0) fail(path, what + ".attributes." + name + " is not a Draco attribute id");
    const auto accessor = primitive.attributes.find(name);
    if (accessor == primitive.attributes.end())
      fail(path, what + " names attribute " + name + ", which the primitive does not have");
    targets.push_back({name, accessor->second, uint32_t(id.GetNumberAsInt())});
  }
  return targets;
}

// An accessor the Draco stream fills, checked before anything is decoded into it.
tinygltf::Accessor& fillableAccessor(const std::string& path, const std::string& where, tinygltf::Model& model,
                                     int index, const std::string& name) {
  if (index < 0 || size_t(index) >= model.accessors.size())
    fail(path, where + ": " + name + " accessor " + std::to_string(index) + " does not exist");
  tinygltf::Accessor& accessor = model.accessors[size_t(index)];
  // Draco fills scalars and vectors, never matrices.
  const size_t elementSize =
      isMatrixType(accessor.type) ? 0 : componentCount(accessor.type) * componentSize(accessor.componentType);
  if (elementSize == 0)
    fail(path, where + ": " + name + " accessor " + std::to_string(index) + " has a type or componentType that Draco cannot fill");
  if (accessor.count > kMaxElements || accessor.count * elementSize > kMaxDecodedBytes)
    fail(path, where + ": " + name + " accessor " + std::to_string(index) + " count " + std::to_string(accessor.count) + " is too large");
  return accessor;
}

// The bufferView holding the compressed stream, checked to lie within its buffer.
const tinygltf::BufferView& dracoStreamView(const std::string& path, const std::string& what,
                                            const tinygltf::Model& model, int viewIndex) {
  if (viewIndex < 0 || size_t(viewIndex) >= model.bufferViews.size())
    fail(path, what + ".bufferView " + std::to_string(viewIndex) + " does not exist");
  const tinygltf::BufferView& view = model.bufferViews[size_t(viewIndex)];
  if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
    fail(path, viewName(viewIndex) + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const std::vector<unsigned char>& buffer = model.buffers[size_t(view.buffer)].data;
  if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset)
    fail(path, viewName(viewIndex) + " does not fit in buffer " + std::to_string(view.buffer));
  return view;
}

// The triangle mesh in a Draco stream; `corrupt` starts the message of any failure (libdraco's allocation
// failures on a hostile stream included).
std::unique_ptr<draco::Mesh> decodeDracoMesh(const std::string& path, const std::string& corrupt,
                                             const unsigned char* bytes, size_t length) {
  std::unique_ptr<draco::Mesh> mesh;
  try {
    draco::DecoderBuffer stream;
    stream.Init(reinterpret_cast<const char*>(bytes), length);
    auto type = draco::Decoder::GetEncodedGeometryType(&stream);
    if (!type.ok()) fail(path, corrupt + ": " + type.status().error_msg_string());
    if (type.value() != draco::TRIANGULAR_MESH) fail(path, corrupt + ": not a triangle mesh (a point cloud?)");
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&stream);
    if (!decoded.ok()) fail(path, corrupt + ": " + decoded.status().error_msg_string());
    mesh = std::move(decoded).value();
  } catch (const std::bad_alloc&) {
    fail(path, corrupt + ": it asks for more memory than there is");
  } catch (const std::length_error&) {
    fail(path, corrupt + ": it asks for more memory than there is");
  }
  if (!mesh) fail(path, corrupt);
  return mesh;
}

// One attribute's values for every point of the decoded mesh, in the accessor's type.
std::vector<unsigned char> decodedAttributeBytes(const std::string& path, const std::string& where,
                                                 const std::string& corrupt, const draco::Mesh& mesh,
                                                 const DracoTarget& target, const tinygltf::Accessor& accessor) {
  const size_t points = mesh.num_points();
  const std::string name = target.name + " accessor " + std::to_string(target.accessor);
  if (accessor.count != points)
    fail(path, where + ": " + name + " has count " + std::to_string(accessor.count) + ", the Draco stream " +
                   std::to_string(points) + " points");
  const draco::PointAttribute* attribute = mesh.GetAttributeByUniqueId(target.uniqueId);
  if (!attribute) fail(path, corrupt + ": no attribute with id " + std::to_string(target.uniqueId) + " (" + target.name + ")");
  const int components = int(componentCount(accessor.type));
  const size_t elementSize = size_t(components) * componentSize(accessor.componentType);
  std::vector<unsigned char> bytes(points * elementSize);
  for (size_t p = 0; p < points; ++p) {
    const draco::AttributeValueIndex value = attribute->mapped_index(draco::PointIndex(uint32_t(p)));
    if (value.value() >= attribute->size() ||
        !convertDracoValue(*attribute, value, accessor.componentType, components, bytes.data() + p * elementSize))
      fail(path, corrupt + ": " + target.name + " of point " + std::to_string(p) + " cannot be read as the accessor's type");
  }
  return bytes;
}

// The decoded mesh's triangles as the indices accessor's values (`indexSize` bytes each).
std::vector<unsigned char> decodedIndexBytes(const std::string& path, const std::string& where,
                                             const std::string& corrupt, const draco::Mesh& mesh,
                                             int indicesAccessor, const tinygltf::Accessor& indices, size_t indexSize) {
  const size_t points = mesh.num_points(), faces = mesh.num_faces();
  if (faces > kMaxElements / 3 || indices.count != faces * 3)
    fail(path, where + ": indices accessor " + std::to_string(indicesAccessor) + " has count " +
                   std::to_string(indices.count) + ", the Draco stream " + std::to_string(faces) + " triangles");
  if (indexSize < 4 && points > (size_t(1) << (8 * indexSize)))
    fail(path, where + ": indices accessor " + std::to_string(indicesAccessor) + " is too narrow for " +
                   std::to_string(points) + " points");
  std::vector<unsigned char> indexBytes(faces * 3 * indexSize);
  for (size_t f = 0; f < faces; ++f) {
    const draco::Mesh::Face& face = mesh.face(draco::FaceIndex(uint32_t(f)));
    for (size_t c = 0; c < 3; ++c) {
      const uint32_t index = face[c].value();
      if (index >= points) fail(path, corrupt + ": triangle " + std::to_string(f) + " refers to point " + std::to_string(index));
      unsigned char* to = indexBytes.data() + (3 * f + c) * indexSize;
      if (indexSize == 1) *to = uint8_t(index);
      else if (indexSize == 2) storeLittleEndian(to, uint16_t(index));
      else storeLittleEndian(to, index);
    }
  }
  return indexBytes;
}

}  // namespace

void decodeDracoPrimitive(const std::string& path, const std::string& where, const tinygltf::Primitive& primitive,
                          tinygltf::Model& model, std::set<int>& decodedAccessors) {
  const auto found = primitive.extensions.find(kDracoExtension);
  if (found == primitive.extensions.end()) return;
  // Points and lines are skipped by the importer; only triangle meshes are decoded.
  if (primitive.mode >= 0 && primitive.mode < TINYGLTF_MODE_TRIANGLES) return;
  const tinygltf::Value& extension = found->second;
  const std::string what = where + ": " + kDracoExtension;
  if (!extension.IsObject() || !extension.Has("bufferView") || !extension.Get("bufferView").IsInt())
    fail(path, what + ".bufferView is missing or not an index");
  if (!extension.Has("attributes") || !extension.Get("attributes").IsObject())
    fail(path, what + ".attributes is missing or not an object");
  const int viewIndex = extension.Get("bufferView").GetNumberAsInt();

  const std::vector<DracoTarget> targets = dracoTargets(path, what, extension.Get("attributes"), primitive);
  if (primitive.indices < 0) fail(path, what + ": the primitive has no indices accessor");
  bool done = decodedAccessors.count(primitive.indices) != 0;
  for (const DracoTarget& target : targets) done = done && decodedAccessors.count(target.accessor) != 0;
  if (done) return;  // a stream shared with a primitive decoded before

  for (const DracoTarget& target : targets) fillableAccessor(path, where, model, target.accessor, target.name);
  tinygltf::Accessor& indices = fillableAccessor(path, where, model, primitive.indices, "indices");
  const size_t indexSize = componentSize(indices.componentType);
  if (indices.type != TINYGLTF_TYPE_SCALAR || indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
      indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT || indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
    fail(path, where + ": indices accessor " + std::to_string(primitive.indices) + " is not SCALAR of an unsigned integer type");

  // The compressed stream.
  const tinygltf::BufferView& view = dracoStreamView(path, what, model, viewIndex);
  const std::vector<unsigned char>& buffer = model.buffers[size_t(view.buffer)].data;
  const std::string corrupt = what + ": corrupt Draco stream in " + viewName(viewIndex) + " (" +
                              std::to_string(view.byteLength) + " bytes)";
  const std::unique_ptr<draco::Mesh> mesh =
      decodeDracoMesh(path, corrupt, buffer.data() + view.byteOffset, view.byteLength);

  // Every output is decoded and checked before the model changes.
  std::vector<std::pair<int, std::vector<unsigned char>>> outputs;
  for (const DracoTarget& target : targets)
    outputs.emplace_back(target.accessor, decodedAttributeBytes(path, where, corrupt, *mesh, target,
                                                                model.accessors[size_t(target.accessor)]));
  outputs.emplace_back(primitive.indices,
                       decodedIndexBytes(path, where, corrupt, *mesh, primitive.indices, indices, indexSize));

  for (auto& [accessorIndex, bytes] : outputs) {
    const int decodedView = appendView(model, std::move(bytes), "decoded Draco accessor " + std::to_string(accessorIndex));
    tinygltf::Accessor& accessor = model.accessors[size_t(accessorIndex)];
    accessor.bufferView = decodedView;
    accessor.byteOffset = 0;
    decodedAccessors.insert(accessorIndex);
  }
}

}  // namespace cpvs::gltf
