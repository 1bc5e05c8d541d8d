#pragma once
// Ray-traced ground truth with Embree 3 (docs/cli.md: tests compare against Embree; cpvs-query --reference).
//
// All rays are given in double world coordinates. Internally the geometry is translated by
// -bounds.center() and stored in float, so scenes far from the origin keep their precision; hit distances
// are refined in double against the hit triangle's plane.
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light_view.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

struct RayHit {
  double t = 0;              // distance along the ray in units of |direction|
  uint32_t triangle = 0;     // index into WorldGeometry::indices / 3
  bool frontFacing = false;  // the ray meets the CCW (front) side: dot(direction, cross(b - a, c - a)) < 0
  bool closed = false;       // the triangle belongs to a closed mesh (WorldGeometry::isClosed)
};

class EmbreeScene {
public:
  // Builds a robust BVH over all triangles (RTC_SCENE_FLAG_ROBUST). Alpha-tested triangles
  // (WorldGeometry::masked) are hit only where their coverage mask blocks light. Throws Error(RuntimeFailure) when
  // Embree reports an error (reported through the device error callback).
  explicit EmbreeScene(const WorldGeometry& geometry);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  static constexpr double kInfinity = std::numeric_limits<double>::infinity();

  // Nearest hit with t in [tmin, tmax], or nullopt.
  std::optional<RayHit> firstHit(const Ray& ray, double tmin = 0.0, double tmax = kInfinity) const;
  // Whether anything lies on the ray with t in [0, tmax].
  bool occluded(const glm::dvec3& origin, const glm::dvec3& direction, double tmax = kInfinity) const;
  // Every hit with t in [tmin, tmax] sorted by t (only closed triangles when closedOnly). Hits of triangles
  // that share a vertex position, have the same facing and lie at the same t (a ray through a shared edge or
  // vertex) are reported once.
  std::vector<RayHit> allHits(const Ray& ray, double tmin = 0.0, double tmax = kInfinity,
                              bool closedOnly = false) const;

  // Number of closed solids that contain `point`: along a ray from the point, +1 per closed back face (the ray
  // leaves a solid) and -1 per closed front face (it enters one). Three rays in fixed, non-axis-aligned
  // directions; the median of the three counts (one ray grazing an edge cannot flip the answer).
  int closedSolidDepth(const glm::dvec3& point) const;
  bool isInsideClosedSolid(const glm::dvec3& point) const { return closedSolidDepth(point) > 0; }

  // Batches with 16-wide packets (rtcIntersect16 / rtcOccluded16), over all cores with TBB when `parallel`.
  std::vector<std::optional<RayHit>> firstHits(std::span<const Ray> rays, double tmin = 0.0,
                                               double tmax = kInfinity, bool parallel = true) const;
  // result[i] = 1 when rays[i] is blocked within tmax[i] (tmax empty: unbounded; one value: for all rays).
  std::vector<uint8_t> occludedBatch(std::span<const Ray> rays, std::span<const double> tmax,
                                     bool parallel = true) const;

  size_t triangleCount() const { return indices_.size() / 3; }
  const glm::dvec3& center() const { return center_; }

private:
  struct Impl;
  RayHit makeHit(const glm::dvec3& origin, const glm::dvec3& direction, uint32_t prim, float tEmbree) const;
  void throwIfFailed(const char* what) const;

  std::unique_ptr<Impl> impl_;
  glm::dvec3 center_{0.0};
  double scale_ = 1.0;  // length of the bounds' diagonal
  std::vector<glm::dvec3> positions_;  // world space, double
  std::vector<uint32_t> indices_;
  size_t closedTriangleCount_ = 0;
  MaskedTriangles masked_;  // alpha-tested triangles, cut by their masks in every query
};

}  // namespace cpvs
