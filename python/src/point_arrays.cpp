#include "python/src/point_arrays.h"

#include <cmath>
#include <limits>
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

const double* VectorArray::doubles(size_t begin, size_t end, std::vector<double>& buffer) const {
  if (single_) begin = 0, end = 1;
  if (f64_) return f64_ + 3 * begin;
  buffer.resize(3 * (end - begin));
  const float* source = f32_ + 3 * begin;
  for (size_t k = 0; k < buffer.size(); ++k) buffer[k] = double(source[k]);
  return buffer.data();
}

PointArrays pointArraysOf(const VectorArray& points, const VectorArray& normals, size_t begin, size_t end,
                          std::vector<double>& positionBuffer, std::vector<double>& normalBuffer) {
  static constexpr double kNoNormal[3] = {0.0, 0.0, 0.0};
  PointArrays arrays;
  arrays.positions = points.doubles(begin, end, positionBuffer);
  arrays.positionStride = 3;
  const bool hasNormals = normals.size() != 0;
  arrays.normals = hasNormals ? normals.doubles(begin, end, normalBuffer) : kNoNormal;
  arrays.normalStride = hasNormals ? normals.stride() : 0;
  return arrays;
}

namespace {

// Whether n doubles are all finite: x * 0 is NaN exactly for an infinite or NaN x, and a sum holding a NaN stays
// NaN. Eight independent sums keep the loop free of a long dependency chain (the compiler pairs them into
// vector adds); no branch per value.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__ELF__)
__attribute__((target_clones("avx2", "default")))  // four doubles per add where the CPU has AVX2
#endif
bool allFinite(const double* v, size_t n) {
  double sums[8] = {};
  size_t k = 0;
  for (; k + 8 <= n; k += 8)
    for (int j = 0; j < 8; ++j) sums[j] += v[k + j] * 0.0;
  for (; k < n; ++k) sums[0] += v[k] * 0.0;
  double total = 0.0;
  for (double s : sums) total += s;
  return total == 0.0;
}

}  // namespace

size_t firstNonFinite(const PointArrays& arrays, const VectorArray& points, const VectorArray& normals, size_t begin,
                      size_t end) {
  const size_t count = end - begin;
  if (allFinite(arrays.positions, 3 * count) && allFinite(arrays.normals, arrays.normalStride ? 3 * count : 3))
    return std::numeric_limits<size_t>::max();
  const bool hasNormals = normals.size() != 0;
  for (size_t i = begin; i < end; ++i) {
    const glm::dvec3 p = points.at(i), n = hasNormals ? normals.at(i) : glm::dvec3(0.0);
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(p[c]) || !std::isfinite(n[c])) return i;
  }
  return std::numeric_limits<size_t>::max();
}

VectorArray normalsFor(py::handle normals, const VectorArray& points) {
  if (normals.is_none()) return {};
  VectorArray out(normals, "normals", true);
  if (!out.single() && out.leadingShape() != points.leadingShape())
    raiseArgumentError("normals: expected the points' shape or (3,)");
  return out;
}

}  // namespace cpvs::python
