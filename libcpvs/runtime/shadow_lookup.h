#pragma once
// Runtime shadow lookups in a baked CPVS (docs/query.md): point -> view -> biased integer voxel -> one DAG
// traversal, unfiltered or K x K PCF. Part of cpvs_runtime: depends only on glm and the light-view mapping,
// no GL, Embree or glTF.
//
// Visibility convention: 1 = lit, 0 = shadowed, PCF gives the lit fraction of the K x K texels.
//
// The lookup of a world point p with normal n (n may be zero: no bias) in one view, step by step:
//  1. g = toGrid(view, p): continuous (u, v, s), the same mapping the baker uses (light_view.h).
//  2. Bias (Kämpe et al. 2015, §4 "Perspective Lights", done in grid space, never with a world-space epsilon):
//       m = J^-T n, with J = d(u, v, s)/d(world) at p (gridJacobian): the surface normal expressed in voxel
//       units (the inverse transpose keeps it perpendicular to the surface however anisotropic the voxels
//       are or however strongly the perspective and log-depth mapping distort them); m^ = m / |m|.
//     Back faces: m^.s > 0 means the surface faces away from the light (n . toLight < 0). Such a point lies in
//       the shadow of its own surface: the answer is 0 without a lookup (a ray tracer says the same; biasing
//       it would push points near the silhouette sideways out of their own solid's shadow). With
//       NormalOrientation::TowardLight the normal is flipped instead (unoriented normals from scans,
//       two-sided open geometry such as foliage).
//     Otherwise q = g + b m^, with b = (K / 2) (|m^.u| + |m^.v|) + margin voxels.
//     The first term is half the filter width, scaled by how much the surface tilts across the footprint:
//     it puts every texel centre of the K x K footprint on the light's side of the surface's tangent plane
//     (a texel centre is at most K/2 texels from q along u and along v), so the enter slice the baker took
//     at that centre (floor of the surface's depth) is at or behind q's slice. The margin (default 0.25
//     voxel, LookupOptions::biasMargin) covers what the tangent plane does not: the rasteriser's float depth
//     and 1/256-texel snapping (about 0.01 voxel) and neighbouring facets near concave edges. So b is the
//     margin for a surface facing the light and at most margin + K/sqrt(2) for a grazing one.
//  3. Voxel: x = floor(q.u), y = floor(q.v), z = floor(q.s) clamped to [0, N-1] (toVoxel, the baker's rule).
//  4. K = 1: the voxel's bit. K > 1: the K x K texels (x - K/2 .. x + K/2, y - K/2 .. y + K/2) at slice z;
//     texels outside [0, N) count as lit. The DAG is walked once for the whole footprint: only nodes whose
//     footprint overlaps the kernel are visited, homogeneous nodes count their overlap area at once, and
//     leaf masks are AND-ed with the kernel's mask of that 8 x 8 tile and popcounted (a 9 x 9 kernel touches
//     at most 4 leaves). Any odd K >= 1 works; bigger K visit more leaves.
// Special cases: a view flagged `empty` (no caster) -> 1; q.u or q.v outside [0, N) -> 1 (no caster there);
// a point behind a perspective view's eye (d <= 0) -> 1; a non-finite point or normal -> 0 (invalid input,
// the caller is expected to count it); a point outside the light's influence (beyond range, outside a spot's
// cone) -> 0.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/shadow_dag.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/batch_cells.h"
#include "libcpvs/runtime/outcome.h"
#include "libcpvs/runtime/light.h"

