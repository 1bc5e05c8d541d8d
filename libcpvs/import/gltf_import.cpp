#include "libcpvs/import/gltf_import.h"
#include "libcpvs/import/texture_decode.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include <fnmatch.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "libcpvs/import/accessor_types.h"
#include "libcpvs/import/compressed_geometry.h"
#include "libcpvs/import/untrusted_input.h"
#include "libcpvs/base/error.h"
#include "libcpvs/scene/mesh_topology.h"

namespace cpvs {
namespace {

using gltf::componentCount;
using gltf::componentSize;
using gltf::componentTypeName;
using gltf::typeName;

static_assert(std::endian::native == std::endian::little, "glTF buffers are read in place as little-endian");

constexpr const char* kLightsExtension = "KHR_lights_punctual";
constexpr const char* kSpecularGlossinessExtension = "KHR_materials_pbrSpecularGlossiness";
// A node's or material's `extras` member that, set to false, keeps it from casting shadows (docs/alpha.md).
constexpr const char* kCastsShadowsExtra = "cpvs_casts_shadows";
// An accessor without a bufferView is all zeros (plus sparse values); its count costs memory but no file
// bytes, so it is capped to keep hostile files from exhausting memory.
constexpr size_t kMaxZeroInitialisedElements = size_t(1) << 24;
constexpr size_t kMaxElements = size_t(UINT32_MAX);  // cpvs meshes index with uint32

constexpr const char* kInstancingExtension = "EXT_mesh_gpu_instancing";
// Extensions that change what the geometry is and that cpvs does not import: importing without them would
// give wrong shadows, so a file that names one in extensionsUsed or extensionsRequired is refused
// (ErrorCategory::NotSupported) before any buffer is read, with how to write the file without it. Material,
// texture, animation, skin, morph and metadata extensions are not among them (docs/cli.md keeps the lists).
const std::map<std::string, std::string> kUnsupportedGeometryExtensions = {
    {"KHR_node_visibility",
     "hidden nodes would cast shadows: delete the hidden nodes and write the file without the extension, e.g. "
     "in Blender"},
    {"KHR_mesh_primitive_restart",
     "strips and fans with restart values: write them as separate primitives or triangle lists, e.g. by "
     "re-exporting without primitive restart"},
};
// The geometry extensions cpvs imports (compressed geometry: libcpvs/import/compressed_geometry.h).
const std::set<std::string> kSupportedGeometryExtensions = {"EXT_meshopt_compression", "KHR_meshopt_compression",
                                                            "KHR_draco_mesh_compression", kInstancingExtension};
// Instances one EXT_mesh_gpu_instancing node may add (instances times primitives): each costs memory.
constexpr size_t kMaxGpuInstances = size_t(1) << 22;

// `bytes` (a .gltf or .glb) with its JSON replaced by `root`; a GLB keeps the chunks after its JSON as they are.
std::vector<unsigned char> withJson(const std::vector<unsigned char>& bytes, bool binary, const gltf::JsonText& json,
                                    const nlohmann::json& root) {
  std::string text = root.dump();
  if (!binary) return std::vector<unsigned char>(text.begin(), text.end());
  while (text.size() % 4) text += ' ';
  const size_t rest = bytes.size() - (json.begin + json.length);
  const uint64_t total = 20 + uint64_t(text.size()) + rest;
  const uint32_t header[5] = {0x46546C67u, 2u, uint32_t(total), uint32_t(text.size()), 0x4E4F534Au};  // "glTF", "JSON"
  std::vector<unsigned char> out(sizeof header);
  std::memcpy(out.data(), header, sizeof header);
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), bytes.begin() + std::ptrdiff_t(json.begin + json.length), bytes.end());
  return out;
}
const std::set<std::string> kSupportedExtensions = {kLightsExtension, "KHR_mesh_quantization", "KHR_texture_transform"};

std::string lowercase(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool hasImageExtension(const std::string& path) {
  static const std::set<std::string> kImageExtensions = {".png", ".jpg",  ".jpeg", ".ktx2", ".ktx", ".webp",
                                                         ".dds", ".basis", ".bmp", ".gif",  ".tga", ".hdr"};
  return kImageExtensions.count(lowercase(std::filesystem::path(path).extension().string())) != 0;
}

// tinygltf looks for external files beside the glTF and also in the working directory; only the former is
// meant (the loader is given an absolute path, so candidates from "." are the relative ones). Images are
// read only when FileAccess allows them: a bake needs just the alpha-tested materials' images.
bool fileExistsBesideScene(const std::string& path, void* userData) {
  const auto& access = *static_cast<const gltf::FileAccess*>(userData);
  if (hasImageExtension(path) && !access.allImages &&
      !access.imageNames.count(std::filesystem::path(path).filename().string()))
    return false;
  return gltf::fileExists(path, userData);
}

bool skipImageDecoding(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                       void*) {
  return true;
}

// With ImportOptions::loadBaseColorTextures tinygltf hands every image's bytes (a file, a data URI or a buffer
// view) to this callback. They are kept encoded, by image index, and decoded only for the images a material
// uses as its base-colour texture: normal, metallic-roughness and occlusion images are never decoded.
using EncodedImages = std::map<int, std::vector<unsigned char>>;

// The alpha channel of a decoded image, what an alpha-tested material's coverage mask is made from.
struct AlphaImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> alpha;  // width * height, row 0 first
};

// The images to keep: every one (cpvs-view), or those alpha-tested materials read.
struct ImageKeeping {
  EncodedImages images;
  bool all = false;
  std::set<int> needed;
};

bool keepImageBytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int, const unsigned char* bytes,
                    int size, void* userData) {
  auto& keeping = *static_cast<ImageKeeping*>(userData);
  if (bytes && size > 0 && (keeping.all || keeping.needed.count(index))) keeping.images[index].assign(bytes, bytes + size);
  return true;  // never fails the import
}

// "%20" and the like in a URI, as the file name on disk has them.
std::string percentDecoded(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

AlphaMode alphaModeOf(const std::string& mode) {
  if (mode == "MASK") return AlphaMode::Mask;
  if (mode == "BLEND") return AlphaMode::Blend;
  return AlphaMode::Opaque;
}

std::string trimmed(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> result;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);)
    if (!trimmed(line).empty()) result.push_back(trimmed(line));
  return result;
}

const char* modeName(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "unknown";
  }
}

template <typename T>
T loadUnaligned(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof value);
  return value;
}

// One component as float; normalized integers follow the glTF/KHR_mesh_quantization rules.
float componentAsFloat(const unsigned char* bytes, int componentType, bool normalized) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const float v = loadUnaligned<int8_t>(bytes);
      return normalized ? std::max(v / 127.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      const float v = loadUnaligned<uint8_t>(bytes);
      return normalized ? v / 255.0f : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      const float v = loadUnaligned<int16_t>(bytes);
      return normalized ? std::max(v / 32767.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      const float v = loadUnaligned<uint16_t>(bytes);
      return normalized ? v / 65535.0f : v;
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return loadUnaligned<float>(bytes);
    default: return 0.0f;  // callers accept only the types above
  }
}

uint32_t componentAsIndex(const unsigned char* bytes, int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return loadUnaligned<uint8_t>(bytes);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return loadUnaligned<uint16_t>(bytes);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return loadUnaligned<uint32_t>(bytes);
    default: return 0;  // callers accept only the types above
  }
}

bool isIndexComponentType(int componentType) {
  return componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
}

