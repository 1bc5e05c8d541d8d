#include "tools/common/cli.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <new>
#include <sstream>

#include "libcpvs/base/error.h"
#include "libcpvs/base/memory_limit.h"
#include "libcpvs/runtime/lookup_isa.h"
#include "libcpvs/version.h"
#include "tools/common/usage_errors.h"

namespace cpvs::tools {

std::vector<double> parseNumbers(const std::string& option, const std::string& text, size_t expected, size_t most,
                                 const std::string& format) {
  most = std::max(most, expected);
  const std::string expectedFormat = format.empty() ? std::string() : " (expected " + format + ")";
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || errno != 0 || !std::isfinite(value))
      throw Error(ErrorCategory::InvalidArgument,
                  option + " '" + text + "': '" + item + "' is not a finite number" + expectedFormat);
    values.push_back(value);
  }
  if (values.size() < expected || values.size() > most)
    throw Error(ErrorCategory::InvalidArgument, option + " '" + text + "': expected " + std::to_string(expected) +
                                                    (most > expected ? " or " + std::to_string(most) : std::string()) +
                                                    " comma-separated numbers, got " + std::to_string(values.size()) +
                                                    (format.empty() ? std::string() : ": " + format));
  return values;
}

namespace {

glm::dvec3 unitDirection(const std::string& option, const std::string& text, double x, double y, double z) {
  const glm::dvec3 d(x, y, z);
  const double length = glm::length(d);
  if (!(length > 0)) throw Error(ErrorCategory::InvalidArgument, option + " '" + text + "': the direction must not be zero");
  return d / length;
}

}  // namespace

std::string exitCodeHelp() {
  return "Exit codes:\n"
         "  0  success\n"
         "  1  usage error (bad option or value)\n"
         "  2  input unreadable or invalid (the message names the file and element)\n"
         "  3  output cannot be written\n"
         "  4  runtime failure (e.g. out of memory, GL failure)\n"
         "  5  not supported in this build or on this machine (e.g. EGL missing)\n";
}

void LightOptions::addTo(CLI::App& app) {
  app.add_option("--sun", suns,
                 "Directional light X,Y,Z: the direction the light travels; optionally its illuminance in lux "
                 "(default 1) (repeatable)")
      ->type_name("X,Y,Z[,LUX]");
  app.add_option("--spot", spots,
                 "Spot light PX,PY,PZ,DX,DY,DZ,OUTER_ANGLE_RAD,RANGE, optionally its intensity in candela (default 1) "
                 "(repeatable; RANGE 0 = unlimited)")
      ->type_name("P,D,ANGLE,RANGE[,CD]");
  app.add_option("--point", points,
                 "Point light PX,PY,PZ,RANGE, optionally its intensity in candela (default 1) (repeatable; RANGE 0 = "
                 "unlimited)")
      ->type_name("PX,PY,PZ,RANGE[,CD]");
  app.add_option("--exclude-mesh", excludedMeshes, "Drop a glTF mesh (all its primitives; NAME#k for one primitive) from the casters, e.g. a skybox (repeatable)")
      ->type_name("NAME");
}

namespace {

std::string shortNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

Light namedLight(LightType type, const char* stem, size_t index) {
  Light light;
  light.name = stem + std::to_string(index);
  light.type = type;
  return light;
}

// The optional intensity after a light's required values (KHR_lights_punctual's units; shading only: it changes
// no voxel, but it is part of the light the file records).
float lightIntensity(const char* flag, const std::string& text, const std::vector<double>& values, size_t required) {
  if (values.size() == required) return 1.0f;
  const double intensity = values[required];
  if (!(intensity >= 0 && intensity <= std::numeric_limits<float>::max()))
    throw Error(ErrorCategory::InvalidArgument, std::string(flag) + " '" + text + "': the intensity must be a non-negative float");
  return float(intensity);
}

// OUTER_ANGLE_RAD as --spot takes it: a half-angle in radians, in (0, pi/2]. A value in degrees is the likely
// slip (45 for pi/4), so a value no angle in radians can be (above pi) up to 90 is named as one; one in
// (pi/2, pi] may be a full cone angle in radians, and is told the range.
double spotConeAngle(const std::string& text, double angle) {
  if (angle > 0 && angle <= M_PI / 2) return angle;
  char radians[32];
  std::snprintf(radians, sizeof radians, "%.3f", angle * M_PI / 180.0);
  if (angle > M_PI && angle <= 90)
    throw Error(ErrorCategory::InvalidArgument, "--spot '" + text + "': OUTER_ANGLE_RAD " + shortNumber(angle) +
                                                    " looks like degrees: the angle is in radians (" + radians + ")");
  throw Error(ErrorCategory::InvalidArgument, "--spot '" + text + "': OUTER_ANGLE_RAD " + shortNumber(angle) +
                                                  " must be a half-angle in radians in (0, pi/2] (90 degrees = 1.571)");
}

// RANGE as the options take it: 0 means unlimited.
double lightRange(const char* flag, const std::string& text, double value) {
  if (value < 0) throw Error(ErrorCategory::InvalidArgument, std::string(flag) + " '" + text + "': RANGE must not be negative");
  return value == 0 ? std::numeric_limits<double>::infinity() : value;
}

}  // namespace