namespace cpvs {

// A query point: world position and surface normal (zero: no normal, no bias).
struct SurfacePoint {
  glm::dvec3 position{0.0};
  glm::dvec3 normal{0.0};
};

inline constexpr double kDefaultBiasMargin = 0.25;  // voxels (docs/query.md has the measurement)

struct LookupOptions {
  int pcfKernel = 1;  // K: odd, >= 1
  NormalOrientation orientation = NormalOrientation::AsGiven;
  double biasMargin = kDefaultBiasMargin;  // voxels added to the bias (step 2 above), >= 0
};

// Validates K (odd, 1..255).
Outcome checkPcfKernel(int pcfKernel);

// d(u, v, s)/d(world) at a world point (glm column-major: column j = derivative along world axis j).
// For a perspective view the point must be in front of the eye (d > 0).
glm::dmat3 gridJacobian(const LightView& view, const glm::dvec3& world);
// The surface normal n in grid space: J^-T n (not normalised; zero when n is zero).
glm::dvec3 gridNormal(const LightView& view, const glm::dvec3& world, const glm::dvec3& normal);
// Bias distance in voxels along the unit grid normal m^ for kernel K (see the rule above).
double biasDistance(const glm::dvec3& unitGridNormal, int pcfKernel, double margin = kDefaultBiasMargin);

// Where a lookup lands in a view.
struct LookupCell {
  enum class Kind : uint8_t {
    Voxel,      // x, y, z valid: look up the DAG
    Lit,        // empty view, outside the lateral grid, or behind a perspective eye
    BackFacing, // the normal faces away from the light (AsGiven): in the shadow of its own surface, 0
    Invalid,    // non-finite point or normal
  };
  Kind kind = Kind::Lit;
  int32_t x = 0, y = 0, z = 0;
  glm::dvec3 uvs{0.0};  // the biased continuous grid position q
};
// Steps 1-3 above (no influence check: the caller has selected the view).
LookupCell lookupCell(const LightView& view, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options);

// The same with the view's constants computed beforehand (LightShadow keeps one ViewMapping per view).
LookupCell lookupCell(const ViewMapping& mapping, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options);

// Number of shadowed texels of the K x K footprint centred on texel (x, y) at slice z (texels outside
// [0, N) are lit), with one traversal. z must be in [0, N). K = 1 gives DagView::shadowed.
uint32_t shadowedTexels(const DagView& dag, int32_t x, int32_t y, uint32_t z, int pcfKernel);

// Visibility in one view (1 lit, 0 shadowed, PCF fraction in between). Checks the light's influence (range,
// cone) but not which view the point belongs to.
float visibility(const LightView& view, const DagView& dag, const Light& light, const glm::dvec3& point,
                 const glm::dvec3& normal, int pcfKernel,
                 NormalOrientation orientation = NormalOrientation::AsGiven);

// What the bias rule (step 2 above) takes from the options, as cell_lanes.h's cellLanes reads it.
CellSettings cellSettings(const LookupOptions& options);

// A dense grid of the DAG's nodes at one level (Kämpe et al. 2015, §5.3 "top-level pointer grid"): entry
// (gx, gy, gz) holds the child code of the node at level `level` covering that cell and, for a reference, its
// word offset, so a traversal starts `level` levels down. 8^level entries of 4 bytes. Built from a DagView.
struct TopGrid {
  uint32_t level = 0;  // 0: no grid (start at the root)
  uint32_t shift = 0;  // log2 of a cell's edge in voxels: log2(N) - level
  std::vector<uint32_t> cells;  // (offset << 2) | code, index (gz << 2 level) | (gy << level) | gx

