// A bake's span from its report (bake.h): what the parallel structure of a bake makes of its serial parts.
#include <algorithm>

#include "libcpvs/bake/bake.h"

namespace cpvs {

double bakeSpanMs(const BakeReport& report) {
  double longestLight = 0;
  for (const LightReport& light : report.lights) {
    double chain = light.serialMs;
    // The lane renders while the DAG of the region before is built: the longer of the two chains counts.
    for (const ViewReport& v : light.views) chain += std::max(v.laneSerialMs, v.dagChainMs) + v.encodeMs;
    longestLight = std::max(longestLight, chain);
  }
  return report.setupSerialMs + longestLight + report.endSerialMs;
}

WallBounds bakeWallBounds(const BakeReport& report, unsigned cores) {
  const double span = bakeSpanMs(report), share = report.cpuMs / std::max(1u, cores);
  return {std::max(share, span), share + span};
}

}  // namespace cpvs
