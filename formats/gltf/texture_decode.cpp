#include "formats/gltf/texture_decode.h"

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
