#include "glb_writer.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace cpvs::scenegen {
namespace {

static_assert(std::endian::native == std::endian::little, "the GLB writer copies little-endian memory");

constexpr int kFloat = 5126;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

void put32(std::string& out, std::uint32_t v) {
  char b[4];
  std::memcpy(b, &v, 4);
  out.append(b, 4);
}

template <typename T>
std::size_t appendBytes(std::string& bin, const std::vector<T>& data) {
  const std::size_t offset = bin.size();
  bin.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(T));
  while (bin.size() % 4 != 0) bin.push_back('\0');
  return offset;
}

nlohmann::json vec3(const glm::dvec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

}  // namespace

std::string writeGlb(const GenScene& scene, const std::string& generator, const nlohmann::json& extras) {
  using nlohmann::json;
  json gltf = json::object();
  gltf["asset"] = {{"version", "2.0"}, {"generator", generator}};
  if (!extras.is_null()) gltf["asset"]["extras"] = extras;

  std::string bin;
  json bufferViews = json::array(), accessors = json::array(), meshes = json::array();
  for (const GenMesh& m : scene.meshes) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const std::size_t posOffset = appendBytes(bin, m.positions);
    const std::size_t idxOffset = appendBytes(bin, m.indices);
    const std::size_t posView = bufferViews.size();
    bufferViews.push_back({{"buffer", 0},
                           {"byteOffset", posOffset},
                           {"byteLength", m.positions.size() * sizeof(glm::vec3)},
                           {"target", kArrayBuffer}});
    bufferViews.push_back({{"buffer", 0},
                           {"byteOffset", idxOffset},
                           {"byteLength", m.indices.size() * sizeof(std::uint32_t)},
                           {"target", kElementArrayBuffer}});
    const std::size_t posAccessor = accessors.size();
    accessors.push_back({{"bufferView", posView},
                         {"componentType", kFloat},
                         {"count", m.positions.size()},
                         {"type", "VEC3"},
                         {"min", json::array({lo.x, lo.y, lo.z})},
                         {"max", json::array({hi.x, hi.y, hi.z})}});
    accessors.push_back({{"bufferView", posView + 1},
                         {"componentType", kUnsignedInt},
                         {"count", m.indices.size()},
                         {"type", "SCALAR"}});
    meshes.push_back({{"name", m.name},
                      {"primitives", json::array({{{"attributes", {{"POSITION", posAccessor}}},
                                                   {"indices", posAccessor + 1},
                                                   {"mode", 4}}})}});
  }

  json nodes = json::array(), roots = json::array();
  for (std::size_t i = 0; i < scene.nodes.size(); ++i) {
    const GenNode& n = scene.nodes[i];
    json node = {{"name", n.name}};
    if (n.mesh >= 0) node["mesh"] = n.mesh;
    if (n.light >= 0) node["extensions"] = {{"KHR_lights_punctual", {{"light", n.light}}}};
    if (n.translation != glm::dvec3(0.0)) node["translation"] = vec3(n.translation);
    if (!n.rotation.isIdentity())
      node["rotation"] = json::array({n.rotation.x, n.rotation.y, n.rotation.z, n.rotation.w});
    nodes.push_back(std::move(node));
    roots.push_back(i);
  }

  gltf["buffers"] = json::array({{{"byteLength", bin.size()}}});
  gltf["bufferViews"] = std::move(bufferViews);
  gltf["accessors"] = std::move(accessors);
  gltf["meshes"] = std::move(meshes);
  gltf["nodes"] = std::move(nodes);
  gltf["scenes"] = json::array({{{"name", "scene"}, {"nodes", std::move(roots)}}});
  gltf["scene"] = 0;

  if (!scene.lights.empty()) {
    json lights = json::array();
    for (const GenLight& l : scene.lights) {
      json j = {{"name", l.name}, {"color", vec3(l.color)}, {"intensity", l.intensity}};
      if (l.type == GenLight::Type::Directional) {
        j["type"] = "directional";
      } else {
        j["type"] = "spot";
        j["spot"] = {{"innerConeAngle", l.innerConeAngle}, {"outerConeAngle", l.outerConeAngle}};
      }
      if (l.range > 0.0) j["range"] = l.range;
      lights.push_back(std::move(j));
    }
    gltf["extensions"] = {{"KHR_lights_punctual", {{"lights", std::move(lights)}}}};
    gltf["extensionsUsed"] = json::array({"KHR_lights_punctual"});
  }

  std::string text = gltf.dump();
  while (text.size() % 4 != 0) text.push_back(' ');

  std::string out;
  const std::uint64_t total = 12 + 8 + text.size() + 8 + bin.size();
  if (total > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("the scene does not fit a GLB file (over 4 GiB)");
  out.reserve(static_cast<std::size_t>(total));
  put32(out, 0x46546C67u);  // "glTF"
  put32(out, 2);
  put32(out, static_cast<std::uint32_t>(total));
  put32(out, static_cast<std::uint32_t>(text.size()));
  put32(out, 0x4E4F534Au);  // "JSON"
  out += text;
  put32(out, static_cast<std::uint32_t>(bin.size()));
  put32(out, 0x004E4942u);  // "BIN\0"
  out += bin;
  return out;
}

}  // namespace cpvs::scenegen
