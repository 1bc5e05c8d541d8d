#pragma once
// The in-memory result of a scene generator: meshes, instances (nodes), lights, and optionally materials,
// textures and GPU instancing (EXT_mesh_gpu_instancing). Written out by glb_writer; a scene that uses none of
// the optional parts is written exactly as before they existed.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace cpvs::scenegen {

struct GenMesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec2> texcoords;    // empty, or one TEXCOORD_0 per position (glTF: v = 0 is the image's top)
  std::vector<std::uint32_t> indices;  // triangle list
  int material = -1;                   // index into GenScene::materials, or -1 (the glTF default material)
  std::uint64_t triangles() const { return indices.size() / 3; }
};

// glTF sampler constants.
inline constexpr int kFilterNearest = 9728;
inline constexpr int kFilterLinear = 9729;
inline constexpr int kWrapClampToEdge = 33071;
inline constexpr int kWrapRepeat = 10497;

// An embedded image (a PNG in the BIN chunk) with its sampler; GenScene::textures holds one per texture.
struct GenTexture {
  std::string name;
  std::string png;  // the encoded file (see png_writer.h)
  int magFilter = kFilterLinear;
  int minFilter = kFilterLinear;
  int wrapS = kWrapRepeat;
  int wrapT = kWrapRepeat;
};

struct GenMaterial {
  enum class AlphaMode { Opaque, Mask, Blend };
  std::string name;
  glm::dvec4 baseColorFactor{1.0, 1.0, 1.0, 1.0};  // linear RGBA
  AlphaMode alphaMode = AlphaMode::Opaque;
  double alphaCutoff = 0.5;  // written for MASK only
  bool doubleSided = false;
  int baseColorTexture = -1;  // index into GenScene::textures, or -1
  int texCoord = 0;           // the TEXCOORD_n set the texture uses
};

// An opaque material of one colour; a two-sided alpha-tested one whose coverage is texture `texture`'s alpha; a
// two-sided blended one of one colour (glass).
inline GenMaterial opaqueMaterial(std::string name, glm::dvec4 color) {
  GenMaterial m;
  m.name = std::move(name);
  m.baseColorFactor = color;
  return m;
}
inline GenMaterial alphaTestedMaterial(std::string name, int texture, double cutoff = 0.5) {
  GenMaterial m;
  m.name = std::move(name);
  m.alphaMode = GenMaterial::AlphaMode::Mask;
  m.alphaCutoff = cutoff;
  m.baseColorTexture = texture;
  m.doubleSided = true;
  return m;
}
inline GenMaterial blendedMaterial(std::string name, glm::dvec4 color) {
  GenMaterial m;
  m.name = std::move(name);
  m.alphaMode = GenMaterial::AlphaMode::Blend;
  m.baseColorFactor = color;
  m.doubleSided = true;
  return m;
}

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
  enum class Type { Directional, Spot, Point };
  std::string name;
  Type type = Type::Directional;
  glm::dvec3 color{1.0, 1.0, 1.0};
  double intensity = 1.0;
  double range = 0.0;  // 0: unbounded (not written)
  double innerConeAngle = 0.0;
  double outerConeAngle = 0.0;
};

// One copy of an instanced mesh: its transform is T * R * S, applied after (inside) the node's own.
struct GenInstance {
  glm::vec3 translation{0.0f};
  glm::vec4 rotation{0.0f, 0.0f, 0.0f, 1.0f};  // unit quaternion (x, y, z, w)
  glm::vec3 scale{1.0f};
};

struct GenNode {
  std::string name;
  int mesh = -1;   // index into GenScene::meshes, or -1
  int light = -1;  // index into GenScene::lights, or -1
  glm::dvec3 translation{0.0};
  Quat rotation;
  // Non-empty (needs a mesh): the node carries EXT_mesh_gpu_instancing and its mesh is drawn once per
  // instance, at node * T * R * S, and not at the node's own transform.
  std::vector<GenInstance> instances;
};

struct GenScene {
  std::vector<GenMesh> meshes;
  std::vector<GenNode> nodes;  // all are roots of the single scene
  std::vector<GenLight> lights;
  std::vector<GenMaterial> materials;
  std::vector<GenTexture> textures;
};

// The same placement as a node's (translation, rotation) in float, as an instance: float(translation) and
// float(rotation) are what a float reader makes of the node's numbers, so both forms give the same floats.
GenInstance instanceOf(const glm::dvec3& translation, const Quat& rotation);

// Rewrites every mesh node as EXT_mesh_gpu_instancing: one node per mesh, at identity, named after the mesh,
// carrying every placement of that mesh (in node order) as an instance; light nodes follow unchanged.
void useGpuInstancing(GenScene& scene);

struct SceneStats {
  std::uint64_t triangles = 0;        // after instancing: what a baker processes
  std::uint64_t storedTriangles = 0;  // in the file's meshes
  std::size_t meshes = 0;
  std::size_t instances = 0;  // mesh placements: plain nodes with a mesh plus every GPU instance
  std::size_t lights = 0;
  glm::dvec3 boundsMin{0.0}, boundsMax{0.0};  // world space, over all instanced vertices
};
SceneStats computeStats(const GenScene& scene);

}  // namespace cpvs::scenegen
