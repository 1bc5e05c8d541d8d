#include "python/src/shadow_file.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/file_shadows.h"
#include "python/src/errors.h"
#include "python/src/file_info.h"
#include "python/src/lookup_output.h"
#include "python/src/point_arrays.h"

namespace py = pybind11;

namespace cpvs::python {

ShadowFile::ShadowFile(const std::string& path) : path_(path) {
  requireFile(path, "file");
  {
    py::gil_scoped_release release;  // opening validates the whole file
    file_ = orThrow(CpvsFile::open(path));
    for (const CpvsFile::LightEntry& entry : file_->lights()) shadows_.push_back(orThrow(lightShadowOf(entry)));
  }
}

py::dict ShadowFile::info() const {
  py::list lights;
  for (size_t l = 0; l < file_->lights().size(); ++l) {
    const CpvsFile::LightEntry& entry = file_->lights()[l];
    std::vector<ViewSummary> views;
    for (const CpvsFile::View& v : entry.views) views.push_back({v.view.resolution, v.view.face, v.view.projection});
    lights.append(lightDict(entry.light, l, views));
  }
  return fileDict(path_, file_->majorVersion(), file_->minorVersion(), file_->fileSize(), file_->settingsJson(), lights);
}

std::vector<size_t> ShadowFile::selectLights(py::handle light, bool& list) const {
  const size_t count = shadows_.size();
  const auto names = [&] {
    std::string text;
    for (size_t i = 0; i < count; ++i) text += (i ? ", " : "") + std::to_string(i) + " '" + shadows_[i].light().name + "'";
    return text.empty() ? std::string("none") : text;
  };
  const auto one = [&](py::handle item) -> size_t {
    if (py::isinstance<py::str>(item)) {
      const std::string name = py::cast<std::string>(item);
      for (size_t i = 0; i < count; ++i)
        if (shadows_[i].light().name == name) return i;
      raiseLightError(path_ + ": no light named '" + name + "' (the file has " + names() + ")");
    }
    if (py::isinstance<py::bool_>(item) || !py::isinstance<py::int_>(item))
      raiseArgumentError("light: an index, a name, or a list of those, not " +
                         std::string(py::str(py::type::of(item).attr("__name__"))));
    const long long index = py::cast<long long>(item);
    if (index < 0 || size_t(index) >= count)
      raiseLightError(path_ + ": light " + std::to_string(index) + " is out of range (the file has " + names() + ")");
    return size_t(index);
  };
  list = py::isinstance<py::list>(light) || py::isinstance<py::tuple>(light);
  if (list) {
    std::vector<size_t> chosen;
    for (py::handle item : light) chosen.push_back(one(item));
    if (chosen.empty()) raiseArgumentError("light: an empty list");
    return chosen;
  }
  if (light.is_none()) {
    if (count != 1)
      raiseArgumentError(path_ + " holds " + std::to_string(count) + " lights: say which with light= (an index, a name "
                         "or a list; the file has " + names() + ")");
    return {0};
  }
  return {one(light)};
}

py::array ShadowFile::lookup(py::handle pointsArg, py::handle normalsArg, py::handle lightArg, py::handle pcfArg,
                             py::handle biasArg, bool towardLight, int threads, py::handle outArg) const {
  const VectorArray points(pointsArg, "points");
  const VectorArray normals = normalsFor(normalsArg, points);
  bool list = false;
  const std::vector<size_t> lights = selectLights(lightArg, list);
  LookupOptions options;
  options.orientation = towardLight ? NormalOrientation::TowardLight : NormalOrientation::AsGiven;
  const bool filtered = !pcfArg.is_none();
  if (filtered) {
    if (py::isinstance<py::bool_>(pcfArg) || !py::isinstance<py::int_>(pcfArg)) raiseArgumentError("pcf: an odd integer K, or None");
    options.pcfKernel = py::cast<int>(pcfArg);
    if (const Outcome k = checkPcfKernel(options.pcfKernel); !k.ok()) raiseArgumentError("pcf: " + k.message());
  }
  if (!biasArg.is_none()) {
    options.biasMargin = py::cast<double>(biasArg);
    if (!(options.biasMargin >= 0 && options.biasMargin <= 64)) raiseArgumentError("bias: a margin of 0 to 64 voxels");
  }
  if (threads < 0 || threads > 1024) raiseArgumentError("threads: 0 (every core) to 1024");
  std::vector<py::ssize_t> shape = points.leadingShape();
  if (list) shape.push_back(py::ssize_t(lights.size()));
  LookupOutput out(outArg, shape, filtered);

  const size_t n = points.size(), width = lights.size();
  std::atomic<size_t> firstBad{std::numeric_limits<size_t>::max()};
  constexpr size_t kChunk = kLookupBatch;  // cpvs-query's batches
  const size_t chunks = (n + kChunk - 1) / kChunk;
  // Chunks [first, last): each chunk's points looked up for every light, its answers stored.
  const auto lookUpChunks = [&](size_t first, size_t last) {
    std::vector<double> positionBuffer, normalBuffer;
    std::vector<float> visibility;
    for (size_t c = first; c != last; ++c) {
      const size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      visibility.resize(end - begin);
      const PointArrays arrays = pointArraysOf(points, normals, begin, end, positionBuffer, normalBuffer);
      for (size_t l = 0; l < width; ++l) {
        orThrow(shadows_[lights[l]].visibility(arrays, options, visibility));
        if (l == 0)  // checked after the first light's lookups have brought the chunk into the caches
          if (const size_t bad = firstNonFinite(arrays, points, normals, begin, end);
              bad != std::numeric_limits<size_t>::max()) {
            size_t seen = firstBad.load();
            while (bad < seen && !firstBad.compare_exchange_weak(seen, bad)) {
            }
            break;
          }
        out.store(begin, end, l, width, visibility.data());
      }
    }
  };
  {
    py::gil_scoped_release release;
    if (threads == 1 || chunks <= 1) {  // on the calling thread: no arena to make for one worker
      lookUpChunks(0, chunks);
    } else {
      tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
      arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks),
                          [&](const tbb::blocked_range<size_t>& r) { lookUpChunks(r.begin(), r.end()); });
      });
    }
  }
  if (firstBad.load() != std::numeric_limits<size_t>::max()) {
    const size_t i = firstBad.load();
    const glm::dvec3 p = points.at(i);
    raiseArgumentError("points: point " + std::to_string(i) + " (" + std::to_string(p.x) + ", " + std::to_string(p.y) +
                       ", " + std::to_string(p.z) + ") or its normal is not finite");
  }
  return out.array();
}

}  // namespace cpvs::python
