#include "libcpvs/runtime/light.h"

#include <cstddef>
#include <iterator>

namespace cpvs {

const char* lightTypeName(LightType type) {
  // Indexed by the enum's value (0, 1, 2 in declaration order).
  static constexpr const char* kNames[] = {"directional", "spot", "point"};
  const size_t i = size_t(type);
  return i < std::size(kNames) ? kNames[i] : "unknown";
}

}  // namespace cpvs
