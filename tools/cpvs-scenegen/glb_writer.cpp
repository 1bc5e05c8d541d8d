#include "glb_writer.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

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

using nlohmann::json;

// The binary chunk and the buffer views and accessors into it, appended to in the order the file lists them.
struct BinaryChunk {
  std::string bin;
  json bufferViews = json::array(), accessors = json::array();
  // EXT_mesh_gpu_instancing attributes already written, by their instances (nodes with the same instances, a
  // tree's trunk and crown, share them).
  std::vector<std::pair<const std::vector<GenInstance>*, json>> instancesWritten;

  // A buffer view of `data` and an accessor of it; returns the accessor's index.
  template <typename T>
  std::size_t addAccessor(const std::vector<T>& data, std::size_t components, const char* type, int componentType,
                          int target) {
    const std::size_t offset = appendBytes(bin, data);
    json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", data.size() * components * sizeof(float)}};
    if (target) view["target"] = target;
    bufferViews.push_back(std::move(view));
    accessors.push_back({{"bufferView", bufferViews.size() - 1},
                         {"componentType", componentType},
                         {"count", data.size()},
                         {"type", type}});
    return accessors.size() - 1;
  }

  json mesh(const GenMesh& m) {
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
    json attributes = {{"POSITION", posAccessor}};
    if (!m.texcoords.empty())  // after the indices, so that meshes without them keep their layout
      attributes["TEXCOORD_0"] = addAccessor(m.texcoords, 2, "VEC2", kFloat, kArrayBuffer);
    json primitive = {{"attributes", std::move(attributes)}, {"indices", posAccessor + 1}, {"mode", 4}};
    if (m.material >= 0) primitive["material"] = m.material;
    return {{"name", m.name}, {"primitives", json::array({std::move(primitive)})}};
  }

  // EXT_mesh_gpu_instancing: three float accessors (no buffer-view target: they are not vertex attributes).
  json instanceAttributes(const std::vector<GenInstance>& instances) {
    static_assert(sizeof(GenInstance) == 10 * sizeof(float), "GenInstance is compared byte for byte");
    for (const auto& [other, attributes] : instancesWritten) {
      if (other->size() == instances.size() &&
          std::memcmp(other->data(), instances.data(), instances.size() * sizeof(GenInstance)) == 0)
        return attributes;
    }
    std::vector<glm::vec3> t, s;
    std::vector<glm::vec4> r;
    t.reserve(instances.size());
    r.reserve(instances.size());
    s.reserve(instances.size());
    for (const GenInstance& i : instances) {
      t.push_back(i.translation);
      r.push_back(i.rotation);
      s.push_back(i.scale);
    }
    json attributes = json::object();
    attributes["TRANSLATION"] = addAccessor(t, 3, "VEC3", kFloat, 0);
    attributes["ROTATION"] = addAccessor(r, 4, "VEC4", kFloat, 0);
    attributes["SCALE"] = addAccessor(s, 3, "VEC3", kFloat, 0);
    instancesWritten.emplace_back(&instances, attributes);
    return attributes;
  }
};

json nodeJson(const GenScene& scene, const GenNode& n, BinaryChunk& chunk, bool& instancing) {
  if (n.mesh >= static_cast<int>(scene.meshes.size())) throw std::logic_error("node '" + n.name + "': no such mesh");
  json node = {{"name", n.name}};
  if (n.mesh >= 0) node["mesh"] = n.mesh;
  if (n.light >= 0) node["extensions"]["KHR_lights_punctual"] = {{"light", n.light}};
  if (!n.instances.empty()) {
    if (n.mesh < 0) throw std::logic_error("node '" + n.name + "': instances without a mesh");
    node["extensions"]["EXT_mesh_gpu_instancing"] = {{"attributes", chunk.instanceAttributes(n.instances)}};
    instancing = true;
  }
  // The transforms of nodes that place meshes are written as 32-bit float values (printed as the doubles they
  // are): a rewrite into EXT_mesh_gpu_instancing (gltf-transform instance, gltfpack -mi), whose accessors are
  // floats, then places every instance exactly where its node was. Lights keep their double directions.
  const auto asFloat = [&n](double v) { return n.mesh >= 0 ? double(float(v)) : v; };
  if (n.translation != glm::dvec3(0.0))
    node["translation"] = json::array({asFloat(n.translation.x), asFloat(n.translation.y), asFloat(n.translation.z)});
  if (!n.rotation.isIdentity())
    node["rotation"] = json::array({asFloat(n.rotation.x), asFloat(n.rotation.y), asFloat(n.rotation.z), asFloat(n.rotation.w)});
  return node;
}

