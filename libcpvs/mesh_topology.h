#pragma once
// Decides whether a mesh is closed (DESIGN.md §4.1) from its geometry alone.
#include "libcpvs/scene.h"

namespace cpvs {

// Welds vertices with identical positions, then counts edges: boundary (one triangle), non-manifold (more
// than two), inconsistent (two triangles that traverse the edge the same way). The mesh is closed when all
// three counts are zero and it has at least one triangle. Degenerate triangles (two equal welded corners)
// are ignored. Sets mesh.closed, the counts, and mesh.insideOut (closed with negative signed volume).
void classifyMesh(Mesh& mesh);

}  // namespace cpvs
