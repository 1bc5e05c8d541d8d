#include "python/src/errors.h"

#include <filesystem>

#include "libcpvs/base/error.h"

namespace py = pybind11;

namespace cpvs::python {
namespace {

struct Classes {
  PyObject* error = nullptr;          // cpvs.Error(Exception)
  PyObject* argument = nullptr;       // cpvs.ArgumentError(Error, ValueError): exit code 1
  PyObject* format = nullptr;         // cpvs.FormatError(Error, ValueError): exit code 2
  PyObject* output = nullptr;         // cpvs.OutputError(Error, OSError): exit code 3
  PyObject* failure = nullptr;        // cpvs.RuntimeFailure(Error, RuntimeError): exit code 4
  PyObject* budget = nullptr;         // cpvs.MemoryBudgetError(RuntimeFailure, MemoryError): exit code 4
  PyObject* unsupported = nullptr;    // cpvs.NotSupportedError(Error, RuntimeError): exit code 5
  PyObject* missing = nullptr;        // cpvs.MissingFileError(FormatError, FileNotFoundError)
  PyObject* light = nullptr;          // cpvs.LightNotFoundError(ArgumentError, IndexError)
  PyObject* cancelled = nullptr;      // cpvs.Cancelled(Error): a bake stopped by its callback
};
Classes gClasses;

PyObject* define(py::module_& module, const char* name, std::initializer_list<PyObject*> bases, const char* doc) {
  py::tuple tuple(bases.size());
  size_t i = 0;
  for (PyObject* base : bases) tuple[i++] = py::reinterpret_borrow<py::object>(base);
  const std::string qualified = std::string("cpvs.") + name;
  PyObject* cls = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, tuple.ptr(), nullptr);
  if (!cls) throw py::error_already_set();
  module.add_object(name, py::reinterpret_borrow<py::object>(cls));
  return cls;
}

PyObject* classOf(const Error& e) {
  if (dynamic_cast<const MemoryBudgetError*>(&e)) return gClasses.budget;
  switch (e.category()) {
    case ErrorCategory::InvalidArgument: return gClasses.argument;
    case ErrorCategory::InvalidInput: return gClasses.format;
    case ErrorCategory::OutputFailed: return gClasses.output;
    case ErrorCategory::NotSupported: return gClasses.unsupported;
    case ErrorCategory::RuntimeFailure: return gClasses.failure;
  }
  return gClasses.error;
}

}  // namespace

void defineErrors(py::module_& m) {
  Classes& c = gClasses;
  c.error = define(m, "Error", {PyExc_Exception}, "Base of every error the cpvs module raises.");
  c.argument = define(m, "ArgumentError", {c.error, PyExc_ValueError},
                      "An argument out of its documented range (cpvs-bake's exit code 1).");
  c.format = define(m, "FormatError", {c.error, PyExc_ValueError},
                    "An input file that is unreadable, malformed or inconsistent (exit code 2).");
  c.output = define(m, "OutputError", {c.error, PyExc_OSError}, "An output that cannot be written (exit code 3).");
  c.failure = define(m, "RuntimeFailure", {c.error, PyExc_RuntimeError},
                     "A resource ran out or a subsystem failed (exit code 4).");
  c.budget = define(m, "MemoryBudgetError", {c.failure, PyExc_MemoryError},
                    "A bake stopped before it would outgrow its memory budget (exit code 4).");
  c.unsupported = define(m, "NotSupportedError", {c.error, PyExc_RuntimeError},
                         "Not available in this build or on this machine (exit code 5).");
  c.missing = define(m, "MissingFileError", {c.format, PyExc_FileNotFoundError}, "An input file that does not exist.");
  c.light = define(m, "LightNotFoundError", {c.argument, PyExc_IndexError}, "A light index or name the file lacks.");
  c.cancelled = define(m, "Cancelled", {c.error}, "A bake stopped by its progress callback (no output written).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(classOf(e), e.what());
    }
  });
}

void raiseArgumentError(const std::string& message) {
  PyErr_SetString(gClasses.argument, message.c_str());
  throw py::error_already_set();
}

void raiseLightError(const std::string& message) {
  PyErr_SetString(gClasses.light, message.c_str());
  throw py::error_already_set();
}

void raiseMissingFile(const std::string& path, const char* what) {
  PyErr_SetString(gClasses.missing, (path + ": no such " + what).c_str());
  throw py::error_already_set();
}

void requireFile(const std::string& path, const char* what) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) raiseMissingFile(path, what);
}

void raiseCancelled(const std::string& message) {
  PyErr_SetString(gClasses.cancelled, message.c_str());
  throw py::error_already_set();
}

}  // namespace cpvs::python
