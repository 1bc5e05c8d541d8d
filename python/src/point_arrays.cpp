#include "python/src/point_arrays.h"

#include <string>

#include "python/src/errors.h"

namespace py = pybind11;

namespace cpvs::python {
namespace {

std::string shapeText(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) text += (d ? ", " : "") + std::to_string(a.shape(d));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

VectorArray::VectorArray(py::handle object, const char* name, bool single) {
  py::array array = py::array::ensure(object);
  if (!array) raiseArgumentError(std::string(name) + ": expected an array of shape (..., 3), got " +
                                 std::string(py::str(py::type::of(object).attr("__name__"))));
  const char kind = array.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    raiseArgumentError(std::string(name) + ": expected real numbers, got dtype " + std::string(py::str(array.dtype())));
  if (array.ndim() < 1 || array.shape(array.ndim() - 1) != 3)
    raiseArgumentError(std::string(name) + ": expected shape (..., 3), got " + shapeText(array));
  single_ = single && array.ndim() == 1;
  const bool inPlace = (array.flags() & py::array::c_style) &&
                       (array.dtype().is(py::dtype::of<float>()) || array.dtype().is(py::dtype::of<double>()));
  keep_ = inPlace ? array : py::array(py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array));
  if (keep_.dtype().is(py::dtype::of<float>()))
    f32_ = static_cast<const float*>(keep_.data());
  else
    f64_ = static_cast<const double*>(keep_.data());
  count_ = size_t(keep_.size() / 3);
  for (py::ssize_t d = 0; d + 1 < keep_.ndim(); ++d) shape_.push_back(keep_.shape(d));
}

VectorArray normalsFor(py::handle normals, const VectorArray& points) {
  if (normals.is_none()) return {};
  VectorArray out(normals, "normals", true);
  if (!out.single() && out.leadingShape() != points.leadingShape())
    raiseArgumentError("normals: expected the points' shape or (3,)");
  return out;
}

}  // namespace cpvs::python
