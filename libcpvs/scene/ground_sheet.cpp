#include "libcpvs/scene/ground_sheet.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <span>
#include <unordered_map>

#include "libcpvs/scene/mesh_topology.h"

namespace cpvs {
namespace {

constexpr double kRimTolerance = 1e-6;     // of the scene diagonal: boundary vertices on the rectangle
constexpr double kAreaTolerance = 1e-6;    // of the rectangle's area: projected areas add up to it
constexpr double kBuriedTolerance = 1e-3;  // of the scene diagonal: how far other geometry may sink in

glm::dvec3 corner(const WorldGeometry& world, size_t t, int k) { return world.positions[world.indices[3 * t + k]]; }

glm::dvec3 areaVector(const WorldGeometry& world, size_t t) {
  const glm::dvec3 a = corner(world, t, 0);
  return glm::cross(corner(world, t, 1) - a, corner(world, t, 2) - a);
}

// The sheet in its own frame: height along `axis`, footprint (u, v) over the other two.
struct SheetFrame {
  int axis = 1, sign = 1, u = 0, v = 2;
  double minU = 0, maxU = 0, minV = 0, maxV = 0;
  glm::dvec2 at(const glm::dvec3& p) const { return {p[u], p[v]}; }
};

// Oriented boundary edges (as their triangle runs them) after welding the instance's vertices by position.
// flatten() gives each instance its own contiguous run of world vertices.
std::vector<std::pair<uint32_t, uint32_t>> boundaryEdges(const WorldGeometry& world, const InstanceTriangles& r) {
  const auto [lo, hi] = std::minmax_element(world.indices.begin() + long(3 * r.begin), world.indices.begin() + long(3 * r.end));
  const uint32_t first = *lo;
  const std::vector<uint32_t> weld =
      weldByPosition(std::span<const glm::dvec3>(world.positions.data() + first, size_t(*hi - first + 1)));
  auto welded = [&](uint32_t vertex) { return first + weld[vertex - first]; };
  // Per undirected edge: how often it is used and the last direction seen.
  struct Use {
    uint32_t count = 0, from = 0, to = 0;
  };
  std::unordered_map<uint64_t, Use> edges;
  for (size_t t = r.begin; t < r.end; ++t) {
    const uint32_t c[3] = {welded(world.indices[3 * t]), welded(world.indices[3 * t + 1]), welded(world.indices[3 * t + 2])};
    if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0]) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t from = c[k], to = c[(k + 1) % 3];
      Use& use = edges[uint64_t(std::min(from, to)) << 32 | std::max(from, to)];
      ++use.count;
      use.from = from;
      use.to = to;
    }
  }
  std::vector<std::pair<uint32_t, uint32_t>> boundary;
  for (const auto& [key, use] : edges)
    if (use.count == 1) boundary.push_back({use.from, use.to});
  std::sort(boundary.begin(), boundary.end());  // deterministic order (the map's is not)
  return boundary;
}

// Heights of the sheet at footprint points: a uniform grid of triangle lists over its rectangle.
class HeightField {
 public:
  HeightField(const WorldGeometry& world, const InstanceTriangles& r, const SheetFrame& f) : world_(world), f_(f) {
    const size_t triangles = r.end - r.begin;
    cells_ = std::clamp<size_t>(size_t(std::sqrt(double(triangles) / 2.0)), 1, 2048);
    cellU_ = std::max(f.maxU - f.minU, 1e-300) / double(cells_);
    cellV_ = std::max(f.maxV - f.minV, 1e-300) / double(cells_);
    std::vector<uint32_t> counts(cells_ * cells_ + 1, 0);
    auto forCells = [&](size_t t, auto&& visit) {
      glm::dvec2 lo(INFINITY), hi(-INFINITY);
      for (int k = 0; k < 3; ++k) {
        lo = glm::min(lo, f_.at(corner(world_, t, k)));
        hi = glm::max(hi, f_.at(corner(world_, t, k)));
      }
      const size_t u0 = cellU(lo.x), u1 = cellU(hi.x), v0 = cellV(lo.y), v1 = cellV(hi.y);
      for (size_t cv = v0; cv <= v1; ++cv)
        for (size_t cu = u0; cu <= u1; ++cu) visit(cv * cells_ + cu);
    };
    for (size_t t = r.begin; t < r.end; ++t) forCells(t, [&](size_t c) { ++counts[c + 1]; });
    for (size_t c = 0; c < cells_ * cells_; ++c) counts[c + 1] += counts[c];
    start_ = counts;
    triangles_.resize(counts.back());
    for (size_t t = r.begin; t < r.end; ++t) forCells(t, [&](size_t c) { triangles_[counts[c]++] = uint32_t(t); });
  }

