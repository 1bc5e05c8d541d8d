#pragma once
// The module's exceptions and how the library's errors map to them (docs/python.md, "Errors"): one class per
// category of the tools' exit codes, each also a subclass of the built-in exception a Python caller expects.
#include <pybind11/pybind11.h>

#include <string>

namespace cpvs::python {

// Creates the exception classes in `module` and registers the translation of cpvs::Error (and of the bake's
// memory budget) into them.
void defineErrors(pybind11::module_& module);

// These set the Python error and throw pybind11::error_already_set.
[[noreturn]] void raiseArgumentError(const std::string& message);  // cpvs.ArgumentError (ValueError)
[[noreturn]] void raiseLightError(const std::string& message);     // cpvs.LightNotFoundError (IndexError)
// cpvs.MissingFileError (FileNotFoundError) for `path`, a `what` ("file", "scene").
[[noreturn]] void raiseMissingFile(const std::string& path, const char* what);
[[noreturn]] void raiseCancelled(const std::string& message);      // cpvs.Cancelled
// Raises MissingFileError unless `path` is an existing file.
void requireFile(const std::string& path, const char* what);

}  // namespace cpvs::python