// Triangles of a primitive as a list, from its vertex sequence (the indices, or 0..n-1 without indices).
// Triangles that repeat a vertex are dropped: strips use them to restart, and they cast no shadow.
struct Triangulation {
  std::vector<uint32_t> indices;
  size_t droppedDegenerate = 0;
  size_t ignoredTrailing = 0;
};

Triangulation triangulate(int mode, const std::vector<uint32_t>& sequence) {
  Triangulation result;
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
    if (a == b || b == c || c == a) {
      ++result.droppedDegenerate;
      return;
    }
    result.indices.insert(result.indices.end(), {a, b, c});
  };
  const size_t n = sequence.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    result.indices.reserve(n - n % 3);
    for (size_t i = 0; i + 2 < n; i += 3) emit(sequence[i], sequence[i + 1], sequence[i + 2]);
    result.ignoredTrailing = n % 3;
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    // glTF: triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), which keeps every triangle's winding.
    for (size_t i = 0; i + 2 < n; ++i) emit(sequence[i], sequence[i + 1 + i % 2], sequence[i + 2 - i % 2]);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 1; i + 1 < n; ++i) emit(sequence[0], sequence[i], sequence[i + 1]);
  }
  return result;
}

class GltfImporter {
public:
  GltfImporter(std::string path, const ImportOptions& options) : path_(std::move(path)), options_(options) {}

  Scene run() {
    scene_.source = path_;
    load();
    checkRequiredExtensions();
    parseLights();
    traverse(rootNodes());
    for (Mesh& mesh : scene_.meshes) classifyMesh(mesh);
    applyMaterialExclusions();
    size_t triangles = 0;
    for (const Instance& instance : scene_.instances) triangles += scene_.meshes[instance.mesh].triangleCount();
    if (triangles == 0) fail("no triangles: the scene has no triangle mesh that a node places");
    if (degenerate_.triangles)
      warn("dropped " + std::to_string(degenerate_.triangles) + " triangles with a repeated index in " +
           std::to_string(degenerate_.primitives) + " primitives (the first: " + degenerate_.first + ")");
    return std::move(scene_);
  }

private:
  [[noreturn]] void fail(const std::string& message) const {
    throw Error(ErrorCategory::InvalidInput, path_ + ": " + message);
  }
  void warn(const std::string& message) { scene_.warnings.push_back(path_ + ": " + message); }
  void warnOnce(const std::string& message) {
    if (warnedOnce_.insert(message).second) warn(message);
  }

  void load() {
    std::error_code ec;
    if (std::filesystem::is_directory(path_, ec)) fail("is a directory, not a glTF file");
    // A FIFO or device would block the read or never end.
    if (std::filesystem::exists(path_, ec) && !std::filesystem::is_regular_file(path_, ec))
      fail("is not a regular file (a FIFO, socket or device)");
    std::ifstream file(path_, std::ios::binary | std::ios::ate);
    if (!file) fail(std::string("cannot open: ") + std::strerror(errno));
    const std::streamoff size = file.tellg();
    if (size < 0) fail("cannot determine the file size");
    if (uint64_t(size) >= UINT32_MAX) fail("larger than 4 GiB, which glTF does not allow");
    std::vector<unsigned char> bytes(static_cast<size_t>(size));
    file.seekg(0);
    if (!file.read(reinterpret_cast<char*>(bytes.data()), size)) fail(std::string("cannot read: ") + std::strerror(errno));
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    // The untrusted-input rules (untrusted_input.h) before tinygltf parses anything.
    const gltf::JsonText json = gltf::locateJson(path_, bytes);
    const std::span<const uint8_t> jsonBytes(bytes.data() + json.begin, json.length);
    gltf::checkJsonNesting(path_, jsonBytes);
    nlohmann::json root = nlohmann::json::parse(jsonBytes.begin(), jsonBytes.end(), nullptr,
                                                /*allow_exceptions=*/false);
    if (root.is_discarded()) fail("the JSON cannot be parsed");
    gltf::checkAssetVersion(path_, root);
    checkGeometryExtensions(root);
    // meshopt fallback buffers have no data and Draco primitives' indices no bufferView, which tinygltf
    // refuses: both get placeholders in what it parses.
    meshopt_ = gltf::prepareMeshopt(path_, root, binary);
    dracoIndices_ = gltf::prepareDracoIndices(root);
    if (!meshopt_.empty() || !dracoIndices_.empty()) {
      bytes = withJson(bytes, binary, json, root);
      if (bytes.size() >= UINT32_MAX) fail("larger than 4 GiB once its JSON is rewritten");
    }

    tinygltf::TinyGLTF loader;
    imageKeeping_.all = options_.loadBaseColorTextures;
    imageKeeping_.needed = alphaTestedImages(root);
    if (imageKeeping_.all || !imageKeeping_.needed.empty()) loader.SetImageLoader(&keepImageBytes, &imageKeeping_);
    else loader.SetImageLoader(&skipImageDecoding, nullptr);
    // An absolute base directory, so that tinygltf's extra search in "." can be told apart and refused.
    const std::string baseDir = std::filesystem::absolute(path_, ec).parent_path().string();
    gltf::FileAccess access;
    access.folder = std::filesystem::weakly_canonical(baseDir, ec).string();
    access.allowExternal = options_.allowExternalUris;
    access.allImages = options_.loadBaseColorTextures;
    for (int image : imageKeeping_.needed)
      if (root.contains("images") && root["images"][size_t(image)].contains("uri") &&
          root["images"][size_t(image)]["uri"].is_string())
        access.imageNames.insert(std::filesystem::path(percentDecoded(root["images"][size_t(image)]["uri"].get<std::string>()))
                                     .filename()
                                     .string());
    loader.SetFsCallbacks({&fileExistsBesideScene,
                           &tinygltf::ExpandFilePath, &gltf::readWholeFile,
                           &tinygltf::WriteWholeFile, &access});
    std::string errors, warnings;
    const bool ok =
        binary ? loader.LoadBinaryFromMemory(&model_, &errors, &warnings, bytes.data(), unsigned(bytes.size()), baseDir)
               : loader.LoadASCIIFromString(&model_, &errors, &warnings, reinterpret_cast<const char*>(bytes.data()),
                                            unsigned(bytes.size()), baseDir);
    for (const std::string& line : lines(warnings)) {
      // Images are skipped on purpose (see fileExistsBesideScene); say nothing about them.
      if (line.find("image[") != std::string::npos) continue;
      if (line.rfind("File not found", 0) == 0 && hasImageExtension(line)) continue;
      warn(gltf::shortenDataUris(line));
    }
    // A buffer refused by the file rules: say why, rather than tinygltf's "file not found".
    if (!access.refusal.empty()) fail("buffer " + gltf::shortenDataUris(access.refusal));
    // tinygltf reports some problems in `errors` and still returns true; those are errors too.
    const std::vector<std::string> errorLines = lines(errors);
    if (!ok || !errorLines.empty()) {
      std::string message;
      for (const std::string& line : errorLines) message += (message.empty() ? "" : "; ") + line;
      fail(message.empty() ? "not a valid glTF 2.0 file" : gltf::shortenDataUris(message));
    }

    // tinygltf silently ignores optional properties of the wrong JSON type ("mesh": "0" would just lose the
    // mesh), so the properties cpvs relies on are type-checked here.
    checkJsonTypes(root);
    gltf::restoreDracoIndices(dracoIndices_, model_);
    gltf::decodeMeshopt(path_, meshopt_, model_);
  }

