#include "libcpvs/io/exr_image.h"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <set>

#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include "libcpvs/base/error.h"

namespace cpvs {

int ExrImage::channelIndex(const std::string& name) const {
  for (size_t i = 0; i < channels.size(); ++i)
    if (channels[i] == name) return int(i);
  return -1;
}

void writeExr(const std::string& path, const ExrImage& image) {
  if (image.width == 0 || image.height == 0 || image.channels.empty())
    throw Error(ErrorCategory::InvalidArgument, path + ": an EXR image needs a width, a height and at least one channel");
  if (image.width > uint32_t(INT32_MAX) || image.height > uint32_t(INT32_MAX))
    throw Error(ErrorCategory::InvalidArgument, path + ": image too large for EXR");
  const size_t nc = image.channels.size();
  if (image.pixels.size() != size_t(image.width) * image.height * nc)
    throw Error(ErrorCategory::InvalidArgument, path + ": pixel count " + std::to_string(image.pixels.size()) + " does not match " +
                                     std::to_string(image.width) + "x" + std::to_string(image.height) + "x" +
                                     std::to_string(nc));
  std::set<std::string> names;
  for (const std::string& c : image.channels)
    if (c.empty() || !names.insert(c).second)
      throw Error(ErrorCategory::InvalidArgument, path + ": EXR channel names must be non-empty and distinct ('" + c + "')");

  const std::filesystem::path target(path);
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "." + std::string.
  std::string tempName = ".";
  tempName += target.filename().string();
  tempName += ".tmp";
  tempName += std::to_string(::getpid());
  const std::filesystem::path temp = target.parent_path() / tempName;
  try {
    Imf::Header header(int(image.width), int(image.height));
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    const size_t xStride = sizeof(float) * nc, yStride = xStride * image.width;
    for (size_t c = 0; c < nc; ++c) {
      header.channels().insert(image.channels[c], Imf::Channel(Imf::FLOAT));
      frame.insert(image.channels[c],
                   Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(image.pixels.data() + c)),
                              xStride, yStride));
    }
    {
      Imf::OutputFile file(temp.c_str(), header);
      file.setFrameBuffer(frame);
      file.writePixels(int(image.height));
    }
    std::filesystem::rename(temp, target);
  } catch (const std::exception& e) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw Error(ErrorCategory::OutputFailed, "cannot write EXR image " + path + ": " + e.what());
  }
}

ExrImage readExr(const std::string& path, const std::vector<std::string>& wanted) {
  ExrImage image;
  try {
    if (!std::filesystem::is_regular_file(path))
      throw Error(ErrorCategory::InvalidInput, "cannot read EXR image " + path + ": no such file");
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    const Imath::Box2i dw = header.dataWindow();
    const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w * h > (int64_t(1) << 31))
      throw Error(ErrorCategory::InvalidInput, "EXR image " + path + ": unsupported data window " + std::to_string(w) +
                                              "x" + std::to_string(h));
    if (wanted.empty()) {
      for (auto it = header.channels().begin(); it != header.channels().end(); ++it)
        image.channels.push_back(it.name());
    } else {
      for (const std::string& name : wanted) {
        if (!header.channels().findChannel(name))
          throw Error(ErrorCategory::InvalidInput, "EXR image " + path + " has no channel '" + name + "'");
        image.channels.push_back(name);
      }
    }
    if (image.channels.empty()) throw Error(ErrorCategory::InvalidInput, "EXR image " + path + " has no channels");
    for (const std::string& name : image.channels) {
      const Imf::Channel* ch = header.channels().findChannel(name);
      if (ch->xSampling != 1 || ch->ySampling != 1)
        throw Error(ErrorCategory::InvalidInput, "EXR image " + path + ": channel '" + name + "' is subsampled");
    }
    image.width = uint32_t(w);
    image.height = uint32_t(h);
    const size_t nc = image.channels.size();
    image.pixels.assign(size_t(w) * size_t(h) * nc, 0.0f);
    const size_t xStride = sizeof(float) * nc, yStride = xStride * size_t(w);
    // The slice base points at pixel (0, 0) of the data window's coordinate system.
    Imf::FrameBuffer frame;
    for (size_t c = 0; c < nc; ++c) {
      char* base = reinterpret_cast<char*>(image.pixels.data() + c) - ptrdiff_t(dw.min.x) * ptrdiff_t(xStride) -
                   ptrdiff_t(dw.min.y) * ptrdiff_t(yStride);
      frame.insert(image.channels[c], Imf::Slice(Imf::FLOAT, base, xStride, yStride));
    }
    file.setFrameBuffer(frame);
    file.readPixels(dw.min.y, dw.max.y);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(ErrorCategory::InvalidInput, "cannot read EXR image " + path + ": " + e.what());
  }
  return image;
}

ExrImage readExr(const std::string& path) { return readExr(path, {}); }

}  // namespace cpvs
