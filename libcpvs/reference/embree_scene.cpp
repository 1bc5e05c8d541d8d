#include "libcpvs/reference/embree_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <string>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "libcpvs/base/error.h"

namespace cpvs {

struct EmbreeScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  mutable std::mutex errorMutex;
  mutable std::string error;  // first error reported by the callback, cleared when thrown

  static void onError(void* user, RTCError code, const char* message) {
    if (code == RTC_ERROR_NONE) return;
    Impl* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->errorMutex);
    if (self->error.empty())
      self->error = "Embree error " + std::to_string(int(code)) + ": " + (message ? message : "(no message)");
  }
};

namespace {

// Collects every hit along one ray through the context filter (the hit is then rejected so traversal goes on).
struct CollectContext {
  RTCIntersectContext context;
  std::vector<std::pair<float, uint32_t>>* hits;
  uint32_t closedCount;
  bool closedOnly;
};

void collectFilter(const RTCFilterFunctionNArguments* args) {
  const CollectContext* c = reinterpret_cast<const CollectContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
    if (!c->closedOnly || prim < c->closedCount) c->hits->emplace_back(RTCRayN_tfar(args->ray, args->N, i), prim);
    args->valid[i] = 0;
  }
}

// Alpha-tested triangles: a hit where the triangle's coverage mask lets light through is no hit (the same
// rule as the depth rasterisers, libcpvs/scene/coverage_mask.h). Geometry filters run before the context
// filter of allHits, so cut-away hits are never collected either.
void alphaFilter(const RTCFilterFunctionNArguments* args) {
  const MaskedTriangles* masked = static_cast<const MaskedTriangles*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
    if (!masked->blocksAt(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)))
      args->valid[i] = 0;
  }
}

float toFloatT(double t) {
  if (t >= double(std::numeric_limits<float>::max())) return std::numeric_limits<float>::infinity();
  return float(t);
}

// A ray as Embree takes it: the origin relative to the scene's centre (Embree holds the scene in float around
// it), [max(0, tnear), tfar] in float, every mask bit on; the rest zero.
RTCRay embreeRay(const glm::dvec3& relativeOrigin, const glm::dvec3& direction, double tnear, double tfar) {
  RTCRay r{};
  r.org_x = float(relativeOrigin.x);
  r.org_y = float(relativeOrigin.y);
  r.org_z = float(relativeOrigin.z);
  r.dir_x = float(direction.x);
  r.dir_y = float(direction.y);
  r.dir_z = float(direction.z);
  r.tnear = float(std::max(0.0, tnear));
  r.tfar = toFloatT(tfar);
  r.mask = 0xFFFFFFFFu;
  return r;
}

RTCRayHit embreeRayHit(const glm::dvec3& relativeOrigin, const glm::dvec3& direction, double tnear, double tfar) {
  RTCRayHit rh{};
  rh.ray = embreeRay(relativeOrigin, direction, tnear, tfar);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

// Lane i of a 16-ray packet, with its lane number as id.
void setLane(RTCRay16& packet, int i, const RTCRay& r) {
  packet.org_x[i] = r.org_x;
  packet.org_y[i] = r.org_y;
  packet.org_z[i] = r.org_z;
  packet.dir_x[i] = r.dir_x;
  packet.dir_y[i] = r.dir_y;
  packet.dir_z[i] = r.dir_z;
  packet.tnear[i] = r.tnear;
  packet.tfar[i] = r.tfar;
  packet.time[i] = r.time;
  packet.mask[i] = r.mask;
  packet.id[i] = unsigned(i);
  packet.flags[i] = r.flags;
}

}  // namespace

