#pragma once
// cpvs-query --reference: Embree shadow rays from the query points, and the error figures of the report.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "formats/io/points.h"
#include "libcpvs/lookup/shadow_lookup.h"
#include "libcpvs/reference/embree_scene.h"

namespace cpvs::query {

// Per light (or pooled): what the report's "reference" object holds.
struct ErrorStats {
  uint64_t samples = 0;               // valid points (x lights when pooled)
  uint64_t misclassified = 0;         // binary CPVS answer (value >= 0.5 is lit) != reference
  uint64_t uniform = 0;               // points whose reference is the same at every offset within two voxels
  uint64_t misclassifiedUniform = 0;
  double absDiffSum = 0;              // sum |CPVS value - reference| (PCF values are fractions)
  double absDiffSumUniform = 0;       // the same over the uniform points
  uint64_t referenceLit = 0;
  uint64_t cpvsLit = 0;               // value >= 0.5

  void add(const ErrorStats& o);
  double rate(uint64_t count, uint64_t of) const { return of ? double(count) / double(of) : 0.0; }
};

class Reference {
public:
  // Imports the scene (glTF), drops the excluded meshes, builds the Embree BVH. Throws Error.
  Reference(const std::string& scenePath, const std::vector<std::string>& excludedMeshes,
            NormalOrientation orientation);
  ~Reference();

  // Ray-traced visibility (1 lit, 0 shadowed; 0 outside the light's influence) of a point: a shadow ray from
  // the point, moved by `epsilon()` along its normal (oriented as the lookup orients it; without a normal the
  // ray starts `epsilon()` along itself), toward the light (directional: along -direction, unbounded;
  // spot/point: to the light's position). A normal facing away from the light gives 0 without a ray: the ray
  // from the surface point enters its own surface at once.
  uint8_t visibility(const Light& light, const QueryPoint& point) const;
  // The same for many points, traced in 16-wide packets (rtcOccluded16) on the calling thread: for the
  // throughput figure next to single rays. out[i] for points[i].
  void visibilityPackets(const Light& light, const std::vector<QueryPoint>& points, std::vector<uint8_t>& out) const;
  // The same, and whether the reference is the same everywhere within two voxels of the point: at 8 points on
  // a circle of radius 2 voxels around it on its tangent plane and at the point 2 voxels out along its normal
  // (all in the grid space of the light's view, so "2 voxels" means the same at any scale and for any view;
  // without a normal: the circle in (u, v) at the point's depth), mapped back with gridToWorld.
  uint8_t visibility(const LightShadow& shadow, const QueryPoint& point, bool& uniform) const;

  // Whether the point lies inside a closed solid of the scene (Embree parity count from just off the surface,
  // along the normal when there is one). Such a point is in free voxels: the bake may answer either way.
  bool insideClosedSolid(const QueryPoint& point) const;

  double epsilon() const { return epsilon_; }
  const std::string& scenePath() const { return scenePath_; }
  size_t triangles() const;
  const std::vector<std::string>& warnings() const { return warnings_; }

private:
  // The shadow ray of a point: false when the answer needs no ray (`known` holds it).
  bool shadowRay(const Light& light, const QueryPoint& point, Ray& ray, double& tmax, uint8_t& known) const;

  std::string scenePath_;
  std::unique_ptr<EmbreeScene> scene_;
  double epsilon_ = 0;
  NormalOrientation orientation_;
  std::vector<std::string> warnings_;
};

}  // namespace cpvs::query
