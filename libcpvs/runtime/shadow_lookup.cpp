#include "libcpvs/runtime/shadow_lookup.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "libcpvs/runtime/dag_footprint.h"

namespace cpvs {

using lookup_detail::finite;

Outcome checkPcfKernel(int pcfKernel) {
  if (pcfKernel < 1 || pcfKernel > 255 || pcfKernel % 2 == 0)
    return {ErrorCategory::InvalidArgument, "PCF kernel " + std::to_string(pcfKernel) + ": expected an odd size from 1 to 255"};
  return {};
}

glm::dmat3 gridJacobian(const LightView& view, const glm::dvec3& world) {
  const glm::dmat3 rotation(view.viewFromWorld);  // rigid: upper-left 3x3
  const glm::dvec3 v = glm::dvec3(view.viewFromWorld * glm::dvec4(world, 1.0));
  const double n = view.resolution;
  const double su = n / (view.xMax - view.xMin), sv = n / (view.yMax - view.yMin);
  const double d = -v.z;
  // Rows of d(a, b, d)/d(view) scaled to grid units; glm matrices are column-major, so build the transpose.
  glm::dvec3 rowU, rowV, rowS;
  if (view.projection == Projection::Orthographic) {
    rowU = {su, 0, 0};
    rowV = {0, sv, 0};
  } else {
    rowU = {su / d, 0, su * v.x / (d * d)};
    rowV = {0, sv / d, sv * v.y / (d * d)};
  }
  const double ds = view.mapping == DepthMapping::Linear ? n / (view.far - view.near)
                                                         : n / (d * std::log(view.far / view.near));
  rowS = {0, 0, -ds};
  const glm::dmat3 gridFromViewT(rowU, rowV, rowS);  // columns = rows of the Jacobian
  return glm::transpose(gridFromViewT) * rotation;
}

// J^-T n in closed form, up to a positive factor. J = G R with R the view's rotation (orthonormal, so
// R^-T = R) and G = d(u, v, s) / d(view) (gridJacobian), hence J^-T n = G^-T (R n): solve G^T m = R n, G
// being upper triangular up to the sign of its last row. Orthographic: G = diag(1/su, 1/sv, -1/ds);
// perspective: rows (1/(su d), 0, x/(su d^2)), (0, 1/(sv d), y/(sv d^2)), (0, 0, -1/ds), with (x, y) the
// view-space point and d its depth. cell_lanes.h's cellLanes computes the same per lane for the bias.
glm::dvec3 gridNormal(const LightView& view, const glm::dvec3& world, const glm::dvec3& normal) {
  if (normal == glm::dvec3(0.0)) return glm::dvec3(0.0);
  const ViewMapping mapping(view);
  const GridLanes<double, bool> g = mapToGrid<double, bool>(mapping, world.x, world.y, world.z);
  glm::dvec3 m;
  gridNormalLanes(mapping, g, normal.x, normal.y, normal.z, m.x, m.y, m.z);
  return m;
}

double biasDistance(const glm::dvec3& m, int pcfKernel, double margin) {
  return 0.5 * double(pcfKernel) * (std::abs(m.x) + std::abs(m.y)) + margin;
}

LookupCell lookupCell(const LightView& view, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options) {
  return lookupCell(ViewMapping(view), point, normal, options);
}

CellSettings cellSettings(const LookupOptions& options) {
  CellSettings settings;
  settings.kernelHalf = 0.5 * double(options.pcfKernel);
  settings.margin = options.biasMargin;
  settings.backFacingIsShadow = options.orientation == NormalOrientation::AsGiven;
  return settings;
}

LookupCell lookupCell(const ViewMapping& mapping, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options) {
  LookupCell cell;
  if (!finite(point) || !finite(normal)) {
    cell.kind = LookupCell::Kind::Invalid;
    return cell;
  }
  if (mapping.empty) return cell;
  const CellSettings settings = cellSettings(options);
  const CellLanes<double, bool> lanes =
      cellLanes<double, bool>(mapping, settings, point.x, point.y, point.z, normal.x, normal.y, normal.z);
  if (!lanes.grid.inFront) return cell;
  if (lanes.back && settings.backFacingIsShadow) {
    cell.kind = LookupCell::Kind::BackFacing;
    cell.uvs = {lanes.grid.u, lanes.grid.v, lanes.grid.s};
    return cell;
  }
  cell.uvs = {lanes.qu, lanes.qv, lanes.qs};
  if (!lanes.inside) return cell;
  cell.kind = LookupCell::Kind::Voxel;
  cell.x = int32_t(lanes.qu);
  cell.y = int32_t(lanes.qv);
  cell.z = int32_t(clampedSlice(lanes.qs, mapping.resolution - 1.0));
  return cell;
}

namespace {

float cellVisibility(const ViewMapping& mapping, const DagView& dag, const TopGrid& grid, const glm::dvec3& point,
                     const glm::dvec3& normal, const LookupOptions& options) {
  const LookupCell cell = lookupCell(mapping, point, normal, options);
  if (cell.kind == LookupCell::Kind::Invalid || cell.kind == LookupCell::Kind::BackFacing) return 0.0f;
  if (cell.kind == LookupCell::Kind::Lit) return 1.0f;
  const int k = options.pcfKernel;
  const uint32_t shadowed = shadowedTexels(dag, grid, cell.x, cell.y, uint32_t(cell.z), k);
  if (k <= 1) return shadowed ? 0.0f : 1.0f;
  return float(1.0 - double(shadowed) / (double(k) * double(k)));
}

}  // namespace

float visibility(const LightView& view, const DagView& dag, const Light& light, const glm::dvec3& point,
                 const glm::dvec3& normal, int pcfKernel, NormalOrientation orientation) {
  if (!finite(point) || !finite(normal)) return 0.0f;
  if (!withinInfluence(light, point)) return 0.0f;
  static const TopGrid none;
  return cellVisibility(ViewMapping(view), dag, none, point, normal, {pcfKernel, orientation});
}

Result<LightShadow> LightShadow::create(const Light& light, std::vector<LightView> views, std::vector<DagView> dags,
                                        int topGridLevels) {
  if (views.size() != dags.size())
    return Outcome(ErrorCategory::InvalidInput, "light '" + light.name + "': " + std::to_string(views.size()) +
                                                    " views but " + std::to_string(dags.size()) + " DAGs");
  if (topGridLevels < kAutomaticTopGrid)
    return Outcome(ErrorCategory::InvalidArgument, "top grid of " + std::to_string(topGridLevels) + " levels");
  return LightShadow(light, std::move(views), std::move(dags), topGridLevels);
}

LightShadow::LightShadow(const Light& light, std::vector<LightView> views, std::vector<DagView> dags,
                         int topGridLevels)
    : light_(light), views_(std::move(views)), dags_(std::move(dags)) {
  for (const DagView& dag : dags_)
    grids_.push_back(TopGrid::build(dag, topGridLevels < 0 ? TopGrid::automaticLevel(dag) : uint32_t(topGridLevels)));
  for (const LightView& view : views_) mappings_.emplace_back(view);
  if (hasCone(light_)) spot_ = spotInfluence(light_);
}

size_t LightShadow::topGridBytes() const {
  size_t bytes = 0;
  for (const TopGrid& g : grids_) bytes += g.cells.size() * sizeof(uint32_t);
  return bytes;
}

int LightShadow::viewIndex(const glm::dvec3& point) const {
  if (views_.empty()) return -1;
  if (!hasRange(light_)) return 0;  // one view, everywhere
  if (hasCone(light_))  // withinInfluence's rule with the cone's cosine computed once, as the batch has it
    return insideSpot<double, bool>(spot_, point.x, point.y, point.z) ? 0 : -1;
  const auto index = selectView(light_, views_, point);
  return index ? int(*index) : -1;
}

float LightShadow::visibility(const glm::dvec3& point, const glm::dvec3& normal, const LookupOptions& options) const {
  if (!finite(point) || !finite(normal)) return 0.0f;
  const int index = viewIndex(point);
  if (index < 0) return 0.0f;
  const size_t i = size_t(index);
  return cellVisibility(mappings_[i], dags_[i], grids_[i], point, normal, options);
}

}  // namespace cpvs
