#include "libcpvs/runtime/view_mapping.h"

#include "libcpvs/runtime/light_view.h"

namespace cpvs {

ViewMapping::ViewMapping(const LightView& view)
    : xMin(view.xMin),
      yMin(view.yMin),
      near(view.near),
      resolution(double(view.resolution)),
      orthographic(view.projection == Projection::Orthographic),
      linear(view.mapping == DepthMapping::Linear),
      empty(view.empty) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) row[i][j] = view.viewFromWorld[j][i];  // glm: [column][row]
  const double n = resolution;
  uScale = n / (view.xMax - view.xMin);
  vScale = n / (view.yMax - view.yMin);
  uStep = (view.xMax - view.xMin) / n;
  vStep = (view.yMax - view.yMin) / n;
  invNear = 1.0 / view.near;
  const double depthSpan = linear ? view.far - view.near : std::log(view.far / view.near);
  sScale = n / depthSpan;
  invDs = depthSpan / n;
}

}  // namespace cpvs
