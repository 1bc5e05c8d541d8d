#pragma once
// The in-memory result of a scene generator: meshes, instances (nodes), lights. Written out by glb_writer.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cpvs::scenegen {

struct GenMesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<std::uint32_t> indices;  // triangle list
  std::uint64_t triangles() const { return indices.size() / 3; }
};

// A unit quaternion in glTF order (x, y, z, w).
struct Quat {
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
  bool isIdentity() const { return x == 0.0 && y == 0.0 && z == 0.0 && w == 1.0; }
};

// Rotates v by q.
glm::dvec3 rotate(const Quat& q, const glm::dvec3& v);
// The rotation that turns the glTF light axis (local -Z) into `direction` (need not be normalised).
Quat rotationFromMinusZ(const glm::dvec3& direction);
// A rotation by `angle` radians about +Y.
Quat rotationAboutY(double angle);

struct GenLight {
  enum class Type { Directional, Spot };
  std::string name;
  Type type = Type::Directional;
  glm::dvec3 color{1.0, 1.0, 1.0};
  double intensity = 1.0;
  double range = 0.0;  // 0: unbounded (not written)
  double innerConeAngle = 0.0;
  double outerConeAngle = 0.0;
};

struct GenNode {
  std::string name;
  int mesh = -1;   // index into GenScene::meshes, or -1
  int light = -1;  // index into GenScene::lights, or -1
  glm::dvec3 translation{0.0};
  Quat rotation;
};

struct GenScene {
  std::vector<GenMesh> meshes;
  std::vector<GenNode> nodes;  // all are roots of the single scene
  std::vector<GenLight> lights;
};

struct SceneStats {
  std::uint64_t triangles = 0;        // after instancing: what a baker processes
  std::uint64_t storedTriangles = 0;  // in the file's meshes
  std::size_t meshes = 0;
  std::size_t instances = 0;  // nodes that reference a mesh
  std::size_t lights = 0;
  glm::dvec3 boundsMin{0.0}, boundsMax{0.0};  // world space, over all instanced vertices
};
SceneStats computeStats(const GenScene& scene);

}  // namespace cpvs::scenegen
