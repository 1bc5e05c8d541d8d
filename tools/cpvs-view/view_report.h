#pragma once
// cpvs-view --report: the run (tool, files, context, settings) and, per frame, the image, camera, pass times,
// light-list figures, bytes uploaded, the technique's own figures and the error against the rays; then the
// mean and largest time of every pass (docs/viewer.md lists the fields).
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/preview/camera.h"
#include "libcpvs/preview/frame.h"
#include "libcpvs/preview/frame_image.h"
#include "libcpvs/preview/preview_renderer.h"

namespace cpvs::tools {

class ViewReport {
public:
  ViewReport(const std::string& scene, const std::string& file, const PreviewRenderer& renderer,
             const FrameSettings& settings, Overlay overlay, double ambient, const BakedFromCheck& check,
             const std::string& automaticShadows = {});
  // Adds a frame; returns its light-list figures and (with --compare) its error against the rays. `coverage`:
  // how much of it lies in the strongest light's shadow (frame_image.h), when a light reaches the scene.
  struct Coverage {
    std::string light;
    ShadowCoverage figures;
  };
  void addFrame(const std::string& image, const PreviewCamera& camera, const Frame& frame, double exposure,
                const std::optional<Coverage>& coverage = std::nullopt);
  // The last frame's figures, for the summary line on stderr.
  const LightListStats& lastLists() const { return lastLists_; }
  const RayErrors& lastErrors() const { return lastErrors_; }
  // The whole report, with the per-pass summary over the frames added.
  std::string text() const;

private:
  const PreviewRenderer& renderer_;
  const FrameSettings& settings_;
  nlohmann::ordered_json report_;
  nlohmann::ordered_json frames_ = nlohmann::ordered_json::array();
  std::map<std::string, std::pair<double, double>> sums_;  // pass -> (sum, max)
  LightListStats lastLists_;
  RayErrors lastErrors_;
};

}  // namespace cpvs::tools
