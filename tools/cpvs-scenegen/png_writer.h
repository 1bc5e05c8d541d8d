#pragma once
// A minimal PNG encoder for the generated textures: 8-bit RGBA, no filtering, zlib "stored" (uncompressed)
// deflate blocks. Written here rather than through stb_image_write so that the bytes depend on nothing but
// the pixels (a compressor's output may change between library versions; the scenes must not).
#include <cstdint>
#include <string>
#include <vector>

namespace cpvs::scenegen {

// `rgba` holds width * height * 4 bytes, rows top to bottom (the image's first row is its top).
std::string encodePngRgba(int width, int height, const std::vector<std::uint8_t>& rgba);

}  // namespace cpvs::scenegen
