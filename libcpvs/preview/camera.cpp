#include "libcpvs/preview/camera.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "libcpvs/base/error.h"

namespace cpvs {

PreviewCamera cameraFromScene(const Camera& camera) {
  PreviewCamera c;
  c.eye = camera.eye;
  c.target = camera.eye + camera.forward;
  c.up = camera.up;
  c.yfov = camera.yfov;
  c.znear = camera.znear;
  c.zfar = camera.zfar;
  return c;
}

std::optional<size_t> strongestLight(std::span<const Light> lights, const Bounds& bounds) {
  const glm::dvec3 centre = bounds.center();
  double strongest = 0;
  std::optional<size_t> found;
  for (size_t i = 0; i < lights.size(); ++i) {
    const double illuminance = strengthAt(lights[i], centre);
    if (std::isfinite(illuminance) && illuminance > strongest && glm::length(towardLight(lights[i], centre)) > 0) {
      strongest = illuminance;
      found = i;
    }
  }
  return found;
}

glm::dvec3 litSide(std::span<const Light> lights, const Bounds& bounds, const glm::dvec3& up) {
  const glm::dvec3 u = glm::normalize(up);
  const std::optional<size_t> strongest = strongestLight(lights, bounds);
  if (!strongest) return kDefaultSide;
  const glm::dvec3 toLight = glm::normalize(towardLight(lights[*strongest], bounds.center()));
  const glm::dvec3 across = toLight - glm::dot(toLight, u) * u;
  if (glm::length(across) < std::sin(glm::radians(20.0))) return kDefaultSide;
  // Turned about up (Rodrigues' formula for a vector perpendicular to the axis).
  const glm::dvec3 a = glm::normalize(across);
  const double turn = glm::radians(kLitSideTurnDegrees);
  return std::cos(turn) * a + std::sin(turn) * glm::cross(u, a);
}

PreviewCamera defaultCamera(const Bounds& bounds, double aspect, const glm::dvec3& up, double yfov,
                            const glm::dvec3& towardEye) {
  PreviewCamera c;
  c.up = glm::normalize(up);
  c.yfov = yfov;
  // A direction from the scene toward the eye: `towardEye` in the plane perpendicular to up, raised by
  // kDefaultCameraRise times its length.
  glm::dvec3 side = towardEye - glm::dot(towardEye, c.up) * c.up;
  if (glm::length(side) < 1e-6) side = kDefaultSide - glm::dot(kDefaultSide, c.up) * c.up;
  if (glm::length(side) < 1e-6) side = glm::dvec3(1.0, 1.0, 0.0) - glm::dot(glm::dvec3(1.0, 1.0, 0.0), c.up) * c.up;
  const glm::dvec3 back = glm::normalize(glm::normalize(side) + kDefaultCameraRise * c.up);
  const glm::dvec3 right = glm::normalize(glm::cross(c.up, back)), cameraUp = glm::cross(back, right);
  // With the orientation fixed, a corner p (coordinates x, y, z along right, cameraUp, back) is in view of an
  // eye e when |x - e.x| <= tanX (e.z - z) and |y - e.y| <= tanY (e.z - z): linear in e. Each pair of planes
  // gives the nearest eye that sees every corner across that axis, and the eye takes the farther of the two.
  // Across each axis it then sits where the box's image is centred (aiming at the box's centre instead leaves
  // the top of the frame empty: the near corners project larger). 5 % of the frame is left as a margin.
  const double tanY = std::tan(0.5 * yfov) / 1.05, tanX = tanY * aspect;
  std::array<glm::dvec3, 8> corners;
  double xPlus = -INFINITY, xMinus = -INFINITY, yPlus = -INFINITY, yMinus = -INFINITY;
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 corner((i & 1) ? bounds.max.x : bounds.min.x, (i & 2) ? bounds.max.y : bounds.min.y,
                            (i & 4) ? bounds.max.z : bounds.min.z);
    corners[i] = {glm::dot(corner, right), glm::dot(corner, cameraUp), glm::dot(corner, back)};
    xPlus = std::max(xPlus, corners[i].x + tanX * corners[i].z);
    xMinus = std::max(xMinus, -corners[i].x + tanX * corners[i].z);
    yPlus = std::max(yPlus, corners[i].y + tanY * corners[i].z);
    yMinus = std::max(yMinus, -corners[i].y + tanY * corners[i].z);
  }
  const double scale = std::max(1.0, glm::length(bounds.center()));
  const double centreZ = glm::dot(bounds.center(), back);
  const double eyeZ = std::max({(xPlus + xMinus) / (2.0 * tanX), (yPlus + yMinus) / (2.0 * tanY),
                                centreZ + 1e-6 * scale});  // a point: just off it
  // The image of the box across one axis spans [min, max] of (a - e) / (eyeZ - z); both ends fall as e grows,
  // so the centred e (max = -min, which also has the most room) is found by bisection between the coordinates.
  const auto centred = [&](int axis) {
    double low = INFINITY, high = -INFINITY;
    for (const glm::dvec3& c : corners) low = std::min(low, c[axis]), high = std::max(high, c[axis]);
    for (int step = 0; step < 100 && low < high; ++step) {
      const double e = 0.5 * (low + high);
      double top = -INFINITY, bottom = INFINITY;
      for (const glm::dvec3& c : corners) {
        const double image = (c[axis] - e) / std::max(eyeZ - c.z, 1e-12 * scale);
        top = std::max(top, image), bottom = std::min(bottom, image);
      }
      (top + bottom > 0 ? low : high) = e;
    }
    return 0.5 * (low + high);
  };
  c.eye = centred(0) * right + centred(1) * cameraUp + eyeZ * back;
  // The target: straight ahead, at the depth of the box's centre (it only sets the direction).
  c.target = c.eye - back * (eyeZ - centreZ);
  return c;
}

PreviewCamera withClipPlanes(PreviewCamera camera, const Bounds& bounds) {
  const double radius = 0.5 * glm::length(bounds.extent());
  const double farthest = glm::length(camera.eye - bounds.center()) + radius;
  if (camera.zfar <= 0) camera.zfar = std::max(farthest * 1.01, 1e-3);
  if (camera.znear <= 0) camera.znear = camera.zfar * 1e-4;
  return camera;
}

void checkCamera(const PreviewCamera& c) {
  const auto finite = [](const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!finite(c.eye) || !finite(c.target) || !finite(c.up))
    throw Error(ErrorCategory::InvalidArgument, "camera: eye, target and up must be finite");
  const glm::dvec3 forward = c.target - c.eye;
  if (!(glm::length(forward) > 0)) throw Error(ErrorCategory::InvalidArgument, "camera: the eye is at the target");
  if (!(glm::length(glm::cross(glm::normalize(forward), c.up)) > 1e-9))
    throw Error(ErrorCategory::InvalidArgument, "camera: up is zero or parallel to the view direction");
  if (!(c.yfov > 0 && c.yfov < 3.14159))
    throw Error(ErrorCategory::InvalidArgument, "camera: the field of view must lie in (0, 180) degrees");
}

glm::dmat4 clipFromWorld(const PreviewCamera& camera, double aspect) {
  return glm::perspective(camera.yfov, aspect, camera.znear, camera.zfar) *
         glm::lookAt(camera.eye, camera.target, camera.up);
}

}  // namespace cpvs
