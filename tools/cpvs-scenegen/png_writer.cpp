#include "png_writer.h"

#include <algorithm>
#include <array>
#include <stdexcept>

namespace cpvs::scenegen {
namespace {

std::uint32_t crc32(const std::string& bytes, std::size_t from) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = from; i < bytes.size(); ++i)
    c = table[(c ^ static_cast<std::uint8_t>(bytes[i])) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

void putBE32(std::string& out, std::uint32_t v) {
  out.push_back(static_cast<char>(v >> 24));
  out.push_back(static_cast<char>(v >> 16));
  out.push_back(static_cast<char>(v >> 8));
  out.push_back(static_cast<char>(v));
}

void chunk(std::string& out, const char type[4], const std::string& data) {
  putBE32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.append(type, 4);
  out += data;
  putBE32(out, crc32(out, start));  // over type and data
}

}  // namespace

std::string encodePngRgba(int width, int height, const std::vector<std::uint8_t>& rgba) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    throw std::invalid_argument("encodePngRgba: bad image size");
  const std::size_t w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  if (rgba.size() != w * h * 4) throw std::invalid_argument("encodePngRgba: pixel data of the wrong size");

  // The filtered scanlines: filter type 0 (none), then the row.
  std::string raw;
  raw.reserve(h * (1 + 4 * w));
  for (std::size_t y = 0; y < h; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(rgba.data() + y * 4 * w), 4 * w);
  }
  // zlib stream: header (deflate, 32K window, no dictionary, level "fastest"), stored blocks, Adler-32.
  std::string z;
  z.push_back(static_cast<char>(0x78));
  z.push_back(static_cast<char>(0x01));
  std::size_t done = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - done);
    const bool last = done + n == raw.size();
    z.push_back(static_cast<char>(last ? 1 : 0));  // BFINAL, BTYPE = 00 (stored)
    z.push_back(static_cast<char>(n & 0xFFu));
    z.push_back(static_cast<char>(n >> 8));
    z.push_back(static_cast<char>(~n & 0xFFu));
    z.push_back(static_cast<char>((~n >> 8) & 0xFFu));
    z.append(raw, done, n);
    done += n;
  } while (done < raw.size());
  std::uint32_t a = 1, b = 0;
  for (const char c : raw) {
    a = (a + static_cast<std::uint8_t>(c)) % 65521u;
    b = (b + a) % 65521u;
  }
  putBE32(z, (b << 16) | a);

  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  putBE32(ihdr, static_cast<std::uint32_t>(width));
  putBE32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.push_back(8);     // bit depth
  ihdr.push_back(6);     // colour type: RGBA
  ihdr.push_back(0);     // compression: deflate
  ihdr.push_back(0);     // filter method 0
  ihdr.push_back(0);     // no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", std::string());
  return png;
}

}  // namespace cpvs::scenegen
