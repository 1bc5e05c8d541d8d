#pragma once
// A bounding volume hierarchy over the world's triangles, built once per bake, so that what each light needs
// ("which triangles can reach this view?", "how far does the geometry it sees extend?") costs what the light
// reaches instead of a pass over the whole scene per light.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/scene/scene.h"

namespace cpvs {

class TriangleBvh {
public:
  explicit TriangleBvh(const WorldGeometry& world);

  // Appends to `out` the triangles whose bounds overlap the box [lo, hi] (every triangle that has a point in it,
  // and some near it), in ascending index order, so a loop over them visits triangles in the order a loop over
  // all of them would.
  void overlapping(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<uint32_t>& out) const;
  size_t triangleCount() const { return order_.size(); }

private:
  // Bounds in float, rounded outward: conservative, and half the memory of doubles.
  struct Box {
    glm::vec3 lo, hi;
    bool overlaps(const glm::vec3& l, const glm::vec3& h) const {
      return lo.x <= h.x && l.x <= hi.x && lo.y <= h.y && l.y <= hi.y && lo.z <= h.z && l.z <= hi.z;
    }
  };
  struct Node {
    Box box;
    uint32_t first = 0;  // leaf: its triangles are order_[first, first + count); inner: its second child (the
                         // first is at first - 1)
    uint32_t count = 0;  // 0 for an inner node
  };
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;  // triangle indices, grouped by leaf
  std::vector<Box> boxes_;       // the bounds of order_[k]
};

}  // namespace cpvs
