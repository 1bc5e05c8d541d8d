// The JSON checks of a glTF file (json_checks.h): the types tinygltf would coerce or drop without a word, and
// the extension lists (what cpvs imports, what it refuses, what it ignores with a warning).
#include "libcpvs/import/json_checks.h"

#include <cstdint>
#include <initializer_list>
#include <map>
#include <set>
#include <utility>

#include "libcpvs/import/gltf_importer.h"
#include "libcpvs/base/error.h"

namespace cpvs::gltf {
namespace {

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
const std::set<std::string> kSupportedExtensions = {kLightsExtension, "KHR_mesh_quantization", "KHR_texture_transform"};

// The checks of one file's JSON: `path` starts every message.
class JsonTypeChecks {
public:
  explicit JsonTypeChecks(const std::string& path) : path_(path) {}

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
        expectMembers(primitive, at, {{"indices", JsonKind::Index}, {"mode", JsonKind::Index},
                                      {"targets", JsonKind::Array}, {"extensions", JsonKind::Object}});
      });
    });
    forEachObject(root, "accessors", "", [&](const nlohmann::json& accessor, const std::string& where) {
      expectMembers(accessor, where,
                    {{"bufferView", JsonKind::Index}, {"byteOffset", JsonKind::Size}, {"componentType", JsonKind::Index},
                     {"count", JsonKind::Size}, {"type", JsonKind::String}, {"normalized", JsonKind::Boolean},
                     {"sparse", JsonKind::Object}});
      if (!accessor.contains("sparse")) return;
      const nlohmann::json& sparse = accessor["sparse"];
      const std::string at = where + ".sparse";
      expectMember(sparse, "count", JsonKind::Index, at);
      for (const char* part : {"indices", "values"}) {
        if (!sparse.contains(part)) fail(at + "." + part + " is missing");
        expectMember(sparse, part, JsonKind::Object, at);
        expectMembers(sparse[part], at + "." + part,
                      {{"bufferView", JsonKind::Index}, {"byteOffset", JsonKind::Index},
                       {"componentType", JsonKind::Index}});
      }
    });
    forEachObject(root, "bufferViews", "", [&](const nlohmann::json& view, const std::string& where) {
      expectMembers(view, where, {{"buffer", JsonKind::Index}, {"byteOffset", JsonKind::Size},
                                  {"byteLength", JsonKind::Size}, {"byteStride", JsonKind::Size}});
    });
    forEachObject(root, "buffers", "", [&](const nlohmann::json& buffer, const std::string& where) {
      expectMember(buffer, "byteLength", JsonKind::Size, where);
      expectMember(buffer, "uri", JsonKind::String, where);
    });
  }

private:
  [[noreturn]] void fail(const std::string& message) const {
    throw Error(ErrorCategory::InvalidInput, path_ + ": " + message);
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

  // Each `object[key]` of the list, when present, of its kind (checked in the list's order).
  void expectMembers(const nlohmann::json& object, const std::string& where,
                     std::initializer_list<std::pair<const char*, JsonKind>> members) const {
    for (const auto& [key, kind] : members) expectMember(object, key, kind, where);
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

  const std::string& path_;
};

}  // namespace

// A file that names a geometry extension cpvs cannot import is refused before any buffer is read.
void checkGeometryExtensions(const std::string& path, const nlohmann::json& root) {
  for (const char* key : {"extensionsRequired", "extensionsUsed"}) {
    const auto list = root.find(key);
    if (list == root.end() || !list->is_array()) continue;  // checkJsonTypes names a wrong type
    for (const nlohmann::json& name : *list) {
      if (!name.is_string()) continue;
      const auto unsupported = kUnsupportedGeometryExtensions.find(name.get<std::string>());
      if (unsupported == kUnsupportedGeometryExtensions.end()) continue;
      throw Error(ErrorCategory::NotSupported, path + ": " + key + " names " + unsupported->first +
                                                  ", which changes the geometry and which cpvs cannot import (" +
                                                  unsupported->second + ")");
    }
  }
}

void checkJsonTypes(const std::string& path, const nlohmann::json& root) { JsonTypeChecks(path).checkJsonTypes(root); }

void GltfImporter::checkRequiredExtensions() {
  for (const std::string& extension : model_.extensionsRequired) {
    if (!kSupportedExtensions.count(extension) && !kSupportedGeometryExtensions.count(extension))
      warn("requires extension " + extension + ", which cpvs ignores (geometry imported as if it were absent)");
  }
}

}  // namespace cpvs::gltf
