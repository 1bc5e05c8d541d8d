#pragma once
// From a rendered Frame to what a person looks at: exposure, tone mapping (ACES fit, sRGB), the overlays
// (lights per tile, shadow count, difference against the ray-traced frame, each with a legend), the linear
// EXR, and the figures of the report (light-list statistics, error against the rays).
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "formats/io/exr_image.h"
#include "formats/io/png_image.h"
#include "libcpvs/preview/frame.h"

namespace cpvs {

// Ambient light added after exposure, as a fraction of each pixel's base colour, so that shadowed geometry
// stays readable.
inline constexpr double kAmbient = 0.04;

// The 99th percentile of the lit pixels' luminance is exposed to at most this (0.92 after the ACES curve), so
// the brightest surfaces keep their shading.
inline constexpr double kBrightestAfterExposure = 2.0;
// The exposure that maps the log-average luminance of the lit, covered pixels (each at least 1/1000 of their
// 99th percentile) to 0.18, or the smaller one that exposes that percentile to kBrightestAfterExposure; 1 when
// no pixel is lit.
double autoExposure(const std::vector<glm::vec4>& radiance);
// exposure * radiance + kAmbient * base colour, tone-mapped (ACES fit) and sRGB-encoded; the background dark
// grey. Rows flipped: row 0 of the image is the top.
RgbImage toneMapped(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure);
// Linear R, G, B, A (A = covered): radiance + (kAmbient / exposure) * base colour; row 0 the top.
ExrImage linearImage(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure);

// The overlay drawn over a tone-mapped image (returned unchanged for Overlay::None). Difference needs the
// frame's rayVisibility.
RgbImage withOverlay(const Frame& frame, const RgbImage& image, Overlay overlay);

struct LightListStats {
  size_t coveredTiles = 0;
  double meanLightsPerTile = 0;  // over covered tiles
  uint32_t maxLightsPerTile = 0;
  uint64_t pairsListed = 0;      // (covered pixel, listed light)
  uint64_t pairsCulled = 0;      // (covered pixel, light) pairs the lists left out
};
LightListStats lightListStats(const Frame& frame, size_t lightCount);

// Against the ray-traced frame (needs compareWithRays): a pair is wrong when its visibility and the ray's fall
// on different sides of 1/2; a pixel is wrong when any of its pairs is. RMSE over the tone-mapped sRGB values
// (0..1, every channel of every pixel) of the two frames with the same exposure.
struct RayErrors {
  uint64_t pairs = 0, wrongPairs = 0;
  size_t coveredPixels = 0, wrongPixels = 0;
  double rmse = 0;
  double meanAbsoluteDifference = 0;  // mean |visibility - reference| over the pairs (filtered against filtered)
  double wrongPixelPercent() const { return coveredPixels ? 100.0 * double(wrongPixels) / double(coveredPixels) : 0.0; }
};
RayErrors errorsAgainstRays(const Frame& frame, double exposure);

}  // namespace cpvs
