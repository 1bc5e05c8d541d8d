#pragma once
// cpvs.bake: cpvs-bake run from Python with the same options (tools/cpvs-bake/bake_command.h), so the bytes and
// the report are cpvs-bake's. The bake runs on its own thread while the calling thread, holding the GIL, calls
// the progress callback about ten times a second and watches for Ctrl-C.
#include <pybind11/pybind11.h>

#include <string>

namespace cpvs::python {

pybind11::dict bake(const std::string& scene, const std::string& output, pybind11::handle lights,
                    pybind11::handle resolution, pybind11::handle cache, int threads, pybind11::handle progress,
                    const pybind11::kwargs& options);

}  // namespace cpvs::python
