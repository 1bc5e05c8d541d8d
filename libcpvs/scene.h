#pragma once
// The scene model shared by import, depth rendering, the Embree reference and the tools.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cpvs {

struct Bounds {
  glm::dvec3 min{std::numeric_limits<double>::infinity()};
  glm::dvec3 max{-std::numeric_limits<double>::infinity()};
  bool empty() const { return !(min.x <= max.x && min.y <= max.y && min.z <= max.z); }
  void extend(const glm::dvec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  glm::dvec3 center() const { return 0.5 * (min + max); }
  glm::dvec3 extent() const { return max - min; }
};

// A triangle mesh in its local space. Winding: counter-clockwise is the front face (glTF).
struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;  // 3 per triangle
  // Closedness is decided by the importer from the geometry alone (DESIGN.md §4.1): after welding
  // vertices by position every edge is shared by exactly two triangles with opposite orientation.
  bool closed = false;
  bool insideOut = false;  // closed but with negative signed volume: flipped when flattened
  uint64_t boundaryEdges = 0;      // edges used by one triangle
  uint64_t nonManifoldEdges = 0;   // edges used by more than two triangles
  uint64_t inconsistentEdges = 0;  // edges whose two triangles run the same way
  size_t triangleCount() const { return indices.size() / 3; }
};

// One use of a mesh by a node.
struct Instance {
  uint32_t mesh = 0;
  glm::dmat4 worldFromLocal{1.0};
  std::string node;
};

enum class LightType : uint8_t { Directional = 0, Spot = 1, Point = 2 };
const char* lightTypeName(LightType type);

// A punctual light (KHR_lights_punctual semantics, world space).
struct Light {
  std::string name;
  LightType type = LightType::Directional;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;
  double range = std::numeric_limits<double>::infinity();  // spot and point only
  double innerConeAngle = 0.0;                             // spot only, radians
  double outerConeAngle = 0.7853981633974483;              // spot only, radians (pi/4)
  glm::dvec3 position{0.0};                                // spot and point
  glm::dvec3 direction{0.0, 0.0, -1.0};                    // the way the light travels (unit)
};

struct Scene {
  std::string source;  // file it came from, for messages
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::vector<std::string> warnings;
};

// All instances flattened into one world-space triangle soup in double precision (so scenes far from the
// origin keep their precision until a light view takes them into its own space). Triangles of closed meshes
// come first, oriented outward; open triangles follow.
struct WorldGeometry {
  std::vector<glm::dvec3> positions;
  std::vector<uint32_t> indices;  // 3 per triangle
  size_t closedTriangleCount = 0; // triangles [0, closedTriangleCount) belong to closed meshes
  Bounds bounds;
  size_t triangleCount() const { return indices.size() / 3; }
  bool isClosed(size_t triangle) const { return triangle < closedTriangleCount; }
};

// Flattens the scene. Negative-determinant transforms and inside-out closed meshes get their winding
// flipped so every closed triangle faces out of its solid.
WorldGeometry flatten(const Scene& scene);

// Removes the meshes whose name is listed (and their instances). Throws Error(Usage) for a name that
// matches no mesh, so a typo does not silently keep a skybox.
void excludeMeshes(Scene& scene, const std::vector<std::string>& names);

}  // namespace cpvs
