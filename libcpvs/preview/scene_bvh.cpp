#include "libcpvs/preview/scene_bvh.h"

#include <algorithm>
#include <limits>

namespace cpvs {

namespace {

struct Box {
  glm::vec3 lo{std::numeric_limits<float>::infinity()}, hi{-std::numeric_limits<float>::infinity()};
  void grow(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  glm::vec3 centre() const { return 0.5f * (lo + hi); }
};

// Splits items at the median of their centres along the axis where the centres spread most.
template <class CentreOf>
size_t medianSplit(uint32_t* begin, size_t count, CentreOf centreOf) {
  Box spread;
  for (size_t k = 0; k < count; ++k) spread.grow({centreOf(begin[k]), centreOf(begin[k])});
  const glm::vec3 extent = spread.hi - spread.lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const size_t half = count / 2;
  std::nth_element(begin, begin + half, begin + count,
                   [&](uint32_t a, uint32_t b) { return centreOf(a)[axis] < centreOf(b)[axis]; });
  return half;
}

class Builder {
public:
  Builder(const CasterTriangles& corners, SceneBvh& out) : corners_(corners), out_(out) {}

  void build(const std::vector<std::vector<uint32_t>>& instances) {
    triangleBoxes_.resize(corners_.count());
    for (size_t t = 0; t < triangleBoxes_.size(); ++t)
      for (int k = 0; k < 3; ++k) triangleBoxes_[t].grow({corners_.corners[3 * t + size_t(k)], corners_.corners[3 * t + size_t(k)]});
    for (const std::vector<uint32_t>& triangles : instances) {
      if (triangles.empty()) continue;
      Box box;
      for (uint32_t t : triangles) box.grow(triangleBox(t));
      instanceTriangles_.push_back(&triangles);
      instanceBoxes_.push_back(box);
    }
    if (instanceBoxes_.empty()) return;
    std::vector<uint32_t> order(instanceBoxes_.size());
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    out_.nodes.emplace_back();
    instanceNode(0, order.data(), order.size(), 0);
  }

private:
  const Box& triangleBox(uint32_t t) const { return triangleBoxes_[t]; }

  // Two new nodes side by side; returns the first.
  uint32_t pair() {
    out_.nodes.resize(out_.nodes.size() + 2);
    return uint32_t(out_.nodes.size() - 2);
  }

  void setBox(uint32_t node, const Box& b, uint32_t level) {
    out_.nodes[node].lo = b.lo;
    out_.nodes[node].hi = b.hi;
    out_.levels = std::max(out_.levels, level + 1);
  }

  void instanceNode(uint32_t node, uint32_t* instances, size_t count, uint32_t level) {
    if (count == 1) {
      std::vector<uint32_t> triangles = *instanceTriangles_[instances[0]];
      triangleNode(node, triangles.data(), triangles.size(), level);
      return;
    }
    Box box;
    for (size_t k = 0; k < count; ++k) box.grow(instanceBoxes_[instances[k]]);
    setBox(node, box, level);
    const size_t half = medianSplit(instances, count, [&](uint32_t i) { return instanceBoxes_[i].centre(); });
    const uint32_t children = pair();
    out_.nodes[node].first = children;
    instanceNode(children, instances, half, level + 1);
    instanceNode(children + 1, instances + half, count - half, level + 1);
  }

  void triangleNode(uint32_t node, uint32_t* triangles, size_t count, uint32_t level) {
    Box box;
    for (size_t k = 0; k < count; ++k) box.grow(triangleBox(triangles[k]));
    setBox(node, box, level);
    if (count <= SceneBvh::kLeafTriangles) {
      out_.nodes[node].first = uint32_t(out_.triangles.size());
      out_.nodes[node].count = uint32_t(count);
      out_.triangles.insert(out_.triangles.end(), triangles, triangles + count);
      return;
    }
    const size_t half = medianSplit(triangles, count, [&](uint32_t t) { return triangleBox(t).centre(); });
    const uint32_t children = pair();
    out_.nodes[node].first = children;
    triangleNode(children, triangles, half, level + 1);
    triangleNode(children + 1, triangles + half, count - half, level + 1);
  }

  const CasterTriangles& corners_;
  SceneBvh& out_;
  std::vector<const std::vector<uint32_t>*> instanceTriangles_;
  std::vector<Box> instanceBoxes_;
  std::vector<Box> triangleBoxes_;  // every triangle's, made once (the splits compare centres many times)
};

}  // namespace

SceneBvh buildSceneBvh(const CasterTriangles& corners, const std::vector<std::vector<uint32_t>>& instances) {
  SceneBvh bvh;
  Builder(corners, bvh).build(instances);
  return bvh;
}

}  // namespace cpvs
