#pragma once
// The scene model shared by import, depth rendering, the Embree reference and the tools.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light.h"
#include "libcpvs/scene/coverage_mask.h"

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
  // Closedness is decided by the importer from the geometry alone (docs/architecture.md): after welding
  // vertices by position every edge is shared by exactly two triangles with opposite orientation.
  bool closed = false;
  bool insideOut = false;  // closed but with negative signed volume: flipped when flattened
  uint64_t boundaryEdges = 0;      // edges used by one triangle
  uint64_t nonManifoldEdges = 0;   // edges used by more than two triangles
  uint64_t inconsistentEdges = 0;  // edges whose two triangles run the same way
  // The material's base colour factor (linear RGBA; white without a material): what cpvs-view shades with.
  glm::vec4 baseColor{1.0f};
  // Only when the importer was asked for textures (cpvs-view): the base-colour texture (index into
  // Scene::textures, -1 none) and its coordinates, one per position.
  int32_t baseColorTexture = -1;
  std::vector<glm::vec2> uvs;
  // As a shadow caster (libcpvs/scene/coverage_mask.h, docs/alpha.md): the material's name, whether the mesh
  // casts at all (its material's alpha rule, a glTF extras flag), and the coverage mask its triangles are cut
  // by (index into Scene::coverageMasks, -1: none) with the mask's coordinates, one per position.
  std::string material;
  bool castsShadows = true;
  bool cutAway = false;  // the alpha test cuts every texel (clear glass under --transparent clip): not seen either
  int32_t coverageMask = -1;
  std::vector<glm::vec2> maskUvs;
  size_t triangleCount() const { return indices.size() / 3; }
};

// One use of a mesh by a node.
struct Instance {
  uint32_t mesh = 0;
  glm::dmat4 worldFromLocal{1.0};
  std::string node;
  bool castsShadows = true;  // false: shown by cpvs-view, but no shadow comes from it (a node's extras flag)
};

// A decoded base-colour texture: RGBA8, sRGB-encoded as stored, row 0 the image's first row.
struct Texture {
  std::string name;
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;
};

// A perspective camera placed by a node (glTF: looking along the node's -Z with +Y up), world space.
struct Camera {
  std::string name;
  glm::dvec3 eye{0.0};
  glm::dvec3 forward{0.0, 0.0, -1.0};  // unit
  glm::dvec3 up{0.0, 1.0, 0.0};        // unit, perpendicular to forward
  double yfov = 0.8;                   // radians
  double aspectRatio = 0;              // 0: the image's
  double znear = 0.01, zfar = 0;       // zfar 0: infinite
};

struct Scene {
  std::string source;  // file it came from, for messages
  std::vector<std::string> files;  // every file the import read: `source` first, then external buffers and images
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::vector<Camera> cameras;
  std::vector<Texture> textures;  // only with ImportOptions::loadBaseColorTextures
  std::vector<CoverageMask> coverageMasks;  // of the alpha-tested materials that meshes use
  std::vector<std::string> warnings;
};

// An instance whose world triangles form a height field spanning the scene (libcpvs/scene/ground_sheet.h), and
// whether flatten() closed it into the top of a solid.
struct GroundSheet {
  std::string mesh, node;
  int axis = 1;       // 0 x, 1 y, 2 z: the height field is over the other two
  int sign = 1;       // the sheet faces +axis (1) or -axis (-1); the solid lies behind it
  bool used = false;  // closed into a solid
  std::string reason; // why not, when !used
  size_t closingTriangles = 0;  // skirt and bottom added when used
};

