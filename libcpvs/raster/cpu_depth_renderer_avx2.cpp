// The CPU rasteriser's passes compiled for AVX2 (cpu_depth_renderer_passes.h): the per-texel loops of the
// tiles that are not uniform (keys in double, compares, selects) take about 5 % off a 64k sun's CPU time
// (docs/depth-maps.md, "What uniform tiles gain"). createCpuDepthRenderer uses it only on CPUs that have AVX2.
// Every header the passes include comes first, outside the target, so that nothing they define is compiled
// for AVX2 (portability.h).
#if defined(__x86_64__) && defined(__GNUC__)

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/raster/cpu_depth_renderer.h"
#include "libcpvs/raster/peel_replay.h"
#include "libcpvs/raster/raster_triangle.h"
#include "libcpvs/raster/slice_table.h"
#include "libcpvs/raster/uniform_tiles.h"
#include "libcpvs/runtime/portability.h"

CPVS_TARGET_BEGIN_AVX2
#define CPVS_RASTER_NAMESPACE avx2
#define CPVS_RASTER_ISA_NAME "AVX2"
#include "libcpvs/raster/cpu_depth_renderer_passes.h"
CPVS_TARGET_END

#endif
