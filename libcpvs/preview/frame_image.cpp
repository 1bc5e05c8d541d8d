#include "libcpvs/preview/frame_image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <stb/stb_easy_font.h>

namespace cpvs {

namespace {

double luminance(const glm::vec4& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

uint8_t srgb8(double linear) {
  linear = std::clamp(linear, 0.0, 1.0);
  const double encoded = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
  return uint8_t(std::lround(encoded * 255.0));
}

double aces(double x) { return std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }

constexpr double kBackground = 0.012;  // linear grey behind the scene

// A heat ramp: dark blue, blue, cyan, green, yellow, red.
glm::dvec3 heat(double t) {
  static const glm::dvec3 stops[] = {{0.05, 0.05, 0.35}, {0.1, 0.3, 1.0}, {0.0, 0.85, 0.9},
                                     {0.2, 0.85, 0.2},   {1.0, 0.9, 0.1}, {0.95, 0.15, 0.1}};
  t = std::clamp(t, 0.0, 1.0) * 5.0;
  const int i = std::min(int(t), 4);
  return glm::mix(stops[i], stops[i + 1], t - i);
}

void blend(RgbImage& image, uint32_t x, uint32_t y, const glm::dvec3& colour, double alpha) {
  uint8_t* p = image.at(x, y);
  for (int c = 0; c < 3; ++c) p[c] = uint8_t(std::lround((1 - alpha) * p[c] + alpha * 255.0 * colour[c]));
}

void fillRect(RgbImage& image, int x0, int y0, int x1, int y1, const glm::dvec3& colour, double alpha = 1.0) {
  for (int y = std::max(0, y0); y < std::min(int(image.height), y1); ++y)
    for (int x = std::max(0, x0); x < std::min(int(image.width), x1); ++x) blend(image, uint32_t(x), uint32_t(y), colour, alpha);
}

// Text with stb_easy_font's quads, `scale` pixels per font unit.
void drawText(RgbImage& image, int x, int y, const std::string& text, int scale, const glm::dvec3& colour) {
  std::vector<char> quads(64 * text.size() * 16 + 1024);
  const int count = stb_easy_font_print(0, 0, const_cast<char*>(text.c_str()), nullptr, quads.data(), int(quads.size()));
  for (int q = 0; q < count; ++q) {
    const float* v0 = reinterpret_cast<const float*>(quads.data() + size_t(q) * 64);
    const float* v2 = reinterpret_cast<const float*>(quads.data() + size_t(q) * 64 + 32);
    fillRect(image, x + int(v0[0]) * scale, y + int(v0[1]) * scale, x + int(v2[0]) * scale, y + int(v2[1]) * scale, colour);
  }
}

// A legend box at the bottom left: the ramp from 0 to `maximum` with a title.
void drawLegend(RgbImage& image, const std::string& title, uint32_t maximum) {
  const int scale = image.height >= 600 ? 2 : 1;
  const int width = 160 * scale, height = 34 * scale;
  const int x0 = 6 * scale, y0 = int(image.height) - height - 6 * scale;
  fillRect(image, x0, y0, x0 + width, y0 + height, {0, 0, 0}, 0.7);
  drawText(image, x0 + 4 * scale, y0 + 3 * scale, title, scale, {1, 1, 1});
  const int barX = x0 + 4 * scale, barY = y0 + 14 * scale, barW = width - 8 * scale, barH = 8 * scale;
  for (int x = 0; x < barW; ++x) fillRect(image, barX + x, barY, barX + x + 1, barY + barH, heat(double(x) / (barW - 1)));
  drawText(image, barX, barY + barH + scale, "0", scale, {1, 1, 1});
  const std::string top = std::to_string(maximum);
  drawText(image, barX + barW - int(top.size()) * 6 * scale, barY + barH + scale, top, scale, {1, 1, 1});
}

RgbImage dimmed(const RgbImage& image, double factor) {
  RgbImage out = image;
  for (uint8_t& v : out.pixels) v = uint8_t(std::lround(v * factor));
  return out;
}

}  // namespace

double autoExposure(const std::vector<glm::vec4>& radiance) {
  std::vector<double> lit;
  for (const glm::vec4& r : radiance) {
    const double l = luminance(r);
    if (r.w != 0.0f && l > 0 && std::isfinite(l)) lit.push_back(l);
  }
  if (lit.empty()) return 1.0;
  const auto p99 = lit.begin() + ptrdiff_t(0.99 * double(lit.size() - 1));
  std::nth_element(lit.begin(), p99, lit.end());
  const double bright = *p99;
  // Pixels darker than 1/1000 of the bright ones count as that: a shadowed pixel lit only by a far light's tail
  // would otherwise pull the log average toward zero and expose the lit surfaces far past white.
  double sum = 0;
  for (const double l : lit) sum += std::log(std::max(l, 1e-3 * bright));
  const double middleGrey = 0.18 / std::exp(sum / double(lit.size()));
  return std::min(middleGrey, kBrightestAfterExposure / bright);
}

glm::dvec3 fillRadiance(const Frame& frame, size_t i, const Fill& fill) {
  if (fill.strength <= 0 || frame.positions[i].w == 0.0f) return glm::dvec3(0.0);
  const glm::dvec3 normal(frame.normals[i]), position(frame.positions[i]);
  const double normalLength = glm::length(normal);
  const glm::dvec3 n = normalLength > 0 ? normal / normalLength : glm::dvec3(0.0);
  const glm::dvec3 toEye = frame.eye - position;
  const double eyeLength = glm::length(toEye);
  const double facingEye = eyeLength > 0 ? std::max(0.0, glm::dot(n, toEye) / eyeLength) : 1.0;
  const double sky = glm::mix(kGroundShade, 1.0, 0.5 + 0.5 * glm::dot(n, fill.up));
  return fill.strength * (kSkyShare * sky + (1.0 - kSkyShare) * facingEye) * glm::dvec3(frame.baseColors[i]);
}

ExposedFrame autoExposed(const Frame& frame, const std::vector<glm::vec4>& radiance, const Fill& fill, double stops) {
  const double lights = autoExposure(radiance);
  double scale = std::exp2(stops);
  if (fill.strength > 0) {
    std::vector<glm::vec4> combined(radiance.size(), glm::vec4(0.0f));
    for (size_t i = 0; i < radiance.size(); ++i)
      if (radiance[i].w != 0.0f)
        combined[i] = glm::vec4(glm::dvec3(radiance[i]) * lights + fillRadiance(frame, i, fill), 1.0);
    scale *= autoExposure(combined);
  }
  return {lights * scale, Fill{fill.strength * scale, fill.up}};
}

RgbImage toneMapped(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure, const Fill& fill) {
  RgbImage image;
  image.width = frame.width;
  image.height = frame.height;
  image.pixels.resize(size_t(frame.width) * frame.height * 3);
  for (uint32_t y = 0; y < frame.height; ++y)
    for (uint32_t x = 0; x < frame.width; ++x) {
      const size_t i = frame.pixel(x, y);
      uint8_t* out = image.at(x, frame.height - 1 - y);
      const glm::dvec3 fillHere = fillRadiance(frame, i, fill);
      for (int c = 0; c < 3; ++c) {
        const double linear = radiance[i].w == 0.0f ? kBackground : exposure * radiance[i][c] + fillHere[c];
        out[c] = srgb8(aces(linear));
      }
    }
  return image;
}

ExrImage linearImage(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure,
                     const Fill& fill) {
  ExrImage image;
  image.width = frame.width;
  image.height = frame.height;
  image.channels = {"R", "G", "B", "A"};
  image.pixels.resize(size_t(frame.width) * frame.height * 4);
  for (uint32_t y = 0; y < frame.height; ++y)
    for (uint32_t x = 0; x < frame.width; ++x) {
      const size_t i = frame.pixel(x, y);
      float* out = &image.pixels[(size_t(frame.height - 1 - y) * frame.width + x) * 4];
      const glm::dvec3 fillHere = fillRadiance(frame, i, fill) / exposure;
      for (int c = 0; c < 3; ++c) out[c] = radiance[i].w == 0.0f ? 0.0f : float(radiance[i][c] + fillHere[c]);
      out[3] = radiance[i].w;
    }
  return image;
}

RgbImage withOverlay(const Frame& frame, const RgbImage& image, Overlay overlay) {
  if (overlay == Overlay::None) return image;
  RgbImage out = dimmed(image, 0.6);
  const uint32_t h = frame.height;
  if (overlay == Overlay::LightsPerTile) {
    uint32_t maximum = 1;
    for (size_t t = 0; t < frame.lists.tiles(); ++t)
      maximum = std::max(maximum, frame.lists.offsets[t + 1] - frame.lists.offsets[t]);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < frame.width; ++x) {
        const size_t t = frame.tileOf(x, y);
        const uint32_t count = frame.lists.offsets[t + 1] - frame.lists.offsets[t];
        if (count) blend(out, x, h - 1 - y, heat(double(count) / maximum), 0.55);
      }
    drawLegend(out, "lights per 8x8 tile", maximum);
  } else if (overlay == Overlay::ShadowCount) {
    uint32_t maximum = 1;
    for (const glm::uvec2& s : frame.stats) maximum = std::max(maximum, s.y);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < frame.width; ++x) {
        const uint32_t count = frame.stats[frame.pixel(x, y)].y;
        if (count) blend(out, x, h - 1 - y, heat(double(count) / maximum), 0.7);
      }
    drawLegend(out, "lights shadowing a pixel", maximum);
  } else if (overlay == Overlay::Difference && !frame.rayVisibility.empty()) {
    std::vector<uint8_t> marked(size_t(frame.width) * h, 0);
    frame.forEachPair([&](uint32_t x, uint32_t y, size_t i, uint32_t, size_t p) {
      const bool lit = frame.visibility[p] >= 0.5f, rayLit = frame.rayVisibility[p] >= 0.5f;
      if (lit == rayLit || marked[i]) return;
      marked[i] = 1;
      // Red: shadowed here but lit for the ray; blue: lit here but shadowed for the ray (the first such light).
      blend(out, x, h - 1 - y, rayLit ? glm::dvec3(1.0, 0.1, 0.1) : glm::dvec3(0.2, 0.4, 1.0), 1.0);
    });
    const int scale = h >= 600 ? 2 : 1;
    fillRect(out, 6 * scale, int(h) - 30 * scale, 200 * scale, int(h) - 6 * scale, {0, 0, 0}, 0.7);
    drawText(out, 10 * scale, int(h) - 27 * scale, "red: shadowed, rays say lit", scale, {1.0, 0.3, 0.3});
    drawText(out, 10 * scale, int(h) - 17 * scale, "blue: lit, rays say shadowed", scale, {0.4, 0.6, 1.0});
  }
  return out;
}

