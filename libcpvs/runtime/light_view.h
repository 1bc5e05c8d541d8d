#pragma once
// Light views and the voxel convention (docs/architecture.md, "The voxel convention"): the one mapping from world space to integer voxel
// coordinates that the baker, the depth renderer and every lookup share.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/view_mapping.h"

namespace cpvs {

enum class Projection : uint8_t { Orthographic = 0, Perspective = 1 };
enum class DepthMapping : uint8_t { Linear = 0, Logarithmic = 1 };

// One view of a light: an N x N x N voxel grid over the light's space.
//  * view space: viewFromWorld is rigid; the light looks along -Z; depth d = -z_view.
//  * lateral: orthographic a = x_view, b = y_view; perspective a = x_view / d, b = y_view / d.
//    u = N (a - xMin) / (xMax - xMin), v = N (b - yMin) / (yMax - yMin).
//  * depth: linear s = N (d - near) / (far - near); logarithmic s = N log(d / near) / log(far / near)
//    (Kämpe et al. 2015, eq. 1).
//  * voxel (x, y, z) = clamp(floor(u, v, s), 0, N - 1). Texel centres are at u = x + 0.5.
struct LightView {
  Projection projection = Projection::Orthographic;
  DepthMapping mapping = DepthMapping::Linear;
  uint32_t resolution = 0;  // N, a power of two
  glm::dmat4 viewFromWorld{1.0};
  double xMin = -1, xMax = 1, yMin = -1, yMax = 1;
  double near = 1, far = 2;
  int face = -1;  // cube face of a point light: 0..5 = +X, -X, +Y, -Y, +Z, -Z; -1 otherwise
  bool empty = false;  // no geometry reaches this view: everything in it is lit
};

// Continuous grid coordinates of a point: u, v, s in [0, N) inside the grid.
struct GridPoint {
  glm::dvec3 uvs;
  double depth;      // view-space depth d (distance along the view axis)
  bool inFront;      // d > 0 (perspective: the point is in front of the light)
};

struct Voxel {
  int32_t x, y, z;
  bool operator==(const Voxel&) const = default;
};

GridPoint toGrid(const LightView& view, const glm::dvec3& world);
// The same with the view's constants computed beforehand (ViewMapping(view)): the same bits.
GridPoint toGrid(const ViewMapping& mapping, const glm::dvec3& world);
// floor + clamp to [0, N-1]; the only rounding rule (docs/architecture.md, "The voxel convention").
Voxel toVoxel(const LightView& view, const glm::dvec3& uvs);
inline Voxel worldToVoxel(const LightView& view, const glm::dvec3& world) {
  return toVoxel(view, toGrid(view, world).uvs);
}
// Slice (continuous, slice units) of a view-space depth, and the inverse.
double depthToSlice(const LightView& view, double depth);
double sliceToDepth(const LightView& view, double slice);
// World-space point at continuous grid coordinates (inverse of toGrid).
glm::dvec3 gridToWorld(const LightView& view, const glm::dvec3& uvs);
// The ray through a texel centre (u, v) as seen by the light: origin on the light side of the grid,
// unit direction. For orthographic views the origin lies on the plane d = near - (far - near).
struct Ray {
  glm::dvec3 origin;
  glm::dvec3 direction;
};
Ray texelRay(const LightView& view, double u, double v);
// Light position (perspective) or a point far behind the near plane (orthographic), world space.
glm::dvec3 viewEye(const LightView& view);

// Which view of a light a world point falls in (cube face by major axis for point lights), or nullopt when
// the point is outside the light's influence (beyond range, outside the cone, behind a spot light).
std::optional<size_t> selectView(const Light& light, const std::vector<LightView>& views, const glm::dvec3& world);

}  // namespace cpvs