// The alpha-tested triangles of a WorldGeometry, [begin, begin + count()): triangle t is cut by
// masks[maskOf[t - begin]], its corners at mask coordinates uvs[3 (t - begin) + k].
struct MaskedTriangles {
  size_t begin = 0;
  std::vector<uint32_t> maskOf;
  std::vector<glm::vec2> uvs;
  std::vector<CoverageMask> masks;
  size_t count() const { return maskOf.size(); }
  bool contains(size_t triangle) const { return triangle >= begin && triangle - begin < maskOf.size(); }
  // Whether triangle t blocks light at barycentric coordinates (b1, b2) of its corners 1 and 2 (every
  // triangle that is not alpha-tested does).
  bool blocksAt(size_t triangle, double b1, double b2) const {
    if (!contains(triangle)) return true;
    const size_t m = triangle - begin;
    const glm::dvec2 uv = (1.0 - b1 - b2) * glm::dvec2(uvs[3 * m]) + b1 * glm::dvec2(uvs[3 * m + 1]) +
                          b2 * glm::dvec2(uvs[3 * m + 2]);
    return masks[maskOf[m]].blocksAt(uv.x, uv.y);
  }
};

// All instances flattened into one world-space triangle soup in double precision (so scenes far from the
// origin keep their precision until a light view takes them into its own space). Triangles of closed meshes
// come first, oriented outward; open triangles follow.
struct WorldGeometry {
  std::vector<glm::dvec3> positions;
  std::vector<uint32_t> indices;  // 3 per triangle
  size_t closedTriangleCount = 0; // triangles [0, closedTriangleCount) belong to closed solids
  // Triangles [closingBegin, closingEnd), at the end of the closed range, are not the scene's: the skirts and
  // bottoms that close ground sheets into solids. They shape the exit depth only: never sampled, never
  // fitted into a view, not in `bounds`, not counted as the scene's triangles.
  // Used ground sheets' own triangles are [groundBegin, closingBegin), just before.
  size_t groundBegin = 0, closingBegin = 0, closingEnd = 0;
  Bounds bounds;  // of the scene's own triangles
  std::vector<GroundSheet> groundSheets;
  // Why groundSheets is empty, for the user who expected a terrain to be taken as ground (cpvs-info): every
  // caster is closed, or the largest open mesh and the first rule it breaks, or ground sheets were off.
  std::string noGroundSheet;
  // Alpha-tested triangles: the last ones, never closed.
  MaskedTriangles masked;
  bool isMasked(size_t triangle) const { return masked.contains(triangle); }
  size_t triangleCount() const { return indices.size() / 3; }
  size_t sceneTriangleCount() const { return triangleCount() - (closingEnd - closingBegin); }
  bool isClosed(size_t triangle) const { return triangle < closedTriangleCount; }
  bool isClosing(size_t triangle) const { return triangle >= closingBegin && triangle < closingEnd; }
  size_t closedMeshTriangleCount() const { return closingBegin < closingEnd ? groundBegin : closedTriangleCount; }
};

// Whether flatten() may close ground sheets into solids (cpvs-bake --ground).
enum class GroundSheets : uint8_t { Auto = 0, Off = 1 };
// "auto" / "off"; throws Error(Usage) for anything else.
GroundSheets parseGroundSheets(const std::string& name);
const char* groundSheetsName(GroundSheets ground);

// Flattens the scene's shadow casters (instances and meshes that cast: castsShadows). Negative-determinant
// transforms and inside-out closed meshes get their winding flipped so every closed triangle faces out of its
// solid. Alpha-tested meshes (coverageMask >= 0) are never closed and come last. With GroundSheets::Auto,
// ground sheets are closed into solids (libcpvs/scene/ground_sheet.h).
WorldGeometry flatten(const Scene& scene, GroundSheets ground = GroundSheets::Auto);

// The bounds of every instance's vertices in world space (what a camera frames; WorldGeometry::bounds is the
// same box after flatten()).
Bounds sceneBounds(const Scene& scene);

// Removes the meshes whose name is listed (and their instances). Throws Error(Usage) for a name that
// matches no mesh, so a typo does not silently keep a skybox.
void excludeMeshes(Scene& scene, const std::vector<std::string>& names);

}  // namespace cpvs
