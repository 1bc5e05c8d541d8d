#pragma once
// cpvs.preview: one cpvs-view still from Python with cpvs-view's options (tools/cpvs-view/view_command.h), so the
// pixels are those cpvs-view writes to a PNG.
#include <pybind11/numpy.h>

#include <string>

namespace cpvs::python {

pybind11::array_t<uint8_t> preview(const std::string& scene, const std::string& file, pybind11::handle size,
                                   int threads, const pybind11::kwargs& options);

}  // namespace cpvs::python