EmbreeScene::EmbreeScene(const WorldGeometry& geometry) : impl_(std::make_unique<Impl>()) {
  positions_ = geometry.positions;
  indices_ = geometry.indices;
  closedTriangleCount_ = geometry.closedTriangleCount;
  masked_ = geometry.masked;
  center_ = geometry.bounds.empty() ? glm::dvec3(0.0) : geometry.bounds.center();
  scale_ = geometry.bounds.empty() ? 1.0 : std::max(1e-30, glm::length(geometry.bounds.extent()));

  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    throw Error(ErrorCategory::RuntimeFailure,
                "Embree: cannot create a device (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
  rtcSetDeviceErrorFunction(impl_->device, &Impl::onError, impl_.get());
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_MEDIUM);
  if (!indices_.empty()) {
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), positions_.size()));
    unsigned* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(unsigned), indices_.size() / 3));
    throwIfFailed("allocating geometry buffers");
    for (size_t i = 0; i < positions_.size(); ++i) {
      const glm::dvec3 p = positions_[i] - center_;
      v[3 * i] = float(p.x);
      v[3 * i + 1] = float(p.y);
      v[3 * i + 2] = float(p.z);
    }
    for (size_t i = 0; i < indices_.size(); ++i) {
      if (indices_[i] >= positions_.size())
        throw Error(ErrorCategory::InvalidInput, "Embree scene: vertex index " + std::to_string(indices_[i]) +
                                                " out of range at index " + std::to_string(i));
      idx[i] = indices_[i];
    }
    if (masked_.count()) {
      rtcSetGeometryUserData(geom, &masked_);
      rtcSetGeometryIntersectFilterFunction(geom, &alphaFilter);
      rtcSetGeometryOccludedFilterFunction(geom, &alphaFilter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  throwIfFailed("building the scene");
}

EmbreeScene::~EmbreeScene() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

void EmbreeScene::throwIfFailed(const char* what) const {
  std::string message;
  {
    std::lock_guard<std::mutex> lock(impl_->errorMutex);
    message.swap(impl_->error);
  }
  if (!message.empty()) throw Error(ErrorCategory::RuntimeFailure, message + " (while " + what + ")");
}

RayHit EmbreeScene::makeHit(const glm::dvec3& origin, const glm::dvec3& direction, uint32_t prim,
                            float tEmbree) const {
  const glm::dvec3& a = positions_[indices_[3 * size_t(prim)]];
  const glm::dvec3& b = positions_[indices_[3 * size_t(prim) + 1]];
  const glm::dvec3& c = positions_[indices_[3 * size_t(prim) + 2]];
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double dn = glm::dot(direction, n);
  RayHit hit;
  hit.triangle = prim;
  hit.frontFacing = dn < 0;
  hit.closed = prim < closedTriangleCount_;
  // Refine the distance in double against the triangle's plane, unless the ray grazes it.
  const double scale = glm::length(direction) * glm::length(n);
  hit.t = std::abs(dn) > 1e-6 * scale ? glm::dot(a - origin, n) / dn : double(tEmbree);
  return hit;
}

std::optional<RayHit> EmbreeScene::firstHit(const Ray& ray, double tmin, double tmax) const {
  const glm::dvec3 o = ray.origin - center_;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh = embreeRayHit(o, ray.direction, tmin, tmax);
  rtcIntersect1(impl_->scene, &context, &rh);
  throwIfFailed("tracing a ray");
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return makeHit(ray.origin, ray.direction, rh.hit.primID, rh.ray.tfar);
}

bool EmbreeScene::occluded(const glm::dvec3& origin, const glm::dvec3& direction, double tmax) const {
  const glm::dvec3 o = origin - center_;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r = embreeRay(o, direction, 0.0, tmax);
  rtcOccluded1(impl_->scene, &context, &r);
  throwIfFailed("tracing a shadow ray");
  return r.tfar < 0.0f;
}

std::vector<RayHit> EmbreeScene::allHits(const Ray& ray, double tmin, double tmax, bool closedOnly) const {
  std::vector<std::pair<float, uint32_t>> raw;
  CollectContext c;
  rtcInitIntersectContext(&c.context);
  c.context.filter = &collectFilter;
  c.hits = &raw;
  c.closedCount = uint32_t(std::min<size_t>(closedTriangleCount_, UINT32_MAX));
  c.closedOnly = closedOnly;
  const glm::dvec3 o = ray.origin - center_;
  RTCRayHit rh = embreeRayHit(o, ray.direction, tmin, tmax);
  rtcIntersect1(impl_->scene, &c.context, &rh);
  throwIfFailed("collecting hits along a ray");

  // One entry per primitive (a primitive referenced from several BVH leaves is reported more than once).
  std::sort(raw.begin(), raw.end(), [](const auto& x, const auto& y) { return x.second < y.second; });
  raw.erase(std::unique(raw.begin(), raw.end(), [](const auto& x, const auto& y) { return x.second == y.second; }),
            raw.end());
  std::vector<RayHit> hits;
  hits.reserve(raw.size());
  for (const auto& [t, prim] : raw) hits.push_back(makeHit(ray.origin, ray.direction, prim, t));
  std::sort(hits.begin(), hits.end(), [](const RayHit& x, const RayHit& y) { return x.t < y.t; });

  // Merge hits of neighbouring triangles at one point (the ray passes through a shared edge or vertex).
  auto sharesVertex = [&](uint32_t p, uint32_t q) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (positions_[indices_[3 * size_t(p) + i]] == positions_[indices_[3 * size_t(q) + j]]) return true;
    return false;
  };
  const double tolerance = 1e-7 * (glm::length(ray.origin - center_) + scale_) / std::max(1e-300, glm::length(ray.direction));
  std::vector<RayHit> merged;
  for (const RayHit& h : hits) {
    bool duplicate = false;
    for (size_t k = merged.size(); k-- > 0 && h.t - merged[k].t <= tolerance;) {
      if (merged[k].frontFacing == h.frontFacing && merged[k].closed == h.closed &&
          sharesVertex(merged[k].triangle, h.triangle)) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) merged.push_back(h);
  }
  return merged;
}

