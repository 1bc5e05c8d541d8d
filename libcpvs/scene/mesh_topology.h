#pragma once
// Decides whether a mesh is closed (docs/architecture.md) from its geometry alone.
#include <cstdint>
#include <span>
#include <vector>

#include "libcpvs/scene/scene.h"

namespace cpvs {

// Maps every vertex to the id of the first vertex with a bit-identical position (-0 and 0 alike); for
// glm::vec3 (a mesh) and glm::dvec3 (world geometry).
template <class Vec>
std::vector<uint32_t> weldByPosition(std::span<const Vec> positions);

// Welds vertices with identical positions, then counts edges: boundary (one triangle), non-manifold (more
// than two), inconsistent (two triangles that traverse the edge the same way). The mesh is closed when all
// three counts are zero and it has at least one triangle. Degenerate triangles (two equal welded corners)
// are ignored. Sets mesh.closed, the counts, and mesh.insideOut (closed with negative signed volume).
void classifyMesh(Mesh& mesh);

}  // namespace cpvs
