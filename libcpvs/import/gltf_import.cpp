// The driver of the glTF import (gltf_import.h): reading the file under the untrusted-input rules, handing it to
// tinygltf, then the scene walk that places each node's meshes, camera and light. The concerns it calls on
// live in files of their own (gltf_importer.h lists them).
#include "libcpvs/import/gltf_import.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "libcpvs/import/compressed_geometry.h"
#include "libcpvs/import/gltf_importer.h"
#include "libcpvs/import/json_checks.h"
#include "libcpvs/import/materials.h"
#include "libcpvs/import/untrusted_input.h"
#include "libcpvs/base/error.h"
#include "libcpvs/scene/mesh_topology.h"

namespace cpvs {
namespace gltf {
namespace {

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

}  // namespace

Scene GltfImporter::run() {
  scene_.source = path_;
  scene_.files.insert(scene_.files.begin(), path_);
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

void GltfImporter::load() {
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
  checkGeometryExtensions(path_, root);
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
    // Nor about image files missing or empty: the material that uses one says what is wrong with it, once.
    if ((line.rfind("File not found", 0) == 0 || line.rfind("File is empty", 0) == 0 ||
         line.rfind("File read error", 0) == 0) &&
        hasImageExtension(line.substr(0, line.find(" : ", line.find(" : ") + 3))))
      continue;
    warn(gltf::shortenDataUris(line));
  }
  // A buffer refused by the file rules: say why, rather than tinygltf's "file not found".
  if (!access.refusal.empty()) fail("buffer " + gltf::shortenDataUris(access.refusal));
  for (const std::string& file : access.read) scene_.files.push_back(file);
  // tinygltf reports some problems in `errors` and still returns true; those are errors too.
  const std::vector<std::string> errorLines = lines(errors);
  if (!ok || !errorLines.empty()) {
    std::string message;
    for (const std::string& line : errorLines) message += (message.empty() ? "" : "; ") + line;
    fail(message.empty() ? "not a valid glTF 2.0 file" : gltf::shortenDataUris(message));
  }

  // tinygltf silently ignores optional properties of the wrong JSON type ("mesh": "0" would just lose the
  // mesh), so the properties cpvs relies on are type-checked here.
  checkJsonTypes(path_, root);
  gltf::restoreDracoIndices(dracoIndices_, model_);
  gltf::decodeMeshopt(path_, meshopt_, model_);
}

// Why glTF image `source` brought no bytes to decode: the loader skipped it, or its file is missing or empty.
std::string GltfImporter::whyImageHasNoBytes(int source) const {
  if (source < 0 || size_t(source) >= model_.images.size()) return "it does not exist";
  const tinygltf::Image& image = model_.images[size_t(source)];
  if (image.uri.empty()) return image.bufferView >= 0 ? "its bufferView holds no bytes" : "it has no uri and no bufferView";
  if (image.uri.rfind("data:", 0) == 0) return "its data: URI holds no bytes";
  std::error_code ec;
  const std::filesystem::path file =
      std::filesystem::absolute(path_, ec).parent_path() / std::filesystem::path(percentDecoded(image.uri));
  if (!std::filesystem::exists(file, ec)) return "the file " + file.lexically_normal().string() + " does not exist";
  if (!std::filesystem::is_regular_file(file, ec)) return "not a regular file";
  if (std::filesystem::file_size(file, ec) == 0) return "the file is empty";
  return "the file cannot be read (no permission, or it lies outside the scene's folder: see --allow-external-uris)";
}

std::string GltfImporter::describeNode(int index) const {
  const std::string& name = model_.nodes[size_t(index)].name;
  return "node " + std::to_string(index) + (name.empty() ? "" : " '" + name + "'");
}

double GltfImporter::finiteNumber(const tinygltf::Value& value, const std::string& what) const {
  if (!value.IsNumber()) fail(what + " is not a number");
  const double number = value.GetNumberAsDouble();
  if (!std::isfinite(number)) fail(what + " is not finite");
  return number;
}

std::vector<int> GltfImporter::rootNodes() const {
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

// Depth-first over the node tree, without recursion (deep hostile trees must not overflow the stack).
void GltfImporter::traverse(const std::vector<int>& roots) {
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

// A node's extras flag (kCastsShadowsExtra): false keeps the node's own meshes from casting shadows.
bool GltfImporter::castsShadows(const tinygltf::Node& node, const std::string& what) const {
  if (!node.extras.IsObject() || !node.extras.Has(kCastsShadowsExtra)) return true;
  const tinygltf::Value& flag = node.extras.Get(kCastsShadowsExtra);
  if (!flag.IsBool()) fail(what + ": extras." + kCastsShadowsExtra + " is not a boolean");
  return flag.Get<bool>();
}

// What a node puts into the world: instances of its mesh's primitives, its camera and its light.
void GltfImporter::place(int index, const glm::dmat4& worldFromLocal) {
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
  placeLight(index, worldFromLocal);
}

}  // namespace gltf

Scene importGltf(const std::string& path, const ImportOptions& options) {
  return gltf::GltfImporter(path, options).run();
}

}  // namespace cpvs