int EmbreeScene::closedSolidDepth(const glm::dvec3& point) const {
  static const std::array<glm::dvec3, 3> directions = {
      glm::normalize(glm::dvec3(0.5227, 0.6715, 0.5253)),
      glm::normalize(glm::dvec3(-0.7071, 0.1736, 0.6853)),
      glm::normalize(glm::dvec3(0.2419, -0.8321, -0.4993)),
  };
  std::array<int, 3> depth{};
  for (size_t i = 0; i < directions.size(); ++i) {
    int d = 0;
    for (const RayHit& h : allHits({point, directions[i]}, 0.0, kInfinity, true)) d += h.frontFacing ? -1 : 1;
    depth[i] = d;
  }
  std::sort(depth.begin(), depth.end());
  return depth[1];
}

namespace {

// Calls packet(first, valid) for each packet of 16 rays out of `count` (first: the packet's first ray; valid: -1
// in the lanes that hold a ray, 0 past the end), over TBB's threads or on this one.
template <class Packet>
void forRayPackets(size_t count, bool parallel, const Packet& packet) {
  const size_t packets = (count + 15) / 16;
  auto work = [&](size_t begin, size_t end) {
    for (size_t p = begin; p < end; ++p) {
      alignas(64) int valid[16];
      for (int i = 0; i < 16; ++i) valid[i] = p * 16 + size_t(i) < count ? -1 : 0;
      packet(p * 16, valid);
    }
  };
  if (parallel)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, packets, 16),
                      [&](const tbb::blocked_range<size_t>& range) { work(range.begin(), range.end()); });
  else
    work(0, packets);
}

}  // namespace

std::vector<std::optional<RayHit>> EmbreeScene::firstHits(std::span<const Ray> rays, double tmin, double tmax,
                                                          bool parallel) const {
  std::vector<std::optional<RayHit>> out(rays.size());
  forRayPackets(rays.size(), parallel, [&](size_t first, int* valid) {
    alignas(64) RTCRayHit16 rh;
    for (int i = 0; i < 16; ++i) {
      const Ray& ray = rays[std::min(first + size_t(i), rays.size() - 1)];
      setLane(rh.ray, i, embreeRay(ray.origin - center_, ray.direction, tmin, tmax));
      rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect16(valid, impl_->scene, &context, &rh);
    for (int i = 0; i < 16; ++i) {
      const size_t r = first + size_t(i);
      if (r >= rays.size() || rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) continue;
      out[r] = makeHit(rays[r].origin, rays[r].direction, rh.hit.primID[i], rh.ray.tfar[i]);
    }
  });
  throwIfFailed("tracing a batch of rays");
  return out;
}

std::vector<uint8_t> EmbreeScene::occludedBatch(std::span<const Ray> rays, std::span<const double> tmax,
                                                bool parallel) const {
  if (tmax.size() > 1 && tmax.size() != rays.size())
    throw Error(ErrorCategory::InvalidArgument, "occludedBatch: tmax must be empty, one value, or one per ray");
  std::vector<uint8_t> out(rays.size(), 0);
  auto limit = [&](size_t r) { return tmax.empty() ? kInfinity : tmax[tmax.size() == 1 ? 0 : r]; };
  forRayPackets(rays.size(), parallel, [&](size_t first, int* valid) {
    alignas(64) RTCRay16 ray16;
    for (int i = 0; i < 16; ++i) {
      const size_t rr = std::min(first + size_t(i), rays.size() - 1);
      const Ray& ray = rays[rr];
      setLane(ray16, i, embreeRay(ray.origin - center_, ray.direction, 0.0, limit(rr)));
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcOccluded16(valid, impl_->scene, &context, &ray16);
    for (int i = 0; i < 16; ++i) {
      const size_t r = first + size_t(i);
      if (r < rays.size() && ray16.tfar[i] < 0.0f) out[r] = 1;
    }
  });
  throwIfFailed("tracing a batch of shadow rays");
  return out;
}

}  // namespace cpvs