  // A file that names a geometry extension cpvs cannot import is refused before any buffer is read.
  void checkGeometryExtensions(const nlohmann::json& root) const {
    for (const char* key : {"extensionsRequired", "extensionsUsed"}) {
      const auto list = root.find(key);
      if (list == root.end() || !list->is_array()) continue;  // checkJsonTypes names a wrong type
      for (const nlohmann::json& name : *list) {
        if (!name.is_string()) continue;
        const auto unsupported = kUnsupportedGeometryExtensions.find(name.get<std::string>());
        if (unsupported == kUnsupportedGeometryExtensions.end()) continue;
        throw Error(ErrorCategory::NotSupported, path_ + ": " + key + " names " + unsupported->first +
                                                     ", which changes the geometry and which cpvs cannot import (" +
                                                     unsupported->second + ")");
      }
    }
  }

  // JSON kinds that tinygltf would otherwise coerce or drop without a word.
  enum class JsonKind { Index, Size, Number, String, Boolean, Object, Array };

  static bool isKind(const nlohmann::json& value, JsonKind kind) {
    const bool nonNegativeInteger = value.is_number_unsigned() || (value.is_number_integer() && value.get<int64_t>() >= 0);
    switch (kind) {
      case JsonKind::Index: return nonNegativeInteger && value.get<uint64_t>() <= uint64_t(INT32_MAX);
      case JsonKind::Size: return nonNegativeInteger;
      case JsonKind::Number: return value.is_number();
      case JsonKind::String: return value.is_string();
      case JsonKind::Boolean: return value.is_boolean();
      case JsonKind::Object: return value.is_object();
      case JsonKind::Array: return value.is_array();
    }
    return false;
  }

  static const char* kindName(JsonKind kind) {
    switch (kind) {
      case JsonKind::Index: return "an index (integer in [0, 2^31))";
      case JsonKind::Size: return "a non-negative integer";
      case JsonKind::Number: return "a number";
      case JsonKind::String: return "a string";
      case JsonKind::Boolean: return "a boolean";
      case JsonKind::Object: return "an object";
      case JsonKind::Array: return "an array";
    }
    return "?";
  }

  static std::string member(const std::string& where, const std::string& key) {
    return where.empty() ? key : where + "." + key;
  }

  void expectKind(const nlohmann::json& value, JsonKind kind, const std::string& what) const {
    if (!isKind(value, kind)) fail(what + " is " + describeJson(value) + ", expected " + kindName(kind));
  }

  static std::string describeJson(const nlohmann::json& value) {
    if (value.is_object()) return "an object";
    if (value.is_array()) return "an array";
    if (value.is_string()) {
      const std::string text = value.get<std::string>();
      return "the string \"" + (text.size() > 32 ? text.substr(0, 32) + "..." : text) + "\"";
    }
    return value.dump();  // number, boolean or null
  }

  // `object[key]`, when present, must be of `kind`.
  void expectMember(const nlohmann::json& object, const char* key, JsonKind kind, const std::string& where) const {
    const auto it = object.find(key);
    if (it != object.end()) expectKind(*it, kind, member(where, key));
  }

  // `object[key]`, when present, must be an array (of `length` elements unless 0) of `kind`.
  void expectArrayOf(const nlohmann::json& object, const char* key, JsonKind kind, size_t length,
                     const std::string& where) const {
    const auto it = object.find(key);
    if (it == object.end()) return;
    const std::string what = member(where, key);
    expectKind(*it, JsonKind::Array, what);
    if (length && it->size() != length)
      fail(what + " has " + std::to_string(it->size()) + " elements, expected " + std::to_string(length));
    for (size_t i = 0; i < it->size(); ++i) expectKind((*it)[i], kind, what + "[" + std::to_string(i) + "]");
  }

  // `object[key]`, when present, must be an array of objects; `check` looks into each.
  template <typename Check>
  void forEachObject(const nlohmann::json& object, const char* key, const std::string& where, Check check) const {
    const auto it = object.find(key);
    if (it == object.end()) return;
    const std::string what = member(where, key);
    expectKind(*it, JsonKind::Array, what);
    for (size_t i = 0; i < it->size(); ++i) {
      const std::string element = what + "[" + std::to_string(i) + "]";
      expectKind((*it)[i], JsonKind::Object, element);
      check((*it)[i], element);
    }
  }

  // The properties that decide the geometry, the transforms and the lights' placement.
  void checkJsonTypes(const nlohmann::json& root) const {
    if (!root.is_object()) fail("the JSON top level is not an object");
    expectMember(root, "scene", JsonKind::Index, "");
    expectMember(root, "extensions", JsonKind::Object, "");
    expectArrayOf(root, "extensionsUsed", JsonKind::String, 0, "");
    expectArrayOf(root, "extensionsRequired", JsonKind::String, 0, "");
    forEachObject(root, "scenes", "", [&](const nlohmann::json& scene, const std::string& where) {
      expectArrayOf(scene, "nodes", JsonKind::Index, 0, where);
    });
    forEachObject(root, "nodes", "", [&](const nlohmann::json& node, const std::string& where) {
      expectArrayOf(node, "children", JsonKind::Index, 0, where);
      expectMember(node, "mesh", JsonKind::Index, where);
      expectArrayOf(node, "matrix", JsonKind::Number, 16, where);
      expectArrayOf(node, "translation", JsonKind::Number, 3, where);
      expectArrayOf(node, "rotation", JsonKind::Number, 4, where);
      expectArrayOf(node, "scale", JsonKind::Number, 3, where);
      expectMember(node, "extensions", JsonKind::Object, where);
    });
    forEachObject(root, "meshes", "", [&](const nlohmann::json& mesh, const std::string& where) {
      if (!mesh.contains("primitives")) fail(where + ".primitives is missing");
      forEachObject(mesh, "primitives", where, [&](const nlohmann::json& primitive, const std::string& at) {
        if (!primitive.contains("attributes")) fail(at + ".attributes is missing");
        expectMember(primitive, "attributes", JsonKind::Object, at);
        for (const auto& [name, value] : primitive["attributes"].items())
          expectKind(value, JsonKind::Index, at + ".attributes." + name);
        expectMember(primitive, "indices", JsonKind::Index, at);
        expectMember(primitive, "mode", JsonKind::Index, at);
        expectMember(primitive, "targets", JsonKind::Array, at);
        expectMember(primitive, "extensions", JsonKind::Object, at);
      });
    });
    forEachObject(root, "accessors", "", [&](const nlohmann::json& accessor, const std::string& where) {
      expectMember(accessor, "bufferView", JsonKind::Index, where);
      expectMember(accessor, "byteOffset", JsonKind::Size, where);
      expectMember(accessor, "componentType", JsonKind::Index, where);
      expectMember(accessor, "count", JsonKind::Size, where);
      expectMember(accessor, "type", JsonKind::String, where);
      expectMember(accessor, "normalized", JsonKind::Boolean, where);
      expectMember(accessor, "sparse", JsonKind::Object, where);
      if (!accessor.contains("sparse")) return;
      const nlohmann::json& sparse = accessor["sparse"];
      const std::string at = where + ".sparse";
      expectMember(sparse, "count", JsonKind::Index, at);
      for (const char* part : {"indices", "values"}) {
        if (!sparse.contains(part)) fail(at + "." + part + " is missing");
        expectMember(sparse, part, JsonKind::Object, at);
        expectMember(sparse[part], "bufferView", JsonKind::Index, at + "." + part);
        expectMember(sparse[part], "byteOffset", JsonKind::Index, at + "." + part);
        expectMember(sparse[part], "componentType", JsonKind::Index, at + "." + part);
      }
    });
    forEachObject(root, "bufferViews", "", [&](const nlohmann::json& view, const std::string& where) {
      expectMember(view, "buffer", JsonKind::Index, where);
      expectMember(view, "byteOffset", JsonKind::Size, where);
      expectMember(view, "byteLength", JsonKind::Size, where);
      expectMember(view, "byteStride", JsonKind::Size, where);
    });
    forEachObject(root, "buffers", "", [&](const nlohmann::json& buffer, const std::string& where) {
      expectMember(buffer, "byteLength", JsonKind::Size, where);
      expectMember(buffer, "uri", JsonKind::String, where);
    });
  }

