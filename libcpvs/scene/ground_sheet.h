#pragma once
// Ground sheets (docs/depth-maps.md "Ground sheets"): an open mesh that is a height field over the whole
// scene is the top of solid ground, the way a closed mesh bounds a solid. flatten() closes such a sheet with
// a skirt and a bottom far behind it, so the exit depth maps see the ground as a solid and the voxels under
// it become free (Kämpe et al. 2015, §3.4), as in the paper's closed FractalLandscape. Answers above the ground do
// not change: a shadow ray from a point above the sheet can only reach the skirt through the sheet itself.
#include <cstddef>
#include <string>
#include <vector>

#include "libcpvs/scene/scene.h"

namespace cpvs {

// The triangles of one instance inside a WorldGeometry under construction: [begin, end).
struct InstanceTriangles {
  size_t instance = 0;
  size_t begin = 0, end = 0;
};

// Finds the ground sheets among the open instances of `ranges` (which cover every triangle of `world`, closed
// instances first) and closes the usable ones: their triangles move to the end of the closed range, followed
// by the closing triangles (WorldGeometry::isClosing). `world.bounds` stays the bounds of the scene's own
// triangles. Appends one GroundSheet per height field that spans the scene to world.groundSheets.
//
// A sheet is used when every condition holds (tolerances relative to the scene's diagonal D):
//  * its mesh is open (it has boundary edges) but manifold with consistent winding;
//  * every triangle faces one way along one coordinate axis (none faces back);
//  * every boundary edge lies on one side of the sheet's bounding rectangle in the other two axes, and the
//    triangles' projected areas add up to the rectangle's: it covers the rectangle exactly once, no holes;
//  * the rectangle contains the whole scene's (the ground reaches the edge of the world, so no geometry lies
//    beside its skirt);
//  * no vertex or triangle centre of any other instance lies more than 1e-3 D behind it (nothing is buried:
//    a basement or a cave under the ground would be inside the solid, where any answer is allowed).
void closeGroundSheets(const Scene& scene, const std::vector<InstanceTriangles>& ranges, WorldGeometry& world);

}  // namespace cpvs
