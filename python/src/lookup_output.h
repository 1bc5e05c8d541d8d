#pragma once
// Where lookups write their answers: an array the caller passed as `out` (checked: shape, dtype, C order,
// writeable) or a new one. bool for unfiltered lookups, float32 for PCF fractions; the last axis is the lights'
// when a list of lights was asked for.
#include <pybind11/numpy.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "python/src/errors.h"

namespace cpvs::python {

class LookupOutput {
public:
  LookupOutput(pybind11::handle out, const std::vector<pybind11::ssize_t>& shape, bool filtered) : filtered_(filtered) {
    const pybind11::dtype dtype = filtered ? pybind11::dtype::of<float>() : pybind11::dtype::of<bool>();
    if (out.is_none()) {
      array_ = pybind11::array(dtype, shape);
    } else {
      array_ = pybind11::array::ensure(out);
      std::vector<pybind11::ssize_t> given;
      if (array_)
        for (pybind11::ssize_t d = 0; d < array_.ndim(); ++d) given.push_back(array_.shape(d));
      if (!array_ || !array_.dtype().is(dtype) || given != shape || !(array_.flags() & pybind11::array::c_style) ||
          !array_.writeable())
        raiseArgumentError(std::string("out: expected a writeable C-ordered ") + (filtered ? "float32" : "bool") +
                           " array of the result's shape");
    }
    data_ = array_.mutable_data();
  }
  // Answers of points [begin, end) for the l-th of `width` lights.
  void store(size_t begin, size_t end, size_t l, size_t width, const float* visibility) {
    if (width == 1) {  // contiguous: loops the compiler turns into vector code
      if (filtered_) {
        std::copy(visibility, visibility + (end - begin), static_cast<float*>(data_) + begin);
      } else {
        bool* out = static_cast<bool*>(data_) + begin;
        for (size_t i = 0; i < end - begin; ++i) out[i] = visibility[i] != 0.0f;
      }
      return;
    }
    if (filtered_) {
      float* out = static_cast<float*>(data_);
      for (size_t i = begin; i < end; ++i) out[i * width + l] = visibility[i - begin];
    } else {
      bool* out = static_cast<bool*>(data_);
      for (size_t i = begin; i < end; ++i) out[i * width + l] = visibility[i - begin] != 0.0f;
    }
  }
  pybind11::array array() const { return array_; }

private:
  bool filtered_;
  pybind11::array array_;
  void* data_ = nullptr;
};

}  // namespace cpvs::python
