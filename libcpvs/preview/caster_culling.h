#pragma once
// Which triangles a per-frame shadow map must draw (cpvs-view --shadows shadowmap, the culling demo,
// docs/culling-demo.md). Every method is conservative: the frame's shadow lookups give the same answers as
// with every triangle drawn (tests/culling_test.cpp checks it, and that frustum culling leaves every texel of
// every map unchanged).
//  * none: every triangle.
//  * frustum: the triangles whose projection can cover a texel of the map: not wholly behind the light, not
//    wholly beyond one lateral side of the view. (With the lights no tile lists left out, the "light and
//    camera frustum culling" the papers compare against.)
//  * voxel-grid (Selgrad et al. 2016, §3-§4): triangles binned into a 32^3 grid over the scene, those spanning
//    more than two cells per axis on a list that is never culled; the cells holding the frame's receivers of a
//    light (widened by what a lookup's PCF footprint and bias reach) are joined to the light by conservative
//    lines (the receiver cell swept toward the light); only casters in crossed cells are drawn, then frustum
//    culled per view.
//  * receiver-mask (Bittner et al. 2011, §4): the receivers are drawn into a coarse mask in the map's own
//    light space (one cell per 8 x 8 texels) holding the farthest receiver depth per cell, widened by what a
//    lookup reaches; a caster is drawn only where its light-space rectangle meets a cell with a receiver no
//    nearer than the caster's nearest point. Variants: fragments (every covered pixel a receiver: Bittner's
//    FRAG) and bounding-volumes (each 8 x 8 screen tile's box: BVOL, coarser and cheaper).
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

enum class CasterCulling : uint8_t { None, Frustum, VoxelGrid, ReceiverMask };
enum class ReceiverMaskVariant : uint8_t { Fragments, BoundingVolumes };
// "none" / "frustum" / "voxel-grid" / "receiver-mask" and "frag" / "bvol"; throw Error(InvalidArgument).
CasterCulling parseCasterCulling(const std::string& name);
const char* casterCullingName(CasterCulling culling);
ReceiverMaskVariant parseReceiverMaskVariant(const std::string& name);
const char* receiverMaskVariantName(ReceiverMaskVariant variant);

// What a light's lookups in this frame read: the receivers (world points of the covered pixels whose tile lists
// the light), the tile boxes they lie in (the bounding-volume variant), and how far a lookup reaches around
// its point in texels of the map (half the PCF footprint, the bias's lateral shift and a texel's rounding).
struct LightReceivers {
  std::vector<glm::vec3> points;
  std::vector<glm::vec3> boxes;  // pairs (min, max)
  double reachTexels = 0;
};

// The lateral reach of a K x K lookup with the given bias margin: K / 2 + the bias's largest lateral shift
// (K / sqrt(2) + margin, shadow_lookup.h) + 1.5 texels of rounding.
double lookupReachTexels(int pcfKernel, double biasMargin);

// Triangles of the scene, three corners each (world space, as the G-buffer and the maps draw them).
struct CasterTriangles {
  std::vector<glm::vec3> corners;
  size_t count() const { return corners.size() / 3; }
};

// Frustum culling of `candidates` (all triangles when null) against a map view.
std::vector<uint32_t> frustumCull(const CasterTriangles& triangles, const LightView& mapView,
                                  const std::vector<uint32_t>* candidates);

// Selgrad et al.'s grid, built once per scene.
class CasterGrid {
public:
  static constexpr uint32_t kCells = 32;
  CasterGrid(const CasterTriangles& triangles, const Bounds& bounds);
  // The triangles in the cells crossed between the receivers and the light, and the uncullable ones, in
  // order. Each receiver is widened by receivers.reachTexels texels of the map view (of `mapViews`) it falls in.
  std::vector<uint32_t> casters(const Light& light, const std::vector<LightView>& mapViews,
                                const LightReceivers& receivers) const;
  size_t uncullableTriangles() const { return uncullable_.size(); }

private:
  void markCellsOfBox(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<uint8_t>& cells) const;
  std::vector<uint32_t> castersOfCells(const std::vector<uint8_t>& cells) const;
  void sweepToLight(const Light& light, const glm::dvec3& lo, const glm::dvec3& hi, std::vector<uint8_t>& cells) const;

  Bounds bounds_;
  glm::dvec3 cellSize_{1.0};
  std::vector<uint32_t> cellStart_;  // kCells^3 + 1
  std::vector<uint32_t> cellTriangles_;
  std::vector<uint32_t> uncullable_;
  size_t triangleCount_ = 0;
};

// Bittner et al.'s receiver mask for one map view, then the casters meeting it (frustum culled on the way).
std::vector<uint32_t> receiverMaskCull(const CasterTriangles& triangles, const LightView& mapView,
                                       const LightReceivers& receivers, ReceiverMaskVariant variant);

}  // namespace cpvs
