#pragma once
// Which OpenGL implementation renders the depth maps: OSMesa (software, no GPU or display) or EGL (a GPU, or
// Mesa's surfaceless platform).
#include <string>

namespace cpvs {

enum class RasterBackend { OSMesa, EGL };
// "osmesa" / "egl"; throws Error(Usage) for anything else.
RasterBackend parseRasterBackend(const std::string& name);
const char* rasterBackendName(RasterBackend backend);

}  // namespace cpvs
