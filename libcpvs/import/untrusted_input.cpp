#include "libcpvs/import/untrusted_input.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "libcpvs/base/error.h"

namespace cpvs::gltf {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& message) {
  throw Error(ErrorCategory::InvalidInput, path + ": " + message);
}

uint32_t readU32(std::span<const uint8_t> bytes, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

bool majorVersionTwo(const std::string& version) { return version.size() >= 3 && version.rfind("2.", 0) == 0; }

// Where `path` really is (symbolic links and ".." resolved), or empty when it does not exist.
std::string canonical(const std::string& path) {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::canonical(path, ec);
  return ec ? std::string() : p.string();
}

bool inside(const std::string& file, const std::string& folder) {
  return file.size() > folder.size() && file.compare(0, folder.size(), folder) == 0 &&
         (folder.back() == '/' || file[folder.size()] == '/');
}

// Why `path` may not be read, or empty when it may.
std::string refusalFor(const std::string& path, const FileAccess& access) {
  const std::string real = canonical(path);
  if (real.empty()) return {};  // does not exist: tinygltf says "file not found"
  struct stat st {};
  if (::stat(real.c_str(), &st) != 0) return {};
  if (!S_ISREG(st.st_mode)) return "'" + path + "' is not a regular file (a directory, FIFO or device)";
  if (!access.allowExternal && !inside(real, access.folder))
    return "'" + path + "' lies outside the scene's folder " + access.folder +
           " (pass --allow-external-uris to read it anyway)";
  if (uint64_t(st.st_size) > kMaxBufferFileBytes) return "'" + path + "' is larger than 4 GiB";
  return {};
}

}  // namespace

JsonText locateJson(const std::string& path, std::span<const uint8_t> bytes) {
  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (!binary) {
    if (bytes.size() > kMaxJsonBytes) fail(path, "JSON of " + std::to_string(bytes.size()) + " bytes (limit 1 GiB)");
    return {0, bytes.size()};
  }
  if (bytes.size() < 20) fail(path, "GLB of " + std::to_string(bytes.size()) + " bytes: too short for its header");
  const uint32_t version = readU32(bytes, 4), length = readU32(bytes, 8);
  if (version != 2)
    fail(path, "GLB container version " + std::to_string(version) + ": this importer reads version 2 (glTF 2.0)");
  if (length != bytes.size())
    fail(path, "GLB header says " + std::to_string(length) + " bytes, the file has " + std::to_string(bytes.size()));
  const uint32_t jsonLength = readU32(bytes, 12), jsonType = readU32(bytes, 16);
  if (jsonType != 0x4E4F534Au) fail(path, "the first GLB chunk is not JSON");
  if (jsonLength > bytes.size() - 20) fail(path, "the GLB JSON chunk of " + std::to_string(jsonLength) + " bytes runs past the end");
  if (jsonLength > kMaxJsonBytes) fail(path, "JSON chunk of " + std::to_string(jsonLength) + " bytes (limit 1 GiB)");
  return {20, jsonLength};
}

void checkJsonNesting(const std::string& path, std::span<const uint8_t> json) {
  size_t depth = 0;
  bool inString = false, escaped = false;
  for (size_t i = 0; i < json.size(); ++i) {
    const char c = char(json[i]);
    if (inString) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') inString = false;
      continue;
    }
    if (c == '"') inString = true;
    else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        fail(path, "the JSON nests more than " + std::to_string(kMaxJsonDepth) + " levels deep (at byte " +
                       std::to_string(i) + ")");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

void checkAssetVersion(const std::string& path, const nlohmann::json& root) {
  if (!root.is_object() || !root.contains("asset") || !root["asset"].is_object())
    fail(path, "no 'asset' object (every glTF file has one, with its version)");
  const nlohmann::json& asset = root["asset"];
  if (!asset.contains("version") || !asset["version"].is_string()) fail(path, "asset.version is missing or not a string");
  const std::string version = asset["version"].get<std::string>();
  if (!majorVersionTwo(version))
    fail(path, "asset.version '" + version + "': this importer reads glTF 2.x (re-export the scene as glTF 2.0)");
  if (asset.contains("minVersion")) {
    if (!asset["minVersion"].is_string()) fail(path, "asset.minVersion is not a string");
    const std::string minVersion = asset["minVersion"].get<std::string>();
    if (!majorVersionTwo(minVersion)) fail(path, "asset.minVersion '" + minVersion + "': this importer reads glTF 2.x");
  }
}

std::string shortenDataUris(const std::string& text) {
  constexpr size_t kKeep = 40;
  std::string out;
  size_t at = 0;
  while (true) {
    const size_t start = text.find("data:", at);
    if (start == std::string::npos) break;
    size_t end = start;
    while (end < text.size() && text[end] != '"' && text[end] != '\'' && text[end] != ' ' && text[end] != '\n') ++end;
    out.append(text, at, start - at);
    if (end - start > kKeep + 16) out += text.substr(start, kKeep) + "...(" + std::to_string(end - start) + " bytes)";
    else out.append(text, start, end - start);
    at = end;
  }
  return out + text.substr(at);
}

bool fileExists(const std::string& path, void* userData) {
  auto& access = *static_cast<FileAccess*>(userData);
  // tinygltf also tries a relative candidate in the working directory: only paths under the scene's folder
  // (made absolute) are meant.
  if (path.empty() || path.front() != '/') return false;
  const std::string refusal = refusalFor(path, access);
  if (!refusal.empty()) {
    if (access.refusal.empty()) access.refusal = refusal;
    return false;
  }
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

bool readWholeFile(std::vector<unsigned char>* out, std::string* error, const std::string& path, void* userData) {
  auto& access = *static_cast<FileAccess*>(userData);
  const std::string refusal = refusalFor(path, access);
  if (!refusal.empty()) {
    if (access.refusal.empty()) access.refusal = refusal;
    if (error) *error += refusal + "\n";
    return false;
  }
  // O_NONBLOCK: a FIFO swapped in after the check above does not block the open; fstat then refuses it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    if (error) *error += "'" + path + "': cannot open: " + std::strerror(errno) + "\n";
    return false;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || uint64_t(st.st_size) > kMaxBufferFileBytes) {
    ::close(fd);
    if (access.refusal.empty()) access.refusal = "'" + path + "' is not a regular file of at most 4 GiB";
    if (error) *error += access.refusal + "\n";
    return false;
  }
  out->resize(size_t(st.st_size));
  size_t done = 0;
  while (done < out->size()) {
    const ssize_t n = ::read(fd, out->data() + done, out->size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += size_t(n);
  }
  ::close(fd);
  if (done != out->size()) {
    if (error) *error += "'" + path + "': cannot read all " + std::to_string(out->size()) + " bytes\n";
    return false;
  }
  access.read.push_back(path);
  return true;
}

}  // namespace cpvs::gltf
