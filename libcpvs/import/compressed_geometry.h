#pragma once
// Compressed glTF geometry, decoded into plain buffer views that the importer then reads like any other
// (docs/robustness.md, "Compressed geometry"):
//  * EXT_meshopt_compression and KHR_meshopt_compression (libmeshoptimizer): every compressed bufferView is
//    decoded into a buffer of its own (byteLength = count * byteStride), filters applied. Fallback buffers
//    (no data: tagged `fallback`, or without a uri and used only by compressed views) would make tinygltf
//    fail, so prepareMeshopt() replaces them in the JSON by a one-byte placeholder before tinygltf parses it;
//    decodeMeshopt() decodes after tinygltf has loaded the real buffers.
//  * KHR_draco_mesh_compression (libdraco): a primitive's Draco stream is decoded into one buffer view per
//    attribute that the extension's `attributes` map names (POSITION, TEXCOORD_n, ...) and one for the
//    indices; the primitive's accessors are pointed at them.
// Every size comes from the file, so every size is checked before anything is allocated from it: element
// counts at most 2^32 - 1, decoded views at most 4 GiB and no larger than the codec can express in the
// stream's bytes. A corrupt stream is Error(InvalidInput) naming the bufferView (meshopt) or the mesh and
// primitive (Draco).
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

namespace cpvs::gltf {

// One meshopt-compressed bufferView, as its extension object describes it.
struct MeshoptView {
  int view = -1;
  std::string extension;  // EXT_meshopt_compression or KHR_meshopt_compression
  int buffer = -1;        // where the compressed bytes are
  size_t byteOffset = 0, byteLength = 0, byteStride = 0, count = 0;
  std::string mode, filter;
};

struct MeshoptPlan {
  std::vector<MeshoptView> views;
  std::set<int> fallbackBuffers;  // replaced by placeholders in the JSON
  bool empty() const { return views.empty() && fallbackBuffers.empty(); }
};

// Finds the compressed bufferViews and the fallback buffers of `root` and checks their extension objects;
// replaces each fallback buffer in `root` by a one-byte data: placeholder (so buffer indices do not change).
// Throws Error(InvalidInput) naming `path` and the bufferView or buffer at fault.
MeshoptPlan prepareMeshopt(const std::string& path, nlohmann::json& root, bool binary);

// Decodes every view of `plan` from the buffers tinygltf loaded into a new buffer of `model`, and points the
// view at it. Throws Error(InvalidInput) naming `path` and the bufferView.
void decodeMeshopt(const std::string& path, const MeshoptPlan& plan, tinygltf::Model& model);

// tinygltf refuses a primitive whose indices accessor has no bufferView, as a Draco primitive's has: such
// accessors get the Draco bufferView in `root` for tinygltf's sake; restoreDracoIndices() takes it away again
// once tinygltf has parsed the file. Returns the accessors so patched.
std::vector<int> prepareDracoIndices(nlohmann::json& root);
void restoreDracoIndices(const std::vector<int>& accessors, tinygltf::Model& model);

// Decodes the KHR_draco_mesh_compression stream of `primitive` (if it has one) and points the accessors the
// extension names (its attributes and the indices) at new buffer views of `model` holding the decoded values.
// `decodedAccessors` remembers accessors done before, so a stream shared by several primitives is decoded once.
// `where` names the mesh and primitive in messages. Throws Error(InvalidInput) naming `path` and `where`.
void decodeDracoPrimitive(const std::string& path, const std::string& where, const tinygltf::Primitive& primitive,
                          tinygltf::Model& model, std::set<int>& decodedAccessors);

}  // namespace cpvs::gltf
