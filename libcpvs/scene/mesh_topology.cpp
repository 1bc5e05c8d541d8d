#include "libcpvs/scene/mesh_topology.h"

#include <algorithm>
#include <array>
#include <bit>
#include <span>
#include <type_traits>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

template <class Real>
auto positionBits(Real value) {
  if (value == Real(0)) value = Real(0);  // -0.0 and 0.0 are the same point
  return std::bit_cast<std::conditional_t<sizeof(Real) == 4, uint32_t, uint64_t>>(value);
}

uint64_t mix64(uint64_t x) {  // splitmix64 finaliser
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ull;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebull;
  x ^= x >> 31;
  return x;
}

}  // namespace

// An open-addressing hash table: linear in the vertex count, unlike a sort.
template <class Vec>
std::vector<uint32_t> weldByPosition(std::span<const Vec> positions) {
  constexpr uint32_t kEmpty = ~0u;
  size_t capacity = 16;
  while (capacity < 2 * positions.size()) capacity *= 2;
  std::vector<uint32_t> table(capacity, kEmpty);
  std::vector<uint32_t> welded(positions.size());
  auto bits = [&](uint32_t v) {
    const Vec& p = positions[v];
    return std::array{positionBits(p.x), positionBits(p.y), positionBits(p.z)};
  };
  for (uint32_t v = 0; v < positions.size(); ++v) {
    const auto key = bits(v);
    size_t slot = mix64(mix64(uint64_t(key[0])) ^ mix64(uint64_t(key[1]) + 0x9E3779B97F4A7C15ull) ^ uint64_t(key[2])) &
                  (capacity - 1);
    while (true) {
      if (table[slot] == kEmpty) {
        table[slot] = v;
        welded[v] = v;
        break;
      }
      if (bits(table[slot]) == key) {
        welded[v] = table[slot];
        break;
      }
      slot = (slot + 1) & (capacity - 1);
    }
  }
  return welded;
}

template std::vector<uint32_t> weldByPosition(std::span<const glm::vec3>);
template std::vector<uint32_t> weldByPosition(std::span<const glm::dvec3>);

void classifyMesh(Mesh& mesh) {
  mesh.closed = false;
  mesh.insideOut = false;
  mesh.boundaryEdges = mesh.nonManifoldEdges = mesh.inconsistentEdges = 0;
  for (uint32_t index : mesh.indices)
    if (index >= mesh.positions.size())
      throw Error(ErrorCategory::InvalidInput, "mesh '" + mesh.name + "': index " + std::to_string(index) +
                                              " out of range (" + std::to_string(mesh.positions.size()) +
                                              " vertices)");

  const std::vector<uint32_t> welded = weldByPosition(std::span<const glm::vec3>(mesh.positions));

  // Bucket every edge by its lower vertex id (a counting sort); each entry keeps the higher id and whether
  // the triangle runs low -> high. Buckets are tiny, so sorting them is cheap.
  const size_t vertexCount = mesh.positions.size();
  std::vector<size_t> bucketStart(vertexCount + 1, 0);
  auto forEachEdge = [&](auto&& visit) {
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const uint32_t a = welded[mesh.indices[t]], b = welded[mesh.indices[t + 1]], c = welded[mesh.indices[t + 2]];
      if (a == b || b == c || c == a) continue;  // degenerate
      visit(a, b);
      visit(b, c);
      visit(c, a);
    }
  };
  forEachEdge([&](uint32_t from, uint32_t to) { ++bucketStart[std::min(from, to) + 1]; });
  for (size_t v = 0; v < vertexCount; ++v) bucketStart[v + 1] += bucketStart[v];
  const size_t edgeCount = bucketStart[vertexCount];
  const size_t triangles = edgeCount / 3;  // non-degenerate ones
  std::vector<uint64_t> entries(edgeCount);
  {
    std::vector<size_t> fill(bucketStart.begin(), bucketStart.end() - 1);
    forEachEdge([&](uint32_t from, uint32_t to) {
      const uint32_t low = std::min(from, to), high = std::max(from, to);
      entries[fill[low]++] = (uint64_t(high) << 1) | (from < to ? 1u : 0u);
    });
  }

  for (size_t v = 0; v < vertexCount; ++v) {
    auto begin = entries.begin() + bucketStart[v], end = entries.begin() + bucketStart[v + 1];
    std::sort(begin, end);
    for (auto group = begin; group != end;) {
      auto next = group;
      size_t forward = 0, uses = 0;
      while (next != end && (*next >> 1) == (*group >> 1)) {
        forward += *next & 1;
        ++uses;
        ++next;
      }
      if (uses == 1)
        ++mesh.boundaryEdges;
      else if (uses > 2)
        ++mesh.nonManifoldEdges;
      else if (forward != 1)
        ++mesh.inconsistentEdges;
      group = next;
    }
  }

  mesh.closed = triangles > 0 && mesh.boundaryEdges == 0 && mesh.nonManifoldEdges == 0 && mesh.inconsistentEdges == 0;
  if (!mesh.closed) return;

  // Signed volume by the divergence theorem, relative to one vertex to keep the sum well conditioned.
  const glm::dvec3 origin(mesh.positions[mesh.indices[0]]);
  double sixVolume = 0.0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec3 a = glm::dvec3(mesh.positions[mesh.indices[t]]) - origin;
    const glm::dvec3 b = glm::dvec3(mesh.positions[mesh.indices[t + 1]]) - origin;
    const glm::dvec3 c = glm::dvec3(mesh.positions[mesh.indices[t + 2]]) - origin;
    sixVolume += glm::dot(a, glm::cross(b, c));
  }
  mesh.insideOut = sixVolume < 0.0;
}

}  // namespace cpvs