  // The sheet's height (along the axis, times sign: larger is further out of the solid) at footprint point q:
  // the lowest over the triangles that contain q, or NaN where none does (outside, or in a crack).
  double lowestHeight(glm::dvec2 q) const {
    const size_t c = cellV(q.y) * cells_ + cellU(q.x);
    double lowest = NAN;
    for (size_t i = start_[c]; i < start_[c + 1]; ++i) {
      const size_t t = triangles_[i];
      const glm::dvec3 p0 = corner(world_, t, 0), p1 = corner(world_, t, 1), p2 = corner(world_, t, 2);
      const glm::dvec2 a = f_.at(p0), b = f_.at(p1), d = f_.at(p2);
      const double area = cross2(b - a, d - a);
      if (!(std::abs(area) > 0.0)) continue;  // seen edge-on from the axis: no height of its own
      const double w0 = cross2(b - q, d - q) / area, w1 = cross2(d - q, a - q) / area, w2 = 1.0 - w0 - w1;
      constexpr double kEdge = -1e-9;
      if (w0 < kEdge || w1 < kEdge || w2 < kEdge) continue;
      const double h = f_.sign * (w0 * p0[f_.axis] + w1 * p1[f_.axis] + w2 * p2[f_.axis]);
      if (!(lowest <= h)) lowest = h;
    }
    return lowest;
  }

 private:
  static double cross2(glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; }
  size_t cellU(double u) const { return clampCell((u - f_.minU) / cellU_); }
  size_t cellV(double v) const { return clampCell((v - f_.minV) / cellV_); }
  // Clamped in double first: a coordinate far outside the frame (or a huge extent ratio) must not convert an
  // out-of-range double to size_t (undefined behaviour, found by fuzzing the import). NaN lands in cell 0.
  size_t clampCell(double x) const { return x > 0.0 ? size_t(std::min(x, double(cells_ - 1))) : 0; }

  const WorldGeometry& world_;
  SheetFrame f_;
  size_t cells_ = 1;
  double cellU_ = 1, cellV_ = 1;
  std::vector<uint32_t> start_, triangles_;
};

