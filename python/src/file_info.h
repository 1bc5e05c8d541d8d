#pragma once
// What a .cpvs says about itself, as Python dicts: version, settings, input hash, size, and its lights with their
// views. cpvs.read_info reads it from the header, the section table and the small sections alone; a ShadowFile
// gives the same for a file it has opened.
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"

namespace cpvs::python {

struct ViewSummary {
  uint32_t resolution = 0;
  int face = -1;
  Projection projection = Projection::Orthographic;
};

// {"name", "index", "type", "color", "intensity", "range", "position", "direction", "inner_cone_angle",
//  "outer_cone_angle", "views": [{"resolution", "face", "projection"}], "resolution"} (the parameters a type does
// not use are None; "resolution" is its largest view's).
pybind11::dict lightDict(const Light& light, size_t index, const std::vector<ViewSummary>& views);
// {"path", "format_version", "bytes", "settings", "input_hash", "lights"}.
pybind11::dict fileDict(const std::string& path, uint32_t major, uint32_t minor, uint64_t bytes,
                        const std::string& settingsJson, pybind11::list lights);

// Reads the header, section table, BAKE, STRS, LGHT and VIEW of `path`, each checked against its checksum, and
// nothing of the DAGs. Raises cpvs.MissingFileError, or cpvs.FormatError naming the file and what is wrong.
pybind11::dict readInfo(const std::string& path);

}  // namespace cpvs::python