void LightOptions::applyTo(Scene& scene) const {
  if (!excludedMeshes.empty()) forFlag("--exclude-mesh", [&] { excludeMeshes(scene, excludedMeshes); });
  if (!any()) return;
  scene.lights.clear();
  // Each option's lights in turn: its required values (and the optional intensity after them) parsed, the light
  // named after the option and its index, its parameters set by `fill`.
  const auto addLights = [&](const std::vector<std::string>& specs, const char* flag, const char* format,
                             size_t required, LightType type, const char* stem, auto&& fill) {
    for (size_t i = 0; i < specs.size(); ++i) {
      const auto v = parseNumbers(flag, specs[i], required, required + 1, format);
      Light light = namedLight(type, stem, i);
      fill(light, specs[i], v);
      light.intensity = lightIntensity(flag, specs[i], v, required);
      scene.lights.push_back(light);
    }
  };
  addLights(suns, "--sun", kSunFormat, 3, LightType::Directional, "sun", [](Light& light, const std::string& spec, const auto& v) {
    light.direction = unitDirection("--sun", spec, v[0], v[1], v[2]);
  });
  addLights(spots, "--spot", kSpotFormat, 8, LightType::Spot, "spot", [](Light& light, const std::string& spec, const auto& v) {
    light.position = {v[0], v[1], v[2]};
    light.direction = unitDirection("--spot", spec, v[3], v[4], v[5]);
    light.outerConeAngle = spotConeAngle(spec, v[6]);
    light.range = lightRange("--spot", spec, v[7]);
  });
  addLights(points, "--point", kPointFormat, 4, LightType::Point, "point", [](Light& light, const std::string& spec, const auto& v) {
    light.position = {v[0], v[1], v[2]};
    light.range = lightRange("--point", spec, v[3]);
  });
}

int runMain(const char* toolName, const std::function<int()>& body) {
  try {
    // CPVS_LOOKUP_ISA=scalar|neon|avx2|avx512 caps the batch lookups' instruction set (docs/cli.md).
    orThrow(limitCellIsaFromEnvironment());
    return body();
  } catch (const Error& e) {
    std::cerr << toolName << ": error: " << e.what() << "\n";
    return int(exitCodeFor(e.category()));
  } catch (const std::bad_alloc&) {
    std::cerr << toolName << ": error: out of memory\n";
    return int(ExitCode::RuntimeFailure);
  } catch (const std::exception& e) {
    std::cerr << toolName << ": error: " << e.what() << "\n";
    return int(ExitCode::RuntimeFailure);
  }
}

void addImportOptions(CLI::App& app, ImportOptions& options) {
  app.add_flag("--allow-external-uris", options.allowExternalUris,
               "Let glTF buffers come from files outside the scene's folder (refused by default: docs/robustness.md)");
  // Alpha-tested casters (docs/alpha.md): they change what casts, so bake, query, sample, sweep and view
  // must be given the same values.
  app.add_option_function<std::string>(
         "--alpha-test", [&options](const std::string& value) { options.alphaTest = value == "on"; },
         "on: MASK materials cut shadows at alphaCutoff and BLEND ones follow --transparent (default); off: every "
         "material casts as OPAQUE")
      ->check(CLI::IsMember({"on", "off"}))
      ->type_name("on|off");
  app.add_option_function<std::string>(
         "--transparent", [&options](const std::string& value) { options.transparent = parseTransparentPolicy(value); },
         "How BLEND materials cast: clip (cut at alpha 0.5, the default: leaf cards dappled, clear glass casts "
         "nothing), opaque, or none")
      ->check(CLI::IsMember({"clip", "opaque", "none"}))
      ->type_name("clip|opaque|none");
  app.add_option("--exclude-material", options.excludeMaterials,
                 "No shadow from meshes whose material name matches GLOB (shell pattern: *, ?, [..]; repeatable); "
                 "they are still drawn by cpvs-view")
      ->type_name("GLOB");
}

std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return reportParseError(app, e) == 0 ? 0 : int(ExitCode::Usage);
  }
  return std::nullopt;
}

void addStandardFlags(CLI::App& app, const char* toolName, const std::string& footerMore) {
  app.name(toolName);  // the name every message of the command line starts with
  app.footer(exitCodeHelp() + footerMore);
  addVersionFlag(app, toolName);
}

void addVersionFlag(CLI::App& app, const char* toolName) {
  app.set_version_flag("--version", std::string(toolName) + " " + kVersion);
}

uint64_t parseByteSize(const std::string& text) {
  const uint64_t bytes = parseMemorySize(text);
  if (bytes < (uint64_t(1) << 20))
    throw Error(ErrorCategory::InvalidArgument, "'" + text + "': expected a size from 1M to 4096T (e.g. 512M, 2G)");
  return bytes;
}

uint32_t parseResolution(const std::string& text) {
  std::string digits = text;
  uint64_t multiplier = 1;
  if (!digits.empty() && (digits.back() == 'k' || digits.back() == 'K')) {
    multiplier = 1024;
    digits.pop_back();
  }
  const bool numeric = !digits.empty() && digits.size() <= 7 && std::all_of(digits.begin(), digits.end(), ::isdigit);
  const uint64_t value = numeric ? std::stoull(digits) * multiplier : 0;
  if (value < 8 || value > 262144 || (value & (value - 1)) != 0)
    throw Error(ErrorCategory::InvalidArgument, "'" + text + "': expected a power of two from 8 to 256k (e.g. 512, 4k, 16k, 64k)");
  return uint32_t(value);
}

}  // namespace cpvs::tools
