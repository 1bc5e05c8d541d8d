#include "libcpvs/preview/camera.h"

#include <algorithm>
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

PreviewCamera defaultCamera(const Bounds& bounds, double aspect, const glm::dvec3& up, double yfov) {
  PreviewCamera c;
  c.up = glm::normalize(up);
  c.yfov = yfov;
  c.target = bounds.center();
  // A direction from the target: +X+Z in the plane perpendicular to up, raised by half the plane's length.
  glm::dvec3 side = glm::dvec3(1.0, 0.0, 1.0) - glm::dot(glm::dvec3(1.0, 0.0, 1.0), c.up) * c.up;
  if (glm::length(side) < 1e-6) side = glm::dvec3(1.0, 1.0, 0.0) - glm::dot(glm::dvec3(1.0, 1.0, 0.0), c.up) * c.up;
  const glm::dvec3 back = glm::normalize(glm::normalize(side) + 0.5 * c.up);  // from the target toward the eye
  const glm::dvec3 right = glm::normalize(glm::cross(c.up, back)), cameraUp = glm::cross(back, right);
  // The nearest eye on that line that sees all eight corners of the box (a flat city fills the frame, where
  // its bounding sphere would leave it small), 5 % further for a margin.
  const double tanY = std::tan(0.5 * yfov), tanX = tanY * aspect;
  double distance = 1e-6;
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 corner((i & 1) ? bounds.max.x : bounds.min.x, (i & 2) ? bounds.max.y : bounds.min.y,
                            (i & 4) ? bounds.max.z : bounds.min.z);
    const glm::dvec3 offset = corner - c.target;
    const double along = glm::dot(offset, back);
    distance = std::max({distance, along + std::fabs(glm::dot(offset, right)) / tanX,
                         along + std::fabs(glm::dot(offset, cameraUp)) / tanY});
  }
  c.eye = c.target + back * (distance * 1.05);
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
