#pragma once
// Float EXR images with any number of named channels (OpenEXR 3): --dump-depth (enter / exit slices) and
// G-buffer inputs of cpvs-query (position / normal).
#include <cstdint>
#include <string>
#include <vector>

namespace cpvs {

// Pixels are interleaved: value of channel c at (x, y) is pixels[(y * width + x) * channels.size() + c].
// Row y = 0 is the first scanline of the file (the top row in image viewers).
struct ExrImage {
  uint32_t width = 0, height = 0;
  std::vector<std::string> channels;
  std::vector<float> pixels;

  // Index of a channel, or -1.
  int channelIndex(const std::string& name) const;
  float at(uint32_t x, uint32_t y, size_t channel) const {
    return pixels[(size_t(y) * width + x) * channels.size() + channel];
  }
};

// Writes FLOAT channels (ZIP compression) atomically: a temporary file next to `path`, renamed on success.
// Channel names must be non-empty and distinct. Throws Error(Usage) for an inconsistent image and
// Error(OutputFailed) naming the file when it cannot be written.
void writeExr(const std::string& path, const ExrImage& image);

// Reads every channel as float (HALF and UINT are converted). Throws Error(InputInvalid) naming the file when
// it is missing, not an EXR, deep, or has subsampled channels.
ExrImage readExr(const std::string& path);
// Reads the named channels only, in that order; a missing channel is Error(InputInvalid).
ExrImage readExr(const std::string& path, const std::vector<std::string>& channels);

}  // namespace cpvs
