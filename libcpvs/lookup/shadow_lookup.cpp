#include "libcpvs/lookup/shadow_lookup.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "libcpvs/error.h"

namespace cpvs {
namespace {

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The kernel's footprint, inclusive texel bounds already clipped to [0, N).
struct Footprint {
  uint32_t x0, x1, y0, y1;
};

inline uint32_t overlap(uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1) {  // inclusive ranges
  const uint32_t lo = std::max(a0, b0), hi = std::min(a1, b1);
  return hi >= lo ? hi - lo + 1 : 0;
}

// Mask of the 8x8 tile at (ox, oy) covered by the footprint (bit (y & 7) * 8 + (x & 7)).
inline uint64_t tileMask(const Footprint& f, uint32_t ox, uint32_t oy) {
  const uint32_t xa = std::max(f.x0, ox) - ox, xb = std::min(f.x1, ox + 7) - ox;
  const uint32_t ya = std::max(f.y0, oy) - oy, yb = std::min(f.y1, oy + 7) - oy;
  const uint64_t row = ((uint64_t(2) << xb) - 1) & ~((uint64_t(1) << xa) - 1);
  // One bit per selected row: bits 8*ya .. 8*yb.
  const uint32_t rows = yb - ya + 1;
  const uint64_t column = (rows == 8 ? 0x0101010101010101ull : (0x0101010101010101ull & ((uint64_t(1) << (8 * rows)) - 1)))
                          << (8 * ya);
  return row * column;
}

// Shadowed texels of the footprint inside a Ref node of edge `size` at (ox, oy), slice z.
uint32_t countNode(const DagView& dag, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy, uint32_t z,
                   const Footprint& f) {
  const uint32_t header = dag.nodes[offset];
  if (size == 8) {  // leaf parent: z-only split into 8x8x1 leaves
    const unsigned c = z & 7u;
    const uint32_t code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Lit)) return 0;
    if (code == uint32_t(ChildCode::Shadowed))
      return overlap(ox, ox + 7, f.x0, f.x1) * overlap(oy, oy + 7, f.y0, f.y1);
    const uint64_t mask = dag.leaves[dag.nodes[offset + 1 + refSlot(header, c)]];
    return uint32_t(std::popcount(mask & tileMask(f, ox, oy)));
  }
  const uint32_t half = size >> 1;
  const unsigned zbit = (z & half) ? 4u : 0u;
  uint32_t count = 0;
  for (unsigned yb = 0; yb < 2; ++yb) {
    const uint32_t cy = oy + yb * half;
    const uint32_t oyCount = overlap(cy, cy + half - 1, f.y0, f.y1);
    if (!oyCount) continue;
    for (unsigned xb = 0; xb < 2; ++xb) {
      const uint32_t cx = ox + xb * half;
      const uint32_t oxCount = overlap(cx, cx + half - 1, f.x0, f.x1);
      if (!oxCount) continue;
      const unsigned c = zbit | (yb << 1) | xb;
      const uint32_t code = childCodeOf(header, c);
      if (code == uint32_t(ChildCode::Lit)) continue;
      if (code == uint32_t(ChildCode::Shadowed)) {
        count += oxCount * oyCount;
      } else {
        count += countNode(dag, dag.nodes[offset + 1 + refSlot(header, c)], half, cx, cy, z, f);
      }
    }
  }
  return count;
}

}  // namespace

