#pragma once
// From a rendered Frame to what a person looks at: exposure, tone mapping (ACES fit, sRGB), the overlays
// (lights per tile, shadow count, difference against the ray-traced frame, each with a legend), the linear
// EXR, and the figures of the report (light-list statistics, error against the rays).
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/io/exr_image.h"
#include "libcpvs/io/png_image.h"
#include "libcpvs/preview/frame.h"

namespace cpvs {

// The fill: light that is none of the baked lights, so that what they leave in shadow keeps its form and
// colour (docs/viewer.md, "The fill"). It is added after exposure, as a fraction of each pixel's base colour,
// so its strength is relative to the exposed image whatever the lights' units:
//   fill = strength * base colour * (kSkyShare * sky(n) + (1 - kSkyShare) * max(0, n . v))
// with sky(n) a hemisphere light: 1 for a normal pointing up, kGroundShade for one pointing down, linear in
// n . up between (an overcast sky over a grey ground), and n . v a light at the eye (v toward the camera), so
// walls facing different ways in the shade still differ. Never shadowed, never compared against the rays.
struct Fill {
  double strength = 0.15;  // 0: no fill (the lights alone)
  glm::dvec3 up{0.0, 1.0, 0.0};  // the scene's up axis (unit)
};
inline constexpr double kSkyShare = 0.6;
inline constexpr double kGroundShade = 0.35;
// The fill of pixel i (after exposure, linear), 0 for a background pixel.
glm::dvec3 fillRadiance(const Frame& frame, size_t i, const Fill& fill);

// The 99th percentile of the lit pixels' luminance is exposed to at most this (0.92 after the ACES curve), so
// the brightest surfaces keep their shading.
inline constexpr double kBrightestAfterExposure = 2.0;
// The exposure that maps the log-average luminance of the lit, covered pixels (each at least 1/1000 of their
// 99th percentile) to 0.18, or the smaller one that exposes that percentile to kBrightestAfterExposure; 1 when
// no pixel is lit.
double autoExposure(const std::vector<glm::vec4>& radiance);
// What the automatic exposure gives a frame with its fill: `exposure` multiplies the lights' radiance, `fill` is
// the fill as added after it (its strength scaled alike).
struct ExposedFrame {
  double exposure = 1;
  Fill fill;
};
// autoExposure of the lights alone, then autoExposure again of that image with the fill added, scaling both
// (so the lit and shaded parts keep their ratio and the whole image is exposed, the fill included), times
// 2^stops. Without a fill (strength 0): autoExposure(radiance) * 2^stops, as before the fill existed.
ExposedFrame autoExposed(const Frame& frame, const std::vector<glm::vec4>& radiance, const Fill& fill,
                         double stops = 0);

// exposure * radiance + fill, tone-mapped (ACES fit) and sRGB-encoded; the background dark grey. Rows flipped:
// row 0 of the image is the top.
RgbImage toneMapped(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure,
                    const Fill& fill = {});
// Linear R, G, B, A (A = covered): radiance + fill / exposure; row 0 the top.
ExrImage linearImage(const Frame& frame, const std::vector<glm::vec4>& radiance, double exposure,
                     const Fill& fill = {});

// The overlay drawn over a tone-mapped image (returned unchanged for Overlay::None). Difference needs the
// frame's rayVisibility.
RgbImage withOverlay(const Frame& frame, const RgbImage& image, Overlay overlay);

// Whether a frame shows a light's shadows: of its geometry pixels, the share in the light's shadow (the light
// listed in the pixel's tile and the pixel's visibility of it below 1/2) and the share near black in the
// tone-mapped image (luma, Rec. 709 weights over the sRGB values, below kNearBlack of white). docs/viewer.md, "The default camera".
inline constexpr double kNearBlack = 0.08;
struct ShadowCoverage {
  size_t geometryPixels = 0;
  double inShadow = 0, nearBlack = 0;  // fractions of geometryPixels
};
// `image`: toneMapped's (row 0 the top).
ShadowCoverage shadowCoverage(const Frame& frame, uint32_t light, const RgbImage& image);

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
// (0..1, every channel of every pixel) of the two frames with the same exposure and no fill (the lights alone:
// the fill is the same on both sides and only the shadows are compared).
struct RayErrors {
  uint64_t pairs = 0, wrongPairs = 0;
  size_t coveredPixels = 0, wrongPixels = 0;
  double rmse = 0;
  double meanAbsoluteDifference = 0;  // mean |visibility - reference| over the pairs (filtered against filtered)
  double wrongPixelPercent() const { return coveredPixels ? 100.0 * double(wrongPixels) / double(coveredPixels) : 0.0; }
};
RayErrors errorsAgainstRays(const Frame& frame, double exposure);

}  // namespace cpvs
