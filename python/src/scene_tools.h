#pragma once
// What a pipeline measures its bake against: points on a scene's surfaces (cpvs.sample, cpvs-sample's points)
// and Embree's ray-traced answers for them (cpvs.reference, what cpvs-query --reference compares with).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <vector>

#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/scene/scene.h"

namespace cpvs::python {

// (points, normals): float64 arrays of shape (n, 3).
pybind11::tuple sample(const std::string& scene, size_t count, uint64_t seed, const std::vector<std::string>& excludeMesh);

class Reference {
public:
  Reference(const std::string& scene, bool towardLight, const std::vector<std::string>& excludeMesh);
  // Ray-traced visibility (bool) of each point for `light`: the scene's light by index or name, or a light as a
  // ShadowFile describes it (a dict of cpvs.ShadowFile.lights).
  pybind11::array lookup(pybind11::handle points, pybind11::handle normals, pybind11::handle light, int threads) const;
  pybind11::list lights() const;

private:
  Light lightOf(pybind11::handle light) const;

  std::string path_;
  Scene scene_;
  WorldGeometry world_;
  std::unique_ptr<ShadowReference> reference_;
};

}  // namespace cpvs::python
