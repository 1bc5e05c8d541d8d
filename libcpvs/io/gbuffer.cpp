#include "libcpvs/io/gbuffer.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <initializer_list>

#include "libcpvs/io/exr_image.h"
#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

int findChannel(const ExrImage& image, std::initializer_list<const char*> names) {
  for (const char* name : names)
    for (size_t c = 0; c < image.channels.size(); ++c) {
      const std::string& have = image.channels[c];
      if (have.size() == std::strlen(name) &&
          std::equal(have.begin(), have.end(), name, [](char a, char b) { return std::tolower(a) == std::tolower(b); }))
        return int(c);
    }
  return -1;
}

}  // namespace

std::vector<QueryPoint> readGBuffer(const std::string& path, const std::string& normalsPath, uint32_t& width,
                                    uint32_t& height, bool& hasNormals) {
  const ExrImage image = readExr(path);
  width = image.width;
  height = image.height;
  int p[3] = {findChannel(image, {"P.X", "position.X", "P.R"}), findChannel(image, {"P.Y", "position.Y", "P.G"}),
              findChannel(image, {"P.Z", "position.Z", "P.B"})};
  if (p[0] < 0 || p[1] < 0 || p[2] < 0) {
    p[0] = findChannel(image, {"R"});
    p[1] = findChannel(image, {"G"});
    p[2] = findChannel(image, {"B"});
  }
  if (p[0] < 0 || p[1] < 0 || p[2] < 0) {
    std::string have;
    for (const auto& c : image.channels) have += (have.empty() ? "" : ", ") + c;
    throw Error(ErrorCategory::InvalidInput, path + ": no position channels (expected P.X, P.Y, P.Z or R, G, B; the image has " +
                                            (have.empty() ? std::string("none") : have) + ")");
  }
  const ExrImage* normalImage = &image;
  ExrImage other;
  int n[3] = {-1, -1, -1};
  if (!normalsPath.empty()) {
    other = readExr(normalsPath);
    if (other.width != image.width || other.height != image.height)
      throw Error(ErrorCategory::InvalidInput, normalsPath + ": " + std::to_string(other.width) + "x" +
                                              std::to_string(other.height) + " pixels, but " + path + " has " +
                                              std::to_string(image.width) + "x" + std::to_string(image.height));
    normalImage = &other;
    n[0] = findChannel(other, {"N.X", "normal.X", "N.R"});
    n[1] = findChannel(other, {"N.Y", "normal.Y", "N.G"});
    n[2] = findChannel(other, {"N.Z", "normal.Z", "N.B"});
    if (n[0] < 0 || n[1] < 0 || n[2] < 0) {
      n[0] = findChannel(other, {"R"});
      n[1] = findChannel(other, {"G"});
      n[2] = findChannel(other, {"B"});
    }
    if (n[0] < 0 || n[1] < 0 || n[2] < 0)
      throw Error(ErrorCategory::InvalidInput, normalsPath + ": no normal channels (expected N.X, N.Y, N.Z or R, G, B)");
  } else {
    n[0] = findChannel(image, {"N.X", "normal.X", "N.R"});
    n[1] = findChannel(image, {"N.Y", "normal.Y", "N.G"});
    n[2] = findChannel(image, {"N.Z", "normal.Z", "N.B"});
  }
  hasNormals = n[0] >= 0 && n[1] >= 0 && n[2] >= 0;
  std::vector<QueryPoint> points(size_t(width) * height);
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      QueryPoint& q = points[size_t(y) * width + x];
      q.position = {image.at(x, y, size_t(p[0])), image.at(x, y, size_t(p[1])), image.at(x, y, size_t(p[2]))};
      if (hasNormals)
        q.normal = {normalImage->at(x, y, size_t(n[0])), normalImage->at(x, y, size_t(n[1])),
                    normalImage->at(x, y, size_t(n[2]))};
    }
  return points;
}

}  // namespace cpvs
