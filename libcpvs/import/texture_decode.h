#pragma once
// Decoding a glTF image (PNG or JPEG bytes) for cpvs-view's base-colour textures, with limits: the importer
// only calls it when asked (ImportOptions::loadBaseColorTextures); the baker never reads images.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "libcpvs/scene/scene.h"

namespace cpvs::gltf {

inline constexpr uint32_t kMaxTextureEdge = 8192;

// RGBA8 pixels (sRGB as stored), row 0 first as in the file; false with `why` set for an unreadable image, an
// unsupported format or one larger than kMaxTextureEdge on a side.
bool decodeTexture(const unsigned char* bytes, size_t size, Texture& out, std::string& why);

}  // namespace cpvs::gltf
