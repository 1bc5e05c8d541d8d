#include "libcpvs/scene/scene.h"

#include <algorithm>
#include <cctype>

#include "libcpvs/base/error.h"
#include "libcpvs/base/named_values.h"
#include "libcpvs/scene/ground_sheet.h"

namespace cpvs {

namespace {

// Vertices a mesh's triangles actually use, so unused vertices neither cost a transform nor widen the bounds.
struct UsedVertices {
  std::vector<uint32_t> original;  // compact id -> mesh vertex
  std::vector<uint32_t> compact;   // mesh vertex -> compact id (valid only for used vertices)
};

UsedVertices findUsedVertices(const Mesh& mesh) {
  constexpr uint32_t kUnused = ~0u;
  UsedVertices used;
  used.compact.assign(mesh.positions.size(), kUnused);
  for (uint32_t index : mesh.indices) {
    if (index >= mesh.positions.size())
      throw Error(ErrorCategory::InvalidInput, "mesh '" + mesh.name + "': index " + std::to_string(index) +
                                              " out of range (" + std::to_string(mesh.positions.size()) +
                                              " vertices)");
    if (used.compact[index] == kUnused) {
      used.compact[index] = uint32_t(used.original.size());
      used.original.push_back(index);
    }
  }
  return used;
}

void appendInstance(const Mesh& mesh, const UsedVertices& used, const Instance& instance, bool outwardFlip,
                    WorldGeometry& world) {
  const size_t base = world.positions.size();
  if (base + used.original.size() > size_t(UINT32_MAX))
    throw Error(ErrorCategory::RuntimeFailure, "scene too large: more than 2^32 world-space vertices");
  for (uint32_t v : used.original) {
    const glm::dvec3 p = glm::dvec3(instance.worldFromLocal * glm::dvec4(glm::dvec3(mesh.positions[v]), 1.0));
    world.positions.push_back(p);
    world.bounds.extend(p);
  }
  // A mirroring transform reverses the winding (glTF: det < 0 flips the front face); undo it so the
  // front face keeps its meaning. Inside-out closed meshes are flipped once more so they face outward.
  const bool mirrored = glm::determinant(glm::dmat3(instance.worldFromLocal)) < 0.0;
  const bool flip = mirrored != outwardFlip;
  const uint32_t offset = uint32_t(base);
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t a = offset + used.compact[mesh.indices[t]];
    const uint32_t b = offset + used.compact[mesh.indices[t + 1]];
    const uint32_t c = offset + used.compact[mesh.indices[t + 2]];
    if (flip)
      world.indices.insert(world.indices.end(), {a, c, b});
    else
      world.indices.insert(world.indices.end(), {a, b, c});
  }
}

// "Box#2" is primitive 2 of the glTF mesh "Box" (see libcpvs/import/gltf_import.h).
bool nameMatches(const std::string& meshName, const std::string& wanted) {
  if (meshName == wanted) return true;
  if (meshName.size() <= wanted.size() + 1 || meshName.compare(0, wanted.size(), wanted) != 0 ||
      meshName[wanted.size()] != '#')
    return false;
  return std::all_of(meshName.begin() + long(wanted.size()) + 1, meshName.end(),
                     [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; });
}

}  // namespace

namespace {
constexpr Named<GroundSheets> kGroundModes[] = {{GroundSheets::Auto, "auto"}, {GroundSheets::Off, "off"}};
}  // namespace

GroundSheets parseGroundSheets(const std::string& name) { return parseNamed(kGroundModes, name, "ground mode"); }
const char* groundSheetsName(GroundSheets ground) { return nameOf(kGroundModes, ground); }

namespace {

enum class CasterKind { None, Closed, Open, Masked };

CasterKind casterKind(const Mesh& mesh, const Instance& instance) {
  if (!mesh.castsShadows || !instance.castsShadows) return CasterKind::None;
  if (mesh.coverageMask >= 0) return CasterKind::Masked;  // a mesh with cut-away texels is never a solid
  return mesh.closed ? CasterKind::Closed : CasterKind::Open;
}

}  // namespace