ShadowCoverage shadowCoverage(const Frame& frame, uint32_t light, const RgbImage& image) {
  ShadowCoverage c;
  size_t shadowed = 0, dark = 0;
  for (uint32_t y = 0; y < frame.height; ++y)
    for (uint32_t x = 0; x < frame.width; ++x) {
      if (frame.positions[frame.pixel(x, y)].w == 0.0f) continue;
      ++c.geometryPixels;
      const size_t tile = frame.tileOf(x, y);
      for (uint32_t slot = 0; slot < frame.lists.offsets[tile + 1] - frame.lists.offsets[tile]; ++slot)
        if (frame.lists.lights[frame.lists.offsets[tile] + slot] == light)
          shadowed += frame.visibility[frame.pairIndex(x, y, slot)] < 0.5f;
      const uint8_t* rgb = image.at(x, frame.height - 1 - y);
      dark += 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2] < kNearBlack * 255.0;
    }
  const double pixels = double(std::max<size_t>(1, c.geometryPixels));
  c.inShadow = double(shadowed) / pixels;
  c.nearBlack = double(dark) / pixels;
  return c;
}

LightListStats lightListStats(const Frame& frame, size_t lightCount) {
  LightListStats s;
  std::vector<uint32_t> coveredPixels(frame.lists.tiles(), 0);
  for (uint32_t y = 0; y < frame.height; ++y)
    for (uint32_t x = 0; x < frame.width; ++x)
      if (frame.positions[frame.pixel(x, y)].w != 0.0f) ++coveredPixels[frame.tileOf(x, y)];
  uint64_t listed = 0;
  for (size_t t = 0; t < frame.lists.tiles(); ++t) {
    if (!coveredPixels[t]) continue;
    const uint32_t count = frame.lists.offsets[t + 1] - frame.lists.offsets[t];
    ++s.coveredTiles;
    listed += count;
    s.maxLightsPerTile = std::max(s.maxLightsPerTile, count);
    s.pairsListed += uint64_t(count) * coveredPixels[t];
    s.pairsCulled += uint64_t(lightCount - count) * coveredPixels[t];
  }
  s.meanLightsPerTile = s.coveredTiles ? double(listed) / double(s.coveredTiles) : 0.0;
  return s;
}

