#pragma once
// cpvs.ShadowFile: an opened .cpvs (memory-mapped, validated as the tools validate it) and its lookups. Immutable
// once open: any number of Python threads may query one file at once.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs::python {

class ShadowFile {
public:
  // Raises cpvs.MissingFileError, or cpvs.FormatError with the reader's message.
  explicit ShadowFile(const std::string& path);

  const std::string& path() const { return path_; }
  pybind11::dict info() const;  // what cpvs.read_info gives
  pybind11::list lights() const { return info()["lights"]; }
  size_t lightCount() const { return shadows_.size(); }

  // Which lights `light` names (None: the only one; an index or a name; a list or tuple of those), and whether
  // it was a list (the result then gets a last axis). Raises cpvs.LightNotFoundError, cpvs.ArgumentError.
  std::vector<size_t> selectLights(pybind11::handle light, bool& list) const;
  const LightShadow& shadow(size_t light) const { return shadows_[light]; }

  // See cpvs.ShadowFile.lookup in docs/python.md.
  pybind11::array lookup(pybind11::handle points, pybind11::handle normals, pybind11::handle light,
                         pybind11::handle pcf, pybind11::handle bias, bool towardLight, int threads,
                         pybind11::handle out) const;

private:
  std::string path_;
  std::unique_ptr<CpvsFile> file_;
  std::vector<LightShadow> shadows_;
};

}  // namespace cpvs::python