// The first reason `r` is not a ground sheet, or "" when it is one. Fills `frame` and `boundary` as far as
// it got; `spansScene` is set once it is known to be a height field spanning the scene (worth reporting).
std::string examine(const Scene& scene, const std::vector<InstanceTriangles>& ranges, const InstanceTriangles& r,
                    const WorldGeometry& world, SheetFrame& frame, bool& spansScene,
                    std::vector<std::pair<uint32_t, uint32_t>>& boundary) {
  spansScene = false;
  const Mesh& mesh = scene.meshes[scene.instances[r.instance].mesh];
  if (mesh.coverageMask >= 0) return "alpha-tested (cut by its material's alpha)";
  if (mesh.closed) return "closed";
  if (mesh.boundaryEdges == 0) return "it has no boundary edge (no rim to span the scene with)";
  if (mesh.nonManifoldEdges || mesh.inconsistentEdges) return "non-manifold or inconsistently wound";

  glm::dvec3 total(0.0);
  for (size_t t = r.begin; t < r.end; ++t) total += areaVector(world, t);
  const glm::dvec3 magnitude = glm::abs(total);
  frame.axis = magnitude.x >= magnitude.y && magnitude.x >= magnitude.z ? 0 : (magnitude.y >= magnitude.z ? 1 : 2);
  frame.sign = total[frame.axis] >= 0.0 ? 1 : -1;
  frame.u = frame.axis == 0 ? 1 : 0;
  frame.v = frame.axis == 2 ? 1 : 2;
  if (!(magnitude[frame.axis] > 0.0)) return "no area along any axis";

  double projected = 0.0;
  frame.minU = frame.minV = INFINITY;
  frame.maxU = frame.maxV = -INFINITY;
  for (size_t t = r.begin; t < r.end; ++t) {
    const glm::dvec3 n = areaVector(world, t);
    const double along = frame.sign * n[frame.axis];
    if (along < -1e-9 * glm::length(n)) return "a triangle faces back";
    projected += 0.5 * along;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec2 q = frame.at(corner(world, t, k));
      frame.minU = std::min(frame.minU, q.x);
      frame.maxU = std::max(frame.maxU, q.x);
      frame.minV = std::min(frame.minV, q.y);
      frame.maxV = std::max(frame.maxV, q.y);
    }
  }

  const double diagonal = glm::length(world.bounds.extent());
  const double rim = kRimTolerance * diagonal;
  boundary = boundaryEdges(world, r);
  auto onSide = [&](const glm::dvec2& p, const glm::dvec2& q, int side) {
    const double value = side == 0 ? frame.minU : side == 1 ? frame.maxU : side == 2 ? frame.minV : frame.maxV;
    const int k = side < 2 ? 0 : 1;
    return std::abs(p[k] - value) <= rim && std::abs(q[k] - value) <= rim;
  };
  for (const auto& [from, to] : boundary) {
    const glm::dvec2 p = frame.at(world.positions[from]), q = frame.at(world.positions[to]);
    if (!(onSide(p, q, 0) || onSide(p, q, 1) || onSide(p, q, 2) || onSide(p, q, 3)))
      return "its outline is not its bounding rectangle (a hole or an irregular edge)";
  }
  const double rectangle = (frame.maxU - frame.minU) * (frame.maxV - frame.minV);
  if (!(std::abs(projected - rectangle) <= kAreaTolerance * rectangle))
    return "it folds over itself or leaves gaps (projected area differs from its rectangle's)";

  const glm::dvec2 sceneLo = frame.at(world.bounds.min), sceneHi = frame.at(world.bounds.max);
  if (sceneLo.x < frame.minU - rim || sceneHi.x > frame.maxU + rim || sceneLo.y < frame.minV - rim ||
      sceneHi.y > frame.maxV + rim)
    return "it does not span the scene";
  spansScene = true;

  const HeightField heights(world, r, frame);
  const double buried = kBuriedTolerance * diagonal;
  for (const InstanceTriangles& other : ranges) {
    if (other.instance == r.instance) continue;
    for (size_t t = other.begin; t < other.end; ++t) {
      const glm::dvec3 points[4] = {corner(world, t, 0), corner(world, t, 1), corner(world, t, 2),
                                    (corner(world, t, 0) + corner(world, t, 1) + corner(world, t, 2)) / 3.0};
      for (const glm::dvec3& p : points) {
        const double depth = heights.lowestHeight(frame.at(p)) - frame.sign * p[frame.axis];
        if (depth > buried) {
          const Instance& instance = scene.instances[other.instance];
          char text[64];
          std::snprintf(text, sizeof text, "%.3g", depth);
          return "mesh '" + scene.meshes[instance.mesh].name + "' (node '" + instance.node + "') lies " + text +
                 " units under it";
        }
      }
    }
  }
  return "";
}

// Skirt and bottom that close the sheet: per boundary edge p -> q a wall quad down to the bottom plane, and
// a fan from the bottom's centre. Wound against the sheet's edges, so the solid is closed and faces out.
void appendClosing(const SheetFrame& f, const std::vector<std::pair<uint32_t, uint32_t>>& boundary, double bottom,
                   WorldGeometry& world, std::vector<uint32_t>& indices) {
  std::unordered_map<uint32_t, uint32_t> below;  // sheet vertex -> its copy on the bottom plane
  auto down = [&](uint32_t vertex) {
    auto [it, added] = below.try_emplace(vertex, uint32_t(world.positions.size()));
    if (added) {
      glm::dvec3 p = world.positions[vertex];
      p[f.axis] = bottom;
      world.positions.push_back(p);
    }
    return it->second;
  };
  glm::dvec3 centre;
  centre[f.u] = 0.5 * (f.minU + f.maxU);
  centre[f.v] = 0.5 * (f.minV + f.maxV);
  centre[f.axis] = bottom;
  const uint32_t c = uint32_t(world.positions.size());
  world.positions.push_back(centre);
  for (const auto& [p, q] : boundary) {
    const uint32_t pb = down(p), qb = down(q);
    indices.insert(indices.end(), {q, p, pb, q, pb, qb, c, qb, pb});
  }
}

double signedVolume(const WorldGeometry& world, const std::vector<uint32_t>& indices, glm::dvec3 origin) {
  double six = 0.0;
  for (size_t i = 0; i + 2 < indices.size(); i += 3)
    six += glm::dot(world.positions[indices[i]] - origin,
                    glm::cross(world.positions[indices[i + 1]] - origin, world.positions[indices[i + 2]] - origin));
  return six / 6.0;
}