RayErrors errorsAgainstRays(const Frame& frame, double exposure) {
  RayErrors e;
  if (frame.rayVisibility.empty()) return e;
  std::vector<uint8_t> wrong(size_t(frame.width) * frame.height, 0);
  for (const glm::vec4& p : frame.positions) e.coveredPixels += p.w != 0.0f;
  frame.forEachPair([&](uint32_t, uint32_t, size_t i, uint32_t, size_t p) {
    ++e.pairs;
    e.meanAbsoluteDifference += std::fabs(double(frame.visibility[p]) - double(frame.rayVisibility[p]));
    if ((frame.visibility[p] >= 0.5f) != (frame.rayVisibility[p] >= 0.5f)) {
      ++e.wrongPairs;
      wrong[i] = 1;
    }
  });
  for (uint8_t w : wrong) e.wrongPixels += w;
  if (e.pairs) e.meanAbsoluteDifference /= double(e.pairs);
  const Fill none{0.0};
  const RgbImage a = toneMapped(frame, frame.radiance, exposure, none);
  const RgbImage b = toneMapped(frame, frame.rayRadiance, exposure, none);
  double sum = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = (double(a.pixels[i]) - double(b.pixels[i])) / 255.0;
    sum += d * d;
  }
  e.rmse = a.pixels.empty() ? 0.0 : std::sqrt(sum / double(a.pixels.size()));
  return e;
}

}  // namespace cpvs