  void checkRequiredExtensions() {
    for (const std::string& extension : model_.extensionsRequired) {
      if (!kSupportedExtensions.count(extension) && !kSupportedGeometryExtensions.count(extension))
        warn("requires extension " + extension + ", which cpvs ignores (geometry imported as if it were absent)");
    }
  }

  std::string describeNode(int index) const {
    const std::string& name = model_.nodes[size_t(index)].name;
    return "node " + std::to_string(index) + (name.empty() ? "" : " '" + name + "'");
  }

  double finiteNumber(const tinygltf::Value& value, const std::string& what) const {
    if (!value.IsNumber()) fail(what + " is not a number");
    const double number = value.GetNumberAsDouble();
    if (!std::isfinite(number)) fail(what + " is not finite");
    return number;
  }

  // The KHR_lights_punctual light definitions (placed later by nodes).
  void parseLights() {
    const auto extension = model_.extensions.find(kLightsExtension);
    if (extension == model_.extensions.end()) return;
    const tinygltf::Value& root = extension->second;
    const std::string prefix = std::string("extensions.") + kLightsExtension;
    if (!root.IsObject()) fail(prefix + " is not an object");
    if (!root.Has("lights")) return;
    const tinygltf::Value& lights = root.Get("lights");
    if (!lights.IsArray()) fail(prefix + ".lights is not an array");
    for (size_t i = 0; i < lights.ArrayLen(); ++i) {
      const tinygltf::Value& object = lights.Get(int(i));
      const std::string what = prefix + ".lights[" + std::to_string(i) + "]";
      if (!object.IsObject()) fail(what + " is not an object");
      Light light;
      if (object.Has("name")) {
        if (!object.Get("name").IsString()) fail(what + ".name is not a string");
        light.name = object.Get("name").Get<std::string>();
      }
      if (!object.Has("type") || !object.Get("type").IsString()) fail(what + ".type is missing or not a string");
      const std::string type = object.Get("type").Get<std::string>();
      if (type == "directional")
        light.type = LightType::Directional;
      else if (type == "spot")
        light.type = LightType::Spot;
      else if (type == "point")
        light.type = LightType::Point;
      else
        fail(what + ".type '" + type + "' is not directional, spot or point");
      if (object.Has("color")) {
        const tinygltf::Value& color = object.Get("color");
        if (!color.IsArray() || color.ArrayLen() != 3) fail(what + ".color is not an array of 3 numbers");
        for (int c = 0; c < 3; ++c) {
          light.color[c] = float(finiteNumber(color.Get(c), what + ".color[" + std::to_string(c) + "]"));
          if (light.color[c] < 0.0f) fail(what + ".color is negative");
        }
      }
      if (object.Has("intensity")) {
        light.intensity = float(finiteNumber(object.Get("intensity"), what + ".intensity"));
        if (light.intensity < 0.0f) fail(what + ".intensity is negative");
      }
      if (object.Has("range") && light.type != LightType::Directional) {
        light.range = finiteNumber(object.Get("range"), what + ".range");
        if (!(light.range > 0.0)) fail(what + ".range must be greater than zero");
      }
      if (light.type == LightType::Spot && object.Has("spot")) {
        const tinygltf::Value& spot = object.Get("spot");
        if (!spot.IsObject()) fail(what + ".spot is not an object");
        if (spot.Has("innerConeAngle"))
          light.innerConeAngle = finiteNumber(spot.Get("innerConeAngle"), what + ".spot.innerConeAngle");
        if (spot.Has("outerConeAngle"))
          light.outerConeAngle = finiteNumber(spot.Get("outerConeAngle"), what + ".spot.outerConeAngle");
        if (!(light.outerConeAngle > 0.0 && light.outerConeAngle <= std::numbers::pi / 2))
          fail(what + ".spot.outerConeAngle " + std::to_string(light.outerConeAngle) + " is not in (0, pi/2]");
        // Exporters write inner == outer (Blender with blend 0); only the outer cone matters for shadows.
        if (light.innerConeAngle < 0.0 || light.innerConeAngle > light.outerConeAngle) {
          warn(what + ".spot.innerConeAngle is outside [0, outerConeAngle]; clamped");
          light.innerConeAngle = std::clamp(light.innerConeAngle, 0.0, light.outerConeAngle);
        }
      }
      lightDefinitions_.push_back(light);
    }
  }

  std::vector<int> rootNodes() const {
    if (model_.defaultScene >= int(model_.scenes.size()))
      fail("default scene " + std::to_string(model_.defaultScene) + " does not exist");
    if (model_.defaultScene >= 0) return model_.scenes[size_t(model_.defaultScene)].nodes;
    if (!model_.scenes.empty()) return model_.scenes[0].nodes;
    std::vector<bool> isChild(model_.nodes.size(), false);
    for (const tinygltf::Node& node : model_.nodes)
      for (int child : node.children)
        if (child >= 0 && size_t(child) < isChild.size()) isChild[size_t(child)] = true;
    std::vector<int> roots;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
      if (!isChild[i]) roots.push_back(int(i));
    return roots;
  }

