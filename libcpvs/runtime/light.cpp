#include "libcpvs/runtime/light.h"

namespace cpvs {

const char* lightTypeName(LightType type) {
  switch (type) {
    case LightType::Directional: return "directional";
    case LightType::Spot: return "spot";
    case LightType::Point: return "point";
  }
  return "unknown";
}

}  // namespace cpvs
