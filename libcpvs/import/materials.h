#pragma once
// The images a glTF import keeps for its materials (materials.cpp): tinygltf's image callbacks, and the
// decoded alpha channels alpha-tested casters are cut by.
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <tiny_gltf.h>

namespace cpvs::gltf {

// With ImportOptions::loadBaseColorTextures tinygltf hands every image's bytes (a file, a data URI or a buffer
// view) to keepImageBytes(). They are kept encoded, by image index, and decoded only for the images a material
// uses as its base-colour texture: normal, metallic-roughness and occlusion images are never decoded.
using EncodedImages = std::map<int, std::vector<unsigned char>>;

// The alpha channel of a decoded image, what an alpha-tested material's coverage mask is made from.
struct AlphaImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> alpha;  // width * height, row 0 first
};

// The images to keep: every one (cpvs-view), or those alpha-tested materials read.
struct ImageKeeping {
  EncodedImages images;
  bool all = false;
  std::set<int> needed;
};

// tinygltf image loaders: keepImageBytes keeps the bytes of the images an ImageKeeping (the user data) asks
// for; skipImageDecoding, for a bake that needs no image, keeps none.
bool keepImageBytes(tinygltf::Image*, const int index, std::string*, std::string*, int, int, const unsigned char* bytes,
                    int size, void* userData);
bool skipImageDecoding(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                       void*);

}  // namespace cpvs::gltf