  glm::dmat4 localTransform(int index) const {
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

  // Depth-first over the node tree, without recursion (deep hostile trees must not overflow the stack).
  void traverse(const std::vector<int>& roots) {
    enum class State : uint8_t { Unvisited, Open, Done };
    std::vector<State> state(model_.nodes.size(), State::Unvisited);
    struct Frame {
      int node;
      glm::dmat4 worldFromLocal;
      size_t nextChild;
    };
    auto checkIndex = [&](int index, const std::string& referrer) {
      if (index < 0 || size_t(index) >= model_.nodes.size())
        fail(referrer + " refers to node " + std::to_string(index) + ", which does not exist");
    };
    for (int root : roots) {
      checkIndex(root, "the scene");
      if (state[size_t(root)] != State::Unvisited)
        fail(describeNode(root) + " is listed more than once in the scene or also is a child of another node");
      std::vector<Frame> stack;
      stack.push_back({root, localTransform(root), 0});
      state[size_t(root)] = State::Open;
      place(root, stack.back().worldFromLocal);
      while (!stack.empty()) {
        const int parent = stack.back().node;
        const tinygltf::Node& node = model_.nodes[size_t(parent)];
        if (stack.back().nextChild == node.children.size()) {
          state[size_t(parent)] = State::Done;
          stack.pop_back();
          continue;
        }
        const int child = node.children[stack.back().nextChild++];
        checkIndex(child, describeNode(parent));
        if (state[size_t(child)] == State::Open)
          fail("recursive node graph: " + describeNode(child) + " is a child of its own descendant " +
               describeNode(parent));
        if (state[size_t(child)] == State::Done)
          fail(describeNode(child) + " has more than one parent (a second one is " + describeNode(parent) + ")");
        const glm::dmat4 world = stack.back().worldFromLocal * localTransform(child);
        state[size_t(child)] = State::Open;
        stack.push_back({child, world, 0});
        place(child, world);
      }
    }
  }

  // ImportOptions::excludeMaterials: every pattern must match a material of the file.
  void applyMaterialExclusions() {
    for (const std::string& pattern : options_.excludeMaterials) {
      bool matched = false;
      for (size_t m = 0; m < model_.materials.size(); ++m) {
        const std::string name = model_.materials[m].name.empty() ? "material" + std::to_string(m) : model_.materials[m].name;
        matched = matched || fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
      }
      if (!matched) {
        std::string known;
        for (size_t m = 0; m < model_.materials.size() && m < 20; ++m)
          known += (m ? ", " : "") + (model_.materials[m].name.empty() ? "material" + std::to_string(m) : model_.materials[m].name);
        if (model_.materials.size() > 20) known += ", ...";
        throw Error(ErrorCategory::InvalidArgument, path_ + ": no material matches '" + pattern + "' (materials: " +
                                                        (known.empty() ? "none" : known) + ")");
      }
      for (Mesh& mesh : scene_.meshes)
        if (!mesh.material.empty() && fnmatch(pattern.c_str(), mesh.material.c_str(), 0) == 0) mesh.castsShadows = false;
    }
  }

  // A node's extras flag (kCastsShadowsExtra): false keeps the node's own meshes from casting shadows.
  bool castsShadows(const tinygltf::Node& node, const std::string& what) const {
    if (!node.extras.IsObject() || !node.extras.Has(kCastsShadowsExtra)) return true;
    const tinygltf::Value& flag = node.extras.Get(kCastsShadowsExtra);
    if (!flag.IsBool()) fail(what + ": extras." + kCastsShadowsExtra + " is not a boolean");
    return flag.Get<bool>();
  }

  // What a node puts into the world: instances of its mesh's primitives, and its light.
  void place(int index, const glm::dmat4& worldFromLocal) {
    const tinygltf::Node& node = model_.nodes[size_t(index)];
    const std::string nodeName = node.name.empty() ? "node" + std::to_string(index) : node.name;
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= model_.meshes.size())
        fail(describeNode(index) + ": mesh " + std::to_string(node.mesh) + " does not exist");
      if (node.skin >= 0) warnOnce("skinned meshes are imported in their bind pose (skins are ignored)");
      const bool casts = castsShadows(node, describeNode(index));
      for (uint32_t mesh : meshIds(node.mesh)) scene_.instances.push_back({mesh, worldFromLocal, nodeName, casts});
      placeGpuInstances(index);
    } else if (node.mesh < -1) {
      fail(describeNode(index) + ": mesh " + std::to_string(node.mesh) + " does not exist");
    }

    if (node.camera >= 0) placeCamera(index, node.camera, worldFromLocal);

