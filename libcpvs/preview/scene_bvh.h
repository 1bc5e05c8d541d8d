#pragma once
// ManyPSMs' scene tree (cpvs-view --shadows manypsm): a bounding volume hierarchy over the triangles that cast,
// built once per scene and read by the GPU traversal as two storage buffers. Its upper levels split whole
// instances, so each instance is one subtree and the levels below split that instance's triangles: the post's "instances are BVH nodes". Vertices are the renderer's world-space ones, so
// the maps it draws are the per-light maps' texel for texel; a node carries no transform.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/preview/caster_culling.h"

namespace cpvs {

// std430-compatible: two vec4s. Inner node: count == 0, children at first and first + 1. Leaf: triangles
// SceneBvh::triangles[first, first + count).
struct SceneBvhNode {
  glm::vec3 lo;
  uint32_t first = 0;
  glm::vec3 hi;
  uint32_t count = 0;
};
static_assert(sizeof(SceneBvhNode) == 32);

struct SceneBvh {
  static constexpr uint32_t kLeafTriangles = 4;
  std::vector<SceneBvhNode> nodes;    // root at 0 (none when nothing casts)
  std::vector<uint32_t> triangles;    // renderer triangle indices, grouped by leaf
  uint32_t levels = 0;                // the root is level 0; the deepest node is at levels - 1
  size_t bytes() const { return nodes.size() * sizeof(SceneBvhNode) + triangles.size() * 4; }
};

// `instances`: per instance, its casting triangles (indices into `corners`).
SceneBvh buildSceneBvh(const CasterTriangles& corners, const std::vector<std::vector<uint32_t>>& instances);

}  // namespace cpvs