  bool empty() const { return level == 0; }
  // Builds the grid for `level` levels (clamped to the DAG's node levels); level 0 gives an empty grid.
  static TopGrid build(const DagView& dag, uint32_t level);
  // The level LightShadow picks by default: kMaxAutomaticTopGridLevels, lowered until the grid takes no more
  // bytes than the DAG itself (a small DAG gains little from skipping levels that stay in cache anyway).
  static uint32_t automaticLevel(const DagView& dag);
};

// Points per LightShadow::visibility batch call in cpvs-query, and in cpvs-sweep's timing so that its
// lookups/s are the query's.
inline constexpr size_t kLookupBatch = 4096;
// Most top-grid levels a LightShadow builds unless told otherwise (docs/query.md has the measurement behind
// it: 6 levels, 1 MiB per view, were the fastest at 4k and 16k once the walks were branch-free).
inline constexpr uint32_t kMaxAutomaticTopGridLevels = 6;
inline constexpr int kAutomaticTopGrid = -1;

// Whether voxel (x, y, z), all in [0, N), is shadowed: DagView::shadowed, starting from `grid` when it has one.
bool shadowedVoxel(const DagView& dag, const TopGrid& grid, uint32_t x, uint32_t y, uint32_t z);
// shadowedTexels with a top grid.
uint32_t shadowedTexels(const DagView& dag, const TopGrid& grid, int32_t x, int32_t y, uint32_t z, int pcfKernel);

// All views of one light with their DAGs: selects the view per point (cube face for point lights).
// Views and DAGs are referenced, not copied: the DAG storage (e.g. a CpvsFile) must outlive this object.
class LightShadow {
public:
  LightShadow() = default;
  // topGridLevels > 0 builds a top-level pointer grid of that many levels per view, 0 none, kAutomaticTopGrid
  // TopGrid::automaticLevel per view (see TopGrid; docs/query.md has the measurement behind the default).
  // Fails (InvalidInput) when views and DAGs differ in number.
  static Result<LightShadow> create(const Light& light, std::vector<LightView> views, std::vector<DagView> dags,
                                    int topGridLevels = kAutomaticTopGrid);

  // Visibility of a point (0 outside the light's influence; see the rules above).
  float visibility(const glm::dvec3& point, const glm::dvec3& normal, const LookupOptions& options) const;
  // The view a point falls in, or -1 outside the light's influence.
  int viewIndex(const glm::dvec3& point) const;
  // The same answers for many points at once (out[i] for points[i]; out.size() == points.size()): the points
  // are mapped to voxels eight or four at a time (batch_cells.h), then the DAG walks advance level by level in
  // groups without data-dependent branches, each node's cache line prefetched when its parent is read and
  // read one pass later, so cache misses overlap instead of adding up. PCF with K <= 9 walks the footprint's
  // (at most four) corner tiles the same way and counts their masks AND-ed with the kernel's; larger K go
  // level by level over every node the footprint overlaps (homogeneous children counted at once).
  // Fails (InvalidArgument, nothing written) when the spans differ in size or K is not valid (checkPcfKernel).
  Outcome visibility(std::span<const SurfacePoint> points, const LookupOptions& options, std::span<float> out) const;
  // The same for out.size() points read where the caller keeps them (PointArrays, batch_cells.h: e.g. separate
  // position and normal arrays, or one normal for all), with the same answers bit for bit.
  Outcome visibility(const PointArrays& points, const LookupOptions& options, std::span<float> out) const;

  const Light& light() const { return light_; }
  const std::vector<LightView>& views() const { return views_; }
  const std::vector<DagView>& dags() const { return dags_; }
  // Bytes of the top grids (0 without).
  size_t topGridBytes() const;

  struct PendingPoint;  // a point of a batch whose answer needs the DAG (batch_lookup.cpp)

private:
  LightShadow(const Light& light, std::vector<LightView> views, std::vector<DagView> dags, int topGridLevels);
  // K <= 9: the same, one walk per corner tile of each footprint.
  void countCornerTiles(uint32_t view, std::span<const PendingPoint> pending, std::vector<uint32_t>& counts) const;
  // K > 1: shadowed texels of each pending footprint of one view (counts[i] for pending[i]).
  void countFootprints(uint32_t view, std::span<const PendingPoint> pending, int pcfKernel,
                       std::vector<uint32_t>& counts) const;
  // K = 1: the walks of one view's mapped points (lane j: point indices[j], or j), answers into out.
  void walkVoxels(uint32_t view, const CellBatchOutput& cells, const uint32_t* indices, size_t count,
                  std::span<float> out) const;

  Light light_;
  std::vector<LightView> views_;
  std::vector<DagView> dags_;
  std::vector<TopGrid> grids_;
  std::vector<ViewMapping> mappings_;
  SpotInfluence spot_;  // spot lights: the cone and range, for the batch's AVX2 path
};

}  // namespace cpvs
