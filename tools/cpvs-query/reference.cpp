#include "tools/cpvs-query/reference.h"

#include <cmath>

#include "formats/gltf/gltf_import.h"

namespace cpvs::query {

void ErrorStats::add(const ErrorStats& o) {
  samples += o.samples;
  misclassified += o.misclassified;
  uniform += o.uniform;
  misclassifiedUniform += o.misclassifiedUniform;
  absDiffSum += o.absDiffSum;
  referenceLit += o.referenceLit;
  cpvsLit += o.cpvsLit;
}

Reference::Reference(const std::string& scenePath, const std::vector<std::string>& excludedMeshes,
                     NormalOrientation orientation)
    : scenePath_(scenePath), orientation_(orientation) {
  Scene scene = importGltf(scenePath);
  if (!excludedMeshes.empty()) excludeMeshes(scene, excludedMeshes);
  warnings_ = scene.warnings;
  const WorldGeometry world = flatten(scene);
  scene_ = std::make_unique<EmbreeScene>(world);
  const double diagonal = world.bounds.empty() ? 1.0 : glm::length(world.bounds.extent());
  // Scale-relative: ~100x the float precision Embree stores the scene with, far below a voxel of any
  // practical resolution (1e-5 of the diagonal is a voxel only at N ~ 100k).
  epsilon_ = 1e-5 * (diagonal > 0 ? diagonal : 1.0);
}

Reference::~Reference() = default;

size_t Reference::triangles() const { return scene_->triangleCount(); }

uint8_t Reference::visibility(const Light& light, const QueryPoint& point) const {
  if (!withinInfluence(light, point.position)) return 0;
  glm::dvec3 toLight;
  double distance = EmbreeScene::kInfinity;
  if (light.type == LightType::Directional) {
    toLight = -light.direction;
  } else {
    const glm::dvec3 d = light.position - point.position;
    distance = glm::length(d);
    if (!(distance > 0)) return 1;
    toLight = d / distance;
  }
  glm::dvec3 origin = point.position;
  const double nLength = glm::length(point.normal);
  if (nLength > 0) {
    glm::dvec3 n = point.normal / nLength;
    if (orientation_ == NormalOrientation::TowardLight && glm::dot(n, toLight) < 0) n = -n;
    origin += epsilon_ * n;
  } else {
    origin += epsilon_ * toLight;
  }
  if (light.type != LightType::Directional) {
    const glm::dvec3 d = light.position - origin;
    distance = glm::length(d);
    if (!(distance > epsilon_)) return 1;
    toLight = d / distance;
    distance -= epsilon_;  // stop short of the light itself
  }
  return scene_->occluded(origin, toLight, distance) ? 0 : 1;
}

uint8_t Reference::visibility(const LightShadow& shadow, const QueryPoint& point, bool& uniform) const {
  const uint8_t centre = visibility(shadow.light(), point);
  uniform = true;
  const int index = shadow.viewIndex(point.position);
  if (index < 0) return centre;  // outside the light's influence: 0 everywhere near it as far as we know
  const LightView& view = shadow.views()[size_t(index)];
  const GridPoint g = toGrid(view, point.position);
  if (!g.inFront) return centre;
  glm::dvec3 m = gridNormal(view, point.position, point.normal);
  const double length = glm::length(m);
  m = length > 0 && std::isfinite(length) ? m / length : glm::dvec3(0.0);
  static const double offsets[8][2] = {{2, 0}, {-2, 0}, {0, 2}, {0, -2}, {2, 2}, {-2, 2}, {2, -2}, {-2, -2}};
  for (const auto& o : offsets) {
    glm::dvec3 w(o[0], o[1], 0.0);
    w -= glm::dot(w, m) * m;  // stay on the tangent plane (grid metric)
    const QueryPoint sample{gridToWorld(view, g.uvs + w), point.normal};
    if (visibility(shadow.light(), sample) != centre) {
      uniform = false;
      break;
    }
  }
  return centre;
}

}  // namespace cpvs::query
