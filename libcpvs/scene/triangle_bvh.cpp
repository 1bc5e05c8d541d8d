#include "libcpvs/scene/triangle_bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cpvs {
namespace {

constexpr uint32_t kLeafSize = 4;

float below(double v) {
  const float f = float(v);
  return double(f) <= v ? f : std::nextafter(f, -std::numeric_limits<float>::infinity());
}
float above(double v) {
  const float f = float(v);
  return double(f) >= v ? f : std::nextafter(f, std::numeric_limits<float>::infinity());
}

}  // namespace

TriangleBvh::TriangleBvh(const WorldGeometry& world) {
  const size_t count = world.triangleCount();
  order_.resize(count);
  std::vector<Box> boxes(count);
  std::vector<glm::vec3> centre(count);
  for (size_t t = 0; t < count; ++t) {
    order_[t] = uint32_t(t);
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3& p = world.positions[world.indices[3 * t + k]];
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    boxes[t].lo = {below(lo.x), below(lo.y), below(lo.z)};
    boxes[t].hi = {above(hi.x), above(hi.y), above(hi.z)};
    centre[t] = 0.5f * (boxes[t].lo + boxes[t].hi);
  }
  if (count == 0) return;
  // Top-down: split each range at the median of its centres along the longest axis of their spread.
  struct Task {
    uint32_t node, first, count;
  };
  nodes_.reserve(2 * (count / kLeafSize + 1));
  nodes_.emplace_back();
  std::vector<Task> stack = {{0, 0, uint32_t(count)}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    uint32_t* begin = order_.data() + task.first;
    Box box{glm::vec3(std::numeric_limits<float>::infinity()), glm::vec3(-std::numeric_limits<float>::infinity())};
    glm::vec3 cLo(std::numeric_limits<float>::infinity()), cHi(-std::numeric_limits<float>::infinity());
    for (uint32_t k = 0; k < task.count; ++k) {
      const uint32_t t = begin[k];
      box.lo = glm::min(box.lo, boxes[t].lo);
      box.hi = glm::max(box.hi, boxes[t].hi);
      cLo = glm::min(cLo, centre[t]);
      cHi = glm::max(cHi, centre[t]);
    }
    nodes_[task.node].box = box;
    const glm::vec3 spread = cHi - cLo;
    if (task.count <= kLeafSize || std::max({spread.x, spread.y, spread.z}) <= 0.0f) {
      nodes_[task.node].first = task.first;
      nodes_[task.node].count = task.count;
      continue;
    }
    const int axis = spread.x >= spread.y && spread.x >= spread.z ? 0 : (spread.y >= spread.z ? 1 : 2);
    const uint32_t half = task.count / 2;
    std::nth_element(begin, begin + half, begin + task.count,
                     [&](uint32_t a, uint32_t b) { return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b); });
    const uint32_t left = uint32_t(nodes_.size());
    nodes_.emplace_back();
    const uint32_t right = uint32_t(nodes_.size());
    nodes_.emplace_back();
    nodes_[task.node].first = right;  // children are allocated as a pair: left = right - 1
    nodes_[task.node].count = 0;
    stack.push_back({right, task.first + half, task.count - half});
    stack.push_back({left, task.first, half});
  }
  boxes_.resize(count);
  for (size_t k = 0; k < count; ++k) boxes_[k] = boxes[order_[k]];
}

void TriangleBvh::overlapping(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<uint32_t>& out) const {
  if (nodes_.empty()) return;
  const glm::vec3 l(below(lo.x), below(lo.y), below(lo.z)), h(above(hi.x), above(hi.y), above(hi.z));
  const size_t start = out.size();
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!node.box.overlaps(l, h)) continue;
    if (node.count > 0) {
      for (uint32_t k = node.first; k < node.first + node.count; ++k)
        if (boxes_[k].overlaps(l, h)) out.push_back(order_[k]);
      continue;
    }
    // Children: the pair at node.first - 1 (left) and node.first (right).
    stack[top++] = node.first;
    stack[top++] = node.first - 1;
  }
  std::sort(out.begin() + ptrdiff_t(start), out.end());
}

}  // namespace cpvs