// Why no instance is a ground sheet: a ground sheet is an open height field spanning the scene; say which open
// instance came closest (the largest) and the first rule it breaks.
std::string noGroundSheetReason(const Scene& scene, size_t openInstances, const InstanceTriangles* largestOpen,
                                const std::string& reason) {
  const std::string rule = "a ground sheet is an open mesh, a height field along one axis, spanning the whole scene";
  if (!largestOpen) return "every casting mesh is closed; " + rule;
  const Instance& instance = scene.instances[largestOpen->instance];
  return rule + "; of the " + std::to_string(openInstances) + " open instance" + (openInstances == 1 ? "" : "s") +
         ", the largest, mesh '" + scene.meshes[instance.mesh].name + "' (node '" + instance.node + "'), is not one: " +
         reason;
}

}  // namespace

void closeGroundSheets(const Scene& scene, const std::vector<InstanceTriangles>& ranges, WorldGeometry& world) {
  if (world.bounds.empty()) {
    world.noGroundSheet = "the scene has no casting triangles";
    return;
  }
  const double diagonal = glm::length(world.bounds.extent());
  std::vector<const InstanceTriangles*> used;
  std::vector<uint32_t> closing;
  size_t openInstances = 0;
  const InstanceTriangles* largestOpen = nullptr;
  std::string largestOpenReason;
  for (const InstanceTriangles& r : ranges) {
    if (r.begin >= r.end || r.begin < world.closedTriangleCount) continue;  // closed instances come first
    SheetFrame frame;
    bool spansScene = false;
    std::vector<std::pair<uint32_t, uint32_t>> boundary;
    std::string reason = examine(scene, ranges, r, world, frame, spansScene, boundary);
    ++openInstances;
    if (!largestOpen || r.end - r.begin > largestOpen->end - largestOpen->begin) largestOpen = &r, largestOpenReason = reason;
    if (!spansScene) continue;
    GroundSheet sheet;
    const Instance& instance = scene.instances[r.instance];
    sheet.mesh = scene.meshes[instance.mesh].name;
    sheet.node = instance.node;
    sheet.axis = frame.axis;
    sheet.sign = frame.sign;
    if (reason.empty()) {
      // One scene diagonal behind the scene: the bottom lies beyond every light view fitted to the scene.
      const double bottom = frame.sign > 0 ? world.bounds.min[frame.axis] - diagonal : world.bounds.max[frame.axis] + diagonal;
      std::vector<uint32_t> solid(world.indices.begin() + long(3 * r.begin), world.indices.begin() + long(3 * r.end));
      const size_t sheetIndices = solid.size();
      const size_t positionsBefore = world.positions.size();
      appendClosing(frame, boundary, bottom, world, solid);
      if (signedVolume(world, solid, world.bounds.center()) > 0.0) {
        closing.insert(closing.end(), solid.begin() + long(sheetIndices), solid.end());
        sheet.closingTriangles = (solid.size() - sheetIndices) / 3;
        sheet.used = true;
        used.push_back(&r);
      } else {
        world.positions.resize(positionsBefore);
        reason = "closing it does not give an outward solid";
      }
    }
    sheet.reason = reason;
    world.groundSheets.push_back(sheet);
  }
  if (world.groundSheets.empty())
    world.noGroundSheet = noGroundSheetReason(scene, openInstances, largestOpen, largestOpenReason);
  if (used.empty()) return;

  // New order: closed instances, used sheets, their closing triangles, the other open instances.
  auto isUsed = [&](const InstanceTriangles& r) { return std::find(used.begin(), used.end(), &r) != used.end(); };
  std::vector<uint32_t> indices(world.indices.begin(), world.indices.begin() + long(3 * world.closedTriangleCount));
  auto append = [&](const InstanceTriangles& r) {
    indices.insert(indices.end(), world.indices.begin() + long(3 * r.begin), world.indices.begin() + long(3 * r.end));
  };
  world.groundBegin = world.closedTriangleCount;
  for (const InstanceTriangles* r : used) append(*r);
  world.closingBegin = indices.size() / 3;
  indices.insert(indices.end(), closing.begin(), closing.end());
  world.closingEnd = indices.size() / 3;
  for (const InstanceTriangles& r : ranges)
    if (r.begin >= world.closedTriangleCount && !isUsed(r)) append(r);
  world.indices = std::move(indices);
  world.closedTriangleCount = world.closingEnd;
}

}  // namespace cpvs