void checkPcfKernel(int pcfKernel) {
  if (pcfKernel < 1 || pcfKernel > 255 || pcfKernel % 2 == 0)
    throw Error(ExitCode::Usage, "PCF kernel " + std::to_string(pcfKernel) + ": expected an odd size from 1 to 255");
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

glm::dvec3 gridNormal(const LightView& view, const glm::dvec3& world, const glm::dvec3& normal) {
  if (normal == glm::dvec3(0.0)) return glm::dvec3(0.0);
  return glm::inverse(glm::transpose(gridJacobian(view, world))) * normal;
}

double biasDistance(const glm::dvec3& m, int pcfKernel) {
  return 0.5 * double(pcfKernel) * (std::abs(m.x) + std::abs(m.y)) + 1.0;
}

LookupCell lookupCell(const LightView& view, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options) {
  LookupCell cell;
  if (!finite(point) || !finite(normal)) {
    cell.kind = LookupCell::Kind::Invalid;
    return cell;
  }
  if (view.empty) return cell;
  const GridPoint g = toGrid(view, point);
  if (!g.inFront) return cell;
  glm::dvec3 q = g.uvs;
  const glm::dvec3 m = gridNormal(view, point, normal);
  const double length = glm::length(m);
  if (length > 0 && std::isfinite(length)) {
    glm::dvec3 unit = m / length;
    if (options.orientation == NormalOrientation::TowardLight && unit.z > 0) unit = -unit;
    q += biasDistance(unit, options.pcfKernel) * unit;
  }
  cell.uvs = q;
  const double n = view.resolution;
  if (!(q.x >= 0 && q.x < n && q.y >= 0 && q.y < n)) return cell;  // also catches NaN
  const Voxel voxel = toVoxel(view, q);
  cell.kind = LookupCell::Kind::Voxel;
  cell.x = voxel.x;
  cell.y = voxel.y;
  cell.z = voxel.z;
  return cell;
}

uint32_t shadowedTexels(const DagView& dag, int32_t x, int32_t y, uint32_t z, int pcfKernel) {
  const int32_t n = int32_t(dag.resolution);
  const int32_t h = pcfKernel / 2;
  if (pcfKernel <= 1) {
    if (x < 0 || y < 0 || x >= n || y >= n) return 0;
    return dag.shadowed(uint32_t(x), uint32_t(y), z) ? 1 : 0;
  }
  const int64_t x0 = std::max<int64_t>(0, int64_t(x) - h), x1 = std::min<int64_t>(n - 1, int64_t(x) + h);
  const int64_t y0 = std::max<int64_t>(0, int64_t(y) - h), y1 = std::min<int64_t>(n - 1, int64_t(y) + h);
  if (x0 > x1 || y0 > y1) return 0;
  const Footprint f{uint32_t(x0), uint32_t(x1), uint32_t(y0), uint32_t(y1)};
  if (dag.rootCode == ChildCode::Lit) return 0;
  if (dag.rootCode == ChildCode::Shadowed) return (f.x1 - f.x0 + 1) * (f.y1 - f.y0 + 1);
  return countNode(dag, 0, dag.resolution, 0, 0, z, f);
}

bool withinInfluence(const Light& light, const glm::dvec3& point) {
  if (light.type == LightType::Directional) return true;
  const glm::dvec3 toPoint = point - light.position;
  const double distance = glm::length(toPoint);
  if (!(distance <= light.range)) return false;
  if (light.type == LightType::Spot) {
    if (distance == 0) return false;
    const double cosAngle = glm::dot(toPoint, light.direction) / distance;
    if (cosAngle < std::cos(std::min(light.outerConeAngle, 3.14159265358979323846 / 2))) return false;
  }
  return true;
}

namespace {

float cellVisibility(const LightView& view, const DagView& dag, const glm::dvec3& point, const glm::dvec3& normal,
                     const LookupOptions& options) {
  const LookupCell cell = lookupCell(view, point, normal, options);
  if (cell.kind == LookupCell::Kind::Invalid) return 0.0f;
  if (cell.kind == LookupCell::Kind::Lit) return 1.0f;
  const int k = options.pcfKernel;
  const uint32_t shadowed = shadowedTexels(dag, cell.x, cell.y, uint32_t(cell.z), k);
  if (k <= 1) return shadowed ? 0.0f : 1.0f;
  return float(1.0 - double(shadowed) / (double(k) * double(k)));
}

}  // namespace

float visibility(const LightView& view, const DagView& dag, const Light& light, const glm::dvec3& point,
                 const glm::dvec3& normal, int pcfKernel, NormalOrientation orientation) {
  if (!finite(point) || !finite(normal)) return 0.0f;
  if (!withinInfluence(light, point)) return 0.0f;
  return cellVisibility(view, dag, point, normal, {pcfKernel, orientation});
}

LightShadow::LightShadow(const Light& light, std::vector<LightView> views, std::vector<DagView> dags)
    : light_(light), views_(std::move(views)), dags_(std::move(dags)) {
  if (views_.size() != dags_.size()) throw Error(ExitCode::InputInvalid, "light '" + light.name + "': views and DAGs differ in number");
}

int LightShadow::viewIndex(const glm::dvec3& point) const {
  const auto index = selectView(light_, views_, point);
  return index ? int(*index) : -1;
}

float LightShadow::visibility(const glm::dvec3& point, const glm::dvec3& normal, const LookupOptions& options) const {
  if (!finite(point) || !finite(normal)) return 0.0f;
  const int index = viewIndex(point);
  if (index < 0) return 0.0f;
  return cellVisibility(views_[size_t(index)], dags_[size_t(index)], point, normal, options);
}

}  // namespace cpvs
