#include "gen_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "det_math.h"

namespace cpvs::scenegen {

glm::dvec3 rotate(const Quat& q, const glm::dvec3& v) {
  const glm::dvec3 u(q.x, q.y, q.z);
  const glm::dvec3 t = 2.0 * glm::cross(u, v);
  return v + q.w * t + glm::cross(u, t);
}

Quat rotationFromMinusZ(const glm::dvec3& direction) {
  const glm::dvec3 d = glm::normalize(direction);
  // q = normalise(1 + a.d, a x d) with a = (0, 0, -1): a x d = (d.y, -d.x, 0).
  const double w = 1.0 - d.z;
  if (w < 1e-12) return Quat{0.0, 1.0, 0.0, 0.0};  // d = +Z: half turn about Y
  const double len = std::sqrt(w * w + d.y * d.y + d.x * d.x);
  return Quat{d.y / len, -d.x / len, 0.0, w / len};
}

Quat rotationAboutY(double angle) {
  // Quarter turns exactly, so that instanced rectangular buildings stay axis-aligned bit for bit.
  const double quarter = angle / (kPi / 2.0);
  const double r = std::round(quarter);
  if (std::abs(quarter - r) < 1e-12) {
    const double h = std::sqrt(0.5);
    switch (((static_cast<long long>(r) % 4) + 4) % 4) {
      case 0: return Quat{0.0, 0.0, 0.0, 1.0};
      case 1: return Quat{0.0, h, 0.0, h};
      case 2: return Quat{0.0, 1.0, 0.0, 0.0};
      default: return Quat{0.0, h, 0.0, -h};
    }
  }
  return Quat{0.0, detSin(angle / 2.0), 0.0, detCos(angle / 2.0)};
}

GenInstance instanceOf(const glm::dvec3& translation, const Quat& rotation) {
  GenInstance i;
  i.translation = glm::vec3(translation);
  i.rotation = glm::vec4(static_cast<float>(rotation.x), static_cast<float>(rotation.y),
                         static_cast<float>(rotation.z), static_cast<float>(rotation.w));
  return i;
}

void useGpuInstancing(GenScene& scene) {
  std::vector<GenNode> meshNodes, lightNodes;
  std::vector<int> nodeOfMesh(scene.meshes.size(), -1);
  for (GenNode& n : scene.nodes) {
    if (n.mesh < 0) {
      lightNodes.push_back(std::move(n));
      continue;
    }
    if (!n.instances.empty()) throw std::logic_error("useGpuInstancing: node '" + n.name + "' is instanced already");
    if (n.light >= 0) throw std::logic_error("useGpuInstancing: node '" + n.name + "' has a mesh and a light");
    int& slot = nodeOfMesh[static_cast<std::size_t>(n.mesh)];
    if (slot < 0) {
      slot = static_cast<int>(meshNodes.size());
      GenNode m;
      m.name = scene.meshes[static_cast<std::size_t>(n.mesh)].name;
      m.mesh = n.mesh;
      meshNodes.push_back(std::move(m));
    }
    meshNodes[static_cast<std::size_t>(slot)].instances.push_back(instanceOf(n.translation, n.rotation));
  }
  scene.nodes = std::move(meshNodes);
  for (GenNode& n : lightNodes) scene.nodes.push_back(std::move(n));
}

SceneStats computeStats(const GenScene& scene) {
  SceneStats s;
  s.meshes = scene.meshes.size();
  s.lights = scene.lights.size();
  for (const GenMesh& m : scene.meshes) s.storedTriangles += m.triangles();
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  const auto extend = [&](const glm::dvec3& w) {
    lo = glm::min(lo, w);
    hi = glm::max(hi, w);
  };
  for (const GenNode& n : scene.nodes) {
    if (n.mesh < 0) continue;
    const GenMesh& m = scene.meshes[static_cast<std::size_t>(n.mesh)];
    if (n.instances.empty()) {
      ++s.instances;
      s.triangles += m.triangles();
      for (const glm::vec3& p : m.positions) extend(rotate(n.rotation, glm::dvec3(p)) + n.translation);
      continue;
    }
    s.instances += n.instances.size();
    s.triangles += m.triangles() * n.instances.size();
    for (const GenInstance& i : n.instances) {
      const Quat r{i.rotation.x, i.rotation.y, i.rotation.z, i.rotation.w};
      for (const glm::vec3& p : m.positions) {
        const glm::dvec3 local = rotate(r, glm::dvec3(i.scale) * glm::dvec3(p)) + glm::dvec3(i.translation);
        extend(rotate(n.rotation, local) + n.translation);
      }
    }
  }
  if (s.instances > 0) {
    s.boundsMin = lo;
    s.boundsMax = hi;
  }
  return s;
}

}  // namespace cpvs::scenegen