json materialJson(const GenScene& scene, const GenMaterial& m) {
  json pbr = {{"baseColorFactor",
               json::array({m.baseColorFactor.r, m.baseColorFactor.g, m.baseColorFactor.b, m.baseColorFactor.a})},
              {"metallicFactor", 0.0},
              {"roughnessFactor", 1.0}};
  if (m.baseColorTexture >= 0) {
    if (m.baseColorTexture >= static_cast<int>(scene.textures.size()))
      throw std::logic_error("material '" + m.name + "': no such texture");
    pbr["baseColorTexture"] = {{"index", m.baseColorTexture}, {"texCoord", m.texCoord}};
  }
  json j = {{"name", m.name}, {"pbrMetallicRoughness", std::move(pbr)}, {"doubleSided", m.doubleSided}};
  switch (m.alphaMode) {
    case GenMaterial::AlphaMode::Opaque: j["alphaMode"] = "OPAQUE"; break;
    case GenMaterial::AlphaMode::Mask:
      j["alphaMode"] = "MASK";
      j["alphaCutoff"] = m.alphaCutoff;
      break;
    case GenMaterial::AlphaMode::Blend: j["alphaMode"] = "BLEND"; break;
  }
  return j;
}

json lightJson(const GenLight& l) {
  json j = {{"name", l.name}, {"color", vec3(l.color)}, {"intensity", l.intensity}};
  if (l.type == GenLight::Type::Directional) {
    j["type"] = "directional";
  } else if (l.type == GenLight::Type::Point) {
    j["type"] = "point";
  } else {
    j["type"] = "spot";
    j["spot"] = {{"innerConeAngle", l.innerConeAngle}, {"outerConeAngle", l.outerConeAngle}};
  }
  if (l.range > 0.0) j["range"] = l.range;
  return j;
}

// The GLB container: header, the JSON chunk (padded with spaces) and the binary chunk.
std::string glbContainer(std::string text, const std::string& bin) {
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

}  // namespace

std::string writeGlb(const GenScene& scene, const std::string& generator, const nlohmann::json& extras) {
  json gltf = json::object();
  gltf["asset"] = {{"version", "2.0"}, {"generator", generator}};
  if (!extras.is_null()) gltf["asset"]["extras"] = extras;

  BinaryChunk chunk;
  json meshes = json::array();
  for (const GenMesh& m : scene.meshes) {
    if (!m.texcoords.empty() && m.texcoords.size() != m.positions.size())
      throw std::logic_error("mesh '" + m.name + "': texcoords and positions differ in count");
    if (m.material >= static_cast<int>(scene.materials.size()))
      throw std::logic_error("mesh '" + m.name + "': no such material");
    meshes.push_back(chunk.mesh(m));
  }
  json nodes = json::array(), roots = json::array();
  bool instancing = false;
  for (std::size_t i = 0; i < scene.nodes.size(); ++i) {
    nodes.push_back(nodeJson(scene, scene.nodes[i], chunk, instancing));
    roots.push_back(i);
  }

  // Materials and embedded PNG textures (one image and one sampler per texture).
  json materials = json::array(), textures = json::array(), images = json::array(), samplers = json::array();
  for (const GenMaterial& m : scene.materials) materials.push_back(materialJson(scene, m));
  for (std::size_t i = 0; i < scene.textures.size(); ++i) {
    const GenTexture& t = scene.textures[i];
    const std::size_t offset = chunk.bin.size();
    chunk.bin += t.png;
    while (chunk.bin.size() % 4 != 0) chunk.bin.push_back('\0');
    chunk.bufferViews.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", t.png.size()}});
    images.push_back({{"name", t.name}, {"bufferView", chunk.bufferViews.size() - 1}, {"mimeType", "image/png"}});
    samplers.push_back(
        {{"magFilter", t.magFilter}, {"minFilter", t.minFilter}, {"wrapS", t.wrapS}, {"wrapT", t.wrapT}});
    textures.push_back({{"name", t.name}, {"sampler", i}, {"source", i}});
  }

  gltf["buffers"] = json::array({{{"byteLength", chunk.bin.size()}}});
  gltf["bufferViews"] = std::move(chunk.bufferViews);
  gltf["accessors"] = std::move(chunk.accessors);
  gltf["meshes"] = std::move(meshes);
  gltf["nodes"] = std::move(nodes);
  if (!materials.empty()) gltf["materials"] = std::move(materials);
  if (!textures.empty()) {
    gltf["textures"] = std::move(textures);
    gltf["images"] = std::move(images);
    gltf["samplers"] = std::move(samplers);
  }
  gltf["scenes"] = json::array({{{"name", "scene"}, {"nodes", std::move(roots)}}});
  gltf["scene"] = 0;

  if (!scene.lights.empty()) {
    json lights = json::array();
    for (const GenLight& l : scene.lights) lights.push_back(lightJson(l));
    gltf["extensions"] = {{"KHR_lights_punctual", {{"lights", std::move(lights)}}}};
  }
  // A loader without EXT_mesh_gpu_instancing would draw each instanced mesh once, at its node: required.
  json used = json::array();
  if (instancing) {
    used.push_back("EXT_mesh_gpu_instancing");
    gltf["extensionsRequired"] = json::array({"EXT_mesh_gpu_instancing"});
  }
  if (!scene.lights.empty()) used.push_back("KHR_lights_punctual");
  if (!used.empty()) gltf["extensionsUsed"] = std::move(used);
  return glbContainer(gltf.dump(), chunk.bin);
}

}  // namespace cpvs::scenegen
