#include "tools/common/ground_json.h"

namespace cpvs::tools {

const char* groundFacesName(int axis, int sign) {
  static const char* names[] = {"-x", "-y", "-z", "+x", "+y", "+z"};
  return axis >= 0 && axis < 3 ? names[(sign > 0 ? 3 : 0) + axis] : "?";
}

}  // namespace cpvs::tools
