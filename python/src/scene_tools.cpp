#include "python/src/scene_tools.h"

#include <algorithm>
#include <cmath>

#include <pybind11/stl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "libcpvs/base/error.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/scene/surface_samples.h"
#include "python/src/errors.h"
#include "python/src/point_arrays.h"
#include "tools/common/cli.h"

namespace py = pybind11;

namespace cpvs::python {
namespace {

Scene loadScene(const std::string& path, const std::vector<std::string>& excludeMesh) {
  requireFile(path, "scene");
  Scene scene = importGltf(path);
  tools::LightOptions options;
  options.excludedMeshes = excludeMesh;
  options.applyTo(scene);
  return scene;
}

glm::dvec3 vectorOf(py::handle value, const char* what) {
  const std::vector<double> v = py::cast<std::vector<double>>(value);
  if (v.size() != 3) raiseArgumentError(std::string("light: ") + what + " must have three numbers");
  return {v[0], v[1], v[2]};
}

}  // namespace

py::tuple sample(const std::string& path, size_t count, uint64_t seed, const std::vector<std::string>& excludeMesh) {
  if (count < 1 || count > 100000000) raiseArgumentError("n: 1 to 100,000,000 points");
  const Scene scene = loadScene(path, excludeMesh);
  std::vector<SurfaceSample> samples;
  {
    py::gil_scoped_release release;
    samples = sampleSurfaces(flatten(scene), count, seed);
  }
  if (samples.empty()) throw Error(ErrorCategory::InvalidInput, path + ": the scene has no surface area to sample");
  py::array_t<double> points({py::ssize_t(samples.size()), py::ssize_t(3)}), normals({py::ssize_t(samples.size()), py::ssize_t(3)});
  double* p = points.mutable_data();
  double* n = normals.mutable_data();
  for (size_t i = 0; i < samples.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      p[3 * i + k] = samples[i].position[k];
      n[3 * i + k] = samples[i].normal[k];
    }
  return py::make_tuple(points, normals);
}

Reference::Reference(const std::string& path, bool towardLight, const std::vector<std::string>& excludeMesh)
    : path_(path), scene_(loadScene(path, excludeMesh)) {
  py::gil_scoped_release release;  // building the BVH takes a while on a large level
  world_ = flatten(scene_);
  reference_ = std::make_unique<ShadowReference>(world_, towardLight ? NormalOrientation::TowardLight
                                                                     : NormalOrientation::AsGiven);
}

py::list Reference::lights() const {
  py::list names;
  for (const Light& l : scene_.lights) names.append(l.name);
  return names;
}

Light Reference::lightOf(py::handle light) const {
  if (py::isinstance<py::dict>(light)) {  // as a ShadowFile describes it
    const py::dict d = py::reinterpret_borrow<py::dict>(light);
    Light l;
    const std::string type = py::cast<std::string>(d["type"]);
    l.type = type == "spot" ? LightType::Spot : type == "point" ? LightType::Point : LightType::Directional;
    l.name = py::cast<std::string>(d["name"]);
    if (hasPosition(l)) l.position = vectorOf(d["position"], "position");
    if (hasDirection(l)) l.direction = vectorOf(d["direction"], "direction");
    if (hasRange(l)) l.range = py::cast<double>(d["range"]);
    if (hasCone(l)) l.outerConeAngle = py::cast<double>(d["outer_cone_angle"]);
    if (hasCone(l)) l.innerConeAngle = py::cast<double>(d["inner_cone_angle"]);
    return l;
  }
  std::string names;
  for (size_t i = 0; i < scene_.lights.size(); ++i) names += (i ? ", " : "") + std::to_string(i) + " '" + scene_.lights[i].name + "'";
  if (names.empty()) names = "none";
  if (py::isinstance<py::str>(light)) {
    const std::string name = py::cast<std::string>(light);
    for (const Light& l : scene_.lights)
      if (l.name == name) return l;
    raiseLightError(path_ + ": no light named '" + name + "' (the scene has " + names + ")");
  }
  if (py::isinstance<py::int_>(light) && !py::isinstance<py::bool_>(light)) {
    const long long i = py::cast<long long>(light);
    if (i < 0 || size_t(i) >= scene_.lights.size())
      raiseLightError(path_ + ": light " + std::to_string(i) + " is out of range (the scene has " + names + ")");
    return scene_.lights[size_t(i)];
  }
  raiseArgumentError("light: an index or a name of the scene's lights, or a light of a ShadowFile");
}

py::array Reference::lookup(py::handle pointsArg, py::handle normalsArg, py::handle lightArg, int threads) const {
  const VectorArray points(pointsArg, "points");
  const VectorArray normals = normalsFor(normalsArg, points);
  const bool hasNormals = !normalsArg.is_none();
  const Light light = lightOf(lightArg);
  if (threads < 0 || threads > 1024) raiseArgumentError("threads: 0 (every core) to 1024");
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::dvec3 p = points.at(i), n = hasNormals ? normals.at(i) : glm::dvec3(0.0);
    if (!std::isfinite(p.x + p.y + p.z + n.x + n.y + n.z))
      raiseArgumentError("points: point " + std::to_string(i) + " or its normal is not finite");
  }
  py::array_t<bool> out(points.leadingShape());
  bool* answers = out.mutable_data();
  {
    py::gil_scoped_release release;
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i)
          answers[i] = reference_->visibility(light, {points.at(i), hasNormals ? normals.at(i) : glm::dvec3(0.0)}) != 0;
      });
    });
  }
  return out;
}

}  // namespace cpvs::python
