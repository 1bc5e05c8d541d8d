#include "libcpvs/lookup/shadow_lookup.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "libcpvs/error.h"
#include "libcpvs/lookup/batch_cells.h"

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

// Shadowed texels of the footprint inside a node of edge `size` at (ox, oy) with child code `code`
// (for a reference: the node at word `offset`), slice z.
uint32_t countCode(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy,
                   uint32_t z, const Footprint& f);

uint32_t countNode(const DagView& dag, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy, uint32_t z,
                   const Footprint& f) {
  const uint32_t header = dag.nodes[offset];
  if (size == 8) {  // leaf parent: z-only split into 8x8x1 leaves
    const unsigned c = z & 7u;
    const uint32_t code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Lit)) return 0;
    if (code == uint32_t(ChildCode::Shadowed))
      return overlap(ox, ox + 7, f.x0, f.x1) * overlap(oy, oy + 7, f.y0, f.y1);
    const uint64_t mask = dag.leaves[dag.child(offset, header, c, 8)];
    return popcount64(mask & tileMask(f, ox, oy));
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
        count += countNode(dag, dag.child(offset, header, c, size), half, cx, cy, z, f);
      }
    }
  }
  return count;
}

uint32_t countCode(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t ox, uint32_t oy,
                   uint32_t z, const Footprint& f) {
  if (code == uint32_t(ChildCode::Lit)) return 0;
  if (code == uint32_t(ChildCode::Shadowed))
    return overlap(ox, ox + size - 1, f.x0, f.x1) * overlap(oy, oy + size - 1, f.y0, f.y1);
  return countNode(dag, offset, size, ox, oy, z, f);
}

