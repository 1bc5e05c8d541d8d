#include "python/src/option_flags.h"

#include <algorithm>

#include "python/src/errors.h"

namespace py = pybind11;

namespace cpvs::python {

std::string optionText(py::handle value) {
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    std::string text;
    for (py::handle item : value) text += (text.empty() ? "" : ",") + std::string(py::str(item));
    return text;
  }
  return py::str(value);
}

void appendOptionFlags(std::vector<std::string>& args, const py::kwargs& options, const std::vector<std::string>& refused,
                       const std::string& function) {
  for (const auto& [key, value] : options) {
    std::string flag = "--" + std::string(py::str(key));
    for (char& c : flag)
      if (c == '_') c = '-';
    if (std::find(refused.begin(), refused.end(), flag) != refused.end())
      raiseArgumentError(std::string(py::str(key)) + ": not an option of " + function);
    if (py::isinstance<py::bool_>(value)) {
      if (value.cast<bool>()) args.push_back(flag);
    } else if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
      for (py::handle item : value) args.insert(args.end(), {flag, std::string(py::str(item))});
    } else if (!value.is_none()) {
      args.insert(args.end(), {flag, std::string(py::str(value))});
    }
  }
}

void parseOptionFlags(CLI::App& app, const std::vector<std::string>& args, const std::string& function) {
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  try {
    app.parse(int(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    raiseArgumentError(function + ": " + e.what());
  }
}

}  // namespace cpvs::python
