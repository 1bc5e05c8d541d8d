#pragma once
// What every cpvs tool shares on its command line: lights, excluded meshes, exit codes (docs/cli.md).
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/base/error.h"
#include "tools/common/exit_codes.h"
#include "tools/common/usage_errors.h"
#include "libcpvs/scene/scene.h"

namespace cpvs::tools {

// The text appended to every tool's --help.
std::string exitCodeHelp();

struct LightOptions {
  std::vector<std::string> suns;    // "X,Y,Z": the direction the light travels
  std::vector<std::string> spots;   // "PX,PY,PZ,DX,DY,DZ,OUTER_ANGLE_RAD,RANGE"
  std::vector<std::string> points;  // "PX,PY,PZ,RANGE"
  std::vector<std::string> excludedMeshes;

  void addTo(CLI::App& app);
  bool any() const { return !suns.empty() || !spots.empty() || !points.empty(); }
  // Replaces the scene's lights by the command-line ones when any are given, and drops excluded meshes.
  // Throws Error(Usage) on malformed values.
  void applyTo(Scene& scene) const;
};

// Parses `expected` comma-separated finite numbers ("1,2.5,-3"), or between `expected` and `most` of them.
// Throws Error(InvalidArgument) naming the option and, when given, the `format` the values follow
// ("X,Y,Z,RANGE[,CANDELA]: RANGE 0 = unlimited").
std::vector<double> parseNumbers(const std::string& option, const std::string& text, size_t expected, size_t most = 0,
                                 const std::string& format = "");

// The formats of the command-line lights, as their messages show them.
inline constexpr const char* kSunFormat = "X,Y,Z[,LUX]: the direction the light travels";
inline constexpr const char* kSpotFormat =
    "PX,PY,PZ,DX,DY,DZ,OUTER_ANGLE_RAD,RANGE[,CANDELA]: position, direction, outer cone half-angle in radians, "
    "RANGE 0 = unlimited";
inline constexpr const char* kPointFormat = "X,Y,Z,RANGE[,CANDELA]: RANGE 0 = unlimited";

// Parses "4k", "16k", "512", "65536": a power of two from 8 to 256k. Throws Error(Usage).
uint32_t parseResolution(const std::string& text);

// Parses "512M", "2G", "1.5G", "1048576": bytes (K, M, G, T are powers of 1024). Throws Error(InvalidArgument).
uint64_t parseByteSize(const std::string& text);

// Runs parse() and puts the command-line flag in front of an InvalidArgument error's message: the library's
// messages name the value and what was expected, the tool names where the user typed it.
template <class Fn>
auto forFlag(const std::string& flag, Fn&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const Error& e) {
    if (e.category() != ErrorCategory::InvalidArgument) throw;
    throw Error(e.category(), flag + ": " + e.what());
  }
}

// Parses the command line. Returns the exit code when parsing ends the run (--help, --version: 0; a usage
// error, printed: 1), nothing when the tool should go on.
std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv);

// --allow-external-uris: glTF buffers may come from outside the scene's folder.
void addImportOptions(CLI::App& app, ImportOptions& options);

// Runs a tool's main body: maps cpvs::Error and other exceptions to messages on stderr and exit codes.
int runMain(const char* toolName, const std::function<int()>& body);

// --version and the exit-code footer (with `footerMore` after it) every tool has.
void addStandardFlags(CLI::App& app, const char* toolName, const std::string& footerMore = "");

// Sets --version on the app to print "<tool> <version>".
void addVersionFlag(CLI::App& app, const char* toolName);


}  // namespace cpvs::tools
