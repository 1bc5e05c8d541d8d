#pragma once
// Points and normals as the lookups take them from numpy: an array of shape (..., 3); float64 in C order read
// where it lies, float32 in C order read where it lies and widened a chunk at a time, anything else numeric
// converted once to float64 (never reinterpreted).
#include <pybind11/numpy.h>

#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs::python {

class VectorArray {
public:
  VectorArray() = default;
  // `array` of shape (..., 3); with `single`, also one vector of shape (3,), used for every point. Raises
  // cpvs.ArgumentError naming `name` for another shape or a dtype that is not a real number (bool, complex,
  // strings, objects).
  VectorArray(pybind11::handle array, const char* name, bool single = false);

  size_t size() const { return count_; }                  // vectors (1 for a single one)
  bool single() const { return single_; }
  const std::vector<pybind11::ssize_t>& leadingShape() const { return shape_; }  // the shape without the last 3
  // Vector i (or the single one); read without the GIL.
  glm::dvec3 at(size_t i) const {
    const size_t k = single_ ? 0 : 3 * i;
    return f32_ ? glm::dvec3(f32_[k], f32_[k + 1], f32_[k + 2]) : glm::dvec3(f64_[k], f64_[k + 1], f64_[k + 2]);
  }

  // Vectors [begin, end) as doubles for the lookups (PointArrays): the caller's own float64 array where it lies,
  // float32 converted into `buffer`; the single vector for every point (stride 0) when single().
  const double* doubles(size_t begin, size_t end, std::vector<double>& buffer) const;
  size_t stride() const { return single_ ? 0 : 3; }

private:
  pybind11::array keep_;  // the array read (the caller's, or the converted copy)
  const float* f32_ = nullptr;
  const double* f64_ = nullptr;
  size_t count_ = 0;
  bool single_ = false;
  std::vector<pybind11::ssize_t> shape_;
};

// The normals of `points`: None (an empty array: no normals), one (3,) vector for every point, or an array of the
// points' shape. Raises cpvs.ArgumentError otherwise.
VectorArray normalsFor(pybind11::handle normals, const VectorArray& points);

// Points [begin, end) and their normals (none: zero) as the lookups read them, converted into the buffers where
// they are not float64.
PointArrays pointArraysOf(const VectorArray& points, const VectorArray& normals, size_t begin, size_t end,
                          std::vector<double>& positionBuffer, std::vector<double>& normalBuffer);

// The first of points [begin, end) whose position or normal is not finite, or SIZE_MAX; `arrays` are those
// points as pointArraysOf gave them (read after the chunk's lookups, while it is still in the caches).
size_t firstNonFinite(const PointArrays& arrays, const VectorArray& points, const VectorArray& normals, size_t begin,
                      size_t end);

}  // namespace cpvs::python