WorldGeometry flatten(const Scene& scene, GroundSheets ground) {
  std::vector<UsedVertices> used;
  used.reserve(scene.meshes.size());
  size_t closedTriangles = 0, totalTriangles = 0, totalVertices = 0, maskedTriangles = 0;
  for (const Mesh& mesh : scene.meshes) used.push_back(findUsedVertices(mesh));
  for (const Instance& instance : scene.instances) {
    if (instance.mesh >= scene.meshes.size())
      throw Error(ErrorCategory::InvalidInput, "instance '" + instance.node + "': mesh index " +
                                              std::to_string(instance.mesh) + " out of range");
    const Mesh& mesh = scene.meshes[instance.mesh];
    const CasterKind kind = casterKind(mesh, instance);
    if (kind == CasterKind::None) continue;
    if (kind == CasterKind::Masked) {
      if (size_t(mesh.coverageMask) >= scene.coverageMasks.size() || mesh.maskUvs.size() != mesh.positions.size())
        throw Error(ErrorCategory::InvalidInput, "mesh '" + mesh.name + "': coverage mask " +
                                                    std::to_string(mesh.coverageMask) +
                                                    " or its coordinates do not exist");
      maskedTriangles += mesh.triangleCount();
    }
    totalTriangles += mesh.triangleCount();
    totalVertices += used[instance.mesh].original.size();
    if (kind == CasterKind::Closed) closedTriangles += mesh.triangleCount();
  }

  WorldGeometry world;
  world.positions.reserve(totalVertices);
  world.indices.reserve(3 * totalTriangles);
  std::vector<InstanceTriangles> ranges;
  ranges.reserve(scene.instances.size());
  // Closed solids first, then open surfaces, then the alpha-tested ones (so that they stay last when ground
  // sheets are closed: they are never sheets).
  std::vector<int32_t> maskIndex(scene.coverageMasks.size(), -1);
  for (CasterKind pass : {CasterKind::Closed, CasterKind::Open, CasterKind::Masked}) {
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      const Instance& instance = scene.instances[i];
      const Mesh& mesh = scene.meshes[instance.mesh];
      if (casterKind(mesh, instance) != pass) continue;
      const size_t begin = world.triangleCount();
      appendInstance(mesh, used[instance.mesh], instance, pass == CasterKind::Closed && mesh.insideOut, world);
      ranges.push_back({i, begin, world.triangleCount()});
      if (pass != CasterKind::Masked) continue;
      int32_t& mask = maskIndex[size_t(mesh.coverageMask)];
      if (mask < 0) {
        mask = int32_t(world.masked.masks.size());
        world.masked.masks.push_back(scene.coverageMasks[size_t(mesh.coverageMask)]);
      }
      // appendInstance may have swapped corners 1 and 2 (mirroring): take the coordinates the way it did.
      const bool mirrored = glm::determinant(glm::dmat3(instance.worldFromLocal)) < 0.0;
      for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        world.masked.maskOf.push_back(uint32_t(mask));
        const uint32_t a = mesh.indices[t], b = mesh.indices[t + (mirrored ? 2 : 1)],
                       c = mesh.indices[t + (mirrored ? 1 : 2)];
        world.masked.uvs.insert(world.masked.uvs.end(), {mesh.maskUvs[a], mesh.maskUvs[b], mesh.maskUvs[c]});
      }
    }
  }
  world.closedTriangleCount = closedTriangles;
  if (ground == GroundSheets::Auto) closeGroundSheets(scene, ranges, world);
  else world.noGroundSheet = "--ground off";
  world.masked.begin = world.triangleCount() - maskedTriangles;
  return world;
}

void excludeMeshes(Scene& scene, const std::vector<std::string>& names) {
  std::vector<bool> excluded(scene.meshes.size(), false);
  for (const std::string& name : names) {
    bool found = false;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
      if (nameMatches(scene.meshes[m].name, name)) {
        excluded[m] = true;
        found = true;
      }
    }
    if (!found) {
      std::string known;
      for (size_t m = 0; m < scene.meshes.size() && m < 20; ++m) known += (m ? ", " : "") + scene.meshes[m].name;
      if (scene.meshes.size() > 20) known += ", ...";
      throw Error(ErrorCategory::InvalidArgument, "no mesh named '" + name + "' in " +
                                       (scene.source.empty() ? std::string("the scene") : scene.source) +
                                       " (meshes: " + known + ")");
    }
  }

  constexpr uint32_t kRemoved = ~0u;
  std::vector<uint32_t> newIndex(scene.meshes.size(), kRemoved);
  std::vector<Mesh> kept;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (excluded[m]) continue;
    newIndex[m] = uint32_t(kept.size());
    kept.push_back(std::move(scene.meshes[m]));
  }
  scene.meshes = std::move(kept);

  std::vector<Instance> instances;
  for (Instance& instance : scene.instances) {
    if (instance.mesh >= newIndex.size() || newIndex[instance.mesh] == kRemoved) continue;
    instance.mesh = newIndex[instance.mesh];
    instances.push_back(std::move(instance));
  }
  scene.instances = std::move(instances);
}

Bounds sceneBounds(const Scene& scene) {
  Bounds bounds;
  for (const Instance& instance : scene.instances)
    for (const glm::vec3& p : scene.meshes[instance.mesh].positions)
      bounds.extend(glm::dvec3(instance.worldFromLocal * glm::dvec4(glm::dvec3(p), 1.0)));
  return bounds;
}

}  // namespace cpvs
