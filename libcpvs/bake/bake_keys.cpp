#include "libcpvs/bake/bake_keys.h"

#include <algorithm>
#include <string>

#include <xxhash.h>

#include "libcpvs/bake/bake.h"
#include "libcpvs/version.h"

namespace cpvs {
namespace {

template <class T>
void hashVector(XXH3_state_t* state, const std::vector<T>& v) {
  const uint64_t count = v.size();
  XXH3_64bits_update(state, &count, sizeof count);
  if (!v.empty()) XXH3_64bits_update(state, v.data(), v.size() * sizeof(T));
}

template <class T>
void hashValue(XXH3_state_t* state, const T& value) {
  XXH3_64bits_update(state, &value, sizeof value);
}

// The version and settings (with `extra`, the light's view count or a frame's tag, in the place the light keys
// always had it), then the light's cone.
void hashSettings(XXH3_state_t* state, const BakeSettings& settings, const Light& light, uint64_t extra) {
  const std::string version = std::string("cpvs-bake ") + kVersion;
  XXH3_64bits_update(state, version.data(), version.size());
  const uint64_t s[] = {settings.resolution, uint64_t(settings.undefinedMode), settings.nodeReuse,
                        settings.peel.maxPeels, settings.peel.stopBelowPerMillion,
                        std::min(settings.regionSize, settings.resolution), uint64_t(settings.ground), extra};
  XXH3_64bits_update(state, s, sizeof s);
  hashValue(state, settings.voxelSize);
  const uint8_t more[] = {uint8_t(settings.cropToCone), uint8_t(settings.backend)};
  XXH3_64bits_update(state, more, sizeof more);
  const std::vector<uint64_t> lossy = lossySettingWords(settings);
  if (!lossy.empty()) XXH3_64bits_update(state, lossy.data(), lossy.size() * sizeof(uint64_t));
  const double cone[] = {double(light.type), hasCone(light) ? light.outerConeAngle : 0.0};
  XXH3_64bits_update(state, cone, sizeof cone);
}

void hashMapping(XXH3_state_t* state, const LightView& v) {
  const double values[] = {double(v.projection), double(v.mapping), double(v.resolution), v.xMin, v.xMax,
                           v.yMin, v.yMax, v.near, v.far, double(v.face), double(v.empty)};
  XXH3_64bits_update(state, values, sizeof values);
  XXH3_64bits_update(state, &v.viewFromWorld[0][0], sizeof(double) * 16);
}

template <class Hash>
uint64_t keyOf(Hash&& hash) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  hash(state);
  const uint64_t key = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return key;
}

}  // namespace

uint64_t lightBakeKey(const BakeSettings& settings, const Light& light, const std::vector<LightView>& views,
                      const std::vector<ViewGeometry>& geometry) {
  return keyOf([&](XXH3_state_t* state) {
    hashSettings(state, settings, light, views.size());
    for (size_t i = 0; i < views.size(); ++i) {
      hashMapping(state, views[i]);
      const ViewGeometry& g = geometry[i];
      hashVector(state, g.positions);
      hashVector(state, g.closedIndices);
      hashVector(state, g.openIndices);
      if (!g.hasMasks()) continue;
      hashVector(state, g.maskOf);  // only the masks this view's triangles are cut by
      hashVector(state, g.maskUvs);
      std::vector<bool> used(g.masks->size(), false);
      for (int32_t m : g.maskOf)
        if (m >= 0) used[size_t(m)] = true;
      for (size_t m = 0; m < used.size(); ++m)
        if (used[m]) hashValue(state, (*g.masks)[m].hash());
    }
  });
}

uint64_t viewFrameKey(const BakeSettings& settings, const Light& light, const LightView& view, uint32_t regionSize,
                      bool summarizeTiles) {
  return keyOf([&](XXH3_state_t* state) {
    constexpr uint64_t kFrameTag = 0x6672616d65ull;  // "frame": never a light's view count
    hashSettings(state, settings, light, kFrameTag);
    hashMapping(state, view);
    const uint64_t more[] = {regionSize, uint64_t(summarizeTiles)};
    XXH3_64bits_update(state, more, sizeof more);
  });
}

uint64_t regionKey(uint64_t frameKey, const RegionRect& rect, bool outsideCone, const ViewGeometry& g,
                   const std::vector<uint64_t>& maskHashes) {
  return keyOf([&](XXH3_state_t* state) {
    const uint64_t head[] = {frameKey, rect.x0, rect.y0, rect.width, rect.height, uint64_t(outsideCone)};
    XXH3_64bits_update(state, head, sizeof head);
    if (outsideCone) return;
    // Each triangle has its own three positions, in order (view_geometry.h): the positions and the two counts
    // say everything the indices would.
    hashVector(state, g.positions);
    const uint64_t counts[] = {g.closedIndices.size(), g.openIndices.size()};
    XXH3_64bits_update(state, counts, sizeof counts);
    // A region without alpha-tested triangles renders the same whether other regions of its view have some.
    if (std::all_of(g.maskOf.begin(), g.maskOf.end(), [](int32_t m) { return m < 0; })) return;
    std::vector<uint64_t> masks(g.maskOf.size());
    for (size_t t = 0; t < masks.size(); ++t) masks[t] = g.maskOf[t] < 0 ? 0 : maskHashes.at(size_t(g.maskOf[t]));
    hashVector(state, masks);
    hashVector(state, g.maskUvs);
  });
}

}  // namespace cpvs
