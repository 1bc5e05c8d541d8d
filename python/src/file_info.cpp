#include "python/src/file_info.h"

#include <cstring>
#include <fstream>

#include <xxhash.h>

#include "formats/cpvs/cpvs_format.h"
#include "formats/cpvs/cpvs_layout.h"
#include "libcpvs/base/error.h"
#include "python/src/errors.h"

namespace py = pybind11;

namespace cpvs::python {
namespace {

using namespace cpvsformat;

py::object vector3(const glm::dvec3& v) { return py::make_tuple(v.x, v.y, v.z); }

template <class T>
T load(const std::string& bytes, size_t at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof value);
  return value;
}

// The file, read piece by piece with every read checked against its size.
class InfoReader {
public:
  explicit InfoReader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    requireFile(path, "file");
    if (!in_) fail("cannot be opened");
    in_.seekg(0, std::ios::end);
    size_ = uint64_t(in_.tellg());
  }
  std::string read(uint64_t offset, uint64_t size, const char* what) {
    if (offset > size_ || size > size_ - offset) fail(std::string(what) + " lies outside the file (truncated?)");
    std::string bytes(size_t(size), '\0');
    in_.seekg(std::streamoff(offset));
    if (!in_.read(bytes.data(), std::streamsize(size))) fail(std::string("cannot read ") + what);
    return bytes;
  }
  [[noreturn]] void fail(const std::string& why) const { throw Error(ErrorCategory::InvalidInput, path_ + ": " + why); }
  uint64_t size() const { return size_; }

private:
  std::string path_;
  std::ifstream in_;
  uint64_t size_ = 0;
};

}  // namespace

py::dict lightDict(const Light& light, size_t index, const std::vector<ViewSummary>& views) {
  py::dict d;
  d["name"] = light.name;
  d["index"] = index;
  d["type"] = lightTypeName(light.type);
  d["color"] = py::make_tuple(light.color.r, light.color.g, light.color.b);
  d["intensity"] = light.intensity;
  d["range"] = hasRange(light) ? py::object(py::float_(light.range)) : py::none();
  d["position"] = hasPosition(light) ? vector3(light.position) : py::none();
  d["direction"] = hasDirection(light) ? vector3(light.direction) : py::none();
  d["inner_cone_angle"] = hasCone(light) ? py::object(py::float_(light.innerConeAngle)) : py::none();
  d["outer_cone_angle"] = hasCone(light) ? py::object(py::float_(light.outerConeAngle)) : py::none();
  py::list list;
  uint32_t largest = 0;
  for (const ViewSummary& v : views) {
    py::dict view;
    view["resolution"] = v.resolution;
    view["face"] = v.face >= 0 ? py::object(py::int_(v.face)) : py::none();
    view["projection"] = v.projection == Projection::Perspective ? "perspective" : "orthographic";
    list.append(view);
    largest = std::max(largest, v.resolution);
  }
  d["views"] = list;
  d["resolution"] = largest;
  return d;
}

py::dict fileDict(const std::string& path, uint32_t major, uint32_t minor, uint64_t bytes,
                  const std::string& settingsJson, py::list lights) {
  py::dict d;
  d["path"] = path;
  d["format_version"] = std::to_string(major) + "." + std::to_string(minor);
  d["bytes"] = bytes;
  py::object settings = py::none();
  try {
    settings = py::module_::import("json").attr("loads")(settingsJson);
  } catch (const py::error_already_set&) {  // a file without readable settings still has lights
  }
  d["settings"] = settings;
  py::object hash = py::none();
  if (py::isinstance<py::dict>(settings) && settings.contains("input_hash")) hash = settings["input_hash"];
  d["input_hash"] = hash;
  d["lights"] = lights;
  return d;
}