// Walks from a node of edge `size` with child code `code` (offset: its words) down to voxel (x, y, z).
inline bool walk(const DagView& dag, uint32_t code, uint32_t offset, uint32_t size, uint32_t x, uint32_t y,
                 uint32_t z) {
  const uint16_t* nodes = dag.nodes.data();
  for (uint32_t half = size >> 1; half >= 8; half >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = dag.child(offset, header, c, half * 2);
  }
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const unsigned c = z & 7u;
  const uint32_t header = nodes[offset];
  code = childCodeOf(header, c);
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const uint64_t mask = dag.leaves[dag.child(offset, header, c, 8)];
  return (mask >> ((y & 7u) * 8u + (x & 7u))) & 1u;
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

// J^-T n in closed form, up to a positive factor. J = G R with R the view's rotation (orthonormal, so
// R^-T = R) and G = d(u, v, s) / d(view) (gridJacobian), hence J^-T n = G^-T (R n): solve G^T m = R n, G
// being upper triangular up to the sign of its last row. Orthographic: G = diag(1/su, 1/sv, -1/ds);
// perspective: rows (1/(su d), 0, x/(su d^2)), (0, 1/(sv d), y/(sv d^2)), (0, 0, -1/ds), with (x, y) the
// view-space point and d its depth. cell_lanes.h's cellLanes computes the same per lane for the bias.
glm::dvec3 gridNormal(const LightView& view, const glm::dvec3& world, const glm::dvec3& normal) {
  if (normal == glm::dvec3(0.0)) return glm::dvec3(0.0);
  const ViewMapping c(view);
  const glm::dvec3 v = glm::dvec3(view.viewFromWorld * glm::dvec4(world, 1.0));
  const double d = -v.z;
  const glm::dvec3 nv = glm::dmat3(view.viewFromWorld) * normal;
  const double invDs = c.linear ? c.invDs : c.invDs * d;  // 1 / (ds/dd)
  if (c.orthographic) return {nv.x * c.uStep, nv.y * c.vStep, -nv.z * invDs};
  return {nv.x * d * c.uStep, nv.y * d * c.vStep, (nv.x * (v.x / d) + nv.y * (v.y / d) - nv.z) * invDs};
}

double biasDistance(const glm::dvec3& m, int pcfKernel, double margin) {
  return 0.5 * double(pcfKernel) * (std::abs(m.x) + std::abs(m.y)) + margin;
}

LookupCell lookupCell(const LightView& view, const glm::dvec3& point, const glm::dvec3& normal,
                      const LookupOptions& options) {
  return lookupCell(ViewMapping(view), point, normal, options);
}

namespace {

CellSettings cellSettings(const LookupOptions& options) {
  CellSettings settings;
  settings.kernelHalf = 0.5 * double(options.pcfKernel);
  settings.margin = options.biasMargin;
  settings.backFacingIsShadow = options.orientation == NormalOrientation::AsGiven;
  return settings;
}

}  // namespace

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

uint32_t shadowedTexels(const DagView& dag, const TopGrid& grid, int32_t x, int32_t y, uint32_t z, int pcfKernel) {
  const int32_t n = int32_t(dag.resolution);
  const int32_t h = pcfKernel / 2;
  if (pcfKernel <= 1) {
    if (x < 0 || y < 0 || x >= n || y >= n) return 0;
    return shadowedVoxel(dag, grid, uint32_t(x), uint32_t(y), z) ? 1 : 0;
  }
  const int64_t x0 = std::max<int64_t>(0, int64_t(x) - h), x1 = std::min<int64_t>(n - 1, int64_t(x) + h);
  const int64_t y0 = std::max<int64_t>(0, int64_t(y) - h), y1 = std::min<int64_t>(n - 1, int64_t(y) + h);
  if (x0 > x1 || y0 > y1) return 0;
  const Footprint f{uint32_t(x0), uint32_t(x1), uint32_t(y0), uint32_t(y1)};
  if (dag.rootCode == ChildCode::Lit) return 0;
  if (dag.rootCode == ChildCode::Shadowed) return (f.x1 - f.x0 + 1) * (f.y1 - f.y0 + 1);
  if (grid.empty()) return countNode(dag, 0, dag.resolution, 0, 0, z, f);
  // Start in the grid cells the footprint overlaps (at most 4 for a kernel no wider than a cell).
  const uint32_t size = 1u << grid.shift, level = grid.level;
  const uint32_t gz = z >> grid.shift;
  uint32_t count = 0;
  for (uint32_t gy = f.y0 >> grid.shift; gy <= (f.y1 >> grid.shift); ++gy)
    for (uint32_t gx = f.x0 >> grid.shift; gx <= (f.x1 >> grid.shift); ++gx) {
      const uint32_t cell = grid.cells[(size_t(gz) << (2 * level)) | (size_t(gy) << level) | gx];
      count += countCode(dag, cell & 3u, cell >> 2, size, gx << grid.shift, gy << grid.shift, z, f);
    }
  return count;
}

uint32_t shadowedTexels(const DagView& dag, int32_t x, int32_t y, uint32_t z, int pcfKernel) {
  static const TopGrid none;
  return shadowedTexels(dag, none, x, y, z, pcfKernel);
}

CPVS_POPCNT_CLONES bool shadowedVoxel(const DagView& dag, const TopGrid& grid, uint32_t x, uint32_t y, uint32_t z) {
  if (grid.empty()) return walk(dag, uint32_t(dag.rootCode), 0, dag.resolution, x, y, z);
  const uint32_t s = grid.shift, level = grid.level;
  const uint32_t cell =
      grid.cells[(size_t(z >> s) << (2 * level)) | (size_t(y >> s) << level) | size_t(x >> s)];
  return walk(dag, cell & 3u, cell >> 2, 1u << s, x, y, z);
}

TopGrid TopGrid::build(const DagView& dag, uint32_t level) {
  TopGrid grid;
  // Entries pack a unit offset above a 2-bit code: no grid for a DAG of 2^30 units (2 GiB) or more.
  if (dag.resolution < 16 || dag.nodes.size() >= (size_t(1) << 30)) return grid;
  const uint32_t log2n = uint32_t(std::countr_zero(dag.resolution));
  level = std::min(level, log2n - 3);  // cells of at least 8 voxels: a leaf-parent node
  if (level == 0) return grid;
  grid.level = level;
  grid.shift = log2n - level;
  const uint32_t side = 1u << level;
  grid.cells.assign(size_t(side) * side * side, uint32_t(dag.rootCode));
  if (dag.rootCode != ChildCode::Ref) return grid;
  // Fill level by level: the entries of level l + 1 from the nodes of level l.
  std::vector<uint32_t> current{uint32_t(ChildCode::Ref)}, next;
  for (uint32_t l = 0; l < level; ++l) {
    const uint32_t width = 1u << l, nextWidth = width << 1;
    next.assign(size_t(nextWidth) * nextWidth * nextWidth, 0);
    for (uint32_t cz = 0; cz < width; ++cz)
      for (uint32_t cy = 0; cy < width; ++cy)
        for (uint32_t cx = 0; cx < width; ++cx) {
          const uint32_t entry = current[(size_t(cz) * width + cy) * width + cx];
          const uint32_t code = entry & 3u, offset = entry >> 2;
          const uint32_t header = code == uint32_t(ChildCode::Ref) ? dag.nodes[offset] : 0;
          for (unsigned c = 0; c < 8; ++c) {
            const uint32_t x = 2 * cx + (c & 1u), y = 2 * cy + ((c >> 1) & 1u), z = 2 * cz + ((c >> 2) & 1u);
            uint32_t child = code;  // homogeneous: every child has the parent's code
            if (code == uint32_t(ChildCode::Ref)) {
              child = childCodeOf(header, c);
              if (child == uint32_t(ChildCode::Ref)) child |= dag.child(offset, header, c, dag.resolution >> l) << 2;
            }
            next[(size_t(z) * nextWidth + y) * nextWidth + x] = child;
          }
        }
    current.swap(next);
  }
  // Root offset 0 is encoded as (0 << 2) | Ref; offsets fit in 30 bits (checked above).
  grid.cells = std::move(current);
  return grid;
}

uint32_t TopGrid::automaticLevel(const DagView& dag) {
  const uint64_t dagBytes = uint64_t(dag.nodes.size()) * 2 + uint64_t(dag.leaves.size()) * 8;
  uint32_t level = kMaxAutomaticTopGridLevels;
  while (level > 0 && (uint64_t(4) << (3 * level)) * 8 > dagBytes) --level;
  return level;
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

LightShadow::LightShadow(const Light& light, std::vector<LightView> views, std::vector<DagView> dags,
                         int topGridLevels)
    : light_(light), views_(std::move(views)), dags_(std::move(dags)) {
  if (views_.size() != dags_.size()) throw Error(ExitCode::InputInvalid, "light '" + light.name + "': views and DAGs differ in number");
  for (const DagView& dag : dags_)
    grids_.push_back(TopGrid::build(dag, topGridLevels < 0 ? TopGrid::automaticLevel(dag) : uint32_t(topGridLevels)));
  for (const LightView& view : views_) mappings_.emplace_back(view);
  if (light_.type == LightType::Spot) {
    for (int i = 0; i < 3; ++i) {
      spot_.position[i] = light_.position[i];
      spot_.direction[i] = light_.direction[i];
    }
    spot_.range = light_.range;
    spot_.cosOuter = std::cos(std::min(light_.outerConeAngle, 3.14159265358979323846 / 2));
  }
}

size_t LightShadow::topGridBytes() const {
  size_t bytes = 0;
  for (const TopGrid& g : grids_) bytes += g.cells.size() * sizeof(uint32_t);
  return bytes;
}

int LightShadow::viewIndex(const glm::dvec3& point) const {
  if (views_.empty()) return -1;
  switch (light_.type) {
    case LightType::Directional: return 0;
    case LightType::Spot:  // selectView's rule with the cone's cosine computed once, as the batch has it
      return insideSpot<double, bool>(spot_, point.x, point.y, point.z) ? 0 : -1;
    case LightType::Point: break;
  }
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

// ---- batches: interleaved walks ----------------------------------------------------------------------

// A point of the batch whose answer needs the DAG.
struct LightShadow::PendingPoint {
  Footprint f;    // clipped K x K footprint (inclusive texel bounds); K = 1: (x0, y0) is the texel
  uint32_t z;
  uint32_t view;
  uint32_t out;   // index into the batch
};

namespace {

// Reused buffers of a batch (per thread: one LightShadow serves many threads).
struct BatchScratch {
  std::vector<int32_t> x, y, z;
  std::vector<uint8_t> state;
  std::vector<uint32_t> indices, face;
  std::vector<LightShadow::PendingPoint> pending;
  void resize(size_t count) {
    if (x.size() >= count) return;
    x.resize(count);
    y.resize(count);
    z.resize(count);
    state.resize(count);
    indices.resize(count);
    face.resize(count);
    pending.resize(count);
  }
};
constexpr uint32_t kNoView = ~0u;

// One step of a walk: a node to read (size >= 8: the node at unit `offset`) or a leaf mask (size == 0: leaves[offset]).
struct Task {
  uint32_t point;  // index into the pending points
  uint32_t offset;
  uint32_t ox, oy;  // origin of the node's (or leaf's) texels
  uint32_t size;
};

// A FIFO of tasks that grows when full (a wide PCF footprint can spawn many).
class TaskQueue {
public:
  TaskQueue() : tasks_(256) {}
  bool empty() const { return head_ == tail_; }
  size_t size() const { return tail_ - head_; }
  void push(const Task& t) {
    if (size() == tasks_.size()) grow();
    tasks_[tail_++ & (tasks_.size() - 1)] = t;
  }
  Task pop() { return tasks_[head_++ & (tasks_.size() - 1)]; }

private:
  void grow() {
    std::vector<Task> bigger(tasks_.size() * 2);
    for (size_t i = 0; i < size(); ++i) bigger[i] = tasks_[(head_ + i) & (tasks_.size() - 1)];
    tail_ = size();
    head_ = 0;
    tasks_.swap(bigger);
  }
  std::vector<Task> tasks_;
  size_t head_ = 0, tail_ = 0;
};

// Walks in flight: enough to overlap the cache misses of one step of each, few enough to stay in L1.
constexpr size_t kWalksInFlight = 24;

inline void prefetch(const void* p) { __builtin_prefetch(p, 0, 3); }
// A node is at most 17 units (34 bytes: a header and 8 wide references) and may straddle two cache lines:
// fetch its first and its last possible byte.
inline void prefetchNode(const uint16_t* node) {
  __builtin_prefetch(node, 0, 3);
  __builtin_prefetch(reinterpret_cast<const char*>(node) + 33, 0, 3);
}

inline uint32_t area(const Footprint& f, uint32_t ox, uint32_t oy, uint32_t size) {
  return overlap(ox, ox + size - 1, f.x0, f.x1) * overlap(oy, oy + size - 1, f.y0, f.y1);
}

}  // namespace

// K = 1: one path per point. The walks go level by level: every point of the view takes its step at one
// level before any takes the next, in a loop without data-dependent branches (the child's code decides only
// which values are kept), so the loop runs at the speed of its loads: each child's node is prefetched when
// its reference is read and read one pass over the batch later, by which time it has arrived from memory.
CPVS_POPCNT_CLONES void LightShadow::walkVoxels(uint32_t view, const CellBatchOutput& cells,
                                                const uint32_t* indices, size_t count, std::span<float> out) const {
  struct Walk {
    uint32_t x, y, z;
    uint32_t offset;  // the node's words, then (after the leaf-parent level) the leaf's index
    uint32_t out;
  };
  thread_local std::vector<Walk> walks;
  if (walks.size() < count) walks.resize(count);
  {
    const DagView& dag = dags_[view];
    const TopGrid& grid = grids_[view];
    const uint16_t* nodes = dag.nodes.data();
    // Start: the root, or the top-grid cell (whose code may answer at once). Every point's answer is written
    // here (the cell's, or the start code's) and a walk kept for those that need one, without a branch on
    // either outcome.
    const uint32_t startSize = grid.empty() ? dag.resolution : 1u << grid.shift;
    const uint32_t sh = grid.shift, level = grid.level;
    // Locals, not members: the float stores to out[] could otherwise alias them and force reloads.
    const uint32_t* gridCells = grid.empty() ? nullptr : grid.cells.data();
    const uint32_t rootEntry = uint32_t(dag.rootCode);  // the root, at offset 0
    const int32_t *xs = cells.x, *ys = cells.y, *zs = cells.z;
    const uint8_t* states = cells.state;
    float* answers = out.data();
    Walk* w = walks.data();
    size_t started = 0;
    for (size_t j = 0; j < count; ++j) {
      const uint32_t i = indices ? indices[j] : uint32_t(j);
      const uint32_t x = uint32_t(xs[j]), y = uint32_t(ys[j]), z = uint32_t(zs[j]);  // 0 unless a voxel
      const uint32_t state = states[j];
      const uint32_t entry =
          gridCells ? gridCells[(size_t(z >> sh) << (2 * level)) | (size_t(y >> sh) << level) | (x >> sh)] : rootEntry;
      const uint32_t code = entry & 3u;
      // Integer flags, not conditionals: the outcomes are unpredictable, and a branch on them mispredicts.
      const uint32_t voxel = state == kCellVoxel;
      const uint32_t lit = (voxel & uint32_t(code != uint32_t(ChildCode::Shadowed))) | uint32_t(state == kCellLit);
      answers[i] = float(lit);  // final unless a walk follows
      prefetchNode(nodes + (entry >> 2));
      w[started] = {x, y, z, entry >> 2, i};
      started += voxel & uint32_t(code == uint32_t(ChildCode::Ref));
    }
    size_t active = started;
    // Octree levels: child c = (z, y, x bits at the child's edge) in Z-order.
    for (uint32_t size = startSize; size > 8 && active > 0; size >>= 1) {
      const unsigned bit = unsigned(std::countr_zero(size)) - 1u;  // log2 of the child's edge
      const uint32_t base = dag.childBase[bit + 1];
      size_t kept = 0;
      for (size_t i = 0; i < active; ++i) {
        Walk walk = w[i];
        const uint32_t header = nodes[walk.offset];
        const unsigned c = (((walk.z >> bit) & 1u) << 2) | (((walk.y >> bit) & 1u) << 1) | ((walk.x >> bit) & 1u);
        const uint32_t code = childCodeOf(header, c);
        const bool ref = code == uint32_t(ChildCode::Ref);
        answers[walk.out] = float(code != uint32_t(ChildCode::Shadowed));  // final unless a reference
        // Without a reference this reads the header again: in bounds, and no branch.
        walk.offset = base + readRef(nodes, walk.offset, header, c);
        prefetchNode(nodes + walk.offset);
        w[kept] = walk;
        kept += ref ? 1u : 0u;
      }
      active = kept;
    }
    // Leaf-parent level: z-only split into 8x8x1 leaves.
    size_t kept = 0;
    for (size_t i = 0; i < active; ++i) {
      Walk walk = w[i];
      const uint32_t header = nodes[walk.offset];
      const unsigned c = walk.z & 7u;
      const uint32_t code = childCodeOf(header, c);
      const bool ref = code == uint32_t(ChildCode::Ref);
      answers[walk.out] = float(code != uint32_t(ChildCode::Shadowed));
      walk.offset = ref ? readRef(nodes, walk.offset, header, c) : 0u;
      prefetch(dag.leaves.data() + walk.offset);
      w[kept] = walk;
      kept += ref ? 1u : 0u;
    }
    // Leaves: the voxel's bit.
    const uint64_t* leaves = dag.leaves.data();
    for (size_t i = 0; i < kept; ++i) {
      const Walk& walk = w[i];
      const uint32_t shadowed = uint32_t(leaves[walk.offset] >> ((walk.y & 7u) * 8u + (walk.x & 7u))) & 1u;
      answers[walk.out] = float(shadowed ^ 1u);
    }
  }
}

CPVS_POPCNT_CLONES void LightShadow::visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                             std::span<float> out) const {
  if (out.size() != points.size())
    throw Error(ExitCode::RuntimeFailure, "LightShadow::visibility: output and point spans differ in size");
  const int k = options.pcfKernel;
  const int64_t h = k / 2;
  const double kernelArea = double(k) * double(k);
  auto value = [&](uint32_t shadowed) {
    return k <= 1 ? (shadowed ? 0.0f : 1.0f) : float(1.0 - double(shadowed) / kernelArea);
  };

  // Phase 1: where each point lands (batch_cells.h: four points at a time where the CPU has AVX2); answers
  // that need no DAG are written at once, the others become pending walks.
  const size_t count = points.size();
  static_assert(sizeof(SurfacePoint) == 6 * sizeof(double), "mapCells reads points as 6 doubles");
  thread_local BatchScratch scratch;
  scratch.resize(count);
  std::vector<PendingPoint>& pendingStore = scratch.pending;
  size_t pendingCount = 0;
  CellBatchInput in;
  in.settings = cellSettings(options);
  in.points = reinterpret_cast<const double*>(points.data());
  const CellBatchOutput cells{scratch.x.data(), scratch.y.data(), scratch.z.data(), scratch.state.data()};
  // Lane j of a mapped run (point indices[j], or j) into out[] and the pending walks.
  auto collect = [&](uint32_t view, const uint32_t* indices, size_t lanes) {
    const DagView& dag = dags_[view];
    const int64_t n = dag.resolution;
    for (size_t j = 0; j < lanes; ++j) {
      const uint32_t i = indices ? indices[j] : uint32_t(j);
      const uint8_t state = cells.state[j];
      const int64_t x = cells.x[j], y = cells.y[j];
      const Footprint f{uint32_t(std::max<int64_t>(0, x - h)), uint32_t(std::min<int64_t>(n - 1, x + h)),
                        uint32_t(std::max<int64_t>(0, y - h)), uint32_t(std::min<int64_t>(n - 1, y + h))};
      float answer = state == kCellLit ? 1.0f : 0.0f;
      if (state == kCellVoxel && dag.rootCode != ChildCode::Ref)  // a DAG of one colour: no walk
        answer = dag.rootCode == ChildCode::Lit ? 1.0f : value((f.x1 - f.x0 + 1) * (f.y1 - f.y0 + 1));
      out[i] = answer;
      // Written every time, kept only for a walk: no branch on the point's (unpredictable) outcome.
      pendingStore[pendingCount] = {f, uint32_t(cells.z[j]), view, i};
      pendingCount += state == kCellVoxel && dag.rootCode == ChildCode::Ref ? 1u : 0u;
    }
  };
  if (views_.size() == 1) {  // directional and spot lights: the influence test runs in mapCells
    in.mapping = &mappings_[0];
    in.spot = light_.type == LightType::Spot ? &spot_ : nullptr;
    in.count = count;
    mapCells(in, cells);
    if (k <= 1) walkVoxels(0, cells, nullptr, count, out);
    else collect(0, nullptr, count);
  } else {  // point lights: the cube face of each point first, then each face's points together
    std::vector<uint32_t>& order = scratch.indices;
    std::vector<uint32_t>& face = scratch.face;
    std::vector<uint32_t> starts(views_.size() + 1, 0);  // then: where each view's run begins in `order`
    for (size_t i = 0; i < count; ++i) {
      out[i] = 0.0f;
      const SurfacePoint& p = points[i];
      const int index = finite(p.position) ? viewIndex(p.position) : -1;
      face[i] = index < 0 ? kNoView : uint32_t(index);
      if (index >= 0) ++starts[size_t(index) + 1];
    }
    for (size_t v = 0; v < views_.size(); ++v) starts[v + 1] += starts[v];
    std::vector<uint32_t> fill(starts.begin(), starts.end() - 1);
    for (size_t i = 0; i < count; ++i)
      if (face[i] != kNoView) order[fill[face[i]]++] = uint32_t(i);
    in.spot = nullptr;
    for (uint32_t v = 0; v < views_.size(); ++v) {
      in.mapping = &mappings_[v];
      in.indices = order.data() + starts[v];
      in.count = starts[v + 1] - starts[v];
      mapCells(in, cells);
      if (k <= 1) walkVoxels(v, cells, in.indices, in.count, out);
      else collect(v, in.indices, in.count);
    }
  }
  const std::span<const PendingPoint> pending(pendingStore.data(), pendingCount);
  if (pending.empty()) return;

  // Phase 2: the walks, interleaved through a FIFO.
  std::vector<uint32_t> counts(pending.size(), 0);
  TaskQueue queue;
  size_t next = 0;
  auto launch = [&](uint32_t pi) {
    const PendingPoint& pp = pending[pi];
    const DagView& dag = dags_[pp.view];
    const TopGrid& grid = grids_[pp.view];
    if (grid.empty()) {
      prefetchNode(dag.nodes.data());
      queue.push({pi, 0, 0, 0, dag.resolution});
      return;
    }
    const uint32_t shift = grid.shift, level = grid.level, size = 1u << shift;
    const size_t zRow = size_t(pp.z >> shift) << (2 * level);
    for (uint32_t gy = pp.f.y0 >> shift; gy <= (pp.f.y1 >> shift); ++gy)
      for (uint32_t gx = pp.f.x0 >> shift; gx <= (pp.f.x1 >> shift); ++gx) {
        const uint32_t entry = grid.cells[zRow | (size_t(gy) << level) | gx];
        const uint32_t code = entry & 3u;
        if (code == uint32_t(ChildCode::Lit)) continue;
        if (code == uint32_t(ChildCode::Shadowed)) {
          counts[pi] += area(pp.f, gx << shift, gy << shift, size);
          continue;
        }
        prefetchNode(dag.nodes.data() + (entry >> 2));
        queue.push({pi, entry >> 2, gx << shift, gy << shift, size});
      }
  };
  for (;;) {
    while (next < pending.size() && queue.size() < kWalksInFlight) launch(uint32_t(next++));
    if (queue.empty()) break;
    const Task t = queue.pop();
    const PendingPoint& pp = pending[t.point];
    const DagView& dag = dags_[pp.view];
    const uint16_t* nodes = dag.nodes.data();
    if (t.size == 0) {  // a leaf mask
      counts[t.point] += popcount64(dag.leaves[t.offset] & tileMask(pp.f, t.ox, t.oy));
      continue;
    }
    const uint32_t header = nodes[t.offset];
    if (t.size == 8) {  // leaf parent: z-only split
      const unsigned c = pp.z & 7u;
      const uint32_t code = childCodeOf(header, c);
      if (code == uint32_t(ChildCode::Shadowed)) {
        counts[t.point] += area(pp.f, t.ox, t.oy, 8);
      } else if (code == uint32_t(ChildCode::Ref)) {
        const uint32_t leaf = readRef(nodes, t.offset, header, c);
        prefetch(dag.leaves.data() + leaf);
        queue.push({t.point, leaf, t.ox, t.oy, 0});
      }
      continue;
    }
    const uint32_t half = t.size >> 1;
    const unsigned zbit = (pp.z & half) ? 4u : 0u;
    // Children the footprint overlaps: one or two in x and in y.
    const unsigned xbFirst = pp.f.x0 >= t.ox + half ? 1u : 0u, xbLast = pp.f.x1 >= t.ox + half ? 1u : 0u;
    const unsigned ybFirst = pp.f.y0 >= t.oy + half ? 1u : 0u, ybLast = pp.f.y1 >= t.oy + half ? 1u : 0u;
    for (unsigned yb = ybFirst; yb <= ybLast; ++yb)
      for (unsigned xb = xbFirst; xb <= xbLast; ++xb) {
        const unsigned c = zbit | (yb << 1) | xb;
        const uint32_t code = childCodeOf(header, c);
        if (code == uint32_t(ChildCode::Lit)) continue;
        const uint32_t cx = t.ox + xb * half, cy = t.oy + yb * half;
        if (code == uint32_t(ChildCode::Shadowed)) {
          counts[t.point] += area(pp.f, cx, cy, half);
          continue;
        }
        const uint32_t child = dag.child(t.offset, header, c, t.size);
        prefetchNode(nodes + child);
        queue.push({t.point, child, cx, cy, half});
      }
  }
  for (size_t pi = 0; pi < pending.size(); ++pi) out[pending[pi].out] = value(counts[pi]);
}

}  // namespace cpvs
