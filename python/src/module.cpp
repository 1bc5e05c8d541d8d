// The Python module `cpvs` (python/cpvs/__init__.py re-exports it; docs/python.md).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "libcpvs/runtime/lookup_isa.h"
#include "libcpvs/version.h"
#include "python/src/bake.h"
#include "python/src/preview.h"
#include "python/src/errors.h"
#include "python/src/file_info.h"
#include "python/src/scene_tools.h"
#include "python/src/shadow_file.h"

namespace py = pybind11;
using namespace py::literals;

PYBIND11_MODULE(_cpvs, m) {
  using namespace cpvs::python;
  m.doc() = "cpvs: Compact Precomputed Voxelized Shadows, baked and looked up from Python (docs/python.md).";
  m.attr("__version__") = cpvs::kVersion;
  // As in the tools: CPVS_LOOKUP_ISA=scalar|neon|avx2|avx512, read at import, caps the lookups' instruction set.
  if (const cpvs::Outcome isa = cpvs::limitCellIsaFromEnvironment(); !isa) throw std::invalid_argument(isa.message());
  defineErrors(m);

  py::class_<ShadowFile>(m, "ShadowFile", "An opened .cpvs file: its lights and their shadow lookups. Immutable; "
                                          "safe to query from many threads at once.")
      .def_property_readonly("path", &ShadowFile::path)
      .def_property_readonly("info", &ShadowFile::info, "What cpvs.read_info gives for the file.")
      .def_property_readonly("lights", &ShadowFile::lights, "The lights: name, type, parameters and views.")
      .def("__len__", &ShadowFile::lightCount)
      .def("__repr__", [](const ShadowFile& f) {
        return "<cpvs.ShadowFile '" + f.path() + "', " + std::to_string(f.lightCount()) + " light(s)>";
      })
      .def("lookup", &ShadowFile::lookup, "points"_a, "normals"_a = py::none(), py::kw_only(), "light"_a = py::none(),
           "pcf"_a = py::none(), "bias"_a = py::none(), "toward_light"_a = false, "threads"_a = 0, "out"_a = py::none(),
           "Visibility of points (shape (..., 3)) from light(s): bool, or float32 PCF fractions with pcf=K.");

  m.def("open", [](const std::string& path) { return std::make_unique<ShadowFile>(path); }, "path"_a,
        "Opens and validates a .cpvs file (memory-mapped, read-only).");
  m.def("read_info", &readInfo, "path"_a, "What a .cpvs holds (version, settings, lights, views), read from its "
                                          "header and small sections without its DAGs.");
  m.def("bake", &bake, "scene"_a, "output"_a, py::kw_only(), "lights"_a = py::none(), "resolution"_a = "4k",
        "cache"_a = py::none(), "threads"_a = 0, "progress"_a = py::none(),
        "Bakes a glTF scene into a .cpvs with cpvs-bake's options; returns cpvs-bake's report as a dict.");
  m.def("preview", &preview, "scene"_a, "file"_a, py::kw_only(), "size"_a = "1920x1080", "threads"_a = 0,
        "Renders the file's shadows on its scene as cpvs-view does, with cpvs-view's options; returns the "
        "tone-mapped sRGB image, shape (height, width, 3), uint8.");
  m.def("sample", &sample, "scene"_a, "n"_a, "seed"_a = 1, py::kw_only(), "exclude_mesh"_a = std::vector<std::string>(),
        "Area-weighted points on the scene's surfaces and their normals, as cpvs-sample draws them.");

  py::class_<Reference>(m, "Reference", "Embree ray tracing of a scene: the ground truth bakes are measured against.")
      .def_property_readonly("lights", &Reference::lights, "The names of the scene's lights.")
      .def("lookup", &Reference::lookup, "points"_a, "normals"_a = py::none(), py::kw_only(), "light"_a, "threads"_a = 0,
           "Ray-traced visibility (bool) of points for a light of the scene (index or name) or of a ShadowFile.");
  m.def("reference", [](const std::string& scene, bool towardLight, const std::vector<std::string>& excludeMesh) {
        return std::make_unique<Reference>(scene, towardLight, excludeMesh);
      }, "scene"_a, py::kw_only(), "toward_light"_a = false, "exclude_mesh"_a = std::vector<std::string>(),
        "Builds the Embree reference of a glTF scene.");
}
