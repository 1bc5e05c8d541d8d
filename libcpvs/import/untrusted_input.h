#pragma once
// The rules a glTF file must pass before tinygltf sees it, and the file access tinygltf is given, so that a
// hostile or broken asset gets a clear message instead of a crash, a hang or a read outside its folder
// (docs/robustness.md):
//  * JSON nesting at most kMaxJsonDepth levels (tinygltf's parser recurses and overflows the stack on deep
//    nesting), JSON text at most kMaxJsonBytes;
//  * a GLB header of version 2 whose lengths agree with the file and whose first chunk is the JSON;
//  * asset.version and asset.minVersion of major version 2;
//  * buffers only from regular files (no directory, FIFO or device) inside the scene's folder, unless
//    external URIs are allowed;
//  * data: URIs shortened wherever they appear in a message.
#include <cstddef>
#include <cstdint>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cpvs::gltf {

inline constexpr size_t kMaxJsonDepth = 128;
inline constexpr uint64_t kMaxJsonBytes = uint64_t(1) << 30;
inline constexpr uint64_t kMaxBufferFileBytes = uint64_t(1) << 32;

// The JSON text of a .gltf or .glb file: offset and length within the file's bytes.
struct JsonText {
  size_t begin = 0, length = 0;
};

// Checks the GLB header (for a file starting with "glTF") and returns where its JSON chunk is, or the whole
// file for a .gltf. Throws Error(InvalidInput) naming `path`.
JsonText locateJson(const std::string& path, std::span<const uint8_t> bytes);
// Throws Error(InvalidInput) when the JSON nests deeper than kMaxJsonDepth (counted outside strings), naming
// the byte offset where the limit is crossed.
void checkJsonNesting(const std::string& path, std::span<const uint8_t> json);
// asset.version (required) and asset.minVersion (optional) must be "2.x".
void checkAssetVersion(const std::string& path, const nlohmann::json& root);
// `text` with every data: URI longer than a few dozen characters cut to its start and its length.
std::string shortenDataUris(const std::string& text);

// What tinygltf's file callbacks may open: files under `folder` (canonical), or anywhere when
// `allowExternal`. The first refusal is kept, to be reported instead of tinygltf's "file not found".
struct FileAccess {
  std::string folder;
  bool allowExternal = false;
  // Image files (by file name) that may be read: every one, or only those named (what alpha-tested
  // materials need when a bake reads no other image).
  bool allImages = false;
  std::set<std::string> imageNames;
  std::string refusal;
  std::vector<std::string> read;  // the files read, in order (what a watch of the scene must watch)
};
// tinygltf::FsCallbacks members; user data is a FileAccess*.
bool fileExists(const std::string& path, void* access);
bool readWholeFile(std::vector<unsigned char>* out, std::string* error, const std::string& path, void* access);

}  // namespace cpvs::gltf
