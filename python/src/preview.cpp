#include "python/src/preview.h"

#include <cstring>
#include <vector>

#include "python/src/errors.h"
#include "python/src/option_flags.h"
#include "tools/cpvs-view/view_command.h"

namespace py = pybind11;

namespace cpvs::python {

py::array_t<uint8_t> preview(const std::string& scene, const std::string& file, py::handle size, int threads,
                             const py::kwargs& options) {
  requireFile(scene, "scene");
  requireFile(file, "file");
  if (threads < 0 || threads > 256) raiseArgumentError("threads: 0 (every core) to 256");
  std::string sizeText;
  if (py::isinstance<py::list>(size) || py::isinstance<py::tuple>(size)) {
    if (py::len(size) != 2) raiseArgumentError("size: (width, height) or \"WIDTHxHEIGHT\"");
    sizeText = std::string(py::str(size[py::int_(0)])) + "x" + std::string(py::str(size[py::int_(1)]));
  } else {
    sizeText = py::str(size);
  }
  std::vector<std::string> args = {"cpvs-view", scene, file, "--quiet", "--size", sizeText};
  if (threads > 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
  // What writes files, animates or opens a window is cpvs-view's, not a still's.
  appendOptionFlags(args, options,
                    {"--output", "--report", "--path", "--orbit", "--frames", "--window", "--screenshot", "--quiet"},
                    "cpvs.preview");
  tools::ViewOptions view;
  CLI::App app{"cpvs.preview"};
  view.addTo(app);
  parseOptionFlags(app, args, "cpvs.preview");
  RgbImage image;
  {
    py::gil_scoped_release release;
    image = tools::renderStill(view, "cpvs.preview(scene, file)");
  }
  py::array_t<uint8_t> out({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(3)});
  std::memcpy(out.mutable_data(), image.pixels.data(), image.pixels.size());
  return out;
}

}  // namespace cpvs::python
