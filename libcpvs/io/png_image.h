#pragma once
// 8-bit RGB PNG images (stb_image_write / stb_image): cpvs-view's output and its reference images.
#include <cstdint>
#include <string>
#include <vector>

namespace cpvs {

// Row 0 is the top row; pixels are RGB, 3 bytes each.
struct RgbImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> pixels;
  uint8_t* at(uint32_t x, uint32_t y) { return pixels.data() + (size_t(y) * width + x) * 3; }
  const uint8_t* at(uint32_t x, uint32_t y) const { return pixels.data() + (size_t(y) * width + x) * 3; }
};

// The PNG file's bytes. Throws Error(RuntimeFailure) when the encoder fails.
std::string encodePng(const RgbImage& image);
// Reads a PNG (any bit depth and channel count, converted to 8-bit RGB). Throws Error(InvalidInput) naming the
// file and stb_image's reason.
RgbImage readPng(const std::string& path);

}  // namespace cpvs
