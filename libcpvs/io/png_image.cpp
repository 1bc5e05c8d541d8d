#include "libcpvs/io/png_image.h"

#include <memory>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include "libcpvs/base/error.h"

namespace cpvs {

std::string encodePng(const RgbImage& image) {
  std::string bytes;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
  };
  if (!stbi_write_png_to_func(append, &bytes, int(image.width), int(image.height), 3, image.pixels.data(),
                              int(image.width * 3)))
    throw Error(ErrorCategory::RuntimeFailure, "cannot encode a " + std::to_string(image.width) + "x" +
                                                   std::to_string(image.height) + " PNG");
  return bytes;
}

RgbImage readPng(const std::string& path) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> data(stbi_load(path.c_str(), &w, &h, &channels, 3), stbi_image_free);
  if (!data) throw Error(ErrorCategory::InvalidInput, path + ": not a readable PNG (" + stbi_failure_reason() + ")");
  RgbImage image;
  image.width = uint32_t(w);
  image.height = uint32_t(h);
  image.pixels.assign(data.get(), data.get() + size_t(w) * size_t(h) * 3);
  return image;
}

}  // namespace cpvs
