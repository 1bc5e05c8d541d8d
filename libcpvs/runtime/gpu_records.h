#pragma once
// The lights, their views and their DAGs as the GPU lookups read them (lookup_records.glsl: cpvs_visibility.comp
// for Vulkan, cpvs-view's passes): plain arrays of doubles and uints, every view's node units and leaves
// appended to two shared buffers. An engine uploads these arrays as they are (docs/runtime.md, "Vulkan").
#include <cstddef>
#include <cstdint>
#include <vector>

#include "libcpvs/runtime/outcome.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

struct GpuSceneRecords {
  std::vector<double> lightReals;   // CPVS_LIGHT_REALS per light
  std::vector<uint32_t> lightWords; // CPVS_LIGHT_WORDS per light
  std::vector<double> viewReals;    // CPVS_MAP_REALS per view
  std::vector<uint32_t> viewWords;  // CPVS_VIEW_WORDS per view
  std::vector<uint32_t> nodes;      // u16 units, two per uint (each DAG starts on a whole uint)
  std::vector<uint64_t> leaves;
  // The shared arrays already in `nodes` and `leaves` (a 3.x file's pool, DagView::sharedNodes), each once: where
  // each starts there.
  struct SharedArray {
    const void* data;
    uint64_t base;
  };
  std::vector<SharedArray> sharedNodes, sharedLeaves;
  size_t lightCount() const;
  size_t bytes() const;
};

// Fails (RuntimeFailure) when a buffer would exceed what 32-bit indices address.
Result<GpuSceneRecords> packGpuScene(const std::vector<LightShadow>& lights);
// Appends one light and its views (with their DAGs, or without: views for shadow maps, whose layer the caller
// sets). The light's shadow light is itself. Fails as packGpuScene, leaving `records` partly appended.
Outcome appendLightRecords(GpuSceneRecords& records, const Light& light, const std::vector<LightView>& views,
                           const std::vector<DagView>* dags);

// The record layout, mirrored from lookup_records.glsl (tests/preview_test.cpp checks every value against the
// file's #defines).
namespace gpu_layout {
inline constexpr uint32_t kMapReals = 24, kViewWords = 40, kLightReals = 16, kLightWords = 12;
// Map reals: row[i][j] at kMapRow + 4 i + j, then ViewMapping's constants in this order from kMapXMin.
inline constexpr uint32_t kMapRow = 0, kMapXMin = 12, kMapYMin = 13, kMapUScale = 14, kMapVScale = 15, kMapUStep = 16,
                          kMapVStep = 17, kMapNear = 18, kMapInvNear = 19, kMapSScale = 20, kMapInvDs = 21,
                          kMapResolution = 22;
inline constexpr uint32_t kLightPosition = 0, kLightDirection = 3, kLightRange = 6, kLightCosOuter = 7,
                          kLightSinOuter = 8, kLightCosInner = 9, kLightColor = 10, kLightIntensity = 13;
inline constexpr uint32_t kLightType = 0, kLightFirstView = 1, kLightViewCount = 2, kLightDisabled = 3, kLightFaceView = 4,
                          kLightShadowLight = 10, kLightShape = 11;
inline constexpr uint32_t kViewFlags = 0, kViewNodeBase = 1, kViewLeafBase = 2, kViewRootCode = 3,
                          kViewResolution = 4, kViewLayer = 5, kViewAtlasX = 6, kViewAtlasY = 7,
                          kViewChildBase = 8;
inline constexpr uint32_t kFlagOrthographic = 1, kFlagLinear = 2, kFlagEmpty = 4;
}  // namespace gpu_layout

}  // namespace cpvs
