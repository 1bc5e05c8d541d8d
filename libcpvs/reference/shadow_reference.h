#pragma once
// The ground truth every error figure is measured against (cpvs-query --reference, cpvs-sweep): Embree shadow
// rays from surface points, whether a point's answer is the same everywhere within two voxels ("uniform"), and
// whether a point lies inside a closed solid. One definition, so the query's and the sweep's rates agree.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/embree_scene.h"

namespace cpvs {

class ShadowReference {
public:
  // Builds the Embree BVH of the geometry. `orientation`: how the lookups being scored orient normals.
  // `relativeEpsilon`: the rays' offset off the surface as a fraction of the scene's diagonal (see epsilon()).
  static constexpr double kDefaultRelativeEpsilon = 1e-6;
  // Validates a relative offset given by a user (1e-9 .. 1e-2). Throws Error(Usage).
  static void checkRelativeEpsilon(double relativeEpsilon);
  explicit ShadowReference(const WorldGeometry& world, NormalOrientation orientation = NormalOrientation::AsGiven,
                           double relativeEpsilon = kDefaultRelativeEpsilon);
  ~ShadowReference();

  // Ray-traced visibility (1 lit, 0 shadowed; 0 outside the light's influence) of a point: a shadow ray from
  // the point, moved by `epsilon()` along its normal (oriented as the lookup orients it; without a normal the
  // ray starts `epsilon()` along itself), toward the light (directional: along -direction, unbounded;
  // spot/point: to the light's position). A normal facing away from the light gives 0 without a ray: the ray
  // from the surface point enters its own surface at once.
  uint8_t visibility(const Light& light, const SurfacePoint& point) const;
  // The same for many points, traced in 16-wide packets (rtcOccluded16) on the calling thread: for the
  // throughput figure next to single rays. out[i] for points[i].
  void visibilityPackets(const Light& light, const std::vector<SurfacePoint>& points, std::vector<uint8_t>& out) const;
  // The same, and whether the reference is the same everywhere within two voxels of the point: at 8 points on
  // a circle of radius 2 voxels around it on its tangent plane and at the point 2 voxels out along its normal
  // (all in the grid space of the light's view, so "2 voxels" means the same at any scale and for any view;
  // without a normal: the circle in (u, v) at the point's depth), mapped back with gridToWorld.
  uint8_t visibility(const LightShadow& shadow, const SurfacePoint& point, bool& uniform) const;
  // Only the uniformity test, for a caller that already has the point's own answer `centre`.
  bool uniformAround(const LightShadow& shadow, const SurfacePoint& point, uint8_t centre) const;

  // Whether the point lies inside a closed solid of the scene (Embree parity count from just off the surface,
  // along the normal when there is one), the ground under a closed ground sheet included. Such a point is in
  // free voxels: the bake may answer either way.
  bool insideClosedSolid(const SurfacePoint& point) const;

  // The offset along the normal: by default 1e-6 of the scene's diagonal, about 16 times the float precision
  // Embree stores the scene with (relative to its centre). It must stay under a voxel of the views being scored
  // and under the gaps between surfaces: an origin moved across a nearby wall escapes its shadow (docs/query.md,
  // "The reference's offset": 1e-5 misjudged back-to-back walls of the generated city).
  double epsilon() const { return epsilon_; }
  size_t triangles() const { return sceneTriangles_; }  // the scene's own, without ground closings
  const EmbreeScene& scene() const { return *scene_; }  // the scene's own triangles

private:
  // The shadow ray of a point: false when the answer needs no ray (`known` holds it).
  bool shadowRay(const Light& light, const SurfacePoint& point, Ray& ray, double& tmax, uint8_t& known) const;

  std::unique_ptr<EmbreeScene> scene_;   // the scene's own triangles: every ray
  std::unique_ptr<EmbreeScene> solids_;  // with the ground sheets' closing triangles, when there are any
  size_t sceneTriangles_ = 0;
  double epsilon_ = 0;
  NormalOrientation orientation_;
};

}  // namespace cpvs