    const auto extension = node.extensions.find(kLightsExtension);
    if (extension == node.extensions.end()) return;
    const tinygltf::Value& reference = extension->second;
    const std::string what = describeNode(index) + ": extensions." + kLightsExtension + ".light";
    if (!reference.IsObject() || !reference.Has("light")) fail(what + " is missing");
    const double lightIndex = finiteNumber(reference.Get("light"), what);
    if (lightIndex < 0 || lightIndex >= double(lightDefinitions_.size()) || lightIndex != std::floor(lightIndex))
      fail(what + " " + std::to_string(lightIndex) + " is not the index of a light (the file defines " +
           std::to_string(lightDefinitions_.size()) + ")");
    Light light = lightDefinitions_[size_t(lightIndex)];
    if (light.name.empty()) light.name = node.name.empty() ? "light" + std::to_string(size_t(lightIndex)) : node.name;
    light.position = glm::dvec3(worldFromLocal * glm::dvec4(0.0, 0.0, 0.0, 1.0));
    const glm::dvec3 direction = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 0.0, -1.0);
    const double length = glm::length(direction);
    if (!(length > 0.0) || !std::isfinite(length)) fail(describeNode(index) + ": the light's transform is degenerate");
    light.direction = direction / length;
    scene_.lights.push_back(light);
  }

  // EXT_mesh_gpu_instancing: the node's mesh is placed once per instance instead of once. The instances
  // replace the ones place() has just added for the node (the last of scene_.instances), each moved by its
  // instance transform (world = node * T * R * S) and named "<node>[<k>]".
  void placeGpuInstances(int index) {
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
  std::vector<glm::dmat4> gpuInstanceTransforms(int index, const tinygltf::Value& extension) const {
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

  // A perspective camera on a node (orthographic ones are skipped with a warning). Name: the camera's, else
  // the node's, else "camera<i>".
  void placeCamera(int nodeIndex, int cameraIndex, const glm::dmat4& worldFromLocal) {
    const std::string what = describeNode(nodeIndex) + ": camera " + std::to_string(cameraIndex);
    if (size_t(cameraIndex) >= model_.cameras.size()) fail(what + " does not exist");
    const tinygltf::Camera& source = model_.cameras[size_t(cameraIndex)];
    if (source.type != "perspective") {
      warn(what + " is " + (source.type.empty() ? "of no type" : source.type) + ", not perspective; skipped");
      return;
    }
    const tinygltf::PerspectiveCamera& p = source.perspective;
    // Cameras only matter to cpvs-view: a bad one is skipped with a warning, never fails a bake.
    if (!(p.yfov > 0 && p.yfov < 3.14159) || !(p.znear > 0) || !(p.aspectRatio >= 0) ||
        !(p.zfar == 0 || p.zfar > p.znear)) {
      warn(what + " skipped: yfov must be in (0, pi), znear > 0, aspectRatio >= 0 and zfar 0 or > znear");
      return;
    }
    Camera camera;
    const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
    camera.name = !source.name.empty() ? source.name
                                       : (!node.name.empty() ? node.name : "camera" + std::to_string(cameraIndex));
    camera.eye = glm::dvec3(worldFromLocal * glm::dvec4(0.0, 0.0, 0.0, 1.0));
    const glm::dvec3 forward = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 0.0, -1.0);
    const glm::dvec3 up = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 1.0, 0.0);
    const glm::dvec3 side = glm::cross(forward, up);
    if (!(glm::length(side) > 0.0) || !std::isfinite(glm::length(side)) || !std::isfinite(camera.eye.x + camera.eye.y + camera.eye.z)) {
      warn(what + " skipped: the node's transform is degenerate");
      return;
    }
    camera.forward = glm::normalize(forward);
    camera.up = glm::normalize(glm::cross(side, forward));
    camera.yfov = p.yfov;
    camera.aspectRatio = p.aspectRatio;
    camera.znear = p.znear;
    camera.zfar = p.zfar;
    scene_.cameras.push_back(camera);
  }

  // The base colour factor of a primitive's material (white without one; a factor outside [0, 1] is clamped
  // with a warning: colours only matter to cpvs-view). A material in the specular-glossiness model
  // (KHR_materials_pbrSpecularGlossiness, which supersedes the metallic-roughness block where present) shows
  // its diffuseFactor's colour; the alpha stays the metallic-roughness factor's, which alpha testing reads.
  glm::vec4 baseColorOf(const tinygltf::Primitive& primitive, const std::string& where) {
    if (primitive.material < 0) return glm::vec4(1.0f);
    if (size_t(primitive.material) >= model_.materials.size())
      fail(where + ": material " + std::to_string(primitive.material) + " does not exist");
    const tinygltf::Material& material = model_.materials[size_t(primitive.material)];
    const std::string what = where + ": material " + std::to_string(primitive.material);
    const auto clamped = [&](double value, const std::string& name) {
      if (!(value >= 0.0 && value <= 1.0)) warn(what + " " + name + " is not in [0, 1]; clamped");
      return std::isfinite(value) ? float(std::clamp(value, 0.0, 1.0)) : 1.0f;
    };
    const std::vector<double>& f = material.pbrMetallicRoughness.baseColorFactor;
    glm::vec4 color(1.0f);
    for (size_t c = 0; c < 4 && c < f.size(); ++c)
      color[int(c)] = clamped(f[c], "baseColorFactor[" + std::to_string(c) + "]");
    const auto specularGlossiness = material.extensions.find(kSpecularGlossinessExtension);
    if (specularGlossiness == material.extensions.end() || !specularGlossiness->second.IsObject() ||
        !specularGlossiness->second.Has("diffuseFactor"))
      return color;
    const tinygltf::Value& diffuse = specularGlossiness->second.Get("diffuseFactor");
    const std::string name = std::string(kSpecularGlossinessExtension) + ".diffuseFactor";
    if (!diffuse.IsArray() || diffuse.ArrayLen() != 4) fail(what + " " + name + " is not an array of 4 numbers");
    for (int c = 0; c < 3; ++c)
      color[c] = clamped(finiteNumber(diffuse.Get(c), what + " " + name + "[" + std::to_string(c) + "]"),
                         name + "[" + std::to_string(c) + "]");
    return color;
  }

  // The primitive's base-colour texture and TEXCOORD_0, when its material has one that decoded (else a
  // warning, and the mesh keeps its factor alone).
  void attachBaseColorTexture(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh) {
    if (primitive.material < 0 || size_t(primitive.material) >= model_.materials.size()) return;
    const tinygltf::TextureInfo& info = model_.materials[size_t(primitive.material)].pbrMetallicRoughness.baseColorTexture;
    if (info.index < 0) return;
    const std::string what = where + ": base-colour texture " + std::to_string(info.index);
    if (info.texCoord != 0) return warnOnce("only TEXCOORD_0 base-colour textures are shown (" + what + " uses another)");
    if (size_t(info.index) >= model_.textures.size()) return warn(what + " does not exist; not shown");
    const int source = model_.textures[size_t(info.index)].source;
    std::string problem;
    const std::vector<float> values = texCoords(primitive, 0, mesh, where, problem);
    if (values.empty()) return warn(problem + "; texture not shown");
    std::string why;
    const int32_t texture = textureOfImage(source, why);
    if (texture < 0) {
      return warnOnce(what + " (" + describeImage(source) + ") not shown: " + why);
    }
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const glm::vec2 t(values[2 * i], values[2 * i + 1]);
      mesh.uvs.push_back(std::isfinite(t.x) && std::isfinite(t.y) ? t : glm::vec2(0.0f));
    }
    mesh.baseColorTexture = texture;
  }

  // The images whose alpha an alpha-tested material reads (MASK, or BLEND when clipped), from the JSON before
  // tinygltf loads anything, so a bake reads no other image. Malformed entries are left to the later checks.
  std::set<int> alphaTestedImages(const nlohmann::json& root) const {
    std::set<int> images;
    if (!options_.alphaTest || !root.is_object() || !root.contains("materials") || !root["materials"].is_array())
      return images;
    const auto index = [](const nlohmann::json& object, const char* key) -> int {
      if (!object.is_object() || !object.contains(key) || !object[key].is_number_unsigned()) return -1;
      const uint64_t value = object[key].get<uint64_t>();
      return value <= uint64_t(INT32_MAX) ? int(value) : -1;
    };
    for (const nlohmann::json& material : root["materials"]) {
      if (!material.is_object() || !material.contains("alphaMode") || !material["alphaMode"].is_string()) continue;
      const AlphaMode mode = alphaModeOf(material["alphaMode"].get<std::string>());
      if (!casterAlpha(mode, 0.5f, options_.transparent, true).tested) continue;
      if (!material.contains("pbrMetallicRoughness")) continue;
      const nlohmann::json& pbr = material["pbrMetallicRoughness"];
      if (!pbr.is_object() || !pbr.contains("baseColorTexture")) continue;
      const int texture = index(pbr["baseColorTexture"], "index");
      if (texture < 0 || !root.contains("textures") || !root["textures"].is_array() ||
          size_t(texture) >= root["textures"].size())
        continue;
      const int source = index(root["textures"][size_t(texture)], "source");
      if (source >= 0 && root.contains("images") && root["images"].is_array() && size_t(source) < root["images"].size())
        images.insert(source);
    }
    return images;
  }

  // A material's shadow-casting rule (libcpvs/scene/coverage_mask.h, docs/alpha.md): whether the mesh casts,
  // and the coverage mask its triangles are cut by. A texture that is missing or cannot be decoded gives a
  // warning and counts as alpha 1.
  void attachCasterAlpha(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh) {
    if (primitive.material < 0) return;
    const tinygltf::Material& material = model_.materials[size_t(primitive.material)];
    mesh.material = material.name.empty() ? "material" + std::to_string(primitive.material) : material.name;
    if (material.extras.IsObject() && material.extras.Has(kCastsShadowsExtra)) {
      const tinygltf::Value& flag = material.extras.Get(kCastsShadowsExtra);
      if (!flag.IsBool()) fail(where + ": material '" + mesh.material + "' extras." + kCastsShadowsExtra + " is not a boolean");
      if (!flag.Get<bool>()) mesh.castsShadows = false;
    }
    const AlphaMode mode = alphaModeOf(material.alphaMode);
    if (mode == AlphaMode::Mask && !(material.alphaCutoff >= 0.0 && std::isfinite(material.alphaCutoff)))
      fail(where + ": material '" + mesh.material + "' alphaCutoff " + std::to_string(material.alphaCutoff) +
           " is not a non-negative number");
    const CasterAlpha rule = casterAlpha(mode, float(std::min(material.alphaCutoff, 2.0)), options_.transparent,
                                         options_.alphaTest);  // a cutoff above 1 cuts everything alike
    if (!rule.casts) mesh.castsShadows = false;
    // A mesh the extras flag keeps from casting still gets its mask: cpvs-view cuts it as a receiver.
    if (!rule.tested) return;
    const float factor = mesh.baseColor.a;
    const auto castsWhole = [&](bool blocks) {
      if (!blocks) mesh.castsShadows = false, mesh.cutAway = true;  // every texel cut away
    };
    const tinygltf::TextureInfo& info = material.pbrMetallicRoughness.baseColorTexture;
    if (info.index < 0) return castsWhole(factor >= rule.cutoff);
    const std::string what = where + ": material '" + mesh.material + "' base-colour texture " + std::to_string(info.index);
    if (size_t(info.index) >= model_.textures.size()) fail(what + " does not exist");
    const tinygltf::Texture& texture = model_.textures[size_t(info.index)];
    // KHR_texture_transform: offset, rotation, scale, and possibly another texture coordinate set.
    int texCoord = info.texCoord;
    glm::dmat3 transform(1.0);
    if (const auto t = info.extensions.find("KHR_texture_transform"); t != info.extensions.end())
      transform = textureTransform(t->second, what + ": KHR_texture_transform", texCoord);
    std::string why;
    const std::shared_ptr<const AlphaImage> alpha = alphaOfImage(texture.source, why);
    if (!alpha) {
      warnOnce(what + ": " + describeImage(texture.source) + ": " + why +
               "; its alpha is taken as 1, so the material casts by its factor alone (docs/alpha.md)");
      return castsWhole(factor >= rule.cutoff);
    }
    TextureWrap wrapS = TextureWrap::Repeat, wrapT = TextureWrap::Repeat;
    if (texture.sampler >= 0) {
      if (size_t(texture.sampler) >= model_.samplers.size()) fail(what + ": sampler " + std::to_string(texture.sampler) + " does not exist");
      wrapS = wrapOf(model_.samplers[size_t(texture.sampler)].wrapS, what + ": sampler wrapS");
      wrapT = wrapOf(model_.samplers[size_t(texture.sampler)].wrapT, what + ": sampler wrapT");
    }
    const std::string key = std::to_string(texture.source) + "/" + std::to_string(int(wrapS)) + "/" +
                            std::to_string(int(wrapT)) + "/" + std::to_string(std::bit_cast<uint32_t>(factor)) + "/" +
                            std::to_string(std::bit_cast<uint32_t>(rule.cutoff));
    int32_t maskIndex;
    if (const auto known = coverageMaskOf_.find(key); known != coverageMaskOf_.end()) {
      maskIndex = known->second;
    } else {
      CoverageMask mask = makeCoverageMask(alpha->width, alpha->height, alpha->alpha, factor, rule.cutoff, wrapS, wrapT);
      const size_t blocking = size_t(std::count(mask.blocks.begin(), mask.blocks.end(), uint8_t(1)));
      // A mask that blocks everywhere is no mask (the mesh may still be a closed solid); one that blocks
      // nowhere casts nothing.
      maskIndex = blocking == mask.blocks.size() ? -1 : (blocking == 0 ? -2 : int32_t(scene_.coverageMasks.size()));
      if (maskIndex >= 0) scene_.coverageMasks.push_back(std::move(mask));
      coverageMaskOf_[key] = maskIndex;
    }
    if (maskIndex == -1) return;
    if (maskIndex == -2) return castsWhole(false);
    std::string problem;
    const std::vector<float> values = texCoords(primitive, texCoord, mesh, where, problem);
    if (values.empty()) fail(what + ": " + problem);
    mesh.maskUvs.resize(mesh.positions.size());
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const glm::dvec3 t = transform * glm::dvec3(values[2 * i], values[2 * i + 1], 1.0);
      // Beyond +-1e30 every wrap has long repeated or clamped; the clamp keeps the float conversion defined. A
      // coordinate that is not finite stays so, and blocks light (coverage_mask.h).
      const auto toFloat = [](double v) { return std::isfinite(v) ? float(std::clamp(v, -1e30, 1e30)) : float(v); };
      mesh.maskUvs[i] = glm::vec2(toFloat(t.x), toFloat(t.y));
    }
    mesh.coverageMask = maskIndex;
  }

  TextureWrap wrapOf(int wrap, const std::string& what) const {
    switch (wrap) {
      case int(TextureWrap::Repeat): return TextureWrap::Repeat;
      case int(TextureWrap::ClampToEdge): return TextureWrap::ClampToEdge;
      case int(TextureWrap::MirroredRepeat): return TextureWrap::MirroredRepeat;
      default: fail(what + " " + std::to_string(wrap) + " is not a glTF wrap mode");
    }
  }

  // KHR_texture_transform as a matrix on (u, v, 1): translation * rotation * scale.
  glm::dmat3 textureTransform(const tinygltf::Value& value, const std::string& what, int& texCoord) const {
    if (!value.IsObject()) fail(what + " is not an object");
    double offset[2] = {0, 0}, scale[2] = {1, 1}, rotation = 0;
    const auto pair = [&](const char* key, double (&out)[2]) {
      if (!value.Has(key)) return;
      const tinygltf::Value& v = value.Get(key);
      if (!v.IsArray() || v.ArrayLen() != 2) fail(what + "." + key + " is not an array of 2 numbers");
      for (int c = 0; c < 2; ++c) out[c] = finiteNumber(v.Get(c), what + "." + key);
    };
    pair("offset", offset);
    pair("scale", scale);
    if (value.Has("rotation")) rotation = finiteNumber(value.Get("rotation"), what + ".rotation");
    if (value.Has("texCoord")) {
      const double set = finiteNumber(value.Get("texCoord"), what + ".texCoord");
      if (set < 0 || set > 64 || set != std::floor(set)) fail(what + ".texCoord is not a texture coordinate set");
      texCoord = int(set);
    }
    const double c = std::cos(rotation), s = std::sin(rotation);
    // Columns (glm is column-major): u' = ox + c sx u + s sy v, v' = oy - s sx u + c sy v.
    return glm::dmat3(glm::dvec3(c * scale[0], -s * scale[0], 0.0), glm::dvec3(s * scale[1], c * scale[1], 0.0),
                      glm::dvec3(offset[0], offset[1], 1.0));
  }

  // The alpha channel of glTF image `source`, decoded on its first use with the viewer's limits (or taken from
  // the base-colour texture cpvs-view already decoded); null with `why` when it is missing or cannot be decoded.
  std::shared_ptr<const AlphaImage> alphaOfImage(int source, std::string& why) {
    if (const auto known = alphaOfImage_.find(source); known != alphaOfImage_.end()) {
      if (!known->second) why = imageFailures_[source];
      return known->second;
    }
    const auto alphaOf = [](const Texture& texture) {
      auto image = std::make_shared<AlphaImage>();
      image->width = texture.width;
      image->height = texture.height;
      image->alpha.resize(size_t(texture.width) * texture.height);
      for (size_t i = 0; i < image->alpha.size(); ++i) image->alpha[i] = texture.rgba[4 * i + 3];
      return image;
    };
    std::shared_ptr<const AlphaImage> result;
    if (const auto decoded = textureOfImage_.find(source); decoded != textureOfImage_.end() && decoded->second >= 0) {
      result = alphaOf(scene_.textures[size_t(decoded->second)]);
    } else if (const auto bytes = imageKeeping_.images.find(source); bytes == imageKeeping_.images.end()) {
      why = "not found, or not a PNG or JPEG";
    } else if (Texture texture; gltf::decodeTexture(bytes->second.data(), bytes->second.size(), texture, why)) {
      result = alphaOf(texture);
    }
    if (!result) imageFailures_[source] = why;
    alphaOfImage_[source] = result;
    return result;
  }

  // "image 3 'leaf.png'" (data: URIs shortened), for messages.
  std::string describeImage(int source) const {
    std::string text = "image " + std::to_string(source);
    if (source >= 0 && size_t(source) < model_.images.size() && !model_.images[size_t(source)].uri.empty())
      text += " '" + gltf::shortenDataUris(model_.images[size_t(source)].uri) + "'";
    return text;
  }

  // The values of the primitive's TEXCOORD_<set> (two per position); empty, with `problem` saying why, when it
  // is missing, not VEC2, or not one per position.
  std::vector<float> texCoords(const tinygltf::Primitive& primitive, int set, const Mesh& mesh,
                               const std::string& where, std::string& problem) const {
    const std::string name = "TEXCOORD_" + std::to_string(set);
    const auto uv = primitive.attributes.find(name);
    if (uv == primitive.attributes.end()) {
      problem = where + ": the primitive has no " + name;
      return {};
    }
    const tinygltf::Accessor& source = accessor(uv->second, where + ": " + name);
    if (source.type != TINYGLTF_TYPE_VEC2) {
      problem = where + ": " + name + " is " + typeName(source.type) + ", not VEC2";
      return {};
    }
    const int componentType = source.componentType;
    const bool normalized = source.normalized;
    std::vector<float> values = decodeAccessor<float>(uv->second, where + ": " + name, [&](const unsigned char* bytes) {
      return componentAsFloat(bytes, componentType, normalized);
    });
    if (values.size() != mesh.positions.size() * 2) {
      problem = where + ": " + name + " has " + std::to_string(values.size() / 2) + " elements, POSITION " +
                std::to_string(mesh.positions.size());
      return {};
    }
    return values;
  }

  // The Scene::textures index of glTF image `source`, decoded on its first use; -1 with `why` when it is
  // missing or cannot be decoded.
  int32_t textureOfImage(int source, std::string& why) {
    if (const auto known = textureOfImage_.find(source); known != textureOfImage_.end()) {
      if (known->second < 0) why = imageFailures_[source];
      return known->second;
    }
    int32_t index = -1;
    Texture texture;
    const auto bytes = imageKeeping_.images.find(source);
    if (bytes == imageKeeping_.images.end()) {
      why = "not found, or not a PNG or JPEG";
    } else if (gltf::decodeTexture(bytes->second.data(), bytes->second.size(), texture, why)) {
      const std::string& name = model_.images[size_t(source)].name;
      texture.name = name.empty() ? "image" + std::to_string(source) : name;
      index = int32_t(scene_.textures.size());
      scene_.textures.push_back(std::move(texture));
    }
    // Decoded or not, the bytes are done with (unless an alpha-tested material may still read them).
    if (bytes != imageKeeping_.images.end() && !imageKeeping_.needed.count(source)) imageKeeping_.images.erase(bytes);
    if (index < 0) imageFailures_[source] = why;
    textureOfImage_[source] = index;
    return index;
  }

  // The cpvs meshes made of a glTF mesh's triangle primitives, decoded on first use.
  const std::vector<uint32_t>& meshIds(int meshIndex) {
    if (meshCache_.empty()) meshCache_.resize(model_.meshes.size());
    auto& cached = meshCache_[size_t(meshIndex)];
    if (cached) return *cached;
    const tinygltf::Mesh& mesh = model_.meshes[size_t(meshIndex)];
    const std::string name = mesh.name.empty() ? "mesh" + std::to_string(meshIndex) : mesh.name;
    std::vector<uint32_t> ids;
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      // A Draco-compressed primitive's accessors are first pointed at its decoded values.
      gltf::decodeDracoPrimitive(path_, "mesh '" + name + "' primitive " + std::to_string(p), mesh.primitives[p],
                                 model_, dracoAccessors_);
      std::optional<Mesh> primitive = importPrimitive(mesh.primitives[p], name, p, mesh.primitives.size() > 1);
      if (!primitive) continue;
      ids.push_back(uint32_t(scene_.meshes.size()));
      scene_.meshes.push_back(std::move(*primitive));
    }
    cached = std::move(ids);
    return *cached;
  }

  std::optional<Mesh> importPrimitive(const tinygltf::Primitive& primitive, const std::string& meshName,
                                      size_t primitiveIndex, bool severalPrimitives) {
    const std::string where = "mesh '" + meshName + "' primitive " + std::to_string(primitiveIndex);
    const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
    if (mode > TINYGLTF_MODE_TRIANGLE_FAN) fail(where + ": unknown primitive mode " + std::to_string(mode));
    if (mode < TINYGLTF_MODE_TRIANGLES) {
      warn(where + ": " + modeName(mode) + " skipped (only triangles cast shadows)");
      return std::nullopt;
    }
    const auto position = primitive.attributes.find("POSITION");
    if (position == primitive.attributes.end()) {
      warn(where + ": no POSITION attribute; skipped");
      return std::nullopt;
    }
    if (!primitive.targets.empty()) warnOnce("morph targets are ignored (meshes are imported in their base shape)");

    Mesh mesh;
    mesh.name = severalPrimitives ? meshName + "#" + std::to_string(primitiveIndex) : meshName;
    mesh.positions = readPositions(position->second, where);
    std::vector<uint32_t> sequence;
    if (primitive.indices >= 0) {
      sequence = readIndices(primitive.indices, where);
      for (uint32_t index : sequence)
        if (index >= mesh.positions.size())
          fail(where + ": index " + std::to_string(index) + " out of range (POSITION accessor " +
               std::to_string(position->second) + " has " + std::to_string(mesh.positions.size()) + " vertices)");
    } else {
      sequence.resize(mesh.positions.size());
      for (size_t i = 0; i < sequence.size(); ++i) sequence[i] = uint32_t(i);
    }
    Triangulation triangles = triangulate(mode, sequence);
    if (triangles.ignoredTrailing)
      warn(where + ": " + std::to_string(triangles.ignoredTrailing) +
           " trailing vertices ignored (TRIANGLES needs a multiple of 3)");
    if (triangles.droppedDegenerate && mode == TINYGLTF_MODE_TRIANGLES) {
      if (degenerate_.primitives++ == 0) degenerate_.first = where;
      degenerate_.triangles += triangles.droppedDegenerate;
    }
    if (triangles.indices.empty()) {
      warn(where + ": no triangles; skipped");
      return std::nullopt;
    }
    mesh.indices = std::move(triangles.indices);
    mesh.baseColor = baseColorOf(primitive, where);
    // The base-colour texture first: an alpha-tested material then takes its alpha from that decode.
    if (options_.loadBaseColorTextures) attachBaseColorTexture(primitive, where, mesh);
    attachCasterAlpha(primitive, where, mesh);
    return mesh;
  }

  const tinygltf::Accessor& accessor(int index, const std::string& what) const {
    if (index < 0 || size_t(index) >= model_.accessors.size())
      fail(what + ": accessor " + std::to_string(index) + " does not exist");
    return model_.accessors[size_t(index)];
  }

  // The bytes of `count` elements of `elementSize` bytes, `stride` apart, from `offset` in a buffer view;
  // every bound is checked (without overflow) before anything is read.
  const unsigned char* viewBytes(int viewIndex, size_t offset, size_t count, size_t elementSize, size_t stride,
                                 const std::string& what) const {
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

  // All elements of an accessor, components in order, sparse substitutions applied.
  template <typename Out, typename Convert>
  std::vector<Out> decodeAccessor(int index, const std::string& what, Convert convert) const {
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

  std::vector<glm::vec3> readPositions(int index, const std::string& where) const {
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

  std::vector<uint32_t> readIndices(int index, const std::string& where) const {
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
  struct {
    size_t triangles = 0, primitives = 0;
    std::string first;
  } degenerate_;  // reported once, not per primitive
};

}  // namespace

Scene importGltf(const std::string& path, const ImportOptions& options) { return GltfImporter(path, options).run(); }

}  // namespace cpvs