py::dict readInfo(const std::string& path) {
  InfoReader file(path);
  const std::string header = file.read(0, kHeaderSize, "the header");
  if (std::memcmp(header.data(), kCpvsMagic, sizeof kCpvsMagic) != 0) file.fail("not a .cpvs file");
  const uint32_t major = load<uint16_t>(header, HeaderLayout::kMajor), minor = load<uint16_t>(header, HeaderLayout::kMinor);
  if (major < 1 || major > 3) file.fail("format version " + std::to_string(major) + " is not one this build reads");
  if (XXH3_64bits(header.data(), HeaderLayout::kChecksum) != load<uint64_t>(header, HeaderLayout::kChecksum))
    file.fail("header checksum mismatch — the file is corrupt");
  const uint64_t declared = load<uint64_t>(header, HeaderLayout::kFileSize);
  if (declared != file.size())
    file.fail("the header says " + std::to_string(declared) + " bytes, the file has " + std::to_string(file.size()) +
              (declared > file.size() ? " (truncated?)" : ""));
  const uint32_t count = load<uint32_t>(header, HeaderLayout::kSectionCount);
  const std::string table = file.read(load<uint64_t>(header, HeaderLayout::kTableOffset), uint64_t(count) * kSectionEntrySize,
                                      "the section table");
  if (XXH3_64bits(table.data(), table.size()) != load<uint64_t>(header, HeaderLayout::kTableChecksum))
    file.fail("section table checksum mismatch — the file is corrupt");
  // The first section of each type that matters here, read and checked.
  const auto section = [&](uint32_t type, const char* name) {
    for (uint32_t s = 0; s < count; ++s) {
      const size_t e = size_t(s) * kSectionEntrySize;
      if (load<uint32_t>(table, e + SectionEntryLayout::kType) != type) continue;
      std::string bytes = file.read(load<uint64_t>(table, e + SectionEntryLayout::kOffset),
                                    load<uint64_t>(table, e + SectionEntryLayout::kSize), name);
      if (XXH3_64bits(bytes.data(), bytes.size()) != load<uint64_t>(table, e + SectionEntryLayout::kChecksum))
        file.fail(std::string(name) + " checksum mismatch — the file is corrupt");
      return bytes;
    }
    file.fail(std::string("no ") + name + " section");
  };
  const std::string bake = section(kBake, "BAKE"), strings = section(kStrs, "STRS"), lights = section(kLght, "LGHT"),
                    views = section(kView, "VIEW");
  const size_t viewSize = major >= 3 ? kPooledViewRecordSize : kViewRecordSize;
  if (lights.size() % kLightRecordSize != 0 || views.size() % viewSize != 0) file.fail("LGHT or VIEW has a partial record");
  py::list list;
  for (size_t l = 0; l < lights.size() / kLightRecordSize; ++l) {
    const size_t at = l * kLightRecordSize;
    using L = LightRecordLayout;
    Light light;
    const uint32_t type = load<uint32_t>(lights, at + L::kType);
    if (type > 2) file.fail("light " + std::to_string(l) + " has type " + std::to_string(type));
    light.type = LightType(type);
    const uint32_t nameAt = load<uint32_t>(lights, at + L::kNameOffset), nameLength = load<uint32_t>(lights, at + L::kNameLength);
    if (nameAt > strings.size() || nameLength > strings.size() - nameAt) file.fail("light " + std::to_string(l) + "'s name lies outside STRS");
    light.name = strings.substr(nameAt, nameLength);
    for (int k = 0; k < 3; ++k) {
      light.color[k] = load<float>(lights, at + L::kColor + 4 * k);
      light.position[k] = load<double>(lights, at + L::kPosition + 8 * k);
      light.direction[k] = load<double>(lights, at + L::kDirection + 8 * k);
    }
    light.intensity = load<float>(lights, at + L::kIntensity);
    light.range = load<double>(lights, at + L::kRange);
    light.innerConeAngle = load<double>(lights, at + L::kInnerCone);
    light.outerConeAngle = load<double>(lights, at + L::kOuterCone);
    const uint32_t first = load<uint32_t>(lights, at + L::kFirstView), n = load<uint32_t>(lights, at + L::kViewCount);
    if (first > views.size() / viewSize || n > views.size() / viewSize - first)
      file.fail("light " + std::to_string(l) + "'s views lie outside VIEW");
    std::vector<ViewSummary> summaries;
    for (uint32_t v = first; v < first + n; ++v) {
      const size_t vat = size_t(v) * viewSize;
      summaries.push_back({load<uint32_t>(views, vat + ViewRecordLayout::kResolution),
                           int(load<int8_t>(views, vat + ViewRecordLayout::kFace)),
                           Projection(load<uint8_t>(views, vat + ViewRecordLayout::kProjection) ? 1 : 0)});
    }
    list.append(lightDict(light, l, summaries));
  }
  return fileDict(path, major, minor, file.size(), bake, list);
}

}  // namespace cpvs::python
