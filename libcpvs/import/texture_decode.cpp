#include "libcpvs/import/texture_decode.h"

#include <algorithm>
#include <climits>
#include <memory>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#include <stb/stb_image.h>

namespace cpvs::gltf {

bool decodeTexture(const unsigned char* bytes, size_t size, Texture& out, std::string& why) {
  if (!bytes || size == 0 || size > size_t(INT_MAX)) {
    why = "no image bytes";
    return false;
  }
  int w = 0, h = 0, channels = 0;
  // stb_image refuses a PNG whose size it will not decode before it reports the size: say which size.
  constexpr unsigned char kPngStart[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  if (size >= 24 && std::equal(kPngStart, kPngStart + 16, bytes)) {
    const auto bigEndian = [&](size_t at) {
      return (uint32_t(bytes[at]) << 24) | (uint32_t(bytes[at + 1]) << 16) | (uint32_t(bytes[at + 2]) << 8) | bytes[at + 3];
    };
    const uint32_t width = bigEndian(16), height = bigEndian(20);
    if (width > kMaxTextureEdge || height > kMaxTextureEdge) {
      why = std::to_string(width) + "x" + std::to_string(height) + " is larger than " + std::to_string(kMaxTextureEdge) +
            " on a side";
      return false;
    }
  }
  if (!stbi_info_from_memory(bytes, int(size), &w, &h, &channels)) {
    why = std::string("not a readable PNG or JPEG (") + stbi_failure_reason() + ")";
    return false;
  }
  if (w <= 0 || h <= 0 || uint32_t(w) > kMaxTextureEdge || uint32_t(h) > kMaxTextureEdge) {
    why = std::to_string(w) + "x" + std::to_string(h) + " is larger than " + std::to_string(kMaxTextureEdge) + " on a side";
    return false;
  }
  std::unique_ptr<stbi_uc, void (*)(void*)> pixels(stbi_load_from_memory(bytes, int(size), &w, &h, &channels, 4),
                                                   stbi_image_free);
  if (!pixels) {
    why = std::string("cannot be decoded (") + stbi_failure_reason() + ")";
    return false;
  }
  out.width = uint32_t(w);
  out.height = uint32_t(h);
  out.rgba.assign(pixels.get(), pixels.get() + size_t(w) * size_t(h) * 4);
  return true;
}

}  // namespace cpvs::gltf
