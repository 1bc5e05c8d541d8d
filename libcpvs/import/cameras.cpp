// Perspective cameras placed by the scene's nodes (what cpvs-view starts from; never needed by a bake).
#include <cmath>

#include "libcpvs/import/gltf_importer.h"

namespace cpvs::gltf {

// A perspective camera on a node (orthographic ones are skipped with a warning). Name: the camera's, else
// the node's, else "camera<i>".
void GltfImporter::placeCamera(int nodeIndex, int cameraIndex, const glm::dmat4& worldFromLocal) {
  const std::string what = describeNode(nodeIndex) + ": camera " + std::to_string(cameraIndex);
  if (size_t(cameraIndex) >= model_.cameras.size()) fail(what + " does not exist");
  const tinygltf::Camera& source = model_.cameras[size_t(cameraIndex)];
  if (source.type != "perspective") {
    warn(what + " is " + (source.type.empty() ? "of no type" : source.type) + ", not perspective; skipped");
    return;
  }
  const tinygltf::PerspectiveCamera& p = source.perspective;
  // Cameras only matter to cpvs-view: a bad one is skipped with a warning, never fails a bake.
  if (!(p.yfov > 0 && p.yfov < 3.14159) || !(p.znear > 0) || !(p.aspectRatio >= 0) ||
      !(p.zfar == 0 || p.zfar > p.znear)) {
    warn(what + " skipped: yfov must be in (0, pi), znear > 0, aspectRatio >= 0 and zfar 0 or > znear");
    return;
  }
  Camera camera;
  const tinygltf::Node& node = model_.nodes[size_t(nodeIndex)];
  camera.name = !source.name.empty() ? source.name
                                     : (!node.name.empty() ? node.name : "camera" + std::to_string(cameraIndex));
  camera.eye = glm::dvec3(worldFromLocal * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  const glm::dvec3 forward = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 0.0, -1.0);
  const glm::dvec3 up = glm::dmat3(worldFromLocal) * glm::dvec3(0.0, 1.0, 0.0);
  const glm::dvec3 side = glm::cross(forward, up);
  if (!(glm::length(side) > 0.0) || !std::isfinite(glm::length(side)) || !std::isfinite(camera.eye.x + camera.eye.y + camera.eye.z)) {
    warn(what + " skipped: the node's transform is degenerate");
    return;
  }
  camera.forward = glm::normalize(forward);
  camera.up = glm::normalize(glm::cross(side, forward));
  camera.yfov = p.yfov;
  camera.aspectRatio = p.aspectRatio;
  camera.znear = p.znear;
  camera.zfar = p.zfar;
  scene_.cameras.push_back(camera);
}

}  // namespace cpvs::gltf
