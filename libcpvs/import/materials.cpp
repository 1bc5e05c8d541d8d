// Materials of a glTF file as cpvs sees them: the base colour (factor and, for cpvs-view, texture), the
// alpha-tested shadow casters and their coverage masks (docs/alpha.md), KHR_texture_transform and sampler
// wraps, the images decoded on first use, and ImportOptions::excludeMaterials.
#include "libcpvs/import/materials.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>

#include <fnmatch.h>

#include "libcpvs/import/accessors.h"
#include "libcpvs/import/gltf_importer.h"
#include "libcpvs/import/texture_decode.h"
#include "libcpvs/import/untrusted_input.h"

namespace cpvs::gltf {
namespace {

constexpr const char* kSpecularGlossinessExtension = "KHR_materials_pbrSpecularGlossiness";

AlphaMode alphaModeOf(const std::string& mode) {
  if (mode == "MASK") return AlphaMode::Mask;
  if (mode == "BLEND") return AlphaMode::Blend;
  return AlphaMode::Opaque;
}

}  // namespace

bool skipImageDecoding(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                       void*) {
  return true;
}

bool keepImageBytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int, const unsigned char* bytes,
                    int size, void* userData) {
  auto& keeping = *static_cast<ImageKeeping*>(userData);
  if (bytes && size > 0 && (keeping.all || keeping.needed.count(index))) keeping.images[index].assign(bytes, bytes + size);
  return true;  // never fails the import
}

// The base colour factor of a primitive's material (white without one; a factor outside [0, 1] is clamped
// with a warning: colours only matter to cpvs-view). A material in the specular-glossiness model
// (KHR_materials_pbrSpecularGlossiness, which supersedes the metallic-roughness block where present) shows
// its diffuseFactor's colour; the alpha stays the metallic-roughness factor's, which alpha testing reads.
glm::vec4 GltfImporter::baseColorOf(const tinygltf::Primitive& primitive, const std::string& where) {
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
void GltfImporter::attachBaseColorTexture(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh) {
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
    const std::string& name = model_.materials[size_t(primitive.material)].name;
    return warnAboutImage(source, "material " + (name.empty() ? std::to_string(primitive.material) : "'" + name + "'"),
                          why, "cpvs-view shows the materials that use it without it");
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec2 t(values[2 * i], values[2 * i + 1]);
    mesh.uvs.push_back(std::isfinite(t.x) && std::isfinite(t.y) ? t : glm::vec2(0.0f));
  }
  mesh.baseColorTexture = texture;
}

// The images whose alpha an alpha-tested material reads (MASK, or BLEND when clipped), from the JSON before
// tinygltf loads anything, so a bake reads no other image. Malformed entries are left to the later checks.
std::set<int> GltfImporter::alphaTestedImages(const nlohmann::json& root) const {
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
void GltfImporter::attachCasterAlpha(const tinygltf::Primitive& primitive, const std::string& where, Mesh& mesh) {
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
    warnAboutImage(texture.source, "material '" + mesh.material + "'", why,
                   "its alpha is taken as 1, so the alpha-tested materials that use it cast by their factor alone "
                   "(docs/alpha.md)");
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

TextureWrap GltfImporter::wrapOf(int wrap, const std::string& what) const {
  switch (wrap) {
    case int(TextureWrap::Repeat): return TextureWrap::Repeat;
    case int(TextureWrap::ClampToEdge): return TextureWrap::ClampToEdge;
    case int(TextureWrap::MirroredRepeat): return TextureWrap::MirroredRepeat;
    default: fail(what + " " + std::to_string(wrap) + " is not a glTF wrap mode");
  }
}

// KHR_texture_transform as a matrix on (u, v, 1): translation * rotation * scale.
glm::dmat3 GltfImporter::textureTransform(const tinygltf::Value& value, const std::string& what, int& texCoord) const {
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
std::shared_ptr<const AlphaImage> GltfImporter::alphaOfImage(int source, std::string& why) {
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
    why = whyImageHasNoBytes(source);
  } else if (Texture texture; gltf::decodeTexture(bytes->second.data(), bytes->second.size(), texture, why)) {
    result = alphaOf(texture);
  }
  if (!result) imageFailures_[source] = why;
  alphaOfImage_[source] = result;
  return result;
}

void GltfImporter::warnAboutImage(int source, const std::string& user, const std::string& why,
                                  const std::string& consequence) {
  const auto [known, first] = imageWarnings_.try_emplace(source, scene_.warnings.size());
  if (first) return warn(describeImage(source) + " (" + user + "): " + why + "; " + consequence);
  std::string& warning = scene_.warnings[known->second];
  if (warning.find(consequence) == std::string::npos) warning += "; " + consequence;
}

// "image 3 'leaf.png'" (data: URIs shortened), for messages.
std::string GltfImporter::describeImage(int source) const {
  std::string text = "image " + std::to_string(source);
  if (source >= 0 && size_t(source) < model_.images.size() && !model_.images[size_t(source)].uri.empty())
    text += " '" + gltf::shortenDataUris(model_.images[size_t(source)].uri) + "'";
  return text;
}

// The values of the primitive's TEXCOORD_<set> (two per position); empty, with `problem` saying why, when it
// is missing, not VEC2, or not one per position.
std::vector<float> GltfImporter::texCoords(const tinygltf::Primitive& primitive, int set, const Mesh& mesh,
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
int32_t GltfImporter::textureOfImage(int source, std::string& why) {
  if (const auto known = textureOfImage_.find(source); known != textureOfImage_.end()) {
    if (known->second < 0) why = imageFailures_[source];
    return known->second;
  }
  int32_t index = -1;
  Texture texture;
  const auto bytes = imageKeeping_.images.find(source);
  if (bytes == imageKeeping_.images.end()) {
    why = whyImageHasNoBytes(source);
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

// ImportOptions::excludeMaterials: every pattern must match a material of the file.
void GltfImporter::applyMaterialExclusions() {
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

}  // namespace cpvs::gltf
