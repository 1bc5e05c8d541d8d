#pragma once
// How every tool's JSON describes a ground sheet (cpvs-bake's --report, cpvs-info --json): the same keys in
// both, so a pipeline reads them one way.
#include <nlohmann/json.hpp>

#include "libcpvs/scene/scene.h"

namespace cpvs::tools {

// "+y", "-z", ...: the way the sheet faces (the solid lies behind it).
const char* groundFacesName(int axis, int sign);
// {"mesh", "node", "faces", "used", and "closing_triangles" when used or "reason" when not}; Json is
// nlohmann::json or nlohmann::ordered_json (the key order is the same either way for a reader).
template <class Json = nlohmann::ordered_json>
Json groundSheetJson(const GroundSheet& sheet) {
  Json j = {{"mesh", sheet.mesh}, {"node", sheet.node}, {"faces", groundFacesName(sheet.axis, sheet.sign)},
            {"used", sheet.used}};
  if (sheet.used) j["closing_triangles"] = sheet.closingTriangles;
  else j["reason"] = sheet.reason;
  return j;
}

}  // namespace cpvs::tools
