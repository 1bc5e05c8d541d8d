#pragma once
// Runtime shadow lookups in a baked CPVS (DESIGN.md §5): point -> view -> biased integer voxel -> one DAG
// traversal, unfiltered or K x K PCF. Part of cpvs_runtime: depends only on glm and the light-view mapping,
// no GL, Embree or glTF.
//
// Visibility convention: 1 = lit, 0 = shadowed, PCF gives the lit fraction of the K x K texels.
//
// The lookup of a world point p with normal n (n may be zero: no bias) in one view, step by step:
//  1. g = toGrid(view, p): continuous (u, v, s), the same mapping the baker uses (light_view.h).
//  2. Bias (seed 004 §4 "Perspective Lights", done in grid space, never with a world-space epsilon):
//       m = J^-T n, with J = d(u, v, s)/d(world) at p (gridJacobian): the surface normal expressed in voxel
//       units (the inverse transpose keeps it perpendicular to the surface however anisotropic the voxels
//       are or however strongly the perspective and log-depth mapping distort them); m^ = m / |m|.
//       q = g + b m^, with b = (K / 2) (|m^.u| + |m^.v|) + 1 voxels.
//     The first term is half the filter width, scaled by how much the surface tilts across the footprint:
//     it puts every texel centre of the K x K footprint on the normal's side of the surface's tangent plane
//     (a texel centre is at most K/2 texels from q along u and along v). The "+ 1" is a one-voxel margin
//     for the baker's rounding (depth at texel centres, floor to slices). So b is 1 voxel for a surface
//     facing the light, at most 1 + K/sqrt(2) for any surface; b >= 1 always.
//     Sign: the offset goes along n as given, so for a surface that faces the light (the usual case for
//     a lit point) it moves toward the light (toward smaller s). A surface that faces away from the light is
//     moved away from it, into the shadow its own solid casts, which matches the ray-traced reference. With
//     NormalOrientation::TowardLight, m^ is flipped when it points away from the light (m^.s > 0): for
//     unoriented normals (scans) or two-sided open geometry (foliage).
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
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/dag/shadow_dag.h"
#include "libcpvs/light_view.h"
#include "libcpvs/scene.h"

namespace cpvs {

enum class NormalOrientation : uint8_t {
  AsGiven = 0,      // offset along n as supplied (outward normals; the default)
  TowardLight = 1,  // flip n where it faces away from the light before biasing
};

struct LookupOptions {
  int pcfKernel = 1;  // K: odd, >= 1
  NormalOrientation orientation = NormalOrientation::AsGiven;
};

// Validates K (odd, 1..255). Throws Error(Usage).
void checkPcfKernel(int pcfKernel);

// d(u, v, s)/d(world) at a world point (glm column-major: column j = derivative along world axis j).
// For a perspective view the point must be in front of the eye (d > 0).
glm::dmat3 gridJacobian(const LightView& view, const glm::dvec3& world);
// The surface normal n in grid space: J^-T n (not normalised; zero when n is zero).
glm::dvec3 gridNormal(const LightView& view, const glm::dvec3& world, const glm::dvec3& normal);
// Bias distance in voxels along the unit grid normal m^ for kernel K (see the rule above).
double biasDistance(const glm::dvec3& unitGridNormal, int pcfKernel);

// Where a lookup lands in a view.
struct LookupCell {
  enum class Kind : uint8_t {
    Voxel,      // x, y, z valid: look up the DAG
    Lit,        // empty view, outside the lateral grid, or behind a perspective eye
    Invalid,    // non-finite point or normal
  };
  Kind kind = Kind::Lit;
  int32_t x = 0, y = 0, z = 0;
  glm::dvec3 uvs{0.0};  // the biased continuous grid position q
};
// Steps 1-3 above (no influence check: the caller has selected the view).
LookupCell lookupCell(const LightView& view, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options);

// Number of shadowed texels of the K x K footprint centred on texel (x, y) at slice z (texels outside
// [0, N) are lit), with one traversal. z must be in [0, N). K = 1 gives DagView::shadowed.
uint32_t shadowedTexels(const DagView& dag, int32_t x, int32_t y, uint32_t z, int pcfKernel);

// Visibility in one view (1 lit, 0 shadowed, PCF fraction in between). Checks the light's influence (range,
// cone) but not which view the point belongs to.
float visibility(const LightView& view, const DagView& dag, const Light& light, const glm::dvec3& point,
                 const glm::dvec3& normal, int pcfKernel,
                 NormalOrientation orientation = NormalOrientation::AsGiven);

// Whether a point lies in the light's influence (directional: always; spot/point: within range; spot: inside
// the outer cone). Same rule as selectView.
bool withinInfluence(const Light& light, const glm::dvec3& point);

// All views of one light with their DAGs: selects the view per point (cube face for point lights).
// Views and DAGs are referenced, not copied: the DAG storage (e.g. a CpvsFile) must outlive this object.
class LightShadow {
public:
  LightShadow() = default;
  LightShadow(const Light& light, std::vector<LightView> views, std::vector<DagView> dags);

  // Visibility of a point (0 outside the light's influence; see the rules above).
  float visibility(const glm::dvec3& point, const glm::dvec3& normal, const LookupOptions& options) const;
  // The view a point falls in, or -1 outside the light's influence.
  int viewIndex(const glm::dvec3& point) const;

  const Light& light() const { return light_; }
  const std::vector<LightView>& views() const { return views_; }
  const std::vector<DagView>& dags() const { return dags_; }

private:
  Light light_;
  std::vector<LightView> views_;
  std::vector<DagView> dags_;
};

}  // namespace cpvs
