#pragma once
// Where cpvs-view looks from: a perspective camera (a glTF camera, one given on the command line, or a
// default framing of the scene) and the matrices the G-buffer pass draws with.
#include <optional>
#include <span>
#include <string>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

struct PreviewCamera {
  glm::dvec3 eye{0.0, 0.0, 1.0};
  glm::dvec3 target{0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double yfov = 0.8;  // radians
  double znear = 0, zfar = 0;  // 0: from the scene's bounds (near = 1e-4 of the distance to the far side)
};

// A glTF camera (its aspect ratio is ignored: the image's size decides). The target is one unit ahead.
PreviewCamera cameraFromScene(const Camera& camera);
// The side a default camera looks from when the scene gives no light: +X+Z.
inline constexpr glm::dvec3 kDefaultSide{1.0, 0.0, 1.0};
// How high the default camera looks from: the eye's direction from the scene is `side` plus this times `up`
// (45 degrees above the ground), so the ground the shadows fall on is in view (docs/viewer.md, "The default camera").
inline constexpr double kDefaultCameraRise = 1.0;
// A three-quarter view of `bounds` from `side` (a direction from the scene toward the eye, taken in the plane
// perpendicular to `up`, the scene's up axis) and above (kDefaultCameraRise): the nearest eye looking that way that sees every
// corner of the box, placed so the box's image is centred and fills the frame (less a 5 % margin) across its
// binding axis.
PreviewCamera defaultCamera(const Bounds& bounds, double aspect, const glm::dvec3& up = {0.0, 1.0, 0.0},
                            double yfov = 0.8, const glm::dvec3& side = kDefaultSide);
// The light giving the most illuminance at the box's centre (a directional light its intensity, a point or spot
// light its intensity / distance^2, 0 beyond its range or outside a spot's outer cone; times the luminance of
// its colour; the first of equals), or none when no light reaches the centre.
std::optional<size_t> strongestLight(std::span<const Light> lights, const Bounds& bounds);
// How far litSide turns from the strongest light's azimuth: across the light, so that the faces it lights and
// the shadows they cast on the ground beside them are both in view (docs/viewer.md, "The default camera").
inline constexpr double kLitSideTurnDegrees = 90.0;
// The side the default camera looks from (docs/viewer.md, "The default camera"): the direction toward the
// strongest light in the plane perpendicular to `up`, turned kLitSideTurnDegrees about `up` (counter-clockwise
// seen from above). kDefaultSide without lights, when no light reaches the centre, or when the strongest is
// within 20 degrees of straight above or below.
glm::dvec3 litSide(std::span<const Light> lights, const Bounds& bounds, const glm::dvec3& up = {0.0, 1.0, 0.0});
// Fills znear / zfar where they are 0 from the bounds (depth precision is the G-buffer's only need).
PreviewCamera withClipPlanes(PreviewCamera camera, const Bounds& bounds);
// Throws Error(InvalidArgument) naming the problem: eye equal to target, up parallel to the view direction,
// a non-finite value, a field of view outside (0, 180) degrees.
void checkCamera(const PreviewCamera& camera);

// OpenGL clip space from world space (right-handed, camera looking along -Z, depth -1..1).
glm::dmat4 clipFromWorld(const PreviewCamera& camera, double aspect);

}  // namespace cpvs
