#pragma once
// What renders the depth maps: the CPU rasteriser (no GL at all), or OpenGL through OSMesa (software, no GPU or
// display) or EGL (a GPU, or Mesa's surfaceless platform).
#include <string>

namespace cpvs {

enum class RasterBackend { OSMesa, EGL, Cpu };
// "osmesa" / "egl" / "cpu"; throws Error(Usage) for anything else.
RasterBackend parseRasterBackend(const std::string& name);
const char* rasterBackendName(RasterBackend backend);

}  // namespace cpvs
