#include "libcpvs/preview/frame.h"

#include "libcpvs/base/named_values.h"

namespace cpvs {

namespace {
constexpr Named<ShadowMode> kShadowModes[] = {{ShadowMode::Gpu, "gpu"},        {ShadowMode::Cpu, "cpu"},
                                              {ShadowMode::RayTraced, "raytraced"}, {ShadowMode::None, "none"},
                                              {ShadowMode::ShadowMap, "shadowmap"}, {ShadowMode::LightCluster, "lightcluster"},
                                              {ShadowMode::ManyPsm, "manypsm"}};
constexpr Named<Overlay> kOverlays[] = {{Overlay::None, "none"},
                                        {Overlay::LightsPerTile, "lights-per-tile"},
                                        {Overlay::Difference, "difference"},
                                        {Overlay::ShadowCount, "shadow-count"}};
}  // namespace

ShadowMode parseShadowMode(const std::string& name) { return parseNamed(kShadowModes, name, "shadow mode"); }
const char* shadowModeName(ShadowMode mode) { return nameOf(kShadowModes, mode); }
Overlay parseOverlay(const std::string& name) { return parseNamed(kOverlays, name, "overlay"); }
const char* overlayName(Overlay overlay) { return nameOf(kOverlays, overlay); }

uint64_t ShadowMapFrame::trianglesDrawn() const {
  uint64_t total = 0;
  for (uint64_t t : triangles) total += t;
  return total;
}

uint64_t ShadowMapFrame::fragmentsDrawn() const {
  uint64_t total = 0;
  for (uint64_t n : fragments) total += n;
  return total;
}

double Frame::milliseconds(const std::string& pass) const {
  for (const PassTime& p : passes)
    if (p.pass == pass) return p.milliseconds;
  return 0;
}

}  // namespace cpvs
